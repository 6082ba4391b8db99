#pragma once
/// \file Moments of a Gaussian pushed through a map, and their derivatives: the common currency of
/// PILCO's analytic moment matching (Deisenroth 2010 thesis §2-3; baselines.md §1a).

#include <Eigen/Core>

namespace drops::pilco {

/// Moments of y = f(x) (dim E) for x ~ N(mu, Sigma) (dim D), and optionally their derivatives with
/// respect to mu, Sigma and the map's parameters theta (dim P).
///
/// Flattening: a matrix A (r x c) is vectorised column-major, entry (i, j) at row/column i + r j
/// (Eigen's default storage, MATLAB's A(:)). So dcov_dsigma(a + E b, k + D l) = dS_ab / dSigma_kl.
///
/// Derivatives with respect to a covariance Sigma follow PILCO's convention (baselines.md §1a, the
/// MATLAB code's): Sigma_kl and Sigma_lk are treated as separate entries and the derivative is the
/// symmetric matrix G with dF = sum_kl G_kl dSigma_kl for every symmetric perturbation dSigma. The
/// columns k + D l and l + D k are therefore equal, and moving one off-diagonal value (Sigma_kl and
/// Sigma_lk together) by eps changes F by 2 G_kl eps. Derivatives *of* a covariance (cov) fill both
/// rows a + E b and b + E a.
///
/// Value type; every field is empty (0 x 0) unless the producing function was asked for it.
struct Moments {
  Eigen::VectorXd mean;  ///< E[y] (E)
  Eigen::MatrixXd cov;   ///< Cov[y] (E x E, symmetric)
  /// Sigma^-1 Cov[x, y] (D x E): PILCO's input-output "V" (gp0) or "C" (gTrig, gSat). Computed
  /// without inverting Sigma (Cov[x, y] = Sigma * cross holds for singular Sigma too).
  Eigen::MatrixXd cross;

  Eigen::MatrixXd dmean_dmu;      ///< E x D
  Eigen::MatrixXd dmean_dsigma;   ///< E x D^2
  Eigen::MatrixXd dcov_dmu;       ///< E^2 x D
  Eigen::MatrixXd dcov_dsigma;    ///< E^2 x D^2
  Eigen::MatrixXd dcross_dmu;     ///< (D E) x D
  Eigen::MatrixXd dcross_dsigma;  ///< (D E) x D^2

  /// Parameter derivatives, only for maps with parameters (RbfPolicy): E x P, E^2 x P, (D E) x P.
  Eigen::MatrixXd dmean_dtheta;
  Eigen::MatrixXd dcov_dtheta;    ///< E^2 x P
  Eigen::MatrixXd dcross_dtheta;  ///< (D E) x P
};

}  // namespace drops::pilco
