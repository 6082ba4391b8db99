#pragma once
/// \file Gaussian process regression with one scalar output (paper eq. 3-6).

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <string>

#include "drops/gp/kernel.hpp"

namespace drops::gp {

/// Options of the iRprop- hyper-parameter search (Igel & Huesken 2000; settings.md §3).
struct RpropOptions {
  int max_iterations = 300;  ///< iterations (gradient evaluations), >= 1
  double delta0 = 0.1;       ///< initial step per parameter (log space), > 0
  double delta_min = 1e-6;   ///< smallest step, > 0; the search stops when every step is below it
  double delta_max = 50.0;   ///< largest step, >= delta0
  double eta_minus = 0.5;    ///< step decrease factor in (0, 1)
  double eta_plus = 1.2;     ///< step increase factor, > 1
  /// Stop early when the best log-likelihood improved by less than this over the last
  /// `patience` iterations (0 disables early stopping: run max_iterations).
  double tolerance = 0.0;
  int patience = 10;  ///< iterations over which `tolerance` is measured, >= 1
  /// Returns true when every field is in range; otherwise false and, if why != nullptr, the reason.
  bool IsValid(std::string* why) const;
};

/// Result of Gp::optimize_h_params.
struct RpropSummary {
  int iterations = 0;                 ///< gradient evaluations performed
  double initial_log_likelihood = 0;  ///< log p(y | X, h) at the warm start
  double final_log_likelihood = 0;    ///< at the best iterate (the one kept)
  int cholesky_failures = 0;          ///< iterates rejected because K was not positive definite
};

/// Scalar-output GP regression, zero mean on the targets it is given (the caller subtracts the prior
/// mean M(x, phi) first, paper eq. 4). Hyper-parameters in log space:
///   h = [log l_1 .. log l_D, log sigma_f, log sigma_n]  (dim D + 2),
/// sigma_n^2 being the observation-noise variance. Defaults: l = 1, sigma_f^2 = 1, sigma_n^2 = 0.01.
///
/// Usage: set data with compute(X, y), optionally optimize_h_params(), then predict().
/// After compute(), every const member is thread-safe (predict may run concurrently).
class Gp {
 public:
  /// GP on inputs of dimension input_dim (>= 1). Throws InvalidArgument otherwise.
  explicit Gp(int input_dim = 1);

  int input_dim() const;
  /// Number of training points N.
  int size() const;

  /// Hyper-parameters h (dim D + 2, log space, see class comment).
  Eigen::VectorXd h_params() const;
  /// Sets h (dim D + 2, finite); if data is present, recomputes the factorisation.
  /// Throws InvalidArgument on wrong size or non-finite values.
  void set_h_params(const Eigen::VectorXd& h);

  const SquaredExpArd& kernel() const;
  double noise_variance() const;

  /// Stores training data and factorises K + sigma_n^2 I. X: N x D (one input per row), y: N.
  /// N may be 0 (then predictions are the prior: mean 0, variance sigma_f^2).
  /// Cholesky failures are retried with jitter 1e-9 * 10^k added to the diagonal (k < 6), then
  /// NumericalError is thrown. Throws InvalidArgument on size mismatch or non-finite data.
  void compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);

  /// Replaces only the targets y (dim N) keeping X and h: reuses the factorisation (O(N^2)).
  /// Used by GP-MI when only the prior mean changes.
  void set_targets(const Eigen::VectorXd& y);

  /// log p(y | X, h) = -1/2 y^T K^-1 y - 1/2 log|K| - N/2 log 2 pi (paper eq. 5), K including noise.
  double log_marginal_likelihood() const;
  /// d log p / d h (dim D + 2), analytic: 1/2 tr((alpha alpha^T - K^-1) dK/dh_j).
  Eigen::VectorXd log_marginal_likelihood_gradient() const;

  /// Maximises the log marginal likelihood over h with iRprop-, starting from the current h (warm
  /// start); keeps the best iterate. Requires data (N >= 1). Throws InvalidArgument on invalid options.
  RpropSummary optimize_h_params(const RpropOptions& options = {});

  /// Posterior mean k*^T alpha and variance k(x,x) - k*^T K^-1 k* (without noise) at x (dim D).
  /// Thread-safe after compute().
  void predict(const Eigen::VectorXd& x, double& mean, double& variance) const;

  /// Batched prediction for B query points. Xq: B x D (one query per row); mean, variance: resized
  /// to B. Equal to B calls of predict() up to round-off; much faster for B >= 4. Thread-safe.
  void predict_batch(const Eigen::MatrixXd& Xq, Eigen::VectorXd& mean,
                     Eigen::VectorXd& variance) const;

  /// alpha = K^-1 y (dim N).
  const Eigen::VectorXd& alpha() const;

 private:
  // Implementation state (see src/gp/gp.cpp). Invariant after construction / compute(): every
  // member below is consistent with (kernel_, log_sigma_n_, X_, y_); a throwing call leaves it intact.
  int input_dim_;
  SquaredExpArd kernel_;
  double log_sigma_n_;
  Eigen::MatrixXd X_;          // N x D training inputs
  Eigen::MatrixXd Xs_;         // N x D, inputs divided by the length scales (column-wise)
  Eigen::VectorXd Xs_sqnorm_;  // N, squared row norms of Xs_
  Eigen::VectorXd y_;          // N targets
  Eigen::MatrixXd Kf_;         // N x N noise-free kernel matrix (used by the gradient)
  Eigen::MatrixXd L_;          // N x N, lower triangle = Cholesky factor of K; strict upper unspecified
  Eigen::VectorXd alpha_;      // N, K^-1 y
  double jitter_ = 0.0;        // extra diagonal added to K by the last successful factorisation

  // Factorises K for (kernel, log_sigma_n, X) with the jitter retries and, on success only, commits
  // kernel, noise, X (unless X aliases X_), Xs_, Kf_, L_, jitter_, y_ and alpha_. Throws NumericalError.
  void factorise(const SquaredExpArd& kernel, double log_sigma_n, const Eigen::MatrixXd& X,
                 const Eigen::VectorXd& y);
  // Applies a log-space h (already validated) and refactorises.
  void apply_h(const Eigen::VectorXd& h);
};

}  // namespace drops::gp
