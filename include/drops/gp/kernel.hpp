#pragma once
/// \file Squared-exponential kernel with automatic relevance determination (ARD).

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

}  // namespace drops::gp
