#pragma once
/// \file Catch and balance: near the goal state a task declares (Task::goal), hand over from the
/// learned policy to an LQR computed on the learned model's linearisation at the goal. The hybrid
/// is what rollouts on the model and episodes on the real system run (algo::BlackDropsOptions::
/// balance), so the policy search sees the catch. docs/balance.md describes the rule.

#include <memory>
#include <optional>
#include <string>

#include "drops/control/lqr.hpp"
#include "drops/core/problem.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/policy/policy.hpp"

namespace drops::control {

/// Whether and how a stabilising controller takes over near the goal.
enum class BalanceMode {
  kOff,  ///< the learned policy alone
  kLqr,  ///< LQR on the learned model's mean linearised at the goal (BalanceController)
};

/// Options of the catch-and-balance controller (keys policy.balance.*).
struct BalanceOptions {
  BalanceMode mode = BalanceMode::kOff;
  /// Q = q I (state weight, > 0) and R = r I (action weight, > 0) of the LQR cost
  /// sum (x - x*)'Q(x - x*) + (u - u*)'R(u - u*), in the raw state's and action's units.
  double q = 1.0;
  double r = 1.0;
  /// The switching rule on the LQR's cost-to-go V(x) = e'Pe, e = Goal::error(x) (angles
  /// wrapped): the LQR takes over when V <= enter and hands back when V > exit (hysteresis,
  /// exit >= enter > 0); an episode starts with the learned policy.
  double enter = 1.0;
  double exit = 4.0;
  /// Central finite-difference step of the linearisation (linearize), in the state's and the
  /// action's units, > 0.
  double step = 1e-4;
  DareOptions dare;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// "off" | "lqr". Thread-safe.
std::string to_string(BalanceMode mode);

/// An LQR at the goal computed on a model: u = u* - K e clipped to the goal's action_limit.
struct BalanceController {
  Goal goal;
  Linearization linearization;  ///< of the model at (x*, u*)
  DareResult dare;              ///< P and K (valid only when usable())
  /// Whether the LQR can be used: the DARE converged and the closed loop A - BK of the model is
  /// stable (spectral radius < 1). When not, the hybrid policy is the learned policy alone.
  bool usable() const { return dare.converged && dare.closed_loop_radius < 1; }
  /// u* - K Goal::error(x), clipped to +-goal.action_limit; x: dim E, u: dim U. Thread-safe.
  void act(const VectorXd& x, Eigen::Ref<VectorXd> u) const;
  /// V(x) = e'Pe, e = Goal::error(x). Thread-safe.
  double cost_to_go(const VectorXd& x) const;
};

/// The LQR of options on model's mean linearised at task.goal() (linearize, then solve_dare with
/// Q = q I, R = r I). Throws InvalidArgument when options are invalid or the task declares no
/// goal (or an invalid one: Goal::check); Error when the model's mean is not finite at the goal.
/// A DARE that does not converge is not an error: see BalanceController::usable(). Thread-safe
/// after the model's learn().
BalanceController make_balance_controller(const Task& task, const model::DynamicsModel& model,
                                          const BalanceOptions& options);

/// The task seen by the hybrid policy: everything is the wrapped task's, but observe() appends
/// the raw state: obs' = [observe(x) (dim O); x (dim E)], dim O + E. The model must be built
/// with the wrapped task (it observes through it); this one is for the policy's input only.
/// Immutable and thread-safe.
class BalanceTask final : public Task {
 public:
  explicit BalanceTask(std::shared_ptr<const Task> task);
  std::string name() const override { return task_->name(); }
  int state_dim() const override { return task_->state_dim(); }
  int action_dim() const override { return task_->action_dim(); }
  int observation_dim() const override { return task_->observation_dim() + task_->state_dim(); }
  int horizon() const override { return task_->horizon(); }
  double dt() const override { return task_->dt(); }
  VectorXd initial_state() const override { return task_->initial_state(); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override;
  void observe_batch(const MatrixXd& X, MatrixXd& obs) const override;
  double reward(const VectorXd& x) const override { return task_->reward(x); }
  void reward_batch(const MatrixXd& X, VectorXd& r) const override { task_->reward_batch(X, r); }
  double action_reward(const VectorXd& u) const override { return task_->action_reward(u); }
  bool has_action_reward() const override { return task_->has_action_reward(); }
  bool solved(const Trajectory& trajectory) const override { return task_->solved(trajectory); }
  bool absorbing(const VectorXd& x) const override { return task_->absorbing(x); }
  std::optional<Reflection> reflection() const override { return task_->reflection(); }
  std::optional<Goal> goal() const override { return task_->goal(); }
  const Task& wrapped() const { return *task_; }

 private:
  std::shared_ptr<const Task> task_;
};

/// The hybrid policy on a BalanceTask's observation [obs; x]: the learned policy pi(obs | theta)
/// until the LQR's cost-to-go V(x) falls to options.enter, then the controller's
/// u* - K (x - x*) (clipped) until V(x) exceeds options.exit, then the learned policy again
/// (hysteresis). The switch is reset at t = 0 (the start of an episode). theta and its
/// dimension are the learned policy's. With an unusable controller it is the learned policy.
/// Stateful: act() updates the switch and the counts, so a clone serves one episode at a time
/// (run_episode and evaluate_policies clone one per episode and per rollout); not thread-safe.
class BalancePolicy final : public policy::Policy {
 public:
  /// inner: the learned policy (observation dim O); E: the state dimension. Throws
  /// InvalidArgument on a null inner policy, E < 1, a controller whose goal has not dim E and
  /// inner's action dim, or invalid options.
  BalancePolicy(std::unique_ptr<policy::Policy> inner, int E,
                std::shared_ptr<const BalanceController> controller, const BalanceOptions& options);
  int observation_dim() const override { return inner_->observation_dim() + E_; }
  int action_dim() const override { return inner_->action_dim(); }
  int param_dim() const override { return inner_->param_dim(); }
  void set_params(const VectorXd& theta) override { inner_->set_params(theta); }
  const VectorXd& params() const override { return inner_->params(); }
  void act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const override;
  std::unique_ptr<policy::Policy> clone() const override;
  /// Steps of the current (or last) episode on which the controller acted.
  int balance_steps() const { return balance_steps_; }
  /// The first of them (-1: none), counted from 0 at t = 0.
  int first_balance_step() const { return first_step_; }

 private:
  std::unique_ptr<policy::Policy> inner_;
  int E_;
  std::shared_ptr<const BalanceController> controller_;
  BalanceOptions options_;
  mutable bool engaged_ = false;
  mutable int step_ = 0, balance_steps_ = 0, first_step_ = -1;
};

}  // namespace drops::control
