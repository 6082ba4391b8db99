// The RealAIGym leaderboards' plant (drops/realaigym/plant.hpp) against oracles: conservation of
// its total energy without torque and friction, the power balance dE/dt = tau' qd with torque,
// and the analytic double pendulum of tests/double_pendulum.hpp (Lagrange, written independently)
// in the same coordinates. Its agreement with the lab's published trajectories is
// docs/decisions/realaigym-scorer.md.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "double_pendulum.hpp"
#include "drops/core/errors.hpp"
#include "drops/realaigym/plant.hpp"

namespace rg = drops::realaigym;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The lab's parameters in the fixture's terms: the lab's I_i is about joint i, the fixture's about
// the centre of mass (I_com = I - m r^2); no rotor, no friction.
drops::fixtures::DoublePendulumParams as_fixture(const rg::PlantParameters& p) {
  drops::fixtures::DoublePendulumParams f;
  f.mass = p.mass;
  f.com_along = p.com;
  f.com_across = {0.0, 0.0};
  for (int i = 0; i < 2; ++i) f.inertia[i] = p.inertia[i] - p.mass[i] * p.com[i] * p.com[i];
  f.length1 = p.length[0];
  f.gravity = p.gravity;
  return f;
}

}  // namespace

TEST(RealAIGymPlant, PresetsAreValidAndCarryTheLeaderboardChanges) {
  for (const rg::PlantParameters& p : {rg::design_c1_model_1_0(), rg::design_a0_model_2_0()}) {
    std::string why;
    EXPECT_TRUE(p.IsValid(&why)) << why;
    EXPECT_EQ(p.torque_limit[0], 6.0);
    EXPECT_EQ(p.torque_limit[1], 0.0);
    EXPECT_EQ(p.motor_inertia, 0.0);
    EXPECT_EQ(p.damping[0] + p.damping[1] + p.coulomb[0] + p.coulomb[1], 0.0);
    EXPECT_DOUBLE_EQ(p.length[0] + p.length[1], 0.5);
  }
  EXPECT_EQ(rg::design_c1_model_1_0().length[0], 0.2);
  EXPECT_EQ(rg::design_a0_model_2_0().length[0], 0.3);
  rg::PlantParameters bad = rg::design_c1_model_1_0();
  bad.mass[1] = -1.0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("m2"), std::string::npos);
}

TEST(RealAIGymPlant, AccelerationsMatchTheAnalyticDoublePendulumInTheSameCoordinates) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-kPi, kPi), speed(-8.0, 8.0), torque(-6.0, 6.0);
  for (const rg::PlantParameters& p : {rg::design_c1_model_1_0(), rg::design_a0_model_2_0()}) {
    const drops::fixtures::DoublePendulumParams f = as_fixture(p);
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::Vector4d x(angle(rng), angle(rng), speed(rng), speed(rng));
      const Eigen::Vector2d tau(torque(rng), torque(rng));
      const Eigen::Vector2d ours = rg::joint_accelerations(p, x, tau);
      const Eigen::Vector2d oracle = drops::fixtures::joint_accelerations(f, x, tau);
      EXPECT_LT((ours - oracle).cwiseAbs().maxCoeff(), 1e-9 * (1 + oracle.norm()))
          << "x = " << x.transpose() << ", tau = " << tau.transpose();
      EXPECT_NEAR(rg::total_energy(p, x), drops::fixtures::energy(f, x), 1e-10);
    }
  }
}

TEST(RealAIGymPlant, TotalEnergyIsConservedWithoutTorqueAndFrictionOverTenSecondsAtTwoMs) {
  for (rg::PlantParameters p : {rg::design_c1_model_1_0(), rg::design_a0_model_2_0()}) {
    p.motor_inertia = 6.287203962819607e-05;  // the rotor terms too (design C.1's Ir)
    Eigen::Vector4d x(2.5, -1.0, 0.5, -2.0);
    const double e0 = rg::total_energy(p, x);
    double worst = 0;
    for (int k = 0; k < 5000; ++k) {
      x = rg::rk4_step(p, x, Eigen::Vector2d::Zero(), 0.002);
      worst = std::max(worst, std::abs(rg::total_energy(p, x) - e0));
    }
    // RK4's error at 2 ms on this chaotic motion stays far below the energy's scale (~6 J).
    EXPECT_LT(worst, 1e-5) << "E0 = " << e0;
  }
}

