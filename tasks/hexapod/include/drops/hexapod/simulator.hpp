#pragma once
/// \file The hexapod prior simulator (paper §V-B; settings.md §6): DART, perfect velocity
/// actuators with infinite torque, physics step 0.01 s, control and observation every 0.1 s.
///
/// This header does not include DART (the world lives behind a pointer to an implementation), so
/// it can be included from any translation unit.
///
/// The 48-D state x (raw state of the GP model; index ranges are [begin, end)):
///   x[0, 18)   joint angles q, rad, order 3 k + j (robot.hpp);
///   x[18, 36)  joint velocities dq, rad/s, same order;
///   x[36, 39)  body position (x, y, z) in the world frame, m (x forward at reset, z up);
///   x[39, 42)  body orientation as roll, pitch, yaw (rad), R = Rz(yaw) Ry(pitch) Rx(roll);
///   x[42, 45)  body linear velocity (of the body frame's origin) in the world frame, m/s;
///   x[45, 48)  body angular velocity in the world frame, rad/s.
/// Why roll/pitch/yaw: the GP models each output of dx = x' - x independently, so each coordinate
/// must change smoothly and by small amounts over one 0.1 s step. A walking robot stays near
/// upright, where roll and pitch are small and far from the pitch = +-pi/2 singularity, and yaw is
/// the heading. A rotation vector would mix heading and tilt in all three entries and flip near a
/// half turn; a quaternion would add a redundant dimension. Roll and yaw are kept continuous
/// (unwrapped): state() returns the roll and the yaw closest to those of the previous state
/// (set_state/reset/step), so a robot turning past +-pi gives yaw beyond pi, and a robot rolling
/// onto its back gives roll beyond pi, rather than a 2 pi jump in dx (which a GP cannot learn and
/// which would put a model rollout outside any plausible state). Pitch stays in [-pi/2, pi/2]:
/// a body pitched past vertical changes representation (roll and yaw jump by pi); a walking robot
/// that does that has fallen over, which the reward already punishes.
/// Joints of a removed leg keep their entries: they follow the same perfect velocity actuator law
/// kinematically (no body attached), so the state dimension is 48 for all 7 priors and a prior
/// without leg k predicts for leg k's joints what a servo without load would do.

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "drops/hexapod/robot.hpp"

namespace dart::simulation {
class World;
}  // namespace dart::simulation

