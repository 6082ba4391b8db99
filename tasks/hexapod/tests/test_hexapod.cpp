// Tests of drops::hexapod: the robot model, the gait controller, the prior simulator and the prior
// mean function with its simulator pool.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/robot.hpp"
#include "drops/hexapod/simulator.hpp"

namespace drops::hexapod {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::VectorXd tripod_params(double lift_lag = 0.0) { return tripod_gait(lift_lag); }

// Runs `steps` control steps of the gait theta from reset; returns the final state.
Eigen::VectorXd walk(PriorSimulator& sim, const Eigen::VectorXd& theta, int steps) {
  GaitController ctrl;
  ctrl.set_params(theta);
  sim.reset();
  for (int n = 0; n < steps; ++n) sim.step(ctrl.targets(n * 0.1));
  return sim.state();
}

int count_prefix(const std::vector<std::string>& names, const std::string& prefix) {
  return static_cast<int>(std::count_if(
      names.begin(), names.end(), [&](const std::string& n) { return n.rfind(prefix, 0) == 0; }));
}

// ---------------- robot model ----------------

TEST(HexapodRobot, SpecDefaultsMatchSettingsAndValidate) {
  const HexapodSpec spec = HexapodSpec::intact();
  EXPECT_TRUE(spec.IsValid());
  const double total = spec.body_mass + 6 * (spec.hip_mass + spec.femur_mass + spec.tibia_mass);
  EXPECT_NEAR(total, 2.495, 1e-12);
  EXPECT_EQ(spec.num_present_legs(), 6);
  EXPECT_EQ(HexapodSpec::with_leg_removed(3).num_present_legs(), 5);
  EXPECT_THROW(HexapodSpec::with_leg_removed(6), InvalidArgument);
  HexapodSpec bad = spec;
  bad.legs[2].blocked_joint = 1;
  bad.legs[2].blocked_angle = 1.0;  // > pi/4
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("legs[2].blocked_angle"), std::string::npos) << why;
  bad = spec;
  bad.legs[4].tibia_length_factor = 0.0;
  EXPECT_THROW(bad.check(), InvalidArgument);
}

TEST(HexapodRobot, IntactModelHasNamedBodiesJointsAndFeet) {
  PriorSimulator sim;
  EXPECT_EQ(sim.num_dofs(), 6 + 18);
  EXPECT_NEAR(sim.mass(), 2.495, 1e-12);
  EXPECT_EQ(sim.body_names().size(), 19u);
  EXPECT_EQ(sim.joint_names().size(), 19u);
  EXPECT_EQ(sim.body_names()[0], "body");
  EXPECT_EQ(sim.joint_names()[0], "root");
  EXPECT_EQ(joint_name(3, 0), "leg3_hip");
  EXPECT_EQ(body_name(5, 2), "leg5_tibia_link");
  const auto joints = sim.joint_names();
  const auto shapes = sim.shape_names();
  for (int k = 0; k < kNumLegs; ++k) {
    for (int j = 0; j < kJointsPerLeg; ++j) {
      EXPECT_EQ(std::count(joints.begin(), joints.end(), joint_name(k, j)), 1);
    }
    EXPECT_EQ(std::count(shapes.begin(), shapes.end(), foot_name(k)), 1);
  }
}

