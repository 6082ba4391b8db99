// Tests of the hexapod's learning problem: the "real" robot (servos, friction, noise, damage), the
// task (observation, reward, walking speed), the gait policy and the prior's state guard.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/simulator.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::hexapod {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::VectorXd tripod_params() { return tripod_gait(); }

// Measured states x_0..x_H of one episode of the gait `p` (gait parameters in [0, 1]) on `real`.
std::vector<Eigen::VectorXd> real_episode(const HexapodRealSystem& real, const Eigen::VectorXd& p,
                                          std::uint64_t seed, int steps = 40) {
  GaitController ctrl;
  ctrl.set_params(p);
  const HexapodTask task;
  Rng rng(seed);
  std::vector<Eigen::VectorXd> xs{task.initial_state()};
  auto session = real.begin_episode(xs[0]);
  for (int n = 0; n < steps; ++n) xs.push_back(session->step(ctrl.targets(n * 0.1), rng));
  return xs;
}

double prior_speed(const Eigen::VectorXd& p, const HexapodSpec& spec = {}) {
  PriorSimulator sim(spec);
  GaitController ctrl;
  ctrl.set_params(p);
  for (int n = 0; n < 40; ++n) sim.step(ctrl.targets(n * 0.1));
  return sim.state()[kBodyPos] / 4.0;
}

RealRobotOptions noiseless(RealRobotOptions o = {}) {
  o.noise = MeasurementNoise{0, 0, 0, 0, 0, 0};
  return o;
}

// ---------------- real robot ----------------

TEST(HexapodReal, TripodWalksForwardUprightButSlowerThanThePrior) {
  const HexapodRealSystem real(noiseless());
  const auto t0 = std::chrono::steady_clock::now();
  const auto xs = real_episode(real, tripod_params(), 1);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Eigen::VectorXd& x = xs.back();
  const double real_speed = x[kBodyPos] / 4.0;
  const double sim_speed = prior_speed(tripod_params());
  std::string why;
  EXPECT_TRUE(check_state(x, real.options().spec, &why)) << why;
  EXPECT_GT(real_speed, 0.05) << "the real robot walks";
  EXPECT_LT(real_speed, 0.9 * sim_speed) << "reality gap: the servos lag, the ground is slippery";
  EXPECT_GT(x[kBodyPos + 2], 0.08);
  EXPECT_LT(body_tilt(x[kBodyRpy], x[kBodyRpy + 1]), 0.5);
  RecordProperty("real_speed", std::to_string(real_speed));
  RecordProperty("prior_speed", std::to_string(sim_speed));
  RecordProperty("real_episode_seconds", std::to_string(seconds));
  std::printf("[info] tripod gait: prior %.3f m/s, real %.3f m/s; one real 4 s episode %.3f s\n",
              sim_speed, real_speed, seconds);
}

TEST(HexapodReal, ServoJointsLagTheirTargets) {
  // Same targets for one control step from rest: the prior's velocity actuators move the hip
  // further than the torque-limited PD servos with friction.
  Eigen::VectorXd target = Eigen::VectorXd::Zero(kNumJoints);
  for (int k = 0; k < kNumLegs; ++k) target[3 * k] = 0.3;
  PriorSimulator prior;
  prior.step(target);
  const HexapodRealSystem real(noiseless());
  Rng rng(0);
  const HexapodTask task;
  const Eigen::VectorXd y = real.begin_episode(task.initial_state())->step(target, rng);
  const Eigen::VectorXd xp = prior.state();
  for (int k = 0; k < kNumLegs; ++k) {
    EXPECT_GT(y[3 * k], 0.0);
    EXPECT_LT(std::abs(0.3 - xp[3 * k]), std::abs(0.3 - y[3 * k])) << "leg " << k;
  }
}

