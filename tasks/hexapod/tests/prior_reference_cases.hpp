#pragma once
/// \file The cases of the prior's reference trajectories (issue 14): computed by
/// make_prior_reference.cpp (which wrote tests/data/prior_reference.txt with the code before the
/// speed-ups) and by test_hexapod_prior_reference.cpp (which compares the current code with that
/// file). Each case is a matrix of 48-D states or state differences (simulator.hpp):
///   chain <gait> <phi>   41 rows: x_0 = HexapodTask::initial_state(), x_{t+1} = x_t +
///                        HexapodPrior::evaluate(x_t, u_t; phi), u_t = the gait's targets at t *
///                        0.1 s (a prior-only model rollout: set_state every step);
///   sim <gait> <phi>     41 rows: PriorSimulator(with_leg_removed(phi)): reset(), state(), then
///                        step(u_t) and state() 40 times;
///   onestep <phi>        80 rows: HexapodPrior::evaluate(x_t, u_t; phi) at the 80 transitions of
///                        two gentle-gait episodes of the default "real" robot (measured, noisy
///                        states: off-trajectory velocities, contacts and tilts);
///   real tripod <leg>    41 rows: a HexapodRealSystem episode (servos, 1 ms step, no noise) of
///                        the tripod gait, leg removed (-1: intact).
/// Gaits: tripod (tripod_gait()), centre (all gait parameters 0.5), gentle7 (testing::gentle_gait
/// of Rng(7)), random11 (uniform gait parameters of Rng(11): large amplitudes, some fall); phi in
/// {-1 (intact), 5, 0}.

#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "drops/core/rng.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/task.hpp"
#include "hexapod_mi_data.hpp"

namespace drops::hexapod::testing {

/// One reference case: its name ("chain tripod -1", ...) and its rows (dim rows x 48).
struct ReferenceCase {
  std::string name;
  Eigen::MatrixXd rows;
};

/// Every case, in the order of the data file; the prior's cases (chain, sim, onestep) with the
/// prior simulator options `options` (e.g. another PriorEngine), the "real" ones as always.
inline std::vector<ReferenceCase> prior_reference_cases(const PriorOptions& options = {}) {
  struct Gait {
    std::string name;
    Eigen::VectorXd params;
  };
  std::vector<Gait> gaits;
  gaits.push_back({"tripod", tripod_gait()});
  gaits.push_back({"centre", Eigen::VectorXd::Constant(36, 0.5)});
  Rng r7(7);
  gaits.push_back({"gentle7", gentle_gait(r7)});
  Rng r11(11);
  Eigen::VectorXd p(36);
  for (int i = 0; i < 36; ++i) p[i] = r11.uniform();
  gaits.push_back({"random11", p});

  std::vector<ReferenceCase> cases;
  const HexapodTask task;
  HexapodPriorOptions prior_options;
  prior_options.simulator = options;
  const HexapodPrior prior(prior_options);
  const int phis[] = {-1, 5, 0};
  for (const Gait& g : gaits) {
    GaitController ctrl;
    ctrl.set_params(g.params);
    for (int phi : phis) {
      const std::string suffix = " " + g.name + " " + std::to_string(phi);
      Eigen::MatrixXd xs(41, kStateDim);
      Eigen::VectorXd x = task.initial_state(), dx(kStateDim);
      xs.row(0) = x.transpose();
      for (int t = 0; t < 40; ++t) {
        prior.evaluate(x, ctrl.targets(t * 0.1), Eigen::VectorXd::Constant(1, phi), dx);
        x += dx;
        xs.row(t + 1) = x.transpose();
      }
      cases.push_back({"chain" + suffix, xs});

      PriorSimulator sim(HexapodSpec::with_leg_removed(phi), options);
      sim.reset();
      xs.row(0) = sim.state().transpose();
      for (int t = 0; t < 40; ++t) {
        sim.step(ctrl.targets(t * 0.1));
        xs.row(t + 1) = sim.state().transpose();
      }
      cases.push_back({"sim" + suffix, xs});
    }
  }

  const std::vector<Transition> data = real_data(damaged(-1), 2);
  for (int phi : phis) {
    Eigen::MatrixXd d(static_cast<Eigen::Index>(data.size()), kStateDim);
    Eigen::VectorXd dx(kStateDim);
    for (std::size_t n = 0; n < data.size(); ++n) {
      prior.evaluate(data[n].x, data[n].u, Eigen::VectorXd::Constant(1, phi), dx);
      d.row(static_cast<Eigen::Index>(n)) = dx.transpose();
    }
    cases.push_back({"onestep " + std::to_string(phi), d});
  }

  for (int leg : {-1, 5}) {
    RealRobotOptions o = damaged(leg);
    o.noise = MeasurementNoise{0, 0, 0, 0, 0, 0};
    const HexapodRealSystem real(o);
    HexapodGaitPolicy policy;
    policy.set_params(policy.theta_of(tripod_gait()));
    Rng rng(1);
    cases.push_back({"real tripod " + std::to_string(leg),
                     rollout::run_episode(task, real, policy, rng).states});
  }
  return cases;
}

/// Reads a file written by make_prior_reference (e.g. tests/data/prior_reference.txt): each case
/// as "<name words> <rows> <cols>" followed by rows x cols numbers; lines starting with '#' are
/// comments, the last of which goes to *header when header is not null. Throws
/// std::runtime_error when the file cannot be opened. Thread-safe.
inline std::map<std::string, Eigen::MatrixXd> read_prior_reference(const std::string& path,
                                                                   std::string* header = nullptr) {
  std::ifstream in(path);
  if (!in.good()) throw std::runtime_error("cannot read " + path);
  std::map<std::string, Eigen::MatrixXd> cases;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      if (header != nullptr) *header = line;
      continue;
    }
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string s; words >> s;) w.push_back(s);
    const int rows = std::stoi(w[w.size() - 2]), cols = std::stoi(w.back());
    std::string name = w[0];
    for (std::size_t i = 1; i + 2 < w.size(); ++i) name += " " + w[i];
    Eigen::MatrixXd m(rows, cols);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) in >> m(r, c);
    cases[name] = m;
  }
  return cases;
}

}  // namespace drops::hexapod::testing