TEST(HexapodRobot, ModelLoadsAndStandsWithZeroTargets) {
  PriorSimulator sim;
  const Eigen::VectorXd x0 = sim.state();
  EXPECT_DOUBLE_EQ(x0[kBodyPos + 2], 0.2);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(kNumJoints);
  for (int n = 0; n < 20; ++n) sim.step(zero);  // 2 s
  const Eigen::VectorXd x = sim.state();
  std::string why;
  EXPECT_TRUE(check_state(x, sim.spec(), &why)) << why;
  // Standing height: tibia (0.14) + foot radius (0.025) below the hip joints, which are at the
  // body's centre height.
  EXPECT_NEAR(x[kBodyPos + 2], 0.165, 0.01);
  EXPECT_LT(std::abs(x[kBodyRpy + 0]), 0.02);
  EXPECT_LT(std::abs(x[kBodyRpy + 1]), 0.02);
  EXPECT_LT(std::abs(x[kBodyPos + 0]), 0.01);
  EXPECT_LT(std::abs(x[kBodyPos + 1]), 0.01);
  EXPECT_LT(x.segment<3>(kBodyLinVel).norm(), 0.01);
  EXPECT_LT(x.segment(kJointPos, kNumJoints).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_NEAR(sim.time(), 2.0, 1e-12);
}

TEST(HexapodRobot, RemovingLegKRemovesExactlyThatLeg) {
  for (int k = 0; k < kNumLegs; ++k) {
    SCOPED_TRACE("removed leg " + std::to_string(k));
    PriorSimulator sim(HexapodSpec::with_leg_removed(k));
    const auto bodies = sim.body_names();
    const auto joints = sim.joint_names();
    const auto shapes = sim.shape_names();
    EXPECT_EQ(bodies.size(), 16u);           // 19 - 3 links
    EXPECT_EQ(joints.size(), 16u);           // 19 - 3 joints
    EXPECT_EQ(shapes.size(), 1u + 5u * 4u);  // body + (3 links + foot) per remaining leg
    EXPECT_EQ(sim.num_dofs(), 6 + 15);
    EXPECT_NEAR(sim.mass(), 2.495 - (0.02 + 0.184 + 0.04), 1e-12);
    const std::string gone = "leg" + std::to_string(k) + "_";
    EXPECT_EQ(count_prefix(bodies, gone), 0);
    EXPECT_EQ(count_prefix(joints, gone), 0);
    EXPECT_EQ(count_prefix(shapes, gone), 0);
    for (int other = 0; other < kNumLegs; ++other) {
      if (other == k) continue;
      const std::string kept = "leg" + std::to_string(other) + "_";
      EXPECT_EQ(count_prefix(bodies, kept), 3);
      EXPECT_EQ(count_prefix(joints, kept), 3);
      EXPECT_EQ(count_prefix(shapes, kept), 4);
    }
  }
}

TEST(HexapodRobot, RobotWithoutARearLegStillStandsUp) {
  PriorSimulator sim(HexapodSpec::with_leg_removed(0));
  for (int n = 0; n < 20; ++n) sim.step(Eigen::VectorXd::Zero(kNumJoints));
  const Eigen::VectorXd x = sim.state();
  EXPECT_GT(x[kBodyPos + 2], 0.1);
  EXPECT_LT(std::abs(x[kBodyRpy + 0]) + std::abs(x[kBodyRpy + 1]), 0.5);
}

TEST(HexapodRobot, BlockedJointStaysAtItsAngle) {
  HexapodSpec spec;
  spec.legs[1].blocked_joint = 1;
  spec.legs[1].blocked_angle = 0.3;
  PriorSimulator sim(spec);
  EXPECT_DOUBLE_EQ(sim.state()[kJointPos + 4], 0.3);
  walk(sim, tripod_params(), 10);
  const Eigen::VectorXd x = sim.state();
  EXPECT_NEAR(x[kJointPos + 4], 0.3, 1e-12);
  EXPECT_NEAR(x[kJointVel + 4], 0.0, 1e-12);
  // The other joints of that leg still move.
  EXPECT_GT(std::abs(x[kJointPos + 3]), 0.01);
}

// ---------------- controller ----------------

TEST(HexapodController, KernelIsNormalisedSymmetricGaussian) {
  const Eigen::VectorXd g = smoothing_kernel();
  ASSERT_EQ(g.size(), 21);
  EXPECT_NEAR(g.sum(), 1.0, 1e-15);
  double z = 0.0;  // hand computation: sum_{j=-10}^{10} exp(-j^2 / 18)
  for (int j = -10; j <= 10; ++j) z += std::exp(-j * j / 18.0);
  EXPECT_NEAR(z, 7.5166, 1e-3);
  for (int j = 0; j <= 10; ++j) {
    EXPECT_NEAR(g[10 + j], g[10 - j], 1e-17);
    EXPECT_NEAR(g[10 + j], std::exp(-j * j / 18.0) / z, 1e-15);
  }
}

TEST(HexapodController, SquareWaveDutyPhaseAndAmplitude) {
  const double g0 = smoothing_kernel()[10];
  // duty 0.3, phase 0: samples 0..29 positive (30 = 0.3 * 100), 30..99 negative.
  const Eigen::VectorXd s = periodic_signal(1.0, 0.0, 0.3);
  ASSERT_EQ(s.size(), 100);
  EXPECT_EQ((s.array() > 0).count(), 30);
  for (int i = 0; i < 30; ++i) EXPECT_GT(s[i], 0.0) << i;
  EXPECT_DOUBLE_EQ(s[15], 1.0);     // window 5..25 is all +1
  EXPECT_NEAR(s[65], -1.0, 1e-15);  // window 55..75 is all -1
  // At an edge the symmetric kernel leaves only its centre tap: +-g0.
  EXPECT_NEAR(s[29], g0, 1e-15);
  EXPECT_NEAR(s[30], -g0, 1e-15);
  EXPECT_NEAR(s[99], -g0, 1e-15);  // circular: the falling edge before sample 0
  EXPECT_NEAR(s[0], g0, 1e-15);
  // Duty fraction for other values.
  EXPECT_EQ((periodic_signal(1.0, 0.0, 0.5).array() > 0).count(), 50);
  EXPECT_EQ((periodic_signal(1.0, 0.0, 0.75).array() > 0).count(), 75);
  EXPECT_TRUE(periodic_signal(0.7, 0.3, 0.0).isApprox(Eigen::VectorXd::Constant(100, -0.7)));
  EXPECT_TRUE(periodic_signal(0.7, 0.3, 1.0).isApprox(Eigen::VectorXd::Constant(100, 0.7)));
  // Phase 0.25 delays the wave by 25 samples: positive samples are 25..54.
  const Eigen::VectorXd shifted = periodic_signal(1.0, 0.25, 0.3);
  for (int i = 0; i < 100; ++i) EXPECT_DOUBLE_EQ(shifted[i], s[(i - 25 + 100) % 100]) << i;
  EXPECT_LT(shifted[24], 0.0);
  EXPECT_GT(shifted[25], 0.0);
  EXPECT_GT(shifted[54], 0.0);
  EXPECT_LT(shifted[55], 0.0);
  // Phase 1 is phase 0; amplitude scales linearly.
  EXPECT_EQ(periodic_signal(1.0, 1.0, 0.3), s);
  EXPECT_TRUE(periodic_signal(0.4, 0.0, 0.3).isApprox(0.4 * s, 1e-15));
  EXPECT_THROW(periodic_signal(1.1, 0.0, 0.3), InvalidArgument);
  EXPECT_THROW(periodic_signal(1.0, -0.1, 0.3), InvalidArgument);
}

TEST(HexapodController, TargetsMapSignalsToJointsWithPeriodOneSecond) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(36);
  // Leg 2: hip (amplitude 1, phase 0, duty 0.5); femur/tibia (amplitude 0.5, phase 0.5, duty 0.5).
  theta.segment<6>(12) << 1.0, 0.0, 0.5, 0.5, 0.5, 0.5;
  GaitController ctrl;
  ctrl.set_params(theta);
  // t = 0.1 s -> sample 10: hip window 0..20 all +1; knee (positive on 50..99) window all -0.5.
  const Eigen::VectorXd q = ctrl.targets(0.1);
  ASSERT_EQ(q.size(), 18);
  EXPECT_NEAR(q[6], kPi / 8, 1e-15);
  EXPECT_NEAR(q[7], -kPi / 8, 1e-15);  // (pi/4) * (-0.5)
  EXPECT_NEAR(q[8], kPi / 8, 1e-15);   // -(pi/4) * (-0.5)
  // t = 0.7 s -> sample 70: hip -1, knee +0.5.
  const Eigen::VectorXd q7 = ctrl.targets(0.7);
  EXPECT_NEAR(q7[6], -kPi / 8, 1e-15);
  EXPECT_NEAR(q7[7], kPi / 8, 1e-15);
  EXPECT_NEAR(q7[8], -kPi / 8, 1e-15);
  // Other legs: amplitude 0 -> 0.
  for (int i = 0; i < 18; ++i) {
    if (i < 6 || i > 8) {
      EXPECT_EQ(q[i], 0.0) << i;
    }
  }
  // Period 1 s; t = step * 0.1 lands on the intended sample despite rounding.
  EXPECT_EQ(ctrl.targets(0.3), ctrl.targets(1.3));
  EXPECT_EQ(ctrl.targets(0.3), ctrl.targets(3.3));
  EXPECT_EQ(ctrl.sample_index(29 * 0.01), 29);
  EXPECT_EQ(ctrl.sample_index(7 * 0.1), 70);
  EXPECT_EQ(ctrl.sample_index(1.05), 5);
  EXPECT_EQ(ctrl.sample_index(0.999), 99);
  EXPECT_THROW(ctrl.targets(-0.1), InvalidArgument);
  theta[5] = 1.5;
  EXPECT_THROW(ctrl.set_params(theta), InvalidArgument);
  EXPECT_THROW(ctrl.set_params(Eigen::VectorXd::Zero(35)), InvalidArgument);
}

