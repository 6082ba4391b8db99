// hexapod_model_error: how well the prior alone and the GP model with that prior predict a
// held-out episode of a hexapod run directory (docs/hexapod.md, "The GP residual").
//
//   build/bench/hexapod_model_error RUN_DIR K REMOVED_LEG [walls RATIO SNR]
//
// Trains a gp_prior model (fixed prior: REMOVED_LEG, -1 = intact) on the measured transitions of
// episodes 1..K of RUN_DIR (episodes/NNN/real.csv), then prints the one-step root-mean-square
// error of dx = x_{t+1} - x_t on episode K + 1, per block of the 48-D state, for the prior alone
// and for the model; "walls RATIO SNR" enables PILCO's soft walls in the kernel fits
// (gp::RpropOptions::penalty). A diagnostic, not a benchmark: single-threaded, no timing.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"

namespace {

using drops::Transition;
using drops::VectorXd;
namespace hx = drops::hexapod;

// Transitions of one episode's real.csv (columns t, the 48 state entries, the 18 actions, ...),
// read with the run-directory reader.
std::vector<Transition> read_transitions(const std::string& path) {
  const drops::experiment::TrajectoryTable table = drops::experiment::read_trajectory_csv(path);
  if (table.columns.size() < 1 + static_cast<std::size_t>(hx::kStateDim + hx::kNumJoints))
    throw drops::InvalidArgument(path + ": " + std::to_string(table.columns.size()) +
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

std::string episode_file(const std::string& dir, int episode) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "/episodes/%03d/real.csv", episode);
  return dir + buf;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4 && argc != 7) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K REMOVED_LEG [walls RATIO SNR]\n"
                 "  one-step prediction error on episode K+1 of the prior alone and of a gp_prior\n"
                 "  model trained on episodes 1..K (REMOVED_LEG: -1 intact, 0..5)\n",
                 argv[0]);
    return 2;
  }
  try {
    const std::string dir = argv[1];
    const int k = std::atoi(argv[2]);
    const int leg = std::atoi(argv[3]);
    if (k < 1) throw drops::InvalidArgument("K must be >= 1");
    std::vector<Transition> train;
    for (int e = 1; e <= k; ++e) {
      const std::vector<Transition> t = read_transitions(episode_file(dir, e));
      train.insert(train.end(), t.begin(), t.end());
    }
    const std::vector<Transition> test = read_transitions(episode_file(dir, k + 1));

    auto task = std::make_shared<hx::HexapodTask>();
    hx::HexapodPriorOptions prior_options;
    prior_options.pool_capacity = 1;
    auto prior = std::make_shared<hx::HexapodPrior>(prior_options);
    prior->check_phi(VectorXd::Constant(1, leg));
    drops::model::PriorParameters fixed = hx::HexapodPrior::prior_parameters();
    fixed.values[0] = leg;  // gp_prior keeps the starting values
    drops::model::ModelOptions options;
    options.type = drops::model::ModelType::kGpPrior;
    options.rprop.tolerance = 1e-3;
    if (argc == 7) {
      if (std::string(argv[4]) != "walls") throw drops::InvalidArgument("expected 'walls'");
      options.rprop.penalty = true;
      options.rprop.max_length_scale_ratio = std::atof(argv[5]);
      options.rprop.max_snr = std::atof(argv[6]);
    }
    auto model = drops::model::make_model(options, task, prior, fixed);
    model->learn(train);

    const char* names[] = {"joint angles", "joint velocities", "body position",
                           "roll pitch yaw", "linear velocity", "angular velocity"};
    const int begin[] = {hx::kJointPos, hx::kJointVel,    hx::kBodyPos,    hx::kBodyRpy,
                         hx::kBodyLinVel, hx::kBodyAngVel, hx::kStateDim};
    double sq_dx[6] = {}, sq_prior[6] = {}, sq_model[6] = {};
    VectorXd dx_prior(hx::kStateDim);
    drops::Prediction p;
    const VectorXd phi = VectorXd::Constant(1, leg);
    for (const Transition& t : test) {
      prior->evaluate(t.x, t.u, phi, dx_prior);
      model->predict(t.x, t.u, p);
      for (int b = 0; b < 6; ++b) {
        for (int j = begin[b]; j < begin[b + 1]; ++j) {
          sq_dx[b] += t.dx[j] * t.dx[j];
          sq_prior[b] += std::pow(dx_prior[j] - t.dx[j], 2);
          sq_model[b] += std::pow(p.mean[j] - t.dx[j], 2);
        }
      }
    }
    std::printf("%zu training transitions (episodes 1-%d), %zu test transitions (episode %d)\n",
                train.size(), k, test.size(), k + 1);
    std::printf("one-step RMSE of dx  | %-10s | %-10s | %-10s\n", "RMS dx", "prior", "model");
    for (int b = 0; b < 6; ++b) {
      const double n = static_cast<double>(test.size()) * (begin[b + 1] - begin[b]);
      std::printf("%-20s | %10.4f | %10.4f | %10.4f\n", names[b], std::sqrt(sq_dx[b] / n),
                  std::sqrt(sq_prior[b] / n), std::sqrt(sq_model[b] / n));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_model_error: %s\n", e.what());
    return 1;
  }
  return 0;
}
