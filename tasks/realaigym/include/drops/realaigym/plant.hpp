#pragma once
/// \file The plant of the RealAIGym leaderboards (DFKI Underactuated Lab, repository
/// dfki-ric-underactuated-lab/double_pendulum): their double pendulum model with the parameters of
/// a design's identified model_parameters.yml, as the leaderboards simulate it (RK4 at 2 ms, 10 s
/// from hanging down at rest, joint 2 unactuated).
///
/// Coordinates (the lab's, src/python/double_pendulum/model/symbolic_plant.py, formulas
/// "UnderactuatedLecture"): q1 the angle of link 1 from hanging straight down, q2 the angle of link
/// 2 relative to link 1; state x = [q1, q2, qd1, qd2] (rad, rad/s), torque tau = [tau1, tau2] (N
/// m). Equations of motion, with I_i the inertia of link i about its joint axis, r_i the distance
/// of its centre of mass from joint i, Ir the motor's rotor inertia and gr the gear ratio:
///   M(q) qdd = tau - C(q, qd) qd + G(q) - F(qd)
///   M11 = I1 + I2 + m2 l1^2 + 2 m2 l1 r2 cos q2 + gr^2 Ir + Ir,  M12 = M21 = I2 + m2 l1 r2 cos q2
///   - gr Ir, M22 = I2 + gr^2 Ir C = [[-2 k qd2, -k qd2], [k qd1, 0]] with k = m2 l1 r2 sin q2 G1 =
///   -g (m1 r1 sin q1 + m2 (l1 sin q1 + r2 sin(q1 + q2))),  G2 = -g m2 r2 sin(q1 + q2) F_i = b_i
///   qd_i + cf_i atan(100 qd_i)
/// The torque the plant receives is the command clipped to [-tl_i, tl_i] (the simulator's
/// get_real_applied_u): with tl2 = 0 joint 2 is passive.
/// The leaderboards' changes to the identified model (leaderboard/ROBOT/simulation_v*/
/// sim_parameters.py): torque limits [6, 0] N m, Ir = 0, b = cf = 0. (ROBOT: the lab's name for the
/// double pendulum with joint 2 passive; the full paths are in docs/decisions/realaigym-scorer.md.)

#include <Eigen/Dense>
#include <array>
#include <string>

#include "drops/core/types.hpp"

namespace drops::realaigym {

/// The lab's model parameters (the fields of model_parameters.yml; names in brackets).
struct PlantParameters {
  std::array<double, 2> mass{0.5, 0.6};          ///< [m1, m2] link masses, kg (> 0)
  std::array<double, 2> length{0.3, 0.2};        ///< [l1, l2] link lengths, m (> 0)
  std::array<double, 2> com{0.3, 0.2};           ///< [r1, r2] centre of mass from joint i, m (>= 0)
  std::array<double, 2> inertia{0.05, 0.02};     ///< [I1, I2] about joint i's axis, kg m^2 (> 0)
  double motor_inertia = 0.0;                    ///< [Ir] rotor inertia, kg m^2 (>= 0)
  double gear_ratio = 6.0;                       ///< [gr] (> 0)
  std::array<double, 2> damping{0.0, 0.0};       ///< [b1, b2] viscous friction, N m s/rad (>= 0)
  std::array<double, 2> coulomb{0.0, 0.0};       ///< [cf1, cf2] Coulomb friction, N m (>= 0)
  double gravity = 9.81;                         ///< [g] m/s^2 (>= 0)
  std::array<double, 2> torque_limit{6.0, 0.0};  ///< [tl1, tl2] |tau_i| <= tl_i, N m (>= 0)
  /// True when every field is finite and in its range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Design C.1, model 1.0 (data/system_identification/identified_parameters/design_C.1/model_1.0/
/// model_parameters.yml) with the leaderboards' changes (torque limits [6, 0], Ir = b = cf = 0):
/// the plant of leaderboard/ROBOT/simulation_v2 (the current simulation leaderboard).
PlantParameters design_c1_model_1_0();

/// Design A.0, model 2.0 (identified_parameters/design_A.0/model_2.0/model_parameters.yml) with the
/// same changes: the plant of leaderboard/ROBOT/simulation_v1, whose published trajectories
/// and scores (the archived v1 table: MC-PILCO 0.891) were simulated on it
/// (docs/decisions/realaigym-scorer.md).
PlantParameters design_a0_model_2_0();

/// The torque the plant applies for a command `tau` (dim 2, N m): each component clipped to
/// [-tl_i, tl_i]. Pure, thread-safe.
Eigen::Vector2d applied_torque(const PlantParameters& p, const Eigen::Vector2d& tau);

/// M(q) (2x2, kg m^2) at joint angles q (dim 2). Pure, thread-safe.
Eigen::Matrix2d mass_matrix(const PlantParameters& p, const Eigen::Vector2d& q);

/// Joint accelerations qdd (dim 2, rad/s^2) at x (dim 4) under the joint torques tau (dim 2,
/// applied as given: clip with applied_torque first). Pure, thread-safe.
Eigen::Vector2d joint_accelerations(const PlantParameters& p, const Eigen::Vector4d& x,
                                    const Eigen::Vector2d& tau);

/// dx/dt = [qd, qdd] (dim 4) at x under tau (dim 2) held.
Eigen::Vector4d state_derivative(const PlantParameters& p, const Eigen::Vector4d& x,
                                 const Eigen::Vector2d& tau);

/// One classical Runge-Kutta step of dt seconds (> 0) from x with tau held (the lab's
/// Simulator.runge_integrator). Returns x after dt. Pure, thread-safe.
Eigen::Vector4d rk4_step(const PlantParameters& p, const Eigen::Vector4d& x,
                         const Eigen::Vector2d& tau, double dt);

/// Total mechanical energy 1/2 qd' M qd + V (J) at x (dim 4), V = m1 g (-r1 cos q1) + m2 g (-l1 cos
/// q1 - r2 cos(q1 + q2)) (zero at the joint's height). Conserved without torque and friction.
double total_energy(const PlantParameters& p, const Eigen::Vector4d& x);

/// Position (horizontal, vertical; m, vertical up, joint 1 at the origin) of the end of link 2 for
/// link lengths l1, l2 (m) at joint angles q (dim 2): the lab's forward_kinematics. Pure.
Eigen::Vector2d end_effector_position(double l1, double l2, const Eigen::Vector2d& q);

/// The states of an open-loop replay: x_0 = x0 (dim 4), then x_{k+1} = rk4_step(x_k,
/// applied_torque(tau.row(k)), dt) for k = 0..K-1; tau (K x 2, N m). Returns (K + 1) x 4. Throws
/// InvalidArgument when tau has not 2 columns or dt <= 0.
MatrixXd simulate_torques(const PlantParameters& p, const Eigen::Vector4d& x0, const MatrixXd& tau,
                          double dt);

}  // namespace drops::realaigym
