#pragma once
/// \file Objectives that return a value and, on request, their gradient (limbo's convention), and
/// the finite-difference check of such a gradient.

#include <Eigen/Core>
#include <functional>

namespace drops::opt {

/// An objective to minimise: returns f(x) for x (dim n); when `gradient` is not null it also
/// writes df/dx into *gradient (resized to n). Callers that only need the value pass nullptr, so
/// an objective can skip the gradient's cost. May throw; the optimizers pass the exception on.
using GradientObjective =
    std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd* gradient)>;

/// Result of check_gradient.
struct GradientCheck {
  Eigen::VectorXd analytic;  ///< the objective's gradient at x (dim n)
  Eigen::VectorXd numeric;   ///< central differences (dim n)
  /// max_i |analytic_i - numeric_i| / max(max_i |numeric_i|, 1e-12): the error relative to the
  /// gradient's scale (the metric of the tests of drops::pilco).
  double relative_error = 0.0;
  Eigen::Index worst = -1;  ///< the entry where |analytic - numeric| is largest (-1 when n = 0)
};

/// Central differences (f(x + h_i e_i) - f(x - h_i e_i)) / (2 h_i), h_i = step * max(1, |x_i|),
/// against the objective's own gradient at x (dim n): 2 n + 1 calls of f. For tests and debugging
/// of a new objective. Throws InvalidArgument when step <= 0 or x is not finite; exceptions of f
/// propagate. Not thread-safe unless f is.
GradientCheck check_gradient(const GradientObjective& f, const Eigen::VectorXd& x,
                             double step = 1e-6);

}  // namespace drops::opt
