#pragma once
/// \file An analytic double pendulum with the physical parameters a robot-description file carries:
/// the oracle of the robot-description priors (issue 64) and of the engine study
/// (docs/decisions/description-file-engine.md). Header-only, for tests and benchmarks.
///
/// Two links on revolute joints with parallel axes: joint 1 fixed to the world, joint 2 on link 1
/// at `length1` from joint 1. Coordinates as in a URDF: q1 the angle of link 1 from hanging
/// straight down, q2 the angle of link 2 relative to link 1, both positive about the joints' axis
/// (right-handed); state x = [q1, q2, qd1, qd2] (rad, rad/s), action u = [u1, u2] with joint
/// torques tau = torque_scale .* u (N m). Gravity g points down, the plane of motion is vertical.
///
/// Equations of motion (Lagrange; Spong, Hutchinson and Vidyasagar, "Robot Modeling and Control",
/// Wiley 2006, ch. 7, the planar elbow manipulator, with angles from hanging, a centre of mass off
/// the link's line, rotor inertia and joint friction added):
///   M(q) qdd + c(q, qd) + g(q) = tau - b .* qd - f_c .* tanh(qd / v_s)
/// With link i's centre of mass at distance r_i from joint i and angle beta_i from the link's line
/// (r_i = hypot(along_i, across_i), beta_i = atan2(across_i, along_i)), k = m2 l1 r2 cos(q2 +
/// beta2), s = m2 l1 r2 sin(q2 + beta2), J_i = m_i r_i^2 + I_i (inertia about joint i):
///   M11 = J1 + m2 l1^2 + J2 + 2 k + A1,  M12 = J2 + k,  M22 = J2 + A2
///   c1 = -s (2 qd1 qd2 + qd2^2),         c2 = s qd1^2
///   g1 = g (m1 r1 sin(q1 + beta1) + m2 l1 sin q1 + m2 r2 sin(q1 + q2 + beta2)),
///   g2 = g m2 r2 sin(q1 + q2 + beta2)
/// The rotor inertia A_i (armature: I_rotor gear^2) adds to M_ii only: the rotor spins with the
/// joint's relative velocity (Featherstone, "Rigid Body Dynamics Algorithms", Springer 2008, §9.6).
/// Coulomb friction is smoothed by tanh with velocity scale v_s: |friction| < f_c, odd and smooth
/// (the DFKI lab's own model uses cf atan(100 qd) instead, whose bound is cf pi / 2).
///
/// tasks/pendubot's equations are this model in absolute angles from upright (theta1 = q1 + pi,
/// theta2 = q1 + q2 + pi) for uniform rods (r_i = l_i / 2, I_i = m_i l_i^2 / 12), without rotor
/// inertia, and with PILCO's friction on the absolute velocities rather than the joints':
/// tests/test_double_pendulum.cpp checks the two against each other without friction.

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "drops/core/types.hpp"

