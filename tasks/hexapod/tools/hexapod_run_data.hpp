#pragma once
/// \file The measured transitions of a hexapod run directory (episodes/NNN/real.csv), for the
/// diagnostic tools of tasks/hexapod/tools (hexapod_model_error, hexapod_prior_scores).

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/types.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/robot.hpp"
#include "drops/hexapod/simulator.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::tools {

/// Transitions (x, u, dx = x_{t+1} - x_t; 48-D state, 18 actions) of one episode's real.csv
/// (columns t, the 48 state entries, the 18 actions, ...), read with the run-directory reader.
/// Throws InvalidArgument when the file has fewer than 67 columns, and what
/// read_trajectory_csv throws when it cannot be read.
inline std::vector<Transition> read_transitions(const std::string& path) {
  namespace hx = drops::hexapod;
  const experiment::TrajectoryTable table = experiment::read_trajectory_csv(path);
  if (table.columns.size() < 1 + static_cast<std::size_t>(hx::kStateDim + hx::kNumJoints))
    throw InvalidArgument(path + ": " + std::to_string(table.columns.size()) +
                          " columns, expected at least 67");
  std::vector<Transition> out;
  for (std::size_t i = 0; i + 1 < table.rows.size(); ++i) {
    const auto& r = table.rows[i];
    const auto& next = table.rows[i + 1];
    Transition t;
    t.x = Eigen::Map<const VectorXd>(r.data() + 1, hx::kStateDim);
    t.u = Eigen::Map<const VectorXd>(r.data() + 1 + hx::kStateDim, hx::kNumJoints);
    t.dx = Eigen::Map<const VectorXd>(next.data() + 1, hx::kStateDim) - t.x;
    out.push_back(std::move(t));
  }
  return out;
}

/// RUN_DIR/episodes/NNN/real.csv of episode `episode` (1-based).
inline std::string episode_file(const std::string& dir, int episode) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "/episodes/%03d/real.csv", episode);
  return dir + buf;
}

/// The transitions of episodes 1..k of RUN_DIR, in order. Throws InvalidArgument when k < 1, and
/// what read_transitions throws.
inline std::vector<Transition> read_episodes(const std::string& dir, int k) {
  if (k < 1) throw InvalidArgument("K must be >= 1");
  std::vector<Transition> data;
  for (int e = 1; e <= k; ++e) {
    const std::vector<Transition> t = read_transitions(episode_file(dir, e));
    data.insert(data.end(), t.begin(), t.end());
  }
  return data;
}

/// The options of a gp_prior model as the tools fit it (Rprop tolerance 1e-3); with the three
/// arguments "walls RATIO SNR" (words[0..2], or none when words is null), PILCO's soft walls in
/// the kernel fits, as `drops run` on the hexapod (10 500). Throws InvalidArgument otherwise.
inline model::ModelOptions gp_prior_options(char** words) {
  model::ModelOptions options;
  options.type = model::ModelType::kGpPrior;
  options.rprop.tolerance = 1e-3;
  if (words != nullptr) {
    if (std::string(words[0]) != "walls") throw InvalidArgument("expected 'walls'");
    options.rprop.penalty = true;
    options.rprop.max_length_scale_ratio = std::atof(words[1]);
    options.rprop.max_snr = std::atof(words[2]);
  }
  return options;
}

/// A gp_prior model of the hexapod whose prior keeps one removed leg, fitted as the tools fit it.
struct FixedLegModel {
  std::shared_ptr<hexapod::HexapodTask> task;
  std::shared_ptr<hexapod::HexapodPrior> prior;  ///< one simulator (pool capacity 1)
  model::PriorParameters parameters;             ///< the prior's phi = [leg]
  VectorXd phi;                                  ///< the same phi (dim 1)
  std::unique_ptr<model::DynamicsModel> model;   ///< learned on `data`
};

/// Builds and learns the gp_prior model of `options` (gp_prior_options) with the prior at
/// removed leg `leg` (-1 intact, 0..5) on `data` (48-D states, 18 actions). Throws InvalidArgument
/// for a leg outside the prior family, and what learn() throws. Single-threaded use.
inline FixedLegModel fit_fixed_leg_model(int leg, const model::ModelOptions& options,
                                         const std::vector<Transition>& data) {
  namespace hx = drops::hexapod;
  FixedLegModel m;
  m.task = std::make_shared<hx::HexapodTask>();
  hx::HexapodPriorOptions prior_options;
  prior_options.pool_capacity = 1;
  m.prior = std::make_shared<hx::HexapodPrior>(prior_options);
  m.phi = VectorXd::Constant(1, leg);
  m.prior->check_phi(m.phi);
  m.parameters = hx::HexapodPrior::prior_parameters();
  m.parameters.values[0] = leg;  // gp_prior keeps the starting values
  m.model = model::make_model(options, m.task, m.prior, m.parameters);
  m.model->learn(data);
  return m;
}

}  // namespace drops::tools