// ---------------- simulator ----------------

TEST(HexapodSimulator, RpyConversionRoundTrip) {
  const Eigen::Vector3d rpy(0.3, -0.7, 2.9);
  EXPECT_TRUE(rotation_to_rpy(rpy_to_rotation(rpy)).isApprox(rpy, 1e-12));
  EXPECT_NEAR(unwrap_near(-3.1, 3.1), -3.1 + 2 * kPi, 1e-15);
  EXPECT_NEAR(unwrap_near(0.2, 0.0), 0.2, 1e-15);
}

TEST(HexapodSimulator, SetStateOfStateIsIdentity) {
  PriorSimulator sim;
  const Eigen::VectorXd x = walk(sim, tripod_params(), 7);  // mid-stride: non-zero velocities
  EXPECT_GT(x.segment(kJointVel, kNumJoints).norm(), 0.1);
  sim.set_state(x);
  EXPECT_LT((sim.state() - x).cwiseAbs().maxCoeff(), 1e-12);

  // An arbitrary tilted, turned, moving state.
  Eigen::VectorXd y = Eigen::VectorXd::Zero(kStateDim);
  for (int i = 0; i < kNumJoints; ++i) {
    y[kJointPos + i] = 0.1 * std::sin(i + 1.0);
    y[kJointVel + i] = 0.5 * std::cos(i + 1.0);
  }
  y.segment<3>(kBodyPos) << 0.3, -0.2, 0.25;
  y.segment<3>(kBodyRpy) << 0.2, -0.3, 2.5;
  y.segment<3>(kBodyLinVel) << 0.1, -0.05, 0.02;
  y.segment<3>(kBodyAngVel) << 0.3, 0.2, -0.4;
  sim.set_state(y);
  EXPECT_LT((sim.state() - y).cwiseAbs().maxCoeff(), 1e-12);
  // Yaw is unwrapped around the state that was set.
  y[kBodyRpy + 2] = 2.5 + 4 * kPi;
  sim.set_state(y);
  EXPECT_NEAR(sim.state()[kBodyRpy + 2], y[kBodyRpy + 2], 1e-12);
  y[kBodyRpy + 2] = std::nan("");
  EXPECT_THROW(sim.set_state(y), InvalidArgument);
  EXPECT_THROW(sim.set_state(Eigen::VectorXd::Zero(47)), InvalidArgument);
}