TEST(HexapodReal, MeasurementNoiseHasTheConfiguredSigma) {
  // The noise never feeds back into the true state and is drawn whatever sigma is, so a noisy and
  // a noiseless robot with the same seed differ by exactly sigma * z, z ~ N(0, 1).
  RealRobotOptions o;
  o.noise = MeasurementNoise{0.01, 0.1, 0.003, 0.02, 0.05, 0.07};
  const HexapodRealSystem noisy(o);
  const HexapodRealSystem exact(noiseless(o));
  const auto a = real_episode(noisy, tripod_params(), 42);
  const auto b = real_episode(exact, tripod_params(), 42);
  const int begins[] = {kJointPos, kJointVel, kBodyPos, kBodyRpy, kBodyLinVel, kBodyAngVel, 48};
  for (int blk = 0; blk < 6; ++blk) {
    double sum = 0, sum2 = 0;
    int n = 0;
    for (std::size_t t = 1; t < a.size(); ++t) {
      for (int i = begins[blk]; i < begins[blk + 1]; ++i) {
        const double e = a[t][i] - b[t][i];
        sum += e;
        sum2 += e * e;
        ++n;
      }
    }
    const double sigma = o.noise.sigma(begins[blk]);
    const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
    // n = 720 (joint blocks) or 120 samples: the sample sd is within 4 standard errors.
    EXPECT_NEAR(sd, sigma, 4.0 * sigma / std::sqrt(2.0 * n)) << "block " << blk;
    EXPECT_NEAR(mean, 0.0, 4.0 * sigma / std::sqrt(static_cast<double>(n))) << "block " << blk;
  }
  EXPECT_EQ(a[0], b[0]) << "x_0 is the exact start state";
}

TEST(HexapodReal, RemovingALegChangesTheSpeed) {
  RealRobotOptions damaged = noiseless();
  // Leg 1 (mid-left): without a rear leg this aggressive tripod flips the robot over, in the prior
  // as well; without a mid leg it keeps upright and limps.
  damaged.spec = HexapodSpec::with_leg_removed(1);
  const double intact =
      real_episode(HexapodRealSystem(noiseless()), tripod_params(), 3).back()[kBodyPos] / 4.0;
  const double without_leg =
      real_episode(HexapodRealSystem(damaged), tripod_params(), 3).back()[kBodyPos] / 4.0;
  std::printf("[info] real robot: intact %.3f m/s, without mid-left leg %.3f m/s\n", intact,
              without_leg);
  EXPECT_GT(intact - without_leg, 0.05) << "the damaged robot is slower";
}

TEST(HexapodReal, SameSeedGivesBitIdenticalEpisodesAndAnotherSeedDiffers) {
  const HexapodRealSystem real;
  const auto a = real_episode(real, tripod_params(), 7, 15);
  const auto b = real_episode(real, tripod_params(), 7, 15);
  const auto c = real_episode(real, tripod_params(), 8, 15);
  for (std::size_t t = 0; t < a.size(); ++t) EXPECT_EQ(a[t], b[t]) << "step " << t;
  EXPECT_NE(a.back(), c.back());
}

TEST(HexapodReal, StatelessStepIsTheFirstStepOfAnEpisodeFromX) {
  const HexapodRealSystem real;
  const HexapodTask task;
  GaitController ctrl;
  ctrl.set_params(tripod_params());
  Rng r1(5), r2(5);
  const Eigen::VectorXd a = real.step(task.initial_state(), ctrl.targets(0.0), r1);
  const Eigen::VectorXd b = real.begin_episode(task.initial_state())->step(ctrl.targets(0.0), r2);
  EXPECT_EQ(a, b);
}

TEST(HexapodReal, BlockedJointAndShortTibiaAreConfigurable) {
  RealRobotOptions o = noiseless();
  o.spec.legs[2].blocked_joint = 1;
  o.spec.legs[2].blocked_angle = 0.3;
  o.spec.legs[4].tibia_length_factor = 0.5;
  const auto xs = real_episode(HexapodRealSystem(o), tripod_params(), 1, 10);
  for (const auto& x : xs) EXPECT_TRUE(x.allFinite());
  EXPECT_NEAR(xs.back()[3 * 2 + 1], 0.3, 1e-9) << "the blocked femur of leg 2 stays at 0.3 rad";
}

