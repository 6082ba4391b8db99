#pragma once
/// \file Covariance functions: squared-exponential with automatic relevance determination (ARD),
/// and the isotropic Matern 5/2 kernel (used by IT&E's M-BOA, drops/ite/mboa.hpp).

#include <Eigen/Core>

namespace drops::gp {

/// Squared-exponential ARD kernel (Rasmussen & Williams 2006, eq. 5.1; paper §IV-A)
///   k(a, b) = sigma_f^2 exp(-1/2 sum_d (a_d - b_d)^2 / l_d^2).
/// Hyper-parameters live in log space, h = [log l_1 .. log l_D, log sigma_f] (dim D + 1).
/// Value type; thread-safe for concurrent const use.
struct SquaredExpArd {
  /// length_scales: l (dim D, > 0), in the units of the inputs.
  Eigen::VectorXd length_scales;
  /// signal_variance: sigma_f^2 (> 0), in squared output units.
  double signal_variance = 1.0;

  /// Kernel of dimension `input_dim` with l = 1 and sigma_f^2 = 1 (settings.md §3).
  explicit SquaredExpArd(int input_dim = 0)
      : length_scales(Eigen::VectorXd::Ones(input_dim)) {}
  int input_dim() const { return static_cast<int>(length_scales.size()); }
  /// k(a, b); a, b: dim D (InvalidArgument otherwise).
  double operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const;
};

/// Isotropic Matern kernel with nu = 5/2 on the Euclidean distance d = |a - b|
/// (Rasmussen & Williams 2006, eq. 4.17; Cully et al. 2015, Methods; baselines.md §3a):
///   k(d) = sigma_f^2 (1 + sqrt(5) d / l + 5 d^2 / (3 l^2)) exp(-sqrt(5) d / l).
/// k(0) = sigma_f^2, k(l) = 0.52399 sigma_f^2; twice differentiable in d (k'(0) = 0). Inputs of any
/// dimension D (both the same). No hyper-parameter optimisation is offered (M-BOA fixes them).
/// Value type; thread-safe for concurrent const use.
struct Matern52 {
  /// length_scale: l (> 0), in the units of the inputs (M-BOA: descriptor units, 0.4 there).
  double length_scale = 1.0;
  /// signal_variance: sigma_f^2 (> 0), in squared output units.
  double signal_variance = 1.0;

  /// k(d) for a distance d >= 0 (in the units of the inputs). Pure; no argument checks.
  double of_distance(double d) const;
  /// k(a, b) = of_distance(|a - b|_2); a, b: same dim D (InvalidArgument otherwise).
  double operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const;
};

}  // namespace drops::gp