TEST(HexapodSimulator, RollIsContinuousWhenTheBodyRollsPastPi) {
  // The body high in the air, rolled to 3.0 rad (almost on its back) and spinning about its
  // forward axis at 4 rad/s: after 0.1 s the roll is about 3.4 rad, not 3.4 - 2 pi; dx stays
  // small, and the state is still plausible for check_state.
  PriorSimulator sim;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(kStateDim);
  x[kBodyPos + 2] = 0.8;
  x[kBodyRpy] = 3.0;
  x[kBodyAngVel] = 4.0;
  sim.set_state(x);
  sim.step(Eigen::VectorXd::Zero(kNumJoints));
  const Eigen::VectorXd y = sim.state();
  EXPECT_NEAR(y[kBodyRpy], 3.4, 0.05);
  EXPECT_LT(std::abs(y[kBodyRpy] - x[kBodyRpy]), 0.5);
  std::string why;
  EXPECT_TRUE(check_state(y, sim.spec(), &why)) << why;
  // set_state(state()) keeps the continuous roll; another step keeps going the same way.
  sim.set_state(y);
  EXPECT_NEAR(sim.state()[kBodyRpy], y[kBodyRpy], 1e-12);
  sim.step(Eigen::VectorXd::Zero(kNumJoints));
  EXPECT_GT(sim.state()[kBodyRpy], y[kBodyRpy] + 0.2);
  // A roll beyond a full turn is implausible.
  Eigen::VectorXd z = y;
  z[kBodyRpy] = 7.0;
  EXPECT_FALSE(check_state(z, sim.spec(), &why));
  EXPECT_NE(why.find("x[39]"), std::string::npos) << why;
}

