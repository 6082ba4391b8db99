#pragma once
/// \file What PILCO needs to know about a task beyond drops' generic Task: which state
/// entries are angles, what the policy and the GP see in PILCO's augmented space, the saturating
/// cost's target and distance, the initial state distribution and the policy's initial length
/// scales (baselines.md §1a, "State bookkeeping" and "Saturating cost"). A task provides it
/// under "pilco" in experiment::TaskSetup::algorithm_data; algo::Pilco uses it.

#include <Eigen/Core>
#include <string>

#include "drops/pilco/cost.hpp"
#include "drops/pilco/propagate.hpp"

namespace drops::pilco {

/// A task as PILCO sees it. Value type; validate with IsValid.
///
/// The cost of a state x (dim D) is PILCO's saturating cost on its augmentation
/// x_aug = [x, sin x_i1, cos x_i1, ...] (dim p = config.augmented_dim()):
///   c_w(x) = 1 - exp(-1/2 |C (x_aug - z)|^2 / w^2),
/// C = cost_map, z = cost_target, w the cost width (a setting of the algorithm), i.e.
/// W = C^T C / w^2 in SaturatingCost. When the task's reward per step is
/// exp(-1/2 |C (x_aug - z)|^2 / reward_width^2) (the swing-up tasks: |C (x_aug - z)| is the tip's
/// distance to the goal), the reward is 1 - c_{reward_width}(x): PILCO's expected cost then
/// gives the expected return, and with w = reward_width PILCO minimises exactly the negative
/// expected return (J = H - E[return]).
struct TaskModel {
  /// State dimension D, angles, policy inputs, GP inputs and squashing bounds (max_u: dim U).
  PropagationConfig config;
  /// C (k x p), the linear map whose norm is the cost's distance (units: of the distance, e.g. m).
  Eigen::MatrixXd cost_map;
  /// z (p), the target in the augmented space.
  Eigen::VectorXd cost_target;
  /// When > 0, the task's reward is 1 - c_{reward_width}(x) (see above); 0 when the task's reward
  /// has another form (the predicted return is then not reported). Units of the distance.
  double reward_width = 0.0;
  /// Sigma_0 (D x D, symmetric positive semi-definite): the initial state distribution
  /// N(task.initial_state(), Sigma_0) that PILCO plans from (a task with a deterministic start
  /// still gives a small Sigma_0: the policy then also works near the start).
  Eigen::MatrixXd initial_cov;
  /// Initial length scales of the RBF policy (dim |config.policy_inputs|, > 0), in the units of
  /// the policy inputs; empty = all 1. PILCO's swing-ups: 1 for velocities, 0.7 for sin/cos.
  Eigen::VectorXd policy_length_scales;

  /// The augmented state [x, sin x_i1, cos x_i1, ...] (dim p) of a state x (dim D; InvalidArgument
  /// otherwise). Order sin, cos per angle (PILCO's gTrig).
  Eigen::VectorXd augment(const Eigen::VectorXd& x) const;
  /// The GP input [x_aug[dynamics_inputs], u] (dim |dynamics_inputs| + U) of a state x (dim D) and
  /// action u (dim U). InvalidArgument on sizes.
  Eigen::VectorXd dynamics_input(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const;
  /// The policy input x_aug[policy_inputs] (dim |policy_inputs|) of a state x (dim D).
  Eigen::VectorXd policy_input(const Eigen::VectorXd& x) const;
  /// The saturating cost of width w (> 0, units of the distance): weight C^T C / w^2, target z.
  /// Throws InvalidArgument when w <= 0.
  SaturatingCost cost(double width) const;
  /// Returns true when the config is valid and every size and value above is consistent
  /// (cost_map k x p with k >= 1, cost_target p, initial_cov D x D symmetric with finite entries
  /// and a non-negative diagonal, policy_length_scales empty or |policy_inputs| and > 0,
  /// reward_width >= 0); otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

}  // namespace drops::pilco
