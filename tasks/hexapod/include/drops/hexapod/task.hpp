#pragma once
/// \file The hexapod learning problem of paper §V-B as a drops rollout::Task (settings.md §6).
/// No DART in this header.

#include <string>

#include "drops/core/problem.hpp"
#include "drops/hexapod/simulator.hpp"

namespace drops::hexapod {

/// Dimension of HexapodTask's observation (GP input part of the state, see HexapodTask).
inline constexpr int kObservationDim = 45;

/// Options of HexapodTask; defaults are settings.md §6 except where marked "ours".
struct HexapodTaskOptions {
  int horizon = 40;              ///< H, control steps per episode (4 s), >= 1
  double dt = 0.1;               ///< control period, s, > 0
  double initial_height = 0.2;   ///< body z of x_0, m, > 0 (the prior's reset state)
  double lateral_limit = 0.5;    ///< |y| above this costs lateral_penalty * dt per step, m, >= 0
  double lateral_penalty = 1.0;  ///< per second, >= 0 (settings.md: -dt per step)
  double tilt_limit = 1.5707963267948966;  ///< tilt >= this costs tilt_penalty, rad, (0, pi]
  double tilt_penalty = 10.0;              ///< per step, >= 0
  /// solved(): walking_speed >= solved_speed (m/s) without a fall (ours: 0.15 m/s, the speed
  /// IT&E reached in the paper's damage experiment; the paper's robot walked at 0.21-0.22 m/s).
  double solved_speed = 0.15;
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// Tilt of the body (rad, in [0, pi]): the angle between the body's z axis and the world's z
/// axis, acos(cos(roll) cos(pitch)). Thread-safe.
double body_tilt(double roll, double pitch);

/// Forward walking speed of an episode, m/s: (x_H - x_0) forward (state entry 36) / (H dt), where
/// H = trajectory.rewards.size(). An episode stopped early (repeated last state) counts its full
/// duration. Throws InvalidArgument when the trajectory is not 48-D or dt <= 0. Thread-safe.
double walking_speed(const rollout::Trajectory& trajectory, double dt);

/// The hexapod task: E = 48 (simulator.hpp), U = 18 target joint angles, H = 40, dt = 0.1 s.
///
/// Observation (the policy's input and the GP's state input, O = 45): the state without the body
/// x, y position and yaw, in this order: q (18), dq (18), z, roll, pitch, world linear velocity
/// (3), world angular velocity (3). Why: the dynamics do not depend on where the robot is on the
/// flat ground (x, y) nor, physically, on its heading (yaw); leaving them out lets the GP
/// generalise across the positions and headings an episode visits instead of treating each new
/// x as unexplored (x grows monotonically while walking, so it would push every new state far
/// from the data). Height, roll and pitch do matter (contacts, gravity). The velocities are kept
/// in the world frame: the GP predicts world-frame dx, so the direction of motion it needs for
/// the x/y entries of dx is carried by these velocities, and while the robot walks ahead (yaw
/// near 0) they equal the heading-frame velocities. The prior mean still sees the full state.
///
/// Reward of reaching x (settings.md §6): x_forward * dt; minus lateral_penalty * dt when
/// |y| > lateral_limit; minus tilt_penalty when body_tilt(roll, pitch) >= tilt_limit.
/// Immutable and thread-safe.
class HexapodTask final : public rollout::Task {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit HexapodTask(const HexapodTaskOptions& options = {});
  std::string name() const override { return "hexapod"; }
  int state_dim() const override { return kStateDim; }
  int action_dim() const override { return kNumJoints; }
  int observation_dim() const override { return kObservationDim; }
  int horizon() const override { return options_.horizon; }
  double dt() const override { return options_.dt; }
  /// The prior's reset state: all joints at 0, zero velocities, body upright at
  /// (0, 0, initial_height). (A blocked joint of a damaged robot is set to its angle by the
  /// simulator whatever x_0 says.)
  VectorXd initial_state() const override;
  /// obs (dim 45) from x (dim 48), see the class comment. Throws InvalidArgument on wrong sizes.
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override;
  /// See the class comment. x: dim 48. Throws InvalidArgument on a wrong size.
  double reward(const VectorXd& x) const override;
  /// walking_speed >= solved_speed and no state tilted >= tilt_limit.
  bool solved(const rollout::Trajectory& trajectory) const override;
  /// A fall: body_tilt >= tilt_limit. The robot does not get up again (its reward, with the tilt
  /// penalty, repeats to the end of the episode), so model rollouts stop there. x: dim 48.
  bool absorbing(const VectorXd& x) const override;
  /// walking_speed(trajectory, dt()).
  double walking_speed(const rollout::Trajectory& trajectory) const;
  const HexapodTaskOptions& options() const { return options_; }

 private:
  HexapodTaskOptions options_;
};

}  // namespace drops::hexapod
