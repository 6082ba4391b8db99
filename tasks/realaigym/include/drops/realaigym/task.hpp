#pragma once
/// \file The RealAIGym swing-up as a drops task (issue 67): the leaderboard's plant as the "real"
/// system, 10 s episodes from hanging down at rest, the policy's torque on joint 1 held over the
/// plant's 2 ms RK4 steps for one control period, and the leaderboard's criteria and RealAI score
/// as episode metrics, computed on the episode re-simulated at 2 ms (the plant is deterministic, so
/// that is the episode itself at the leaderboard's resolution).

#include <optional>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/realaigym/plant.hpp"
#include "drops/realaigym/score.hpp"

namespace drops::realaigym {

/// Which leaderboard: its plant and its score together (docs/decisions/realaigym-scorer.md).
enum class Leaderboard {
  kV1,  ///< simulation_v1: design A.0 model 2.0, the linear score (MC-PILCO 0.891)
  kV2,  ///< simulation_v2: design C.1 model 1.0, the tanh score (MC-PILCO 0.480)
};

/// The plant of a leaderboard (design_a0_model_2_0() or design_c1_model_1_0()).
PlantParameters leaderboard_plant(Leaderboard leaderboard);
/// The score of a leaderboard (simulation_v1() or simulation_v2()).
ScoreDefinition leaderboard_score(Leaderboard leaderboard);

/// Settings of the task.
struct TaskOptions {
  Leaderboard leaderboard = Leaderboard::kV2;  ///< the plant and the score
  /// Control period, s: the policy's torque is held over dt / sim_dt plant steps. 0.02 s (50 Hz):
  /// 500 steps per 10 s episode; MC-PILCO's entry controls at 0.01 s.
  double dt = 0.02;
  double sim_dt = 0.002;       ///< the plant's RK4 step, s (the leaderboards': 2 ms)
  double duration = 10.0;      ///< episode length, s (the leaderboards': 10 s)
  double max_torque = 6.0;     ///< the policy's |u| bound on joint 1, N m (<= the plant's 6)
  double reward_sigma = 0.25;  ///< width of the reward exp(-d^2 / (2 sigma^2)), m
  /// True when 0 < sim_dt <= dt, dt is a whole number of sim_dt (to 1e-9), duration >= dt,
  /// 0 < max_torque and 0 < reward_sigma; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
  /// Plant steps per control period, round(dt / sim_dt).
  int substeps() const;
};

/// The swing-up: x = [q1, q2, qd1, qd2] (the lab's coordinates, rad from hanging, q2 relative),
/// u = [tau1] (N m), start at rest hanging down (x = 0); observation [qd1, qd2, cos q1, sin q1,
/// cos q2, sin q2] (dim 6); reward exp(-d^2 / (2 sigma^2)) with d the distance of the end of link 2
/// from upright (0, l1 + l2) (m); solved: the leaderboard's swing-up rule (height rule) on the
/// control-period states (the exact rule at 2 ms is the metric swingup_success). Immutable,
/// thread-safe.
class SwingupTask final : public rollout::Task {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit SwingupTask(const TaskOptions& options = {});
  std::string name() const override { return "realaigym_pendubot"; }
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  int observation_dim() const override { return 6; }
  int horizon() const override { return horizon_; }
  double dt() const override { return options_.dt; }
  VectorXd initial_state() const override { return VectorXd::Zero(4); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override;
  double reward(const VectorXd& x) const override;
  bool solved(const rollout::Trajectory& trajectory) const override;
  /// The mirror about the vertical, x -> -x, u -> -u: the lab's equations of motion are odd in
  /// the angles, velocities and torques; the start (0) is its fixed point.
  std::optional<rollout::Reflection> reflection() const override;
  /// Upright at rest: x* = [pi, 0, 0, 0] (link 1 up, link 2 aligned), u* = 0,
  /// |u| <= max_torque, angles q1, q2 (entries 0 and 1) wrapped.
  std::optional<rollout::Goal> goal() const override;
  const TaskOptions& options() const { return options_; }

 private:
  TaskOptions options_;
  ScoreDefinition score_;
  int horizon_;
};

/// The leaderboard's plant as a drops system: u (dim 1) clipped to the plant's limit and held over
/// substeps() RK4 steps of sim_dt. Deterministic; thread-safe.
class PlantSystem final : public rollout::System {
 public:
  /// Throws InvalidArgument when the parameters or options are invalid.
  PlantSystem(const PlantParameters& plant, const TaskOptions& options);
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override;

 private:
  PlantParameters plant_;
  TaskOptions options_;
};

/// Names of the simulator prior's phi: m1, m2, l1, r1, r2, I1, I2 (the lab's model parameters
/// that enter the equations of motion without friction; l2 only places the tip).
std::vector<std::string> prior_parameter_names();
/// The phi (dim 7) of plant parameters, in prior_parameter_names()' order.
VectorXd to_phi(const PlantParameters& plant);

/// The simulator prior M(x, u; phi) = step(x, u; phi) - x: the plant's equations with phi's
/// values over `base`'s other fields (torque limits, gravity, friction). Shares the plant's code,
/// so phi = to_phi(plant) reproduces PlantSystem exactly. Thread-safe.
class PlantPrior final : public model::MeanFunction {
 public:
  PlantPrior(const PlantParameters& base, const TaskOptions& options);
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return prior_parameter_names(); }
  void check_phi(const VectorXd& phi) const override;
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  std::unique_ptr<model::MeanFunction> clone() const override;

 private:
  PlantParameters with_phi(const VectorXd& phi) const;
  PlantParameters base_;
  TaskOptions options_;
};

/// An episode's 2 ms trajectory in the leaderboard's file layout: from x0 (dim 4), each action of
/// `actions` (H x 1, N m, clipped to the plant's limit) held over `substeps` RK4 steps of sim_dt.
/// Rows follow definition.rows_after_step (ScoreDefinition). Throws InvalidArgument on sizes.
SwingupTrajectory leaderboard_trajectory(const PlantParameters& plant, const ScoreDefinition& def,
                                         const Eigen::Vector4d& x0, const MatrixXd& actions,
                                         int substeps, double sim_dt);

/// Names of the task's episode metrics, in the order of episode_metrics(): swingup_success,
/// swingup_time_s, energy_j, max_tau_nm, integrated_tau_nms, tau_cost, tau_smoothness_nm,
/// velocity_cost, realai_score.
std::vector<std::string> metric_names();
/// The leaderboard's criteria and score of a Score, in metric_names()' order (success as 0/1).
std::vector<double> metric_values(const Score& score);

}  // namespace drops::realaigym