TEST(HexapodSimulator, TripodGaitWalksForwardUprightAndReversedLiftWalksBack) {
  PriorSimulator sim;
  const Eigen::VectorXd x = walk(sim, tripod_params(), 40);  // one 4 s episode
  std::string why;
  EXPECT_TRUE(check_state(x, sim.spec(), &why)) << why;
  EXPECT_GT(x[kBodyPos + 0], 0.4) << "about 0.28 m/s expected in the prior";
  EXPECT_LT(std::abs(x[kBodyPos + 1]), 0.3);
  EXPECT_GT(x[kBodyPos + 2], 0.1);
  EXPECT_LT(std::abs(x[kBodyRpy + 0]), 0.5);
  EXPECT_LT(std::abs(x[kBodyRpy + 1]), 0.5);
  const Eigen::VectorXd back = walk(sim, tripod_params(0.5), 40);
  EXPECT_LT(back[kBodyPos + 0], -0.1);
}

TEST(HexapodSimulator, TwoInstancesGiveBitIdenticalResults) {
  PriorSimulator a;
  PriorSimulator b;
  const Eigen::VectorXd xa = walk(a, tripod_params(), 15);
  const Eigen::VectorXd xb = walk(b, tripod_params(), 15);
  EXPECT_EQ(xa, xb);
}

TEST(HexapodSimulator, StepFromASetStateDoesNotDependOnHistory) {
  PriorSimulator a;
  PriorSimulator b;
  const Eigen::VectorXd x = walk(a, tripod_params(), 12);
  GaitController ctrl;
  ctrl.set_params(tripod_params());
  const Eigen::VectorXd u = ctrl.targets(1.2);
  a.set_state(x);
  a.step(u);
  const Eigen::VectorXd first = a.state();
  walk(b, Eigen::VectorXd::Constant(36, 0.3), 5);  // a different history
  b.set_state(x);
  b.step(u);
  a.set_state(x);
  a.step(u);
  EXPECT_EQ(b.state(), first);
  EXPECT_EQ(a.state(), first);
}