TEST(HexapodReal, RejectsInvalidOptions) {
  RealRobotOptions o;
  o.noise.body_position = -1;
  EXPECT_THROW(HexapodRealSystem{o}, InvalidArgument);
  o = RealRobotOptions{};
  o.simulator.servo.stall_torque = 31.0;  // above spec.max_torque = 30
  EXPECT_THROW(HexapodRealSystem{o}, InvalidArgument);
  o = RealRobotOptions{};
  o.simulator.servo.kp = 0;
  EXPECT_THROW(HexapodRealSystem{o}, InvalidArgument);
  const HexapodRealSystem real;
  EXPECT_THROW(real.begin_episode(Eigen::VectorXd::Zero(47)), InvalidArgument);
}

// ---------------- task ----------------

TEST(HexapodTask, DimensionsAndInitialStateAreThePriorsReset) {
  const HexapodTask task;
  EXPECT_EQ(task.state_dim(), 48);
  EXPECT_EQ(task.action_dim(), 18);
  EXPECT_EQ(task.observation_dim(), 45);
  EXPECT_EQ(task.horizon(), 40);
  EXPECT_DOUBLE_EQ(task.dt(), 0.1);
  PriorSimulator sim;
  EXPECT_EQ(task.initial_state(), sim.state());
}

TEST(HexapodTask, ObservationDropsXYAndYawKeepsTheRestInOrder) {
  const HexapodTask task;
  Eigen::VectorXd x(48);
  for (int i = 0; i < 48; ++i) x[i] = 0.01 * (i + 1);
  Eigen::VectorXd obs(45);
  task.observe(x, obs);
  for (int i = 0; i < 36; ++i) EXPECT_EQ(obs[i], x[i]);
  EXPECT_EQ(obs[36], x[38]);  // z
  EXPECT_EQ(obs[37], x[39]);  // roll
  EXPECT_EQ(obs[38], x[40]);  // pitch
  for (int i = 0; i < 6; ++i) EXPECT_EQ(obs[39 + i], x[42 + i]);
  // Invariance: moving or turning the robot does not change the observation.
  Eigen::VectorXd y = x, obs2(45);
  y[36] += 3.0;
  y[37] -= 2.0;
  y[41] += 1.0;
  task.observe(y, obs2);
  EXPECT_EQ(obs, obs2);
  EXPECT_THROW(task.observe(Eigen::VectorXd::Zero(47), obs), InvalidArgument);
}

TEST(HexapodTask, RewardMatchesHandComputations) {
  const HexapodTask task;
  Eigen::VectorXd x = task.initial_state();
  x[kBodyPos] = 0.37;
  EXPECT_NEAR(task.reward(x), 0.037, 1e-15) << "forward position * dt";
  x[kBodyPos + 1] = 0.5;
  EXPECT_NEAR(task.reward(x), 0.037, 1e-15) << "|y| = 0.5 is not beyond the limit";
  x[kBodyPos + 1] = -0.51;
  EXPECT_NEAR(task.reward(x), 0.037 - 0.1, 1e-15) << "lateral penalty -dt";
  x[kBodyPos + 1] = 0.0;
  x[kBodyRpy] = 1.2;  // roll 1.2 rad, pitch 0: tilt 1.2 < pi/2
  EXPECT_NEAR(task.reward(x), 0.037, 1e-15);
  x[kBodyRpy + 1] = 0.5;  // cos(1.2) cos(0.5) > 0: tilt acos(0.318) = 1.247 < pi/2
  EXPECT_NEAR(task.reward(x), 0.037, 1e-15);
  x[kBodyRpy] = kPi;  // upside down
  x[kBodyRpy + 1] = 0.0;
  EXPECT_NEAR(task.reward(x), 0.037 - 10.0, 1e-15) << "tilt penalty -10";
  x[kBodyRpy] = 0.0;
  x[kBodyRpy + 1] = -1.6;  // pitched over beyond 90 deg
  x[kBodyPos] = -0.2;
  x[kBodyPos + 1] = 0.8;
  EXPECT_NEAR(task.reward(x), -0.02 - 0.1 - 10.0, 1e-15) << "all three terms";
  EXPECT_NEAR(body_tilt(0.3, 0.0), 0.3, 1e-12);
  EXPECT_NEAR(body_tilt(0.0, -0.4), 0.4, 1e-12);
}

