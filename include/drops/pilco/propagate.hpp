#pragma once
/// \file PILCO's one-step propagation of a Gaussian state through [state, trig(state), policy,
/// squashing, GP] (propagate.m, propagated.m) and the expected cumulative cost J(theta) with its
/// analytic gradient by forward-mode recursion (value.m); baselines.md §1a.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "drops/pilco/cost.hpp"
#include "drops/pilco/moments.hpp"
#include "drops/pilco/rbf_policy.hpp"
#include "drops/pilco/se_model.hpp"

namespace drops::pilco {

/// Which state entries are angles and which entries feed the policy and the GP. The augmented
/// vector is x_aug = [x (D), sin x_i1, cos x_i1, sin x_i2, cos x_i2, ...] (D + 2 |angles|), the
/// policy sees x_aug[policy_inputs], the GP sees [x_aug[dynamics_inputs], u] with u the squashed
/// control, and its E = D outputs are the state differences: x' = x + Delta (PILCO's difi = all).
/// The swing-up of paper §V-A (baselines.md §1a, x = [dtheta1, dtheta2, theta1, theta2]): angles {2, 3},
/// policy_inputs = dynamics_inputs = {0, 1, 4, 5, 6, 7}, max_u = [3.5].
struct PropagationConfig {
  int state_dim = 0;                 ///< D >= 1
  std::vector<int> angles;           ///< PILCO's angi: indices into x, each in [0, D), no repeats
  std::vector<int> policy_inputs;    ///< poli: indices into x_aug, >= 1 of them, no repeats
  std::vector<int> dynamics_inputs;  ///< dyni: indices into x_aug, no repeats
  Eigen::VectorXd max_u;             ///< squashing bounds (U >= 1 controls), > 0, units of u

  /// D + 2 |angles|.
  int augmented_dim() const { return state_dim + 2 * static_cast<int>(angles.size()); }
  /// U.
  int control_dim() const { return static_cast<int>(max_u.size()); }
  /// Returns true when every field is in range; otherwise false and, if why != nullptr, the reason.
  bool IsValid(std::string* why) const;
  /// Throws InvalidArgument unless IsValid and the dynamics model has input dimension
  /// |dynamics_inputs| + U and D outputs, and the policy has input dimension |policy_inputs| and U
  /// outputs.
  void check(const SeModel& dynamics, const RbfPolicy& policy) const;
};

/// Which derivatives propagate() computes.
enum class StepDerivatives {
  kNone,            ///< moments only
  kState,           ///< + derivatives w.r.t. the state moments (mu, Sigma)
  kStateAndPolicy,  ///< + derivatives w.r.t. the policy parameters theta
};

/// Moments of x_{t+1} (dim D) given x_t ~ N(mu, Sigma), and derivatives (conventions: Moments;
/// empty unless requested): PILCO's propagated.m outputs dMdm, dMds, dSdm, dSds, dMdp, dSdp.
struct StepMoments {
  Eigen::VectorXd mean;          ///< D
  Eigen::MatrixXd cov;           ///< D x D, symmetric
  Eigen::MatrixXd dmean_dmu;     ///< D x D
  Eigen::MatrixXd dmean_dsigma;  ///< D x D^2
  Eigen::MatrixXd dcov_dmu;      ///< D^2 x D
  Eigen::MatrixXd dcov_dsigma;   ///< D^2 x D^2
  Eigen::MatrixXd dmean_dtheta;  ///< D x P
  Eigen::MatrixXd dcov_dtheta;   ///< D^2 x P
  /// The joint Gaussian the step built, over [x (D), trig (2 |angles|), u~ (U), u (U), Delta (D)]
  /// (dim 2 D + 2 |angles| + 2 U): the unsquashed and squashed control and the GP's prediction,
  /// jointly with the state (e.g. the predicted control distribution of a step).
  Eigen::VectorXd joint_mean;
  Eigen::MatrixXd joint_cov;  ///< symmetric
};

/// One step of PILCO's propagation (baselines.md §1a "One-step propagation"): on the growing joint
/// Gaussian of [x, trig(x), u~, u, Delta], each block (trig_moments, RbfPolicy::moments,
/// squash_moments, se_moments) maps its inputs i to moments (M, S, C = S_ii^-1 cov(i, new)) and the
/// cross-covariances with every earlier entry j follow the linear-Gaussian rule S(j, new) =
/// S(j, i) C (exact for jointly Gaussian inputs); then x' = x + Delta. Derivatives are carried
/// through every block by the chain rule (forward mode). Sigma must be positive semi-definite.
/// Throws InvalidArgument on sizes or an inconsistent config (PropagationConfig::check);
/// NumericalError as the blocks. Thread-safe.
StepMoments propagate(const PropagationConfig& config, const SeModel& dynamics,
                      const RbfPolicy& policy, const Eigen::VectorXd& mu,
                      const Eigen::MatrixXd& sigma,
                      StepDerivatives derivatives = StepDerivatives::kNone);

/// E[c(x_aug)] of the state x ~ N(mu, Sigma) (dim D), x_aug being its trig augmentation
/// (config.angles; cost.weight is augmented_dim() square), with derivatives with respect to the
/// state moments: dmean_dmu (D), dmean_dsigma (D x D, convention of Moments). PILCO's loss
/// functions do this augmentation themselves (PILCO's loss functions). Thread-safe.
CostMoments state_cost(const PropagationConfig& config, const SaturatingCost& cost,
                       const Eigen::VectorXd& mu, const Eigen::MatrixXd& sigma,
                       bool derivatives = false);

/// Predicted state distributions and expected costs of a policy (ExpectedCost::predict).
struct PredictedTrajectory {
  std::vector<Eigen::VectorXd> means;  ///< H + 1 state means x_0 .. x_H
  std::vector<Eigen::MatrixXd> covs;   ///< H + 1 state covariances
  Eigen::VectorXd expected_costs;      ///< H: E[c(x_1)] .. E[c(x_H)] (undiscounted)
  Eigen::VectorXd cost_variances;      ///< H: Var[c(x_t)]
  /// H: E[u_t] (dim U each), the squashed control's mean at the step from x_t to x_{t+1}.
  std::vector<Eigen::VectorXd> action_means;
  double total = 0.0;                  ///< J = sum_t gamma^t E[c(x_t)]
};

/// PILCO's policy objective (value.m; baselines.md §1a "Policy objective and analytic gradient"):
///   J(theta) = sum_{t=1}^{H} gamma^t E[c(x_t)],  x_0 ~ N(initial_mean, initial_cov),
/// x_t from propagate() with the RbfPolicy at theta, to be minimised. The gradient is PILCO's
/// forward-mode recursion: dm_t/dtheta = dM/dmu dm_{t-1}/dtheta + dM/dSigma dSigma_{t-1}/dtheta +
/// dM/dtheta (the same for Sigma_t), dJ/dtheta = sum_t gamma^t (dE[c]/dm_t dm_t/dtheta +
/// dE[c]/dSigma_t dSigma_t/dtheta). The call operator fits NLopt's gradient-based algorithms
/// (e.g. LD_LBFGS) through nlopt_objective. Immutable after construction; every member is
/// const and thread-safe (each call works on its own copy of the policy).
class ExpectedCost {
 public:
  /// policy: its structure (sizes) only, parameters come with each call. horizon H >= 1, discount
  /// gamma in (0, 1]. Throws InvalidArgument on inconsistent sizes (PropagationConfig::check, cost
  /// of dim config.augmented_dim(), initial moments of dim D) or invalid values.
  ExpectedCost(PropagationConfig config, SeModel dynamics, RbfPolicy policy, SaturatingCost cost,
               Eigen::VectorXd initial_mean, Eigen::MatrixXd initial_cov, int horizon,
               double discount = 1.0);

