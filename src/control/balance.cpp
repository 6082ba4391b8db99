#include "drops/control/balance.hpp"

#include <algorithm>
#include <cmath>

#include "drops/core/errors.hpp"

namespace drops::control {

bool BalanceOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(q > 0) || !std::isfinite(q)) return fail("q must be > 0");
  if (!(r > 0) || !std::isfinite(r)) return fail("r must be > 0");
  if (!(enter > 0) || !std::isfinite(enter)) return fail("enter must be > 0");
  if (!(exit >= enter) || !std::isfinite(exit)) return fail("exit must be >= enter");
  if (!(step > 0) || !std::isfinite(step)) return fail("step must be > 0");
  std::string w;
  if (!dare.IsValid(&w)) return fail("dare: " + w);
  return true;
}

std::string to_string(BalanceMode mode) { return mode == BalanceMode::kLqr ? "lqr" : "off"; }

void BalanceController::act(const VectorXd& x, Eigen::Ref<VectorXd> u) const {
  const VectorXd e = goal.error(x);
  u = goal.action - dare.K * e;
  for (Eigen::Index i = 0; i < u.size(); ++i)
    u[i] = std::clamp(u[i], -goal.action_limit[i], goal.action_limit[i]);
}

double BalanceController::cost_to_go(const VectorXd& x) const {
  const VectorXd e = goal.error(x);
  return e.dot(dare.P * e);
}

BalanceController make_balance_controller(const Task& task, const model::DynamicsModel& model,
                                          const BalanceOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("balance options: " + why);
  const std::optional<Goal> goal = task.goal();
  if (!goal)
    throw InvalidArgument("policy.balance.mode = lqr: the task '" + task.name() +
                          "' declares no goal state (Task::goal)");
  goal->check(task.state_dim(), task.action_dim());
  BalanceController c;
  c.goal = *goal;
  c.linearization = linearize(model, goal->state, goal->action, options.step);
  const Eigen::Index E = goal->state.size(), U = goal->action.size();
  c.dare = solve_dare(c.linearization.A, c.linearization.B, options.q * MatrixXd::Identity(E, E),
                      options.r * MatrixXd::Identity(U, U), options.dare);
  return c;
}

BalanceTask::BalanceTask(std::shared_ptr<const Task> task) : task_(std::move(task)) {
  if (!task_) throw InvalidArgument("BalanceTask: task is null");
}

void BalanceTask::observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const {
  const int O = task_->observation_dim();
  task_->observe(x, obs.head(O));
  obs.tail(x.size()) = x;
}

void BalanceTask::observe_batch(const MatrixXd& X, MatrixXd& obs) const {
  MatrixXd inner;
  task_->observe_batch(X, inner);  // the wrapped task's batch (a Python task: one lock)
  obs.resize(X.rows(), inner.cols() + X.cols());
  obs.leftCols(inner.cols()) = inner;
  obs.rightCols(X.cols()) = X;
}

BalancePolicy::BalancePolicy(std::unique_ptr<policy::Policy> inner, int E,
                             std::shared_ptr<const BalanceController> controller,
                             const BalanceOptions& options)
    : inner_(std::move(inner)), E_(E), controller_(std::move(controller)), options_(options) {
  if (!inner_) throw InvalidArgument("BalancePolicy: the learned policy is null");
  if (E < 1) throw InvalidArgument("BalancePolicy: E must be >= 1");
  if (!controller_) throw InvalidArgument("BalancePolicy: the controller is null");
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("balance options: " + why);
  check_size("BalancePolicy: goal state vs E", E, controller_->goal.state.size());
  check_size("BalancePolicy: goal action vs the policy's action_dim", inner_->action_dim(),
             controller_->goal.action.size());
}

void BalancePolicy::act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const {
  check_size("BalancePolicy::act: observation", observation_dim(), obs.size());
  if (t == 0) {  // a new episode
    engaged_ = false;
    step_ = balance_steps_ = 0;
    first_step_ = -1;
  }
  const int O = inner_->observation_dim();
  if (controller_->usable()) {
    const VectorXd x = obs.tail(E_);
    const double v = controller_->cost_to_go(x);
    engaged_ = engaged_ ? !(v > options_.exit) : v <= options_.enter;
    if (engaged_) {
      controller_->act(x, u);
      if (first_step_ < 0) first_step_ = step_;
      ++balance_steps_;
      ++step_;
      return;
    }
  }
  inner_->act(obs.head(O), t, u);
  ++step_;
}

std::unique_ptr<policy::Policy> BalancePolicy::clone() const {
  auto p = std::make_unique<BalancePolicy>(inner_->clone(), E_, controller_, options_);
  return p;
}

}  // namespace drops::control
