#pragma once
/// \file Gradient-free local search over a box whose coordinates are continuous or discrete:
/// exhaustive over the discrete choices, Subplex (Rowan 1990, NLopt's LN_SBPLX) over the
/// continuous coordinates for each discrete combination. GP-MI's outer loop over phi (paper
/// Algorithm 2; settings.md §4) and MI's identification use it.

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace drops::opt {

/// A box of n coordinates. Coordinate i is continuous in [lower_i, upper_i] when choices[i] is
/// empty, else discrete with the listed values (lower_i and upper_i are then unused).
struct MixedBox {
  Eigen::VectorXd lower;                     ///< dim n
  Eigen::VectorXd upper;                     ///< dim n, >= lower
  std::vector<std::vector<double>> choices;  ///< n entries; empty = continuous
  /// Returns true when the sizes agree, lower <= upper and every choice is finite; otherwise
  /// false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Options of maximize_mixed (defaults: settings.md §4, the reference's GP-MI outer loop).
struct SubplexOptions {
  int max_evaluations = 1000;  ///< Subplex evaluations per discrete combination, >= 1
  double xtol_rel = 1e-4;      ///< relative tolerance on x (NLopt xtol_rel), >= 0
  double ftol_rel = 1e-4;      ///< relative tolerance on the value (NLopt ftol_rel), >= 0
  /// Initial step of each continuous coordinate, as a fraction of its interval (> 0); at least
  /// 1e-6 in absolute terms.
  double initial_step = 0.1;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Result of maximize_mixed.
struct SubplexSummary {
  Eigen::VectorXd best_x;  ///< best point evaluated (dim n; x0 when no value was finite)
  double best_value = 0;   ///< its value; -inf when no evaluation returned a finite value
  int evaluations = 0;     ///< calls of the objective over all combinations
  int combinations = 0;    ///< discrete combinations searched (1 when every coordinate is continuous)
};

/// Objective to MAXIMISE at x (dim n). May return -inf or NaN for an invalid point (treated as
/// -inf; Subplex then sees -1e300) or throw drops::InvalidArgument (treated as -inf as well).
using MixedObjective = std::function<double(const Eigen::VectorXd& x)>;

/// Maximises f over `box`: for each combination of the discrete coordinates' choices (Cartesian
/// product, in the order of the choices, the first coordinate slowest), Subplex over the
/// continuous coordinates starting from x0 (clamped into the box), with the discrete coordinates
/// set to the combination; with no continuous coordinate, one evaluation per combination. The
/// best point over every evaluation is returned (ties: the first). Deterministic. Throws
/// InvalidArgument when x0 and box disagree in size or the box or options are invalid. Calls f
/// sequentially from the calling thread; f may itself run in parallel.
SubplexSummary maximize_mixed(const MixedObjective& f, const Eigen::VectorXd& x0,
                              const MixedBox& box, const SubplexOptions& options = {});

}  // namespace drops::opt