TEST(HexapodTask, WalkingSpeedAndSolved) {
  const HexapodTask task;
  rollout::Trajectory tr;
  tr.states = Eigen::MatrixXd::Zero(41, 48);
  tr.actions = Eigen::MatrixXd::Zero(40, 18);
  tr.rewards = Eigen::VectorXd::Zero(40);
  for (int t = 0; t <= 40; ++t) tr.states(t, kBodyPos) = 0.1 + 0.02 * t;  // 0.2 m/s
  EXPECT_NEAR(task.walking_speed(tr), 0.2, 1e-12);
  EXPECT_NEAR(walking_speed(tr, 0.05), 0.4, 1e-12);
  EXPECT_TRUE(task.solved(tr));
  tr.states(20, kBodyRpy) = 2.0;  // a fall on the way
  EXPECT_FALSE(task.solved(tr));
  tr.states(20, kBodyRpy) = 0.0;
  tr.states(40, kBodyPos) = 0.1 + 0.1 * 4.0;  // 0.1 m/s
  EXPECT_NEAR(task.walking_speed(tr), 0.1, 1e-12);
  EXPECT_FALSE(task.solved(tr));
  EXPECT_THROW(walking_speed(tr, 0.0), InvalidArgument);
}

// ---------------- gait policy ----------------

TEST(HexapodGaitPolicy, OutputEqualsControllerTargetsAtTimeT) {
  HexapodGaitPolicy policy;
  EXPECT_EQ(policy.param_dim(), 36);
  EXPECT_EQ(policy.action_dim(), 18);
  EXPECT_EQ(policy.observation_dim(), 45);
  Rng rng(11);
  Eigen::VectorXd p(36);
  for (int i = 0; i < 36; ++i) p[i] = rng.uniform();
  const Eigen::VectorXd theta = policy.theta_of(p);
  EXPECT_NEAR((theta - (p.array() - 0.5).matrix()).cwiseAbs().maxCoeff(), 0.0, 1e-15);
  policy.set_params(theta);
  EXPECT_NEAR((policy.gait_params() - p).cwiseAbs().maxCoeff(), 0.0, 1e-15);
  GaitController ctrl;
  ctrl.set_params(policy.gait_params());
  const Eigen::VectorXd obs = Eigen::VectorXd::Zero(45);
  Eigen::VectorXd u(18);
  for (int n : {0, 1, 7, 10, 25, 39}) {
    policy.act(obs, n * 0.1, u);
    EXPECT_EQ(u, ctrl.targets(n * 0.1)) << "t = " << n * 0.1;
  }
  // Open loop: the observation does not matter; the clone acts identically.
  const auto copy = policy.clone();
  Eigen::VectorXd v(18);
  copy->act(Eigen::VectorXd::Constant(45, 3.0), 0.7, v);
  EXPECT_EQ(v, ctrl.targets(0.7));
}

TEST(HexapodGaitPolicy, ThetaBoundMapsOntoTheUnitBox) {
  HexapodGaitPolicyOptions o;
  o.theta_bound = 5.0;
  HexapodGaitPolicy policy(o);
  policy.set_params(Eigen::VectorXd::Constant(36, -5.0));
  EXPECT_EQ(policy.gait_params(), Eigen::VectorXd::Zero(36));
  policy.set_params(Eigen::VectorXd::Constant(36, 5.0));
  EXPECT_EQ(policy.gait_params(), Eigen::VectorXd::Ones(36));
  policy.set_params(Eigen::VectorXd::Constant(36, 2.5));
  EXPECT_EQ(policy.gait_params(), Eigen::VectorXd::Constant(36, 0.75));
  Eigen::VectorXd bad = Eigen::VectorXd::Zero(36);
  bad[17] = 5.1;
  EXPECT_THROW(policy.set_params(bad), InvalidArgument);
  bad[17] = std::nan("");
  EXPECT_THROW(policy.set_params(bad), InvalidArgument);
  EXPECT_THROW(policy.set_params(Eigen::VectorXd::Zero(35)), InvalidArgument);
  Eigen::VectorXd u(18);
  EXPECT_THROW(policy.act(Eigen::VectorXd::Zero(45), -0.1, u), InvalidArgument);
  o.theta_bound = 0;
  EXPECT_THROW(HexapodGaitPolicy{o}, InvalidArgument);
}

