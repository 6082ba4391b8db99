#pragma once
/// \file The "real" hexapod (issue 4): the same parametrised DART simulator as the prior
/// (simulator.hpp), configured to differ from it the way the physical robot does, behind the
/// drops rollout::System interface with a stateful episode session. No DART in this header.
///
/// Differences from the prior (numbers are ours unless marked; see RealRobotOptions):
/// - actuators: position-controlled servos, a PD loop on a torque motor (Actuation::kServo) with
///   kp = 10 N m/rad, kd = 0.1 N m s/rad, instead of perfect velocity actuators. The stall torque
///   is 2.5 N m, not the 30 N m effort limit of settings.md: 30 N m is the URDF's nominal value,
///   while the pexod's Dynamixel MX-28-class servos stall at about 2.5 N m (standing needs up to
///   about 0.7 N m at a femur joint: 8 N per leg on a tripod x 0.085 m). The available torque
///   falls linearly to 0 at the no-load speed 7 rad/s (settings.md's velocity limit), which DART
///   also enforces. A first, softer servo (kp = 1.2) matched the paper's 0.22 m/s through servo
///   lag alone, but then the robot sagged and lagged so much (0.16 rad) that every method (MI,
///   GP-MI) explained the robot without leg 0 by the prior without leg 5 and vice versa; with
///   kp = 10 the joints lag about 0.024 rad, the body stands at about 0.186 m (prior 0.19 m), and
///   the tripod gait of the tests walks at about 0.24 m/s against 0.28 m/s in the prior, the gap
///   now coming mostly from the ground friction below (measured);
/// - joint friction: viscous 0.02 N m s/rad and Coulomb 0.05 N m (DART joint damping and
///   Coulomb friction constraints);
/// - physics step 1 ms (prior: 10 ms); control every 0.1 s as the prior;
/// - ground friction 0.4 (prior 1.0; DART uses the smaller coefficient of the two shapes);
/// - measurement: the state is measured every 0.1 s with independent Gaussian noise per component
///   (MeasurementNoise), drawn from the Rng passed to step(); the true state stays hidden inside
///   the episode session, so the next step starts from the true state, not the measured one;
/// - damage (leg removed, shortened tibia, blocked joint) from RealRobotOptions::spec.

#include <memory>
#include <string>

#include "drops/core/problem.hpp"
#include "drops/hexapod/simulator.hpp"

namespace drops::hexapod {

/// Standard deviations of the measurement noise, per block of the 48-D state (simulator.hpp).
/// Defaults (ours): joint encoders 0.005 rad (about 0.3 deg: resolution plus backlash), joint
/// velocities 0.05 rad/s, motion capture of the body position 2 mm and orientation 0.005 rad,
/// body linear velocity 0.01 m/s and angular velocity 0.03 rad/s (finite differences of the
/// tracked pose). All >= 0; zero gives exact measurements.
struct MeasurementNoise {
  double joint_angle = 0.005;       ///< rad, x[0, 18)
  double joint_velocity = 0.05;     ///< rad/s, x[18, 36)
  double body_position = 0.002;     ///< m, x[36, 39)
  double body_orientation = 0.005;  ///< rad, x[39, 42)
  double linear_velocity = 0.01;    ///< m/s, x[42, 45)
  double angular_velocity = 0.03;   ///< rad/s, x[45, 48)
  /// sigma of state entry i (0..47). Throws InvalidArgument out of range.
  double sigma(int i) const;
};

/// The simulator options of the real robot (see the file comment): servo actuation, 1 ms physics
/// step, ground friction 0.4, everything else as the prior.
PriorOptions real_simulator_defaults();

/// Options of HexapodRealSystem.
struct RealRobotOptions {
  HexapodSpec spec;                                    ///< the robot, with its damage (robot.hpp)
  PriorOptions simulator = real_simulator_defaults();  ///< physics and servos
  MeasurementNoise noise;                              ///< measurement noise
  /// True when spec, simulator and noise are valid (stall torque <= spec.max_torque, sigmas
  /// finite and >= 0); otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// The "real" hexapod as a rollout::System. State x and action u as HexapodPrior: x dim 48
/// (simulator.hpp), u = 18 target joint angles (rad). Use it through run_episode(), which calls
/// begin_episode(): the session owns one simulator (its own DART world) whose true state persists
/// between steps, and each step returns the measured state (true state + noise drawn from rng,
/// one normal draw per entry in index order). Same options, x0, actions and rng seed give
/// bit-identical measurements. Thread-safe: sessions share nothing.
class HexapodRealSystem final : public rollout::System {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit HexapodRealSystem(const RealRobotOptions& options = {});
  /// One control period from true state x (the robot is placed exactly at x, i.e. stateless use;
  /// builds a world per call, so prefer run_episode). Returns the measured next state.
  /// Throws InvalidArgument on wrong sizes or non-finite values.
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override;
  /// Starts an episode with the robot placed at the true state x0 (dim 48, e.g. the reset state
  /// of HexapodTask::initial_state()). Throws InvalidArgument on a wrong size or non-finite x0.
  std::unique_ptr<rollout::EpisodeSession> begin_episode(const VectorXd& x0) const override;
  const RealRobotOptions& options() const { return options_; }

 private:
  RealRobotOptions options_;
};

}  // namespace drops::hexapod