namespace drops::fixtures {

/// The physical parameters of the double pendulum. Defaults: a 1 m, 1 kg uniform rod per link.
struct DoublePendulumParams {
  /// Mass of link i, kg (> 0).
  std::array<double, 2> mass{1.0, 1.0};
  /// Centre of mass of link i along the link, m: from joint i towards joint 2 for link 1 (the
  /// direction that hangs straight down at q = 0), the same direction for link 2 at q2 = 0.
  std::array<double, 2> com_along{0.5, 0.5};
  /// Centre of mass of link i across the link, m, in the plane of motion, positive towards
  /// increasing angle (where the link moves when its angle grows).
  std::array<double, 2> com_across{0.0, 0.0};
  /// Rotational inertia of link i about the axis through its centre of mass parallel to the
  /// joints' axis, kg m^2 (>= 0).
  std::array<double, 2> inertia{1.0 / 12, 1.0 / 12};
  /// Distance from joint 1 to joint 2, m (> 0).
  double length1 = 1.0;
  /// Viscous damping of joint i, N m s / rad (>= 0).
  std::array<double, 2> damping{0.0, 0.0};
  /// Coulomb friction of joint i, N m (>= 0): f_c tanh(qd / coulomb_velocity).
  std::array<double, 2> coulomb{0.0, 0.0};
  /// Velocity scale of the Coulomb friction's tanh, rad/s (> 0).
  double coulomb_velocity = 0.01;
  /// Rotor inertia reflected at joint i (armature, I_rotor gear^2), kg m^2 (>= 0).
  std::array<double, 2> armature{0.0, 0.0};
  /// Joint torque per unit of action, tau_i = torque_scale_i u_i (a gear ratio times a motor
  /// constant; 1: the action is the joint torque in N m).
  std::array<double, 2> torque_scale{1.0, 1.0};
  /// Gravitational acceleration, m/s^2 (>= 0).
  double gravity = 9.81;
};

/// The double pendulum of the DFKI underactuated lab's URDF (tests/data/double-pendulum-dfki/
/// double_pendulum.urdf) taken literally: masses and centres of mass from the links' <inertial>,
/// ixx as the inertia about the centre of mass (the file's values are in fact the lab's inertias
/// about the joint axis: see that folder's README), length1 from Joint2's origin (z = -0.3),
/// damping and friction from the joints' <dynamics>, gravity 9.81 (the engines' default). Link2's
/// frame is turned by rpy = (-3.1416, 0, 0), not by pi: its centre of mass (z = +0.16635 in it)
/// then lies 7.35e-6 rad off the line of link 1 at q2 = 0, hence com_across[1].
inline DoublePendulumParams dfki_urdf_double_pendulum() {
  DoublePendulumParams p;
  p.mass = {0.608, 0.6306};
  const double r2 = 0.16634950840469392, beta2 = 3.141592653589793 - 3.1416;
  p.com_along = {0.27401315789473685, r2 * std::cos(beta2)};
  p.com_across = {0.0, r2 * std::sin(beta2)};
  p.inertia = {0.05472, 0.02522};
  p.length1 = 0.3;
  p.damping = {0.08089, 0.0};
  p.coulomb = {0.09335, 0.1865};
  p.gravity = 9.81;
  return p;
}

/// M(q) (2x2, kg m^2) at joint angles q (dim 2). Symmetric positive definite for valid parameters.
inline Eigen::Matrix2d mass_matrix(const DoublePendulumParams& p, const Eigen::Vector2d& q) {
  const double r1sq = p.com_along[0] * p.com_along[0] + p.com_across[0] * p.com_across[0];
  const double r2sq = p.com_along[1] * p.com_along[1] + p.com_across[1] * p.com_across[1];
  const double j1 = p.mass[0] * r1sq + p.inertia[0];
  const double j2 = p.mass[1] * r2sq + p.inertia[1];
  // m2 l1 r2 cos(q2 + beta2) = m2 l1 (along2 cos q2 - across2 sin q2)
  const double k =
      p.mass[1] * p.length1 * (p.com_along[1] * std::cos(q[1]) - p.com_across[1] * std::sin(q[1]));
  Eigen::Matrix2d m;
  m(0, 0) = j1 + p.mass[1] * p.length1 * p.length1 + j2 + 2 * k + p.armature[0];
  m(0, 1) = m(1, 0) = j2 + k;
  m(1, 1) = j2 + p.armature[1];
  return m;
}

/// Coriolis, centrifugal and gravity torques c(q, qd) + g(q) (dim 2, N m) at x = [q1, q2, qd1,
/// qd2].
inline Eigen::Vector2d bias_torques(const DoublePendulumParams& p, const Eigen::Vector4d& x) {
  const double q1 = x[0], q2 = x[1], qd1 = x[2], qd2 = x[3];
  // m2 l1 r2 sin(q2 + beta2) = m2 l1 (along2 sin q2 + across2 cos q2)
  const double s =
      p.mass[1] * p.length1 * (p.com_along[1] * std::sin(q2) + p.com_across[1] * std::cos(q2));
  // m r sin(theta + beta) = m (along sin theta + across cos theta)
  auto moment = [](double m, double along, double across, double theta) {
    return m * (along * std::sin(theta) + across * std::cos(theta));
  };
  const double g2 = p.gravity * moment(p.mass[1], p.com_along[1], p.com_across[1], q1 + q2);
  const double g1 = p.gravity * (moment(p.mass[0], p.com_along[0], p.com_across[0], q1) +
                                 p.mass[1] * p.length1 * std::sin(q1)) +
                    g2;
  return {-s * (2 * qd1 * qd2 + qd2 * qd2) + g1, s * qd1 * qd1 + g2};
}

/// Joint friction torques b .* qd + f_c .* tanh(qd / v_s) (dim 2, N m) at velocities qd (dim 2).
inline Eigen::Vector2d friction_torques(const DoublePendulumParams& p, const Eigen::Vector2d& qd) {
  Eigen::Vector2d f;
  for (int i = 0; i < 2; ++i)
    f[i] = p.damping[i] * qd[i] + p.coulomb[i] * std::tanh(qd[i] / p.coulomb_velocity);
  return f;
}

/// Joint accelerations qdd (dim 2, rad/s^2) at x = [q1, q2, qd1, qd2] under action u (dim 2):
/// forward dynamics M(q)^-1 (tau - c - g - friction). Pure, thread-safe.
inline Eigen::Vector2d joint_accelerations(const DoublePendulumParams& p, const Eigen::Vector4d& x,
                                           const Eigen::Vector2d& u) {
  const Eigen::Vector2d tau(p.torque_scale[0] * u[0], p.torque_scale[1] * u[1]);
  const Eigen::Vector2d rhs = tau - bias_torques(p, x) - friction_torques(p, x.tail<2>());
  return mass_matrix(p, x.head<2>()).llt().solve(rhs);
}

/// joint_accelerations() for a batch: x (B, 4) rows [q1, q2, qd1, qd2], u (B, 2); returns (B, 2).
inline MatrixXd batch_joint_accelerations(const DoublePendulumParams& p, const MatrixXd& x,
                                          const MatrixXd& u) {
  MatrixXd qdd(x.rows(), 2);
  for (Eigen::Index b = 0; b < x.rows(); ++b)
    qdd.row(b) = joint_accelerations(p, x.row(b).transpose(), u.row(b).transpose()).transpose();
  return qdd;
}

/// dx/dt = [qd, qdd] (dim 4) at x under action u held.
inline Eigen::Vector4d state_derivative(const DoublePendulumParams& p, const Eigen::Vector4d& x,
                                        const Eigen::Vector2d& u) {
  Eigen::Vector4d d;
  d << x.tail<2>(), joint_accelerations(p, x, u);
  return d;
}

/// One classical RK4 step of h seconds from x with u held. Returns x after h.
inline Eigen::Vector4d rk4_step(const DoublePendulumParams& p, const Eigen::Vector4d& x,
                                const Eigen::Vector2d& u, double h) {
  const Eigen::Vector4d k1 = state_derivative(p, x, u);
  const Eigen::Vector4d k2 = state_derivative(p, x + 0.5 * h * k1, u);
  const Eigen::Vector4d k3 = state_derivative(p, x + 0.5 * h * k2, u);
  const Eigen::Vector4d k4 = state_derivative(p, x + h * k3, u);
  return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
}

/// Positions (horizontal, vertical; m, vertical up, joint 1 at the origin) of the two links'
/// centres of mass at joint angles q, from the geometry alone (independent of mass_matrix()).
inline std::array<Eigen::Vector2d, 2> com_positions(const DoublePendulumParams& p,
                                                    const Eigen::Vector2d& q) {
  // A link at absolute angle theta points along e = (sin, -cos); its "across" direction is
  // n = de/dtheta = (cos, sin).
  auto e = [](double t) { return Eigen::Vector2d(std::sin(t), -std::cos(t)); };
  auto n = [](double t) { return Eigen::Vector2d(std::cos(t), std::sin(t)); };
  const double t1 = q[0], t2 = q[0] + q[1];
  return {p.com_along[0] * e(t1) + p.com_across[0] * n(t1),
          p.length1 * e(t1) + p.com_along[1] * e(t2) + p.com_across[1] * n(t2)};
}

/// The Lagrangian T - V (J) at x = [q1, q2, qd1, qd2], written from the centres of mass' Cartesian
/// velocities and the links' angular velocities (not from mass_matrix()): the oracle of the
/// equations of motion. Rotor kinetic energy 1/2 A_i qd_i^2 included.
inline double lagrangian(const DoublePendulumParams& p, const Eigen::Vector4d& x) {
  const double t1 = x[0], t2 = x[0] + x[1], w1 = x[2], w2 = x[2] + x[3];
  // d/dt of com_positions(): de/dtheta = n, dn/dtheta = -e.
  auto e = [](double t) { return Eigen::Vector2d(std::sin(t), -std::cos(t)); };
  auto n = [](double t) { return Eigen::Vector2d(std::cos(t), std::sin(t)); };
  const Eigen::Vector2d v1 = w1 * (p.com_along[0] * n(t1) - p.com_across[0] * e(t1));
  const Eigen::Vector2d v2 =
      w1 * p.length1 * n(t1) + w2 * (p.com_along[1] * n(t2) - p.com_across[1] * e(t2));
  const double kinetic = 0.5 * p.mass[0] * v1.squaredNorm() + 0.5 * p.inertia[0] * w1 * w1 +
                         0.5 * p.mass[1] * v2.squaredNorm() + 0.5 * p.inertia[1] * w2 * w2 +
                         0.5 * p.armature[0] * x[2] * x[2] + 0.5 * p.armature[1] * x[3] * x[3];
  const auto c = com_positions(p, x.head<2>());
  const double potential = p.gravity * (p.mass[0] * c[0][1] + p.mass[1] * c[1][1]);
  return kinetic - potential;
}

/// Total mechanical energy T + V (J) at x: 1/2 qd' M qd + V.
inline double energy(const DoublePendulumParams& p, const Eigen::Vector4d& x) {
  const auto c = com_positions(p, x.head<2>());
  const Eigen::Vector2d qd = x.tail<2>();
  return 0.5 * qd.dot(mass_matrix(p, x.head<2>()) * qd) +
         p.gravity * (p.mass[0] * c[0][1] + p.mass[1] * c[1][1]);
}

}  // namespace drops::fixtures