TEST(RealAIGymPlant, EnergyChangesAtThePowerOfTheJointTorques) {
  const rg::PlantParameters p = rg::design_c1_model_1_0();
  const Eigen::Vector4d x(0.7, 1.9, 1.5, -3.0);
  const Eigen::Vector2d tau(2.0, -0.5);  // applied as given: the dynamics do not clip
  const double h = 1e-5;
  // Central difference of E along the motion against tau' qd.
  const double rate = (rg::total_energy(p, rg::rk4_step(p, x, tau, h)) -
                       rg::total_energy(p, rg::rk4_step(p, x, tau, -h))) /
                      (2 * h);
  EXPECT_NEAR(rate, tau.dot(x.tail<2>()), 1e-6);
  // With friction, the friction's power is lost too: b qd^2 + cf atan(100 qd) qd.
  rg::PlantParameters f = p;
  f.damping = {0.01, 0.02};
  f.coulomb = {0.1, 0.05};
  const double rate_f = (rg::total_energy(f, rg::rk4_step(f, x, tau, h)) -
                         rg::total_energy(f, rg::rk4_step(f, x, tau, -h))) /
                        (2 * h);
  double loss = 0;
  for (int i = 0; i < 2; ++i) {
    const double qd = x[2 + i];
    loss += f.damping[i] * qd * qd + f.coulomb[i] * std::atan(100 * qd) * qd;
  }
  EXPECT_NEAR(rate_f, tau.dot(x.tail<2>()) - loss, 1e-6);
}

TEST(RealAIGymPlant, TorqueIsClippedToTheLimitsAndJointTwoIsPassive) {
  const rg::PlantParameters p = rg::design_c1_model_1_0();
  EXPECT_EQ(rg::applied_torque(p, {10.0, 3.0}), Eigen::Vector2d(6.0, 0.0));
  EXPECT_EQ(rg::applied_torque(p, {-7.0, -1.0}), Eigen::Vector2d(-6.0, 0.0));
  EXPECT_EQ(rg::applied_torque(p, {2.5, 0.0}), Eigen::Vector2d(2.5, 0.0));
  // simulate_torques clips: a commanded joint-2 torque changes nothing.
  drops::MatrixXd a(100, 2), b(100, 2);
  a.col(0).setConstant(1.0);
  a.col(1).setZero();
  b.col(0).setConstant(1.0);
  b.col(1).setConstant(3.0);
  EXPECT_EQ(rg::simulate_torques(p, Eigen::Vector4d::Zero(), a, 0.002),
            rg::simulate_torques(p, Eigen::Vector4d::Zero(), b, 0.002));
  EXPECT_THROW(rg::simulate_torques(p, Eigen::Vector4d::Zero(), a, 0.0), drops::InvalidArgument);
  EXPECT_THROW(rg::simulate_torques(p, Eigen::Vector4d::Zero(), drops::MatrixXd(3, 1), 0.002),
               drops::InvalidArgument);
}

TEST(RealAIGymPlant, HangingAtRestIsAnEquilibriumAndUprightPutsTheTipAtTheTotalLength) {
  const rg::PlantParameters p = rg::design_c1_model_1_0();
  const drops::MatrixXd states =
      rg::simulate_torques(p, Eigen::Vector4d::Zero(), drops::MatrixXd::Zero(5000, 2), 0.002);
  EXPECT_EQ(states.bottomRows(1).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::Vector2d up = rg::end_effector_position(0.2, 0.3, {kPi, 0.0});
  EXPECT_NEAR(up[0], 0.0, 1e-15);
  EXPECT_NEAR(up[1], 0.5, 1e-15);
  const Eigen::Vector2d bent = rg::end_effector_position(0.2, 0.3, {kPi / 2, kPi / 2});
  EXPECT_NEAR(bent[0], 0.2, 1e-15);  // link 1 horizontal, link 2 pointing up
  EXPECT_NEAR(bent[1], 0.3, 1e-15);
}
