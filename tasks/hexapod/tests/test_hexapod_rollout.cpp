// drops::rollout::run_episode on the "real" hexapod with the gait policy (links drops_core and DART
// code; built only with -DDROPS_NATIVE=OFF, see ../CMakeLists.txt).

#include <gtest/gtest.h>

#include "drops/rollout/rollout.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::hexapod {
namespace {

Eigen::VectorXd tripod_params() { return tripod_gait(); }

TEST(HexapodRollout, RunEpisodeOfTheRealRobotWalksAndMatchesAManualSession) {
  const HexapodTask task;
  const HexapodRealSystem real;
  HexapodGaitPolicy policy;
  policy.set_params(policy.theta_of(tripod_params()));
  Rng rng(2024);
  long nonfinite = 0;
  const rollout::Trajectory tr = rollout::run_episode(task, real, policy, rng, &nonfinite);
  EXPECT_EQ(nonfinite, 0);
  ASSERT_EQ(tr.states.rows(), 41);
  ASSERT_EQ(tr.states.cols(), 48);
  ASSERT_EQ(tr.actions.rows(), 40);
  EXPECT_EQ(Eigen::VectorXd(tr.states.row(0).transpose()), task.initial_state());
  GaitController ctrl;
  ctrl.set_params(tripod_params());
  for (int t = 0; t < 40; ++t) {
    EXPECT_EQ(Eigen::VectorXd(tr.actions.row(t).transpose()), ctrl.targets(t * 0.1)) << t;
    EXPECT_EQ(tr.rewards[t], task.reward(tr.states.row(t + 1).transpose())) << t;
  }
  const double speed = task.walking_speed(tr);
  EXPECT_GT(speed, 0.05);
  EXPECT_EQ(tr.transitions().size(), 40u);
  // The same episode by hand through the session, same seed: bit-identical.
  Rng rng2(2024);
  auto session = real.begin_episode(task.initial_state());
  for (int t = 0; t < 40; ++t) {
    const Eigen::VectorXd x = session->step(ctrl.targets(t * 0.1), rng2);
    EXPECT_EQ(x, Eigen::VectorXd(tr.states.row(t + 1).transpose())) << t;
  }
}

}  // namespace
}  // namespace drops::hexapod