TEST(HexapodSimulator, StateGuardCatchesCorruptedStates) {
  PriorSimulator sim;
  const HexapodSpec spec;
  Eigen::VectorXd x = walk(sim, tripod_params(), 5);
  std::string why;
  EXPECT_TRUE(check_state(x, spec, &why)) << why;
  Eigen::VectorXd bad = x;
  bad[kJointVel + 3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(check_state(bad, spec, &why));
  EXPECT_NE(why.find("x[21]"), std::string::npos) << why;
  bad = x;
  bad[kJointPos + 2] = 3.0;  // far outside +-pi/4
  EXPECT_FALSE(check_state(bad, spec, &why));
  EXPECT_NE(why.find("joint angle"), std::string::npos) << why;
  bad = x;
  bad[kBodyLinVel] = 1e6;
  EXPECT_FALSE(check_state(bad, spec, &why));
  bad = x;
  bad[kBodyRpy + 1] = 7.0;  // beyond a full turn
  EXPECT_FALSE(check_state(bad, spec, &why));
  EXPECT_FALSE(check_state(Eigen::VectorXd::Zero(47), spec, &why));
  EXPECT_NE(why.find("expected size 48"), std::string::npos) << why;
}

TEST(HexapodSimulator, RejectsInvalidOptionsAndTargets) {
  PriorOptions o;
  o.control_dt = 0.105;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(PriorSimulator(HexapodSpec{}, o), InvalidArgument);
  PriorSimulator sim;
  EXPECT_THROW(sim.step(Eigen::VectorXd::Zero(17)), InvalidArgument);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(18);
  u[4] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(sim.step(u), InvalidArgument);
}

// ---------------- prior mean function and pool ----------------

TEST(HexapodPrior, InterfaceAndPhiChecks) {
  HexapodPrior prior;
  EXPECT_EQ(prior.state_dim(), 48);
  EXPECT_EQ(prior.action_dim(), 18);
  EXPECT_EQ(prior.parameter_names(), std::vector<std::string>{"removed_leg"});
  for (int k = -1; k < 6; ++k) EXPECT_NO_THROW(prior.check_phi(Eigen::VectorXd::Constant(1, k)));
  EXPECT_THROW(prior.check_phi(Eigen::VectorXd::Constant(1, 6)), InvalidArgument);
  EXPECT_THROW(prior.check_phi(Eigen::VectorXd::Constant(1, -2)), InvalidArgument);
  EXPECT_THROW(prior.check_phi(Eigen::VectorXd::Constant(1, 0.5)), InvalidArgument);
  EXPECT_THROW(prior.check_phi(Eigen::VectorXd::Zero(2)), InvalidArgument);
  const model::PriorParameters p = HexapodPrior::prior_parameters();
  ASSERT_EQ(p.choices.size(), 1u);
  EXPECT_EQ(p.choices[0].size(), 7u);
}

TEST(HexapodPrior, EvaluateIsOneSimulatorStepFromX) {
  HexapodPrior prior;
  PriorSimulator sim({}, prior.options().simulator);  // the prior's own engine (rigid by default)
  const Eigen::VectorXd x = walk(sim, tripod_params(), 8);
  GaitController ctrl;
  ctrl.set_params(tripod_params());
  const Eigen::VectorXd u = ctrl.targets(0.8);
  sim.step(u);
  const Eigen::VectorXd continued = sim.state() - x;
  sim.set_state(x);
  sim.step(u);
  const Eigen::VectorXd expected = sim.state() - x;
  Eigen::VectorXd dx(48);
  prior.evaluate(x, u, Eigen::VectorXd::Constant(1, -1), dx);
  EXPECT_EQ(dx, expected);
  // Continuing the trajectory instead of restarting from x differs only by the rounding of the
  // state round trip (orientation and velocity frame conversions).
  EXPECT_LT((dx - continued).cwiseAbs().maxCoeff(), 1e-9);
  // Removing a leg changes the prediction; the removed leg's joints still track u kinematically.
  Eigen::VectorXd dx3(48);
  prior.evaluate(x, u, Eigen::VectorXd::Constant(1, 3), dx3);
  EXPECT_GT((dx3 - dx).norm(), 1e-6);
  for (int j = 9; j < 12; ++j) {
    EXPECT_LT(std::abs(x[j] + dx3[j] - u[j]), std::abs(x[j] - u[j]) + 1e-12) << j;
  }
  // A non-finite x gives NaNs (the MeanFunction contract), not an exception.
  Eigen::VectorXd bad = x;
  bad[40] = std::numeric_limits<double>::infinity();
  prior.evaluate(bad, u, Eigen::VectorXd::Constant(1, -1), dx);
  EXPECT_TRUE(dx.array().isNaN().all());
  EXPECT_THROW(prior.evaluate(x, Eigen::VectorXd::Zero(17), Eigen::VectorXd::Constant(1, -1), dx),
               InvalidArgument);
}

TEST(HexapodPrior, SameResultsWithOneAndTwoThreads) {
  // A batch of (x, u, phi) from a short walk, evaluated serially and by two threads that share
  // one prior (two simulators per pool).
  PriorSimulator sim;
  GaitController ctrl;
  ctrl.set_params(tripod_params());
  std::vector<Eigen::VectorXd> xs, us;
  sim.reset();
  for (int n = 0; n < 12; ++n) {
    xs.push_back(sim.state());
    us.push_back(ctrl.targets(n * 0.1));
    sim.step(us.back());
  }
  const int m = static_cast<int>(xs.size());
  auto phi_of = [](int i) { return Eigen::VectorXd::Constant(1, (i % 3 == 0) ? -1.0 : i % 6); };

  HexapodPriorOptions one;
  one.pool_capacity = 1;
  HexapodPrior serial(one);
  std::vector<Eigen::VectorXd> expected(m, Eigen::VectorXd(48));
  for (int i = 0; i < m; ++i) serial.evaluate(xs[i], us[i], phi_of(i), expected[i]);

  HexapodPriorOptions two;
  two.pool_capacity = 2;
  HexapodPrior parallel(two);
  std::vector<Eigen::VectorXd> got(m, Eigen::VectorXd(48));
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i = next++; i < m; i = next++) parallel.evaluate(xs[i], us[i], phi_of(i), got[i]);
  };
  std::thread t1(worker), t2(worker);
  t1.join();
  t2.join();
  for (int i = 0; i < m; ++i) EXPECT_EQ(got[i], expected[i]) << i;
}

TEST(HexapodPrior, PoolBlocksWhenAllSimulatorsAreLeased) {
  SimulatorPool pool(HexapodSpec{}, PriorOptions{}, 1);
  std::atomic<bool> acquired{false};
  auto lease = std::make_unique<SimulatorPool::Lease>(pool.acquire());
  std::thread other([&] {
    SimulatorPool::Lease l = pool.acquire();
    acquired = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(acquired.load()) << "the second acquire must wait for the lease to come back";
  lease.reset();
  other.join();
  EXPECT_TRUE(acquired.load());
  EXPECT_EQ(pool.created(), 1);
  EXPECT_THROW(SimulatorPool(HexapodSpec{}, PriorOptions{}, -1), InvalidArgument);
}

TEST(HexapodPrior, CloneIsIndependentAndEqual) {
  HexapodPrior prior;
  auto copy = prior.clone();
  PriorSimulator sim;
  const Eigen::VectorXd x = walk(sim, tripod_params(), 3);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(18, 0.1);
  Eigen::VectorXd a(48), b(48);
  prior.evaluate(x, u, Eigen::VectorXd::Constant(1, 2), a);
  copy->evaluate(x, u, Eigen::VectorXd::Constant(1, 2), b);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace drops::hexapod
