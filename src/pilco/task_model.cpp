// PILCO's view of a task (baselines.md §1a "State bookkeeping", "Saturating cost").
#include "drops/pilco/task_model.hpp"

#include <cmath>

#include "drops/core/errors.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd TaskModel::augment(const VectorXd& x) const {
  check_size("TaskModel::augment: x (state_dim)", config.state_dim, x.size());
  VectorXd a(config.augmented_dim());
  a.head(config.state_dim) = x;
  Index k = config.state_dim;
  for (int i : config.angles) {
    a[k++] = std::sin(x[i]);
    a[k++] = std::cos(x[i]);
  }
  return a;
}

VectorXd TaskModel::dynamics_input(const VectorXd& x, const VectorXd& u) const {
  check_size("TaskModel::dynamics_input: u (control_dim)", config.control_dim(), u.size());
  const VectorXd a = augment(x);
  const Index n = static_cast<Index>(config.dynamics_inputs.size());
  VectorXd in(n + u.size());
  for (Index k = 0; k < n; ++k) in[k] = a[config.dynamics_inputs[static_cast<std::size_t>(k)]];
  in.tail(u.size()) = u;
  return in;
}

VectorXd TaskModel::policy_input(const VectorXd& x) const {
  const VectorXd a = augment(x);
  VectorXd in(config.policy_inputs.size());
  for (Index k = 0; k < in.size(); ++k)
    in[k] = a[config.policy_inputs[static_cast<std::size_t>(k)]];
  return in;
}

SaturatingCost TaskModel::cost(double width) const {
  if (!(width > 0.0) || !std::isfinite(width))
    throw InvalidArgument("TaskModel::cost: width: expected a finite value > 0, got " +
                          std::to_string(width));
  SaturatingCost c;
  c.weight = cost_map.transpose() * cost_map / (width * width);
  c.weight = 0.5 * (c.weight + c.weight.transpose());
  c.target = cost_target;
  return c;
}

bool TaskModel::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = "pilco::TaskModel: " + w;
    return false;
  };
  std::string w;
  if (!config.IsValid(&w)) {
    if (why != nullptr) *why = "pilco::TaskModel: " + w;
    return false;
  }
  const Index p = config.augmented_dim(), D = config.state_dim;
  if (cost_map.rows() < 1 || cost_map.cols() != p)
    return fail("cost_map: expected k x " + std::to_string(p) + " with k >= 1, got " +
                std::to_string(cost_map.rows()) + " x " + std::to_string(cost_map.cols()));
  if (cost_target.size() != p)
    return fail("cost_target: expected size " + std::to_string(p) + ", got " +
                std::to_string(cost_target.size()));
  if (!cost_map.allFinite() || !cost_target.allFinite())
    return fail("cost_map, cost_target: expected finite values");
  if (!(reward_width >= 0.0) || !std::isfinite(reward_width))
    return fail("reward_width: expected a finite value >= 0, got " + std::to_string(reward_width));
  if (initial_cov.rows() != D || initial_cov.cols() != D)
    return fail("initial_cov: expected " + std::to_string(D) + " x " + std::to_string(D) +
                ", got " + std::to_string(initial_cov.rows()) + " x " +
                std::to_string(initial_cov.cols()));
  if (!initial_cov.allFinite() ||
      (initial_cov - initial_cov.transpose()).cwiseAbs().maxCoeff() >
          1e-12 * (1.0 + initial_cov.cwiseAbs().maxCoeff()) ||
      (initial_cov.diagonal().array() < 0).any())
    return fail("initial_cov: expected a finite symmetric matrix with a non-negative diagonal");
  if (policy_length_scales.size() != 0 &&
      policy_length_scales.size() != static_cast<Index>(config.policy_inputs.size()))
    return fail("policy_length_scales: expected empty or size " +
                std::to_string(config.policy_inputs.size()) + ", got " +
                std::to_string(policy_length_scales.size()));
  if (policy_length_scales.size() &&
      (!(policy_length_scales.array() > 0).all() || !policy_length_scales.allFinite()))
    return fail("policy_length_scales: expected finite values > 0");
  return true;
}

}  // namespace drops::pilco
