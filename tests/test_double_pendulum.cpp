// The analytic double pendulum of tests/double_pendulum.hpp (the oracle of the robot-description
// priors) against oracles of its own: energy conservation, the work-energy balance, the
// Euler-Lagrange equations of a Lagrangian written from Cartesian velocities (finite differences),
// and the pendubot's hand-written equations.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "double_pendulum.hpp"
#include "drops/core/rng.hpp"
#include "drops/pendubot/pendubot.hpp"

using namespace drops;
using fixtures::DoublePendulumParams;

namespace {

// Every parameter away from its special values: centres of mass off the links' lines, unequal
// links, rotor inertia, a torque scale, damping and friction.
DoublePendulumParams general_params() {
  DoublePendulumParams p;
  p.mass = {0.7, 0.45};
  p.com_along = {0.21, 0.14};
  p.com_across = {0.03, -0.02};
  p.inertia = {0.011, 0.006};
  p.length1 = 0.35;
  p.damping = {0.05, 0.03};
  p.coulomb = {0.08, 0.12};
  p.coulomb_velocity = 0.05;
  p.armature = {0.002, 0.0015};
  p.torque_scale = {1.5, 0.8};
  p.gravity = 9.81;
  return p;
}

DoublePendulumParams without_friction(DoublePendulumParams p) {
  p.damping = {0, 0};
  p.coulomb = {0, 0};
  return p;
}

Eigen::Vector4d random_state(Rng& rng, double max_speed) {
  const double pi = std::numbers::pi;
  return {rng.uniform(-pi, pi), rng.uniform(-pi, pi), rng.uniform(-max_speed, max_speed),
          rng.uniform(-max_speed, max_speed)};
}

}  // namespace

TEST(DoublePendulum, ConservesEnergyOverTwoSecondsOfRk4WithoutFrictionOrTorque) {
  const double h = 1e-3;
  Rng rng(11);
  for (const auto& p : {without_friction(general_params()),
                        without_friction(fixtures::dfki_urdf_double_pendulum())}) {
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::Vector4d x = random_state(rng, 4.0);
      const double e0 = fixtures::energy(p, x);
      double drift = 0;
      for (int k = 0; k < 2000; ++k) {
        x = fixtures::rk4_step(p, x, Eigen::Vector2d::Zero(), h);
        drift = std::max(drift, std::abs(fixtures::energy(p, x) - e0));
      }
      // RK4's truncation: at 1 ms the drift is 2e-11 to 2e-8 J (energies of 0.2 to 3 J) and 16
      // times smaller at 0.5 ms; a wrong sign or factor in the Coriolis or gravity terms gives
      // drifts of 1e-2 J or more.
      EXPECT_LT(drift, 1e-7) << "trial " << trial << " from " << x.transpose();
    }
  }
}

TEST(DoublePendulum, EnergyChangesByTheWorkOfTheTorquesAndTheFriction) {
  // E(T) - E(0) = integral of (tau - friction) . qd dt along the trajectory (Simpson's rule).
  const double h = 1e-3;
  const int steps = 2000;
  const DoublePendulumParams p = general_params();
  Rng rng(12);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::Vector4d x = random_state(rng, 3.0);
    const Eigen::Vector2d u(rng.uniform(-1, 1), rng.uniform(-1, 1));
    const Eigen::Vector2d tau(p.torque_scale[0] * u[0], p.torque_scale[1] * u[1]);
    auto power = [&](const Eigen::Vector4d& s) {
      return (tau - fixtures::friction_torques(p, s.tail<2>())).dot(s.tail<2>());
    };
    const double e0 = fixtures::energy(p, x);
    double work = power(x);
    for (int k = 1; k <= steps; ++k) {
      x = fixtures::rk4_step(p, x, u, h);
      work += (k == steps ? 1 : (k % 2 ? 4 : 2)) * power(x);
    }
    work *= h / 3;
    const double change = fixtures::energy(p, x) - e0;
    EXPECT_GT(std::abs(change), 1e-2);  // the balance below is not trivially 0 = 0
    // Simpson's rule and RK4 leave ~1.5e-6 J; a friction or torque with a wrong sign or factor
    // changes the balance by ~0.1 J.
    EXPECT_NEAR(change, work, 1e-5) << "trial " << trial;
  }
}

