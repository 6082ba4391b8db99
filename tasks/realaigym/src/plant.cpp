#include "drops/realaigym/plant.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "drops/core/errors.hpp"

namespace drops::realaigym {

namespace {

bool check(bool ok, const std::string& message, std::string* why) {
  if (!ok && why != nullptr) *why = message;
  return ok;
}

// The leaderboards' changes to an identified model: a passive joint 2, no rotor, no friction.
PlantParameters with_leaderboard_changes(PlantParameters p) {
  p.torque_limit = {6.0, 0.0};
  p.motor_inertia = 0.0;
  p.damping = {0.0, 0.0};
  p.coulomb = {0.0, 0.0};
  return p;
}

}  // namespace

bool PlantParameters::IsValid(std::string* why) const {
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i + 1);
    if (!check(std::isfinite(mass[i]) && mass[i] > 0, "m" + n + " must be > 0", why) ||
        !check(std::isfinite(length[i]) && length[i] > 0, "l" + n + " must be > 0", why) ||
        !check(std::isfinite(com[i]) && com[i] >= 0, "r" + n + " must be >= 0", why) ||
        !check(std::isfinite(inertia[i]) && inertia[i] > 0, "I" + n + " must be > 0", why) ||
        !check(std::isfinite(damping[i]) && damping[i] >= 0, "b" + n + " must be >= 0", why) ||
        !check(std::isfinite(coulomb[i]) && coulomb[i] >= 0, "cf" + n + " must be >= 0", why) ||
        !check(std::isfinite(torque_limit[i]) && torque_limit[i] >= 0, "tl" + n + " must be >= 0",
               why)) {
      return false;
    }
  }
  return check(std::isfinite(motor_inertia) && motor_inertia >= 0, "Ir must be >= 0", why) &&
         check(std::isfinite(gear_ratio) && gear_ratio > 0, "gr must be > 0", why) &&
         check(std::isfinite(gravity) && gravity >= 0, "g must be >= 0", why);
}

PlantParameters design_c1_model_1_0() {
  PlantParameters p;
  p.mass = {0.5234602302310271, 0.6255677234174437};
  p.length = {0.2, 0.3};
  p.com = {0.2, 0.25569305436052964};
  p.inertia = {0.031887199591513114, 0.05086984812807257};
  p.gear_ratio = 6.0;
  p.gravity = 9.81;
  return with_leaderboard_changes(p);
}

PlantParameters design_a0_model_2_0() {
  PlantParameters p;
  p.mass = {0.5593806151425046, 0.6043459469186889};
  p.length = {0.3, 0.2};
  p.com = {0.3, 0.18377686083653508};
  p.inertia = {0.053470810264216295, 0.02392374528789766};
  p.gear_ratio = 6.0;
  p.gravity = 9.81;
  return with_leaderboard_changes(p);
}

Eigen::Vector2d applied_torque(const PlantParameters& p, const Eigen::Vector2d& tau) {
  return {std::clamp(tau[0], -p.torque_limit[0], p.torque_limit[0]),
          std::clamp(tau[1], -p.torque_limit[1], p.torque_limit[1])};
}

Eigen::Matrix2d mass_matrix(const PlantParameters& p, const Eigen::Vector2d& q) {
  const double k = p.mass[1] * p.length[0] * p.com[1] * std::cos(q[1]);
  const double ir = p.motor_inertia, gr = p.gear_ratio;
  Eigen::Matrix2d m;
  m(0, 0) = p.inertia[0] + p.inertia[1] + p.mass[1] * p.length[0] * p.length[0] + 2 * k +
            gr * gr * ir + ir;
  m(0, 1) = m(1, 0) = p.inertia[1] + k - gr * ir;
  m(1, 1) = p.inertia[1] + gr * gr * ir;
  return m;
}

Eigen::Vector2d joint_accelerations(const PlantParameters& p, const Eigen::Vector4d& x,
                                    const Eigen::Vector2d& tau) {
  const double q1 = x[0], q2 = x[1], qd1 = x[2], qd2 = x[3];
  const double k = p.mass[1] * p.length[0] * p.com[1] * std::sin(q2);
  // C(q, qd) qd
  const Eigen::Vector2d coriolis(-2 * k * qd2 * qd1 - k * qd2 * qd2, k * qd1 * qd1);
  const double s12 = std::sin(q1 + q2);
  const Eigen::Vector2d gravity(
      -p.gravity * (p.mass[0] * p.com[0] * std::sin(q1) +
                    p.mass[1] * (p.length[0] * std::sin(q1) + p.com[1] * s12)),
      -p.gravity * p.mass[1] * p.com[1] * s12);
  const Eigen::Vector2d friction(p.damping[0] * qd1 + p.coulomb[0] * std::atan(100 * qd1),
                                 p.damping[1] * qd2 + p.coulomb[1] * std::atan(100 * qd2));
  const Eigen::Vector2d force = tau - coriolis + gravity - friction;
  return mass_matrix(p, x.head<2>()).inverse() * force;
}

Eigen::Vector4d state_derivative(const PlantParameters& p, const Eigen::Vector4d& x,
                                 const Eigen::Vector2d& tau) {
  Eigen::Vector4d dx;
  dx.head<2>() = x.tail<2>();
  dx.tail<2>() = joint_accelerations(p, x, tau);
  return dx;
}

Eigen::Vector4d rk4_step(const PlantParameters& p, const Eigen::Vector4d& x,
                         const Eigen::Vector2d& tau, double dt) {
  const Eigen::Vector4d k1 = state_derivative(p, x, tau);
  const Eigen::Vector4d k2 = state_derivative(p, x + 0.5 * dt * k1, tau);
  const Eigen::Vector4d k3 = state_derivative(p, x + 0.5 * dt * k2, tau);
  const Eigen::Vector4d k4 = state_derivative(p, x + dt * k3, tau);
  return x + dt * (k1 + 2.0 * (k2 + k3) + k4) / 6.0;
}

double total_energy(const PlantParameters& p, const Eigen::Vector4d& x) {
  const Eigen::Vector2d qd = x.tail<2>();
  const double kinetic = 0.5 * qd.dot(mass_matrix(p, x.head<2>()) * qd);
  const double y1 = -p.com[0] * std::cos(x[0]);
  const double y2 = -p.length[0] * std::cos(x[0]) - p.com[1] * std::cos(x[0] + x[1]);
  return kinetic + p.gravity * (p.mass[0] * y1 + p.mass[1] * y2);
}

Eigen::Vector2d end_effector_position(double l1, double l2, const Eigen::Vector2d& q) {
  return {l1 * std::sin(q[0]) + l2 * std::sin(q[0] + q[1]),
          -l1 * std::cos(q[0]) - l2 * std::cos(q[0] + q[1])};
}

MatrixXd simulate_torques(const PlantParameters& p, const Eigen::Vector4d& x0, const MatrixXd& tau,
                          double dt) {
  check_size("simulate_torques: tau's columns", 2, tau.cols());
  if (!(dt > 0))
    throw InvalidArgument("simulate_torques: dt must be > 0, got " + std::to_string(dt));
  MatrixXd x(tau.rows() + 1, 4);
  Eigen::Vector4d xk = x0;
  x.row(0) = xk.transpose();
  for (Eigen::Index k = 0; k < tau.rows(); ++k) {
    xk = rk4_step(p, xk, applied_torque(p, tau.row(k).transpose()), dt);
    x.row(k + 1) = xk.transpose();
  }
  return x;
}

}  // namespace drops::realaigym
