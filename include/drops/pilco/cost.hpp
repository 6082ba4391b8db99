#pragma once
/// \file PILCO's saturating cost and its expectation under a Gaussian state (lossSat; baselines.md
/// §1a, Deisenroth 2010 §3.4).

#include <Eigen/Core>

namespace drops::pilco {

/// c(x) = 1 - exp(-1/2 (x - z)^T W (x - z)), in [0, 1). For the swing-up of paper §V-A, x is the augmented state
/// [x, sin/cos of the angles] and W = C^T C / width^2 measures the squared tip distance
/// (baselines.md §1a "Saturating cost"). Value type.
struct SaturatingCost {
  Eigen::MatrixXd weight;  ///< W (p x p), symmetric positive semi-definite, units 1 / x^2
  Eigen::VectorXd target;  ///< z (p)
  /// c(x) at a deterministic x (dim p; InvalidArgument otherwise).
  double operator()(const Eigen::VectorXd& x) const;
  /// Throws InvalidArgument unless W is p x p, symmetric and finite and z has dim p.
  void validate(int dim) const;
};

/// E[c(x)] and Var[c(x)] for x ~ N(mu, Sigma), with dE/dmu (p) and dE/dSigma (p x p, symmetric;
/// PILCO's convention, see Moments) when derivatives is set (empty otherwise):
///   E[c] = 1 - |I + Sigma W|^-1/2 exp(-1/2 d^T S d), S = W (I + Sigma W)^-1, d = mu - z,
///   Var[c] = |I + 2 Sigma W|^-1/2 exp(-d^T W (I + 2 Sigma W)^-1 d) - (1 - E[c])^2 (0 if < 1e-12),
///   dE/dmu = (1 - E) S d,  dE/dSigma = -1/2 (1 - E) (S d d^T - I) S.
struct CostMoments {
  double mean = 0.0;             ///< E[c]
  double variance = 0.0;         ///< Var[c]
  Eigen::VectorXd dmean_dmu;     ///< p
  Eigen::MatrixXd dmean_dsigma;  ///< p x p
};

/// See CostMoments. Throws InvalidArgument on sizes or an invalid cost; NumericalError when
/// I + Sigma W is singular (Sigma not positive semi-definite). Cost O(p^3). Thread-safe.
CostMoments expected_cost(const SaturatingCost& cost, const Eigen::VectorXd& mu,
                          const Eigen::MatrixXd& sigma, bool derivatives = false);

}  // namespace drops::pilco
