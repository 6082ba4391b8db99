// A test task: another task with a torque cost, action_reward(u) = -w |u|^2 (Task::action_reward).
#pragma once

#include <memory>
#include <string>
#include <utility>

#include "drops/core/problem.hpp"

namespace drops::testing {

/// `task` (its dynamics' dimensions, reward, observation, solved) plus action_reward(u) =
/// -w |u|^2, under its own name when one is given. Immutable, thread-safe as `task`.
class TorqueCostTask final : public rollout::Task {
 public:
  TorqueCostTask(std::shared_ptr<const rollout::Task> task, double w, std::string name = "")
      : task_(std::move(task)), w_(w), name_(std::move(name)) {}
  std::string name() const override { return name_.empty() ? task_->name() : name_; }
  int state_dim() const override { return task_->state_dim(); }
  int action_dim() const override { return task_->action_dim(); }
  int observation_dim() const override { return task_->observation_dim(); }
  int horizon() const override { return task_->horizon(); }
  double dt() const override { return task_->dt(); }
  VectorXd initial_state() const override { return task_->initial_state(); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override { task_->observe(x, obs); }
  double reward(const VectorXd& x) const override { return task_->reward(x); }
  double action_reward(const VectorXd& u) const override { return -w_ * u.squaredNorm(); }
  bool has_action_reward() const override { return true; }
  bool solved(const rollout::Trajectory& t) const override { return task_->solved(t); }

 private:
  std::shared_ptr<const rollout::Task> task_;
  double w_;
  std::string name_;
};

}  // namespace drops::testing
