#pragma once
/// \file The pendubot swing-up task (paper §V-A; settings.md §2). One parametrised dynamics serves
/// both the "real" system (actual parameters) and the simulator prior (tunable parameters phi).

#include <array>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/pilco/task_model.hpp"

namespace drops::pendubot {

/// Physical parameters. Masses in kg, lengths in m, viscous friction in N m s, gravity in m/s^2.
/// Defaults: Table I's actual system. Link i has inertia m_i l_i^2 / 12 about its centre of mass,
/// which sits at l_i / 2.
struct Params {
  double m1 = 0.5, m2 = 0.5, l1 = 0.5, l2 = 0.5, b1 = 0.1, b2 = 0.1, g = 9.82;
  /// phi = [m1, m2, l1, l2, b1, b2] (dim 6), the order of parameter_names().
  VectorXd to_phi() const;
  /// Inverse of to_phi; g keeps its default. Throws InvalidArgument on wrong size.
  static Params from_phi(const VectorXd& phi);
  /// Throws InvalidArgument naming the parameter when a mass or length is < kMinMassOrLength or a
  /// friction is negative or any value is not finite (the inertia matrix is singular at 0).
  void check() const;
};

/// Smallest mass (kg) or length (m) accepted: keeps the 2x2 inertia matrix well conditioned.
inline constexpr double kMinMassOrLength = 1e-2;
/// Names of phi in order.
std::vector<std::string> parameter_names();

/// Named priors of paper Table I: "tunable-useful" (A), "tunable" (B), "tunable-misleading" (C),
/// "partially-tunable" (D), plus "actual". Throws InvalidArgument listing the names when unknown.
Params preset(const std::string& name);
/// The names accepted by preset().
std::vector<std::string> preset_names();

/// Time derivative of the raw state x = [dtheta1, dtheta2, theta1, theta2] under torque u on joint 1
/// (settings.md §2: PILCO's pendubot equations plus viscous friction). Angles in rad from upright,
/// anti-clockwise. Thread-safe (pure).
std::array<double, 4> derivative(const Params& p, const std::array<double, 4>& x, double u);

/// Integrates one control period dt (s) with the torque u clipped to |u| <= max_torque and held
/// (zero-order hold), by classical RK4 with `substeps` equal substeps. Returns x_{t+1}. Pure.
std::array<double, 4> step(const Params& p, const std::array<double, 4>& x, double u, double dt,
                           int substeps, double max_torque);

/// Settings of the pendubot task (settings.md §2).
struct TaskOptions {
  double dt = 0.05;            ///< control period, s
  double duration = 2.5;       ///< episode length, s (horizon = duration / dt = 50)
  double max_torque = 3.5;     ///< |u| bound, N m
  int substeps = 5;            ///< RK4 substeps per control period (0.01 s each by default)
  double reward_sigma = 0.5;   ///< sigma_c of the reward, m
  double goal_l1 = 0.5;        ///< link lengths used for the tip position in the reward, m
  double goal_l2 = 0.5;
  double solved_radius = 0.15; ///< the tip must stay within this distance of the goal, m
  double solved_window = 0.5;  ///< ... over the last solved_window seconds of the episode
  /// Returns true when dt > 0, duration >= dt, substeps >= 1, max_torque > 0, reward_sigma > 0,
  /// solved_radius > 0 and solved_window >= 0; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Tip (end-effector) position (x, y) in m for state x (dim 4) and link lengths l1, l2.
std::array<double, 2> tip_position(const VectorXd& x, double l1, double l2);

/// The swing-up task: start hanging [0, 0, pi, pi], observation [dth1, dth2, cos th1, sin th1,
/// cos th2, sin th2] (dim 6), reward exp(-d^2 / (2 sigma_c^2)) with d the tip's distance to the
/// upright goal (0, l1 + l2); solved when the tip stays within solved_radius of the goal for the
/// whole last solved_window seconds. Immutable, thread-safe.
class SwingUpTask final : public rollout::Task {
 public:
  explicit SwingUpTask(const TaskOptions& options = {});
  std::string name() const override { return "pendubot"; }
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  int observation_dim() const override { return 6; }
  int horizon() const override { return horizon_; }
  double dt() const override { return options_.dt; }
  VectorXd initial_state() const override;
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override;
  double reward(const VectorXd& x) const override;
  bool solved(const rollout::Trajectory& trajectory) const override;
  /// The mirror about the vertical: x -> [-dth1, -dth2, 2 pi - th1, 2 pi - th2], u -> -u. The
  /// dynamics (gravity sin th, the Coriolis terms, viscous friction, the torque) are odd in the
  /// angles, velocities and torque, whatever the parameters, so the real robot and every prior
  /// share it; the start state (hanging) and the goal (upright) are its fixed points.
  std::optional<rollout::Reflection> reflection() const override;
  /// Upright at rest: x* = [0, 0, 0, 0], u* = 0, |u| <= max_torque, angles theta1, theta2
  /// (entries 2 and 3) wrapped.
  std::optional<rollout::Goal> goal() const override;
  const TaskOptions& options() const { return options_; }
  /// Distance (m) from the tip to the goal for state x.
  double goal_distance(const VectorXd& x) const;

 private:
  TaskOptions options_;
  int horizon_;
};

/// The swing-up as PILCO sees it (baselines.md §1a, pilco-matlab's pendubot scenario): x =
/// [dtheta1, dtheta2, theta1, theta2], angles {2, 3}, x_aug = [x, sin theta1, cos theta1,
/// sin theta2, cos theta2], policy and GP inputs [dtheta1, dtheta2, sin/cos theta1, sin/cos
/// theta2] (indices {0, 1, 4, 5, 6, 7}), max_u = max_torque; the cost's distance |C (x_aug - z)|
/// with C = [l1 0 l2 0; 0 l1 0 l2] on the sin/cos entries and z = (0, 1, 0, 1) there is the tip's
/// distance to the goal with the reward's lengths goal_l1, goal_l2, so the reward
/// exp(-d^2 / (2 sigma_c^2)) is 1 - c_{sigma_c}: reward_width = reward_sigma. Sigma_0 =
/// diag(0.1, 0.1, 0.01, 0.01)^2 (pilco-matlab's S0: the real start [0, 0, pi, pi] is deterministic;
/// planning from a slightly wider Gaussian also makes the policy work near it); policy length
/// scales [1, 1, 0.7, 0.7, 0.7, 0.7] (settings_pendubot.m). Throws InvalidArgument when options
/// are invalid.
pilco::TaskModel pilco_task_model(const TaskOptions& options);

/// The "real" pendubot: deterministic dynamics with the given parameters. Thread-safe.
class PendubotSystem final : public rollout::System {
 public:
  /// Throws InvalidArgument when params are invalid.
  PendubotSystem(const Params& params, const TaskOptions& options = {});
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override;
  const Params& params() const { return params_; }

 private:
  Params params_;
  TaskOptions options_;
};

/// The simulator prior M(x, u; phi) = step(x, u; phi) - x, phi = [m1, m2, l1, l2, b1, b2].
/// Shares derivative()/step() with PendubotSystem, so phi = actual parameters reproduces the real
/// system exactly. Thread-safe.
class PendubotPrior final : public model::MeanFunction {
 public:
  explicit PendubotPrior(const TaskOptions& options = {});
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override;
  void check_phi(const VectorXd& phi) const override;
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  std::unique_ptr<model::MeanFunction> clone() const override;

 private:
  TaskOptions options_;
};

}  // namespace drops::pendubot