// ---------------- state guard of the prior ----------------

TEST(HexapodStateGuard, StopPolicyReturnsNaNAndCountsEveryCorruptedState) {
  HexapodPriorOptions o;
  o.pool_capacity = 1;
  const HexapodPrior prior(o);
  const Eigen::VectorXd phi = Eigen::VectorXd::Constant(1, -1.0);
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(18);
  const Eigen::VectorXd good = HexapodTask().initial_state();
  Eigen::VectorXd dx(48);
  prior.evaluate(good, u, phi, dx);
  EXPECT_TRUE(dx.allFinite());
  std::vector<Eigen::VectorXd> bad(4, good);
  bad[0][5] = 3.0;              // joint angle far beyond pi/4 + margin
  bad[1][kBodyPos + 2] = -0.3;  // body under the ground
  bad[2][kJointVel + 3] = std::nan("");
  bad[3][kBodyLinVel] = 1e6;  // implausible velocity
  for (const auto& x : bad) {
    std::string why;
    EXPECT_FALSE(prior.guard_state(x, nullptr, &why));
    EXPECT_FALSE(why.empty());
    prior.evaluate(x, u, phi, dx);
    EXPECT_TRUE(dx.array().isNaN().all());
  }
  const StateGuardCounts c = prior.guard_counts();
  EXPECT_EQ(c.evaluations, 5);
  EXPECT_EQ(c.stopped, 4);
  EXPECT_EQ(c.clamped, 0);
}

TEST(HexapodStateGuard, ClampPolicyRepairsAndCountsAndStopsOnlyNonFiniteStates) {
  HexapodPriorOptions o;
  o.pool_capacity = 1;
  o.guard.policy = StateGuardPolicy::kClamp;
  const HexapodPrior prior(o);
  const Eigen::VectorXd phi = Eigen::VectorXd::Constant(1, -1.0);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(18);
  u[0] = 0.2;
  Eigen::VectorXd x = HexapodTask().initial_state();
  x[4] = -2.0;            // femur of leg 1 beyond -pi/4 - 0.5
  x[kBodyPos + 2] = 1.7;  // above max_height 1 m
  Eigen::VectorXd repaired;
  EXPECT_FALSE(prior.guard_state(x, &repaired));
  EXPECT_NEAR(repaired[4], -kPi / 4, 1e-15);
  EXPECT_EQ(repaired[kBodyPos + 2], 1.0);
  Eigen::VectorXd dx(48);
  prior.evaluate(x, u, phi, dx);
  ASSERT_TRUE(dx.allFinite());
  // x + dx is the prior's successor of the repaired state.
  PriorSimulator sim;
  sim.set_state(repaired);
  sim.step(u);
  EXPECT_LT((x + dx - sim.state()).cwiseAbs().maxCoeff(), 1e-12);
  Eigen::VectorXd nan_x = x;
  nan_x[0] = std::nan("");
  prior.evaluate(nan_x, u, phi, dx);
  EXPECT_TRUE(dx.array().isNaN().all());
  StateGuardCounts c = prior.guard_counts();
  EXPECT_EQ(c.evaluations, 2);
  EXPECT_EQ(c.clamped, 1);
  EXPECT_EQ(c.stopped, 1);
  const_cast<HexapodPrior&>(prior).reset_guard_counts();
  c = prior.guard_counts();
  EXPECT_EQ(c.evaluations + c.clamped + c.stopped, 0);
}

TEST(HexapodStateGuard, RejectsInvalidOptions) {
  HexapodPriorOptions o;
  o.guard.min_height = 1.0;
  o.guard.max_height = 0.5;
  EXPECT_THROW(HexapodPrior{o}, InvalidArgument);
}

}  // namespace
}  // namespace drops::hexapod
