// Writes the reference trajectories of test_hexapod_prior_reference.cpp to stdout (issue 14, item
// 1: the prior's trajectories must stay what they were before the prior was made faster).
//
//   build/systems/hexapod/make_prior_reference > systems/hexapod/tests/data/prior_reference.txt
//
// The checked-in data file was written by this program built from the commit named in its first
// line (the code before the speed-ups); the test reads it back and compares the current code with
// it. What is recorded (every number with 17 significant digits):
//   chain <name> <phi> 41 48    model-path prior rollouts: x_0 = HexapodTask::initial_state(),
//                               x_{t+1} = x_t + HexapodPrior::evaluate(x_t, u_t; phi) with
//                               u_t = the gait's targets at t * 0.1 s (the path of a prior-only
//                               model rollout, set_state every step);
//   sim <name> <phi> 41 48      PriorSimulator: reset(), then step(u_t) 40 times, state() after
//   each; onestep <phi> 80 48         HexapodPrior::evaluate(x_t, u_t; phi) at the 80 transitions
//   of two
//                               gentle-gait episodes of the default "real" robot (noisy measured
//                               states: off-trajectory velocities, contacts, tilts);
//   real <name> <leg> 41 48     HexapodRealSystem (servos, 1 ms) episodes without noise.
// Gaits: tripod (tripod_gait()), centre (all gait parameters 0.5), gentle7 (gentle_gait of Rng(7)),
// random11 (uniform gait parameters of Rng(11): large amplitudes, the robot may fall).
#include <cstdio>
#include <string>
#include <vector>

#include "drops/core/rng.hpp"
#include "drops/rollout/rollout.hpp"
#include "hexapod/controller.hpp"
#include "hexapod/policy.hpp"
#include "hexapod/prior.hpp"
#include "hexapod/real_robot.hpp"
#include "hexapod/task.hpp"
#include "hexapod_mi_data.hpp"

using namespace drops;
using namespace drops::hexapod;

namespace {

struct Gait {
  std::string name;
  Eigen::VectorXd params;  // gait parameters in [0, 1], dim 36
};

std::vector<Gait> gaits() {
  std::vector<Gait> g;
  g.push_back({"tripod", tripod_gait()});
  g.push_back({"centre", Eigen::VectorXd::Constant(36, 0.5)});
  Rng r7(7);
  g.push_back({"gentle7", testing::gentle_gait(r7)});
  Rng r11(11);
  Eigen::VectorXd p(36);
  for (int i = 0; i < 36; ++i) p[i] = r11.uniform();
  g.push_back({"random11", p});
  return g;
}

void print_rows(const Eigen::MatrixXd& m) {
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) std::printf(c ? " %.17g" : "%.17g", m(r, c));
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* commit = argc > 1 ? argv[1] : "unknown";
  std::printf("# prior reference, written by make_prior_reference built from commit %s\n", commit);
  const HexapodTask task;
  const HexapodPrior prior;
  const std::vector<Gait> all = gaits();
  const int phis[] = {-1, 5, 0};
  for (const Gait& g : all) {
    GaitController ctrl;
    ctrl.set_params(g.params);
    for (int phi : phis) {
      Eigen::MatrixXd xs(41, kStateDim);
      Eigen::VectorXd x = task.initial_state(), dx(kStateDim);
      xs.row(0) = x.transpose();
      for (int t = 0; t < 40; ++t) {
        prior.evaluate(x, ctrl.targets(t * 0.1), Eigen::VectorXd::Constant(1, phi), dx);
        x += dx;
        xs.row(t + 1) = x.transpose();
      }
      std::printf("chain %s %d 41 48\n", g.name.c_str(), phi);
      print_rows(xs);

      PriorSimulator sim(HexapodSpec::with_leg_removed(phi));
      sim.reset();
      xs.row(0) = sim.state().transpose();
      for (int t = 0; t < 40; ++t) {
        sim.step(ctrl.targets(t * 0.1));
        xs.row(t + 1) = sim.state().transpose();
      }
      std::printf("sim %s %d 41 48\n", g.name.c_str(), phi);
      print_rows(xs);
    }
  }

  const std::vector<Transition> data = testing::real_data(testing::damaged(-1), 2);
  for (int phi : phis) {
    Eigen::MatrixXd d(static_cast<Eigen::Index>(data.size()), kStateDim);
    Eigen::VectorXd dx(kStateDim);
    for (std::size_t n = 0; n < data.size(); ++n) {
      prior.evaluate(data[n].x, data[n].u, Eigen::VectorXd::Constant(1, phi), dx);
      d.row(static_cast<Eigen::Index>(n)) = dx.transpose();
    }
    std::printf("onestep %d %d 48\n", phi, static_cast<int>(data.size()));
    print_rows(d);
  }

  for (int leg : {-1, 5}) {
    RealRobotOptions o = testing::damaged(leg);
    o.noise = MeasurementNoise{0, 0, 0, 0, 0, 0};
    const HexapodRealSystem real(o);
    HexapodGaitPolicy policy;
    policy.set_params(policy.theta_of(tripod_gait()));
    Rng rng(1);
    const rollout::Trajectory tr = rollout::run_episode(task, real, policy, rng);
    std::printf("real tripod %d 41 48\n", leg);
    print_rows(tr.states);
  }
  return 0;
}