TEST(DoublePendulum, AccelerationsSatisfyTheEulerLagrangeEquationsOfTheCartesianLagrangian) {
  // d/dt dL/dqd - dL/dq = tau - friction, with L = T - V from the centres of mass' Cartesian
  // velocities and the derivatives by central differences. The accelerations come from the batch
  // function (B = 200), so it is checked too.
  const DoublePendulumParams p = general_params();
  Rng rng(13);
  const int batch = 200;
  MatrixXd x(batch, 4), u(batch, 2);
  for (int b = 0; b < batch; ++b) {
    x.row(b) = random_state(rng, 5.0).transpose();
    u.row(b) << rng.uniform(-2, 2), rng.uniform(-2, 2);
  }
  const MatrixXd qdd = fixtures::batch_joint_accelerations(p, x, u);
  ASSERT_EQ(qdd.rows(), batch);
  ASSERT_EQ(qdd.cols(), 2);
  auto L = [&](const Eigen::Vector4d& s) { return fixtures::lagrangian(p, s); };
  // dL/dqd (L is quadratic in qd: central differences are exact up to round-off).
  auto momentum = [&](const Eigen::Vector4d& s) {
    const double e = 1e-3;
    Eigen::Vector2d m;
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector4d a = s, b = s;
      a[2 + i] += e;
      b[2 + i] -= e;
      m[i] = (L(a) - L(b)) / (2 * e);
    }
    return m;
  };
  double worst = 0;
  for (int b = 0; b < batch; ++b) {
    const Eigen::Vector4d s = x.row(b).transpose();
    const Eigen::Vector2d a = qdd.row(b).transpose();
    // d/dt momentum = (d momentum / dq) qd + (d momentum / dqd) qdd, as directional differences.
    const double eq = 1e-4, ev = 1e-3;
    Eigen::Vector4d sp = s, sm = s;
    sp.head<2>() += eq * s.tail<2>();
    sm.head<2>() -= eq * s.tail<2>();
    Eigen::Vector2d dmomentum = (momentum(sp) - momentum(sm)) / (2 * eq);
    sp = s;
    sm = s;
    sp.tail<2>() += ev * a;
    sm.tail<2>() -= ev * a;
    dmomentum += (momentum(sp) - momentum(sm)) / (2 * ev);
    Eigen::Vector2d dLdq;
    for (int i = 0; i < 2; ++i) {
      const double e = 1e-5;
      Eigen::Vector4d c = s, d = s;
      c[i] += e;
      d[i] -= e;
      dLdq[i] = (L(c) - L(d)) / (2 * e);
    }
    const Eigen::Vector2d tau(p.torque_scale[0] * u(b, 0), p.torque_scale[1] * u(b, 1));
    const Eigen::Vector2d residual =
        dmomentum - dLdq - (tau - fixtures::friction_torques(p, s.tail<2>()));
    worst = std::max(worst, residual.cwiseAbs().maxCoeff());
  }
  // Torques here are ~1 N m; the differences' truncation and round-off are ~1e-8 N m.
  EXPECT_LT(worst, 1e-6);
}

TEST(DoublePendulum, EqualsThePendubotsEquationsForUniformRodsWithoutFriction) {
  // tasks/pendubot: absolute angles from upright, x = [dth1, dth2, th1, th2], torque on joint 1.
  pendubot::Params pp;
  pp.m1 = 0.6;
  pp.m2 = 0.4;
  pp.l1 = 0.5;
  pp.l2 = 0.35;
  pp.b1 = pp.b2 = 0;
  DoublePendulumParams p;
  p.mass = {pp.m1, pp.m2};
  p.com_along = {pp.l1 / 2, pp.l2 / 2};
  p.inertia = {pp.m1 * pp.l1 * pp.l1 / 12, pp.m2 * pp.l2 * pp.l2 / 12};
  p.length1 = pp.l1;
  p.gravity = pp.g;
  Rng rng(14);
  const double pi = std::numbers::pi;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector4d x = random_state(rng, 6.0);
    const double u = rng.uniform(-3, 3);
    const Eigen::Vector2d a = fixtures::joint_accelerations(p, x, Eigen::Vector2d(u, 0));
    const auto d = pendubot::derivative(pp, {x[2], x[2] + x[3], x[0] + pi, x[0] + x[1] + pi}, u);
    EXPECT_NEAR(a[0], d[0], 1e-10 * (1 + std::abs(d[0])));
    EXPECT_NEAR(a[0] + a[1], d[1], 1e-10 * (1 + std::abs(d[1])));
  }
}
