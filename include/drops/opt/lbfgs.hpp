#pragma once
/// \file Gradient-based local minimisation by limited-memory BFGS (NLopt's LD_LBFGS: Nocedal 1980,
/// Liu & Nocedal 1989, in Luksan's implementation), e.g. PILCO's policy search on the analytic
/// gradient of the expected cost (baselines.md §1a "Policy optimiser": the MATLAB code uses
/// Rasmussen's minimize with BFGS; results are not bit-identical).

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>

#include "drops/opt/objective.hpp"

namespace drops::opt {

/// Options of lbfgs_minimize. Every field has a usable default.
struct LbfgsOptions {
  /// Budget of objective evaluations (each with its gradient), >= 1. L-BFGS spends about one
  /// evaluation per iteration, more when a line search backtracks.
  int max_evaluations = 300;
  /// Stop when an iteration changes f by less than ftol_rel * |f| (>= 0; 0 disables).
  double ftol_rel = 1e-10;
  /// Stop when an iteration changes f by less than ftol_abs (>= 0; 0 disables).
  double ftol_abs = 0.0;
  /// Stop when an iteration changes every x_i by less than xtol_rel * |x_i| (>= 0; 0 disables).
  double xtol_rel = 1e-10;
  /// Number of stored correction pairs (>= 0; 0 = NLopt's choice, min(n, 10) by default in
  /// NLopt 2.7; PILCO's minimize uses min(100, n) in its LBFGS mode).
  int memory = 0;
  /// After a failed line search (NLopt's FAILURE or ROUNDOFF_LIMITED, e.g. on an objective whose
  /// round-off noise hides the decrease of very short steps), restart from the best point with
  /// the memory cleared (the next step is along the steepest descent, as Rasmussen's minimize.m
  /// does after a failed line search), at most this many times (>= 0) and only while each run
  /// improves f. The budget is shared by the runs.
  int max_restarts = 0;
  /// NLopt's L-BFGS tries the full step -g at the start of a run and gives up after 10 reductions
  /// (by about 3 each): on a steep objective (|g| = 1e3) no step is ever tried short enough. When
  /// set, each run minimises f / (1 + |g0|^2) instead (g0 the gradient at the run's start; the
  /// start is evaluated once more for it, before the first run), so that the first trial step
  /// has length |g0| / (1 + |g0|^2), the first step of Rasmussen's minimize.m. Apart from that
  /// first step L-BFGS does not depend on the scale of f; values and gradients reported are f's.
  bool scale_first_step = false;
  /// Box bounds (dim n each, lower <= upper; may hold +-inf), or empty for none.
  Eigen::VectorXd lower, upper;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Why lbfgs_minimize stopped.
enum class LbfgsTermination {
  kConverged,       ///< ftol or xtol reached (NLopt's FTOL_REACHED, XTOL_REACHED, SUCCESS)
  kMaxEvaluations,  ///< the budget of evaluations is spent
  kStopped,         ///< the progress callback returned false
  /// NLopt gave up because round-off kept the line search from progressing (ROUNDOFF_LIMITED,
  /// often near a minimum) or it failed otherwise (FAILURE); the best point is still valid.
  kRoundoffLimited,
  kFailure,
  /// The objective returned a non-finite value or gradient: the search stops there (L-BFGS's line
  /// search cannot use it) and returns the best finite point.
  kNonFinite,
};

/// "converged", "max_evaluations", "stopped", "roundoff_limited", "failure", "non_finite".
const char* to_string(LbfgsTermination t);

/// Progress after each evaluation (for displays and stopping).
struct LbfgsProgress {
  int evaluations = 0;  ///< evaluations so far (this one included)
  double value = 0;     ///< f at the point just evaluated
  double best_value = std::numeric_limits<double>::infinity();  ///< lowest f so far
};

/// Result of lbfgs_minimize.
struct LbfgsSummary {
  Eigen::VectorXd x;  ///< the best point evaluated (lowest finite f; x0 if none was finite)
  double value = std::numeric_limits<double>::infinity();           ///< f(x)
  double initial_value = std::numeric_limits<double>::quiet_NaN();  ///< f(x0)
  int evaluations = 0;                                              ///< objective calls
  int restarts = 0;  ///< restarts after failed line searches (LbfgsOptions::max_restarts)
  LbfgsTermination termination = LbfgsTermination::kFailure;
  std::string nlopt_result;  ///< NLopt's result code, e.g. "FTOL_REACHED"
  double seconds = 0;        ///< wall-clock time, s
  /// One line: "L-BFGS: 12.3 -> 4.56 in 150 evaluations, 2 restarts (max_evaluations), 3.2 s".
  std::string BriefReport() const;
};

/// Minimises f from x0 (dim n >= 1, finite, inside the box when there is one) with L-BFGS,
/// calling f with a gradient at every evaluation, sequentially on the calling thread. Returns the
/// best point evaluated. `on_evaluation` (optional) is called after each evaluation; returning
/// false stops the search (kStopped).
/// Errors: InvalidArgument on invalid options, sizes or x0. An exception thrown by f (or by
/// on_evaluation) stops the search and is rethrown unchanged to the caller (NLopt itself swallows
/// exceptions in objectives; this function keeps them, with their type and message).
/// Deterministic. Thread-safe for distinct calls if f is.
LbfgsSummary lbfgs_minimize(const GradientObjective& f, const Eigen::VectorXd& x0,
                            const LbfgsOptions& options = {},
                            const std::function<bool(const LbfgsProgress&)>& on_evaluation = {});

}  // namespace drops::opt
