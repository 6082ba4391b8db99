// Tests of the pendubot's IT&E behaviour descriptor: sample times, normalisation of the tip to the
// reachable disc, and a descriptor computed from a real episode.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/policy/policy.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/pendubot/ite_descriptor.hpp"
#include "drops/pendubot/pendubot.hpp"

namespace {

using drops::InvalidArgument;
using drops::MatrixXd;
using drops::Rng;
using drops::VectorXd;
using drops::rollout::Trajectory;
using namespace drops::pendubot;

constexpr double kPi = std::numbers::pi;

// Tip from settings.md §2, written out here: (-l1 sin th1 - l2 sin th2, l1 cos th1 + l2 cos th2).
std::array<double, 2> Tip(double th1, double th2, double l1, double l2) {
  return {-l1 * std::sin(th1) - l2 * std::sin(th2), l1 * std::cos(th1) + l2 * std::cos(th2)};
}

Trajectory Constant(int horizon, double th1, double th2) {
  Trajectory t;
  t.states.resize(horizon + 1, 4);
  for (int i = 0; i <= horizon; ++i) t.states.row(i) << 0.0, 0.0, th1, th2;
  return t;
}

TEST(PendubotDescriptor, SamplesThreeEquallySpacedStepsAfterTheStart) {
  EXPECT_EQ(tip_descriptor_steps(50), (std::array<int, 3>{17, 33, 50}));
  EXPECT_EQ(tip_descriptor_steps(3), (std::array<int, 3>{1, 2, 3}));
  EXPECT_EQ(tip_descriptor_steps(60), (std::array<int, 3>{20, 40, 60}));
  EXPECT_THROW(tip_descriptor_steps(2), InvalidArgument);
}

TEST(PendubotDescriptor, HangingAndUprightPoses) {
  // Hanging: tip at (0, -(l1 + l2)) -> (0.5, 0); upright: (0, l1 + l2) -> (0.5, 1).
  const VectorXd hanging = tip_descriptor(Constant(50, kPi, kPi), 0.5, 0.5);
  const VectorXd upright = tip_descriptor(Constant(50, 0.0, 0.0), 0.5, 0.25);
  ASSERT_EQ(hanging.size(), 6);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(hanging[2 * k], 0.5, 1e-12);
    EXPECT_NEAR(hanging[2 * k + 1], 0.0, 1e-12);
    EXPECT_NEAR(upright[2 * k], 0.5, 1e-12);
    EXPECT_NEAR(upright[2 * k + 1], 1.0, 1e-12);
  }
  // Arm horizontal to the left (th = pi/2: x = -(l1 + l2)) -> (0, 0.5).
  const VectorXd left = tip_descriptor(Constant(10, kPi / 2, kPi / 2), 0.3, 0.6);
  EXPECT_NEAR(left[0], 0.0, 1e-12);
  EXPECT_NEAR(left[1], 0.5, 1e-12);
}

TEST(PendubotDescriptor, ReadsOnlyTheThreeSampledStates) {
  const double l1 = 0.5, l2 = 0.4, L = l1 + l2;
  Trajectory t;
  t.states = MatrixXd::Constant(51, 4, std::numeric_limits<double>::quiet_NaN());
  const double th[3][2] = {{0.3, -1.2}, {2.5, 0.7}, {-0.4, 4.0}};
  const int steps[3] = {17, 33, 50};
  for (int k = 0; k < 3; ++k) t.states.row(steps[k]) << 1.0, -2.0, th[k][0], th[k][1];
  const VectorXd b = tip_descriptor(t, l1, l2);
  for (int k = 0; k < 3; ++k) {
    const auto tip = Tip(th[k][0], th[k][1], l1, l2);
    EXPECT_NEAR(b[2 * k], (tip[0] + L) / (2 * L), 1e-14);
    EXPECT_NEAR(b[2 * k + 1], (tip[1] + L) / (2 * L), 1e-14);
  }
  // A non-finite sampled state gives a non-finite descriptor (MAP-Elites counts it as invalid).
  t.states(33, 2) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(tip_descriptor(t, l1, l2).allFinite());
  EXPECT_THROW(tip_descriptor(t, 0.0, l2), InvalidArgument);
  Trajectory wrong;
  wrong.states = MatrixXd::Zero(51, 3);
  EXPECT_THROW(tip_descriptor(wrong, l1, l2), InvalidArgument);
}

TEST(PendubotDescriptor, OfARealEpisodeLiesInTheUnitCubeAndMatchesItsStates) {
  const TaskOptions options;
  const SwingUpTask task(options);
  const PendubotSystem system(Params{}, options);
  drops::policy::NeuralNetPolicy policy;
  Rng rng(8);
  int moved = 0;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd theta(policy.param_dim());
    for (Eigen::Index i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-5, 5);
    policy.set_params(theta);
    const Trajectory t = drops::rollout::run_episode(task, system, policy, rng);
    const VectorXd b = tip_descriptor(t, 0.5, 0.5);
    ASSERT_EQ(b.size(), 6);
    EXPECT_GE(b.minCoeff(), 0.0);
    EXPECT_LE(b.maxCoeff(), 1.0);
    const VectorXd x = t.states.row(50).transpose();
    const auto tip = tip_position(x, 0.5, 0.5);
    EXPECT_NEAR(b[4], (tip[0] + 1.0) / 2.0, 1e-12);
    EXPECT_NEAR(b[5], (tip[1] + 1.0) / 2.0, 1e-12);
    if (std::abs(b[1]) > 0.05) ++moved;  // the tip left the bottom by 0.85 s
  }
  EXPECT_GT(moved, 5);  // random policies give varied behaviours
}

}  // namespace