  /// P, the policy's number of parameters.
  int num_params() const { return policy_.num_params(); }
  /// H, the number of predicted steps.
  int horizon() const { return horizon_; }

  /// J(theta) (theta: dim P); if gradient != nullptr, also dJ/dtheta (resized to P).
  /// Errors: RbfPolicy::set_params, propagate. Cost per step O(E^2 N^2 D) for the GP moments, plus
  /// with the gradient the input derivatives of every block and O(n^2 d) per policy output scalar:
  /// about 0.23 s (J) and 0.31 s (J and gradient) for the sizes of paper §V-A's swing-up (D = 7, E = 4, N = 250,
  /// 200 centres, H = 50; bench/bench_pilco.cpp, one core).
  double operator()(const Eigen::VectorXd& theta, Eigen::VectorXd* gradient = nullptr) const;

  /// The state distributions and expected costs along the horizon (no gradient).
  PredictedTrajectory predict(const Eigen::VectorXd& theta) const;

  /// NLopt objective (the C API's nlopt_func, also accepted by nlopt::opt::set_min_objective):
  /// data must point to an ExpectedCost, x and grad (may be null) to n = P doubles. Exceptions
  /// propagate; NLopt's C++ wrapper catches them, stops the run and optimize() then throws
  /// (std::runtime_error "nlopt failure" for drops' exceptions), so a caller that needs the
  /// message should evaluate the objective itself first.
  static double nlopt_objective(unsigned n, const double* x, double* grad, void* data);

 private:
  PropagationConfig config_;
  SeModel dynamics_;
  RbfPolicy policy_;
  SaturatingCost cost_;
  Eigen::VectorXd initial_mean_;
  Eigen::MatrixXd initial_cov_;
  int horizon_;
  double discount_;
};

}  // namespace drops::pilco
