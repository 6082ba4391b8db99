#pragma once
/// \file PILCO's deterministic GP policy, an RBF network (congp + gp2; baselines.md §1a), with
/// exact moments under a Gaussian input and their derivatives with respect to the input moments and
/// to the policy parameters.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <vector>

#include "drops/pilco/moments.hpp"
#include "drops/pilco/se_model.hpp"

namespace drops::pilco {

/// Unsquashed control u~(x) (dim E) of an input x (dim d): per output a, the posterior mean of a
/// noise-free-ish GP through n pseudo-observations (centres c_i, targets t_a):
///   u~_a(x) = sum_i beta_a,i exp(-1/2 (x - c_i)^T Lambda_a^-1 (x - c_i)),
///   beta_a = (K_a + sigma_n^2 I)^-1 t_a,  Lambda_a = diag(l_a^2),
/// with alpha^2 = 1 and sigma_n = 0.01 fixed as in congp ("avoids some potential numerical
/// problems"). Centres are shared by the outputs, length scales are per output.
///
/// Parameters theta (dim P = n d + n E + d E), in this order:
///   vec(centres)           n x d, column-major: coordinate k of centre i at i + n k;
///   vec(targets)           n x E: target of centre i for output a at n d + i + n a;
///   vec(log_length_scales) d x E: log l_a,k at n d + n E + k + d a.
/// PILCO also stores log alpha and log sigma_n in its hyper-parameters but zeroes their gradients
/// (1408 = 1200 + 200 + 8 for paper §V-A's swing-up); here they are constants (P = 1406).
///
/// Usage: construct, set_params(theta) or set(), then action() or moments(). Every const member is
/// thread-safe; set/set_params are not (one policy per thread when parameters differ).
class RbfPolicy {
 public:
  /// alpha^2, the signal variance (fixed).
  static constexpr double kSignalVariance = 1.0;
  /// sigma_n^2 = 0.01^2, the noise variance of the pseudo-observations (fixed).
  static constexpr double kNoiseVariance = 1e-4;
  /// Added to the diagonal of the moment-matched covariance (gp2.m).
  static constexpr double kOutputJitter = 1e-6;

  /// A policy on inputs of dimension input_dim (d >= 1) with num_centres (n >= 1) centres and
  /// output_dim (E >= 1) outputs: centres and targets 0, length scales 1. InvalidArgument
  /// otherwise.
  RbfPolicy(int input_dim, int num_centres, int output_dim = 1);

  int input_dim() const { return input_dim_; }      ///< d
  int num_centres() const { return num_centres_; }  ///< n
  int output_dim() const { return output_dim_; }    ///< E
  /// P = n d + n E + d E.
  int num_params() const;

  /// theta (dim P, layout in the class comment).
  Eigen::VectorXd params() const;
  /// Sets theta (dim P, finite; InvalidArgument otherwise) and refactorises K_a + sigma_n^2 I
  /// (O(E n^3)); NumericalError if a factorisation fails (the policy is then unchanged).
  void set_params(const Eigen::VectorXd& theta);
  /// Sets centres (n x d), targets (n x E) and log length scales (d x E; |entries| < 50), same
  /// errors as set_params.
  void set(const Eigen::MatrixXd& centres, const Eigen::MatrixXd& targets,
           const Eigen::MatrixXd& log_length_scales);

  const Eigen::MatrixXd& centres() const { return centres_; }                      ///< n x d
  const Eigen::MatrixXd& targets() const { return targets_; }                      ///< n x E
  const Eigen::MatrixXd& log_length_scales() const { return log_length_scales_; }  ///< d x E
  /// beta (n x E): column a is (K_a + sigma_n^2 I)^-1 t_a.
  const Eigen::MatrixXd& weights() const { return beta_; }

  /// u~(x) (dim E) at a deterministic input x (dim d; InvalidArgument otherwise).
  Eigen::VectorXd action(const Eigen::VectorXd& x) const;

  /// The network as an SeModel: output a is one block (centres, beta_a, l_a, alpha^2 = 1), no
  /// variance.
  SeModel as_se_model() const;

  /// Moments of u~(x) for x ~ N(mu, Sigma) (mu: d, Sigma: d x d): mean, cov (+ kOutputJitter on the
  /// diagonal, no alpha^2 - tr(K^-1 Q) term) and cross = Sigma^-1 Cov[x, u~] (d x E), i.e. gp2.m's
  /// moments (baselines.md §1a). With input_derivatives, d/dmu and d/dSigma; with
  /// param_derivatives, dmean_dtheta, dcov_dtheta, dcross_dtheta (all through beta's dependence on
  /// centres, targets and length scales). Conventions: Moments. Errors: as se_moments.
  /// Cost O(E^2 n^2 d) for the moments; parameter derivatives add O(E (E + E^2 + d E) n^2 d).
  /// Thread-safe.
  Moments moments(const Eigen::VectorXd& mu, const Eigen::MatrixXd& sigma,
                  bool input_derivatives = false, bool param_derivatives = false) const;

 private:
  int input_dim_;
  int num_centres_;
  int output_dim_;
  Eigen::MatrixXd centres_;                       // n x d
  Eigen::MatrixXd targets_;                       // n x E
  Eigen::MatrixXd log_length_scales_;             // d x E
  Eigen::MatrixXd beta_;                          // n x E
  std::vector<Eigen::MatrixXd> k_;                // per output: K_a (n x n, noise-free)
  std::vector<Eigen::LLT<Eigen::MatrixXd>> llt_;  // per output: K_a + sigma_n^2 I
};

}  // namespace drops::pilco