namespace drops::hexapod {

/// Dimension of the state x.
inline constexpr int kStateDim = 48;
/// Offsets of the blocks of x (see the file comment).
inline constexpr int kJointPos = 0;
inline constexpr int kJointVel = 18;
inline constexpr int kBodyPos = 36;
inline constexpr int kBodyRpy = 39;
inline constexpr int kBodyLinVel = 42;
inline constexpr int kBodyAngVel = 45;

/// R = Rz(rpy[2]) Ry(rpy[1]) Rx(rpy[0]). Thread-safe.
Eigen::Matrix3d rpy_to_rotation(const Eigen::Vector3d& rpy);
/// Inverse of rpy_to_rotation with roll, yaw in (-pi, pi], pitch in [-pi/2, pi/2]. Thread-safe.
Eigen::Vector3d rotation_to_rpy(const Eigen::Matrix3d& r);
/// angle + 2 pi n closest to reference (rad). Thread-safe.
double unwrap_near(double angle, double reference);

/// Bounds of a plausible state, used by check_state to catch corrupted states (e.g. from a
/// diverging model rollout) before they reach the simulator.
struct StateBounds {
  double joint_angle_margin = 0.5;    ///< |q_j| <= limit_j + margin, rad
  double max_joint_velocity = 100;    ///< |dq_j|, rad/s
  double max_position = 1e3;          ///< |body x|, |body y|, |body z|, m
  double max_linear_velocity = 50;    ///< |v_i|, m/s
  double max_angular_velocity = 200;  ///< |w_i|, rad/s
  /// |roll|, |pitch| <= max_roll_pitch, rad. Roll is continuous (file comment), so a robot that
  /// rolled onto its back has |roll| near pi; a full turn is not plausible within an episode.
  double max_roll_pitch = 2 * 3.14159265358979323846;
};

/// Checks that x has dim 48, is finite and inside `bounds`.
/// Returns false with the first offending entry (index, block name, value, bound) in *why when
/// why is not null. Thread-safe.
bool check_state(const Eigen::VectorXd& x, const HexapodSpec& spec, std::string* why = nullptr,
                 const StateBounds& bounds = {});

/// How the leg joints are driven.
enum class Actuation {
  /// The prior of settings.md §6: DART VELOCITY actuators (infinite torque) commanded
  /// (q_target - q) / (velocity_gain_period * physics_dt), clipped to +-max_velocity.
  kVelocity,
  /// A position-controlled servo (the "real" robot of real_robot.hpp): a PD loop on a torque
  /// motor, tau = kp (q_target - q) - kd dq, limited by the motor's torque-speed line
  /// (ServoOptions),
  /// applied through DART FORCE actuators, plus joint viscous and Coulomb friction.
  kServo,
};

/// How a physics step of the prior is computed (issue 14).
enum class PriorEngine {
  /// dart::simulation::World::step (DART 6.12's generic articulated-body and constraint code).
  kDart,
  /// A dedicated step for a robot whose leg joints are all kinematic (src/rigid_step.hpp): the
  /// same world and the same contact model as kDart, computed as one rigid body with prescribed
  /// joint motion, without DART's per-step machinery. Joint trajectories are kDart's to the bit;
  /// the body's state agrees to round-off, amplified by the contact dynamics over an episode
  /// (docs/benchmarks.md, "A dedicated rigid-body step"). Requires Actuation::kVelocity. The
  /// skeleton in world() holds the state after every step(); the DART world's own clock
  /// (World::getTime) does not advance (PriorSimulator::time() does).
  kRigid,
};

/// The servo of Actuation::kServo (ours; Dynamixel MX-28-class numbers, see real_robot.hpp).
/// Available motor torque: tau in [-stall_torque (1 + dq / no_load_speed),
/// stall_torque (1 - dq / no_load_speed)], each side clipped to +-stall_torque (a DC motor's
/// torque-speed line: no torque in the direction of motion at no_load_speed, so joints cannot be
/// driven faster than it; DART also enforces the skeleton's +-max_velocity limit).
struct ServoOptions {
  double kp = 10.0;            ///< proportional gain, N m / rad, > 0
  double kd = 0.1;             ///< derivative gain, N m s / rad, >= 0
  double stall_torque = 2.5;   ///< N m, in (0, spec.max_torque]
  double no_load_speed = 7.0;  ///< rad/s, > 0
  double viscous_friction =
      0.02;  ///< joint damping (DART setDampingCoefficient), N m s / rad, >= 0
  double coulomb_friction = 0.05;  ///< joint dry friction (DART setCoulombFriction), N m, >= 0
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// Options of the prior simulator; defaults are settings.md §6.
struct PriorOptions {
  double physics_dt = 0.01;      ///< DART time step, s, > 0
  double control_dt = 0.1;       ///< one step() = control_dt, an integer multiple of physics_dt
  double initial_height = 0.2;   ///< body z at reset, m, > 0
  double gravity = 9.81;         ///< m/s^2, >= 0
  double ground_friction = 1.0;  ///< Coulomb coefficient of the ground, > 0
  double robot_friction = 1.0;   ///< Coulomb coefficient of the robot's shapes, > 0
  /// Velocity command (q_target - q) / (velocity_gain_period * physics_dt), rad/s; settings.md: pi.
  double velocity_gain_period = 3.14159265358979323846;
  /// Clip the velocity command to +-spec.max_velocity (7 rad/s). settings.md states the command law
  /// and the robot's 7 rad/s limit but not whether the prior applied the limit; we apply it (a
  /// target jump of pi/4 would otherwise ask for 25 rad/s). Set false for an unclipped prior.
  bool clip_velocity_command = true;
  /// kVelocity for the prior (settings.md §6); kServo for the "real" robot (real_robot.hpp).
  Actuation actuation = Actuation::kVelocity;
  /// Servo model, used when actuation == kServo.
  ServoOptions servo;
  /// How a physics step is computed; kRigid needs actuation == kVelocity.
  PriorEngine engine = PriorEngine::kDart;
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// The prior simulator of one HexapodSpec (intact or damaged): a DART world with the robot and the
/// ground. Joints are DART VELOCITY actuators (the commanded velocity is reached in one physics
/// step whatever the torque), or torque-limited PD servos with options.actuation == kServo (the
/// same parametrised simulator then plays the "real" robot, real_robot.hpp); a blocked joint is
/// LOCKED at its angle. The joints of a removed leg follow the velocity law kinematically under
/// both actuations (an unloaded servo). A step is a function of the
/// current state x and the targets only (no contact caching), so set_state(x); step(u) evaluates
/// the prior M(x, u) reproducibly. Not thread-safe: use one instance per thread (see prior.hpp).
class PriorSimulator {
 public:
  /// Builds the world and resets. Throws InvalidArgument when spec or options are invalid.
  explicit PriorSimulator(const HexapodSpec& spec = {}, const PriorOptions& options = {});
  ~PriorSimulator();
  PriorSimulator(PriorSimulator&&) noexcept;
  PriorSimulator& operator=(PriorSimulator&&) noexcept;
  PriorSimulator(const PriorSimulator&) = delete;
  PriorSimulator& operator=(const PriorSimulator&) = delete;

  /// Time 0; all joints at 0 (a blocked joint at its angle), zero velocities, body upright at
  /// (0, 0, initial_height).
  void reset();
  /// Advances control_dt seconds (control_dt / physics_dt physics steps) towards the targets
  /// q_target (rad, dim 18, order 3 k + j), each clipped to its joint's position limits. At every
  /// physics step joint j gets the velocity command (q_target_j - q_j) / (pi physics_dt), clipped
  /// to +-max_velocity when options.clip_velocity_command. Throws InvalidArgument on a wrong size
  /// or a non-finite target. May produce a non-finite state if DART diverges (check_state).
  void step(const Eigen::VectorXd& q_target);
  /// The 48-D state (file comment).
  Eigen::VectorXd state() const;
  /// Writes the state into x (dim 48). Throws InvalidArgument on a wrong size.
  void state(Eigen::Ref<Eigen::VectorXd> x) const;
  /// Sets the simulator to state x (dim 48, file comment); the time is unchanged. A blocked joint
  /// stays at its blocked angle with zero velocity whatever x says. Throws InvalidArgument when x
  /// has a wrong size or a non-finite entry.
  void set_state(const Eigen::VectorXd& x);
  /// Height of each foot's lowest point above the ground plane z = 0, m, in leg order (NaN for a
  /// removed leg), in the current state: about 0 (a few mm below with contact penetration) when
  /// the foot touches the ground. For gait diagrams (drops plot). Thread-safety as the class.
  std::array<double, kNumLegs> foot_heights() const;
  /// Simulated time since reset, s.
  double time() const;
  /// Physics steps per step().
  int substeps() const;
  const HexapodSpec& spec() const;
  const PriorOptions& options() const;

  /// Names of the skeleton's bodies, joints (the root free joint included) and shape nodes, in
  /// DART's order (for tests and diagnostics).
  std::vector<std::string> body_names() const;
  std::vector<std::string> joint_names() const;
  std::vector<std::string> shape_names() const;
  /// Number of degrees of freedom of the skeleton (6 + 3 per present leg).
  int num_dofs() const;
  /// Total mass of the skeleton, kg (2.495 for the intact robot).
  double mass() const;
  /// The simulator's DART world (the robot and the ground), e.g. for a viewer that replays
  /// recorded states through set_state (hexapod_animate). Declared, not defined, here: using it
  /// needs DART's headers. Valid while the simulator lives; not thread-safe.
  std::shared_ptr<dart::simulation::World> world() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drops::hexapod
