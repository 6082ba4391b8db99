#pragma once
/// \file BIPOP-aCMA-ES: CMA-ES with active covariance update and BIPOP restarts, box bounds,
/// elitism and optional uncertainty handling (paper §IV-C; settings.md §5).
/// References: Hansen & Ostermeier 2001; Jastrebski & Arnold 2006 (active update);
/// Hansen 2009 "Benchmarking a BI-population CMA-ES on the BBOB-2009 function testbed" (BIPOP);
/// Hansen et al. 2009 "A method for handling uncertainty in evolutionary optimization" (UH);
/// Hansen, "The CMA Evolution Strategy: A Tutorial" (2016) for the default parameters.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace drops::opt {

/// Where the restarts of a search begin (the first run always starts at x0).
enum class CmaesRestartStart {
  kRandom,  ///< every restart from a uniform point of the box (Hansen 2009)
  kStart,   ///< every restart from x0
  /// BIPOP's two regimes split the work: the small-population runs (small step sizes: local
  /// searches) start from x0, the large-population runs (global searches) from uniform points.
  kMixed,
};

/// Options of Cmaes. Every field has a usable default.
struct CmaesOptions {
  /// Initial step size sigma0 (> 0), in the units of the parameters. 0 means "automatic": 0.3 of the
  /// smallest box width when bounded, else 1.
  double sigma0 = 0.0;
  /// Population size lambda of the first run (>= 2); 0 means the default 4 + floor(3 ln n).
  int lambda = 0;
  /// Total budget of objective evaluations over all restarts (>= 1).
  long max_evaluations = 10000;
  /// Budget of one run (>= 0; 0 = only the total budget applies). A run that would exceed it stops
  /// ("MaxRunEvals") and the search restarts, so restarts happen even when no tolerance fires (e.g.
  /// on a noisy objective). The small BIPOP runs keep their own, smaller budget. A run evaluates
  /// at least one generation, also when its budget is smaller than its population.
  long max_run_evaluations = 0;
  /// Evaluate x0 first (one evaluation, counted) and treat it as the best seen of every run that
  /// starts from x0: elitism re-injects it until a sample beats it, and the search returns it when
  /// nothing evaluated is better. CmaesSummary::start_value holds its value.
  bool evaluate_start = false;
  /// Where restarts begin (kRandom as in Hansen 2009).
  CmaesRestartStart restart_start = CmaesRestartStart::kRandom;
  /// Number of best distinct evaluated points reported in CmaesSummary::best_candidates (>= 1), e.g.
  /// for a re-evaluation that picks the best mean of a noisy objective.
  int keep_best = 1;
  /// Maximum number of restarts after the first run (>= 0). BIPOP alternates large populations
  /// (lambda doubling) and small ones (Hansen 2009). As in Hansen's reference (pycma), this counts
  /// the large-population (IPOP, lambda doubling) restarts only: the small-population runs that
  /// BIPOP interleaves (each limited to half the budget of the latest large run) do not count, so the
  /// search ends after the run with lambda = 2^max_restarts * lambda0 (or the budget).
  /// CmaesSummary::restarts counts every restart of both regimes.
  int max_restarts = 3;
  /// Use BIPOP restarts; when false, restarts are IPOP (population doubling) only.
  bool bipop = true;
  /// Active covariance matrix update (negative weights, Jastrebski & Arnold 2006).
  bool active = true;
  /// Elitism: re-inject the best-ever candidate into each generation's population (replacing the
  /// worst sample) so that the search cannot lose it (settings.md §5). "Best-ever" is per run: each
  /// restart starts a fresh elite (re-injecting an earlier run's best would defeat the restarts);
  /// the best over all runs is what CmaesSummary reports. The elite keeps its recorded value (it is
  /// not re-evaluated) and is injected only when it beats every sample of the generation.
  bool elitism = true;
  /// Uncertainty handling (Hansen et al. 2009): re-evaluate a few candidates each generation and
  /// increase sigma when the ranking is dominated by noise. For noisy objectives. Simplified UH:
  /// max(1, lambda / 10) candidates are re-evaluated with fresh streams (counted as evaluations and
  /// ranked by the mean of their two values); when the rank-change measure s > 0, sigma is
  /// multiplied by 1 + 2 / (n + 10).
  bool uncertainty_handling = false;
  /// Stopping criteria of one run (standard values from the tutorial):
  double tol_x = 1e-12;          ///< stop when all sigma * sqrt(C_ii) and sigma * p_c < tol_x
  double tol_fun = 1e-12;        ///< stop when the range of recent best values is < tol_fun
  double tol_hist_fun = 1e-12;   ///< stop when the range of the best values over 10 + 30n/lambda generations < it
  double max_condition = 1e14;   ///< stop when cond(C) exceeds it (ConditionCov)
  /// Hansen 2009's Stagnation criterion: over the last 20 % of the generations (at least
  /// 120 + 30 n / lambda), the medians of the most recent 30 % of the generations' best and median
  /// values are both no better than those of the first 30 %. Fires on noisy objectives, where the
  /// tolerances above do not.
  bool stagnation = true;
  /// Stop the whole search as soon as a value <= this is reached (minimisation).
  double stop_fitness = -1e300;
  /// Seed of the optimizer's own random stream (sampling of candidates).
  std::uint64_t seed = 1;
  /// Evaluate the population in parallel (drops::parallel_for). Results do not depend on it.
  bool parallel = true;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Why a cmaes_minimize call ended.
enum class CmaesTermination {
  kMaxEvaluations,   ///< budget exhausted
  kMaxRestarts,      ///< last permitted run stopped by its own criteria
  kStopFitness,      ///< reached options.stop_fitness
  kCallback,         ///< the user callback asked to stop
};

/// One CMA-ES run of a search (the first run or a restart).
struct CmaesRun {
  int lambda = 0;              ///< population size
  double sigma0 = 0;           ///< initial step size
  bool from_start = true;      ///< started from x0 (else from a uniform point of the box)
  bool small = false;          ///< a small-population BIPOP run
  long evaluations = 0;        ///< objective evaluations of this run
  int generations = 0;         ///< generations of this run
  double best_value = 0;       ///< best value evaluated in this run (+inf if none)
  Eigen::VectorXd final_mean;  ///< the distribution mean when the run stopped, inside the bounds
  std::string stop_reason;     ///< as in CmaesSummary::run_stop_reasons
};

/// An evaluated point and its (single, possibly noisy) value.
struct CmaesCandidate {
  Eigen::VectorXd x;  ///< dim n, inside the bounds
  double value = 0;   ///< objective value as evaluated
};

/// Result of cmaes_minimize (and cmaes_minimize_batch).
struct CmaesSummary {
  Eigen::VectorXd best_x;        ///< best candidate ever evaluated (dim n), inside the bounds
  double best_value = 0;         ///< objective value at best_x (as evaluated, noise included)
  long evaluations = 0;          ///< objective evaluations used
  int restarts = 0;              ///< restarts performed
  int generations = 0;           ///< generations over all runs
  CmaesTermination termination = CmaesTermination::kMaxEvaluations;
  /// Per run, why it stopped: "MaxFunEvals" (total budget), "MaxRunEvals" (the run's budget,
  /// options.max_run_evaluations), "RunBudget" (a small BIPOP run used its
  /// budget, half of the latest large run's), "Stagnation", "TolX", "TolFun", "TolHistFun", "EqualFunVals", "ConditionCov", "NoEffectAxis",
  /// "NoEffectCoord", "TolUpSigma", "MaxIter", "NumericalError", "StopFitness" or "Callback".
  std::vector<std::string> run_stop_reasons;
  /// Every run, in order (same length as run_stop_reasons).
  std::vector<CmaesRun> runs;
  /// The options.keep_best best distinct evaluated points, best first (x0 included when evaluated).
  std::vector<CmaesCandidate> best_candidates;
  /// Value of x0 when options.evaluate_start (NaN otherwise).
  double start_value = std::numeric_limits<double>::quiet_NaN();
  /// One line: "cmaes: best -12.3 after 10000 evaluations, 3 restarts (MaxEvaluations)".
  std::string BriefReport() const;
};

/// Progress of a search, passed to the callback after every generation.
struct CmaesProgress {
  long evaluations;   ///< objective evaluations used so far (all runs)
  int restarts;       ///< restarts performed so far (0 during the first run)
  int generation;     ///< generations completed so far over all runs (1 after the first one)
  double best_value;  ///< best value evaluated so far over all runs (never increases)
  double sigma;       ///< current step size of the running run
  int lambda;         ///< population size of the running run
};

/// Objective: value to MINIMISE at x (dim n). `stream` is a seed unique to this evaluation,
/// derive_seed(CmaesOptions::seed, {run, generation within the run, candidate index}) where run is 0
/// for the first run and candidate index is in [0, lambda) (lambda + j for the j-th re-evaluation of
/// uncertainty handling); x0's evaluation (options.evaluate_start) gets derive_seed(seed,
/// {kCmaesStartStream}); to be used by stochastic
/// objectives so that results do not depend on the evaluation order or thread count. Called
/// concurrently from several threads when options.parallel is true: must be thread-safe.
/// Non-finite values are treated as +infinity (worst).
using Objective = std::function<double(const Eigen::VectorXd& x, std::uint64_t stream)>;

/// Stream tag of x0's evaluation (see Objective).
inline constexpr std::uint64_t kCmaesStartStream = 0x5747A27ULL;

/// Callback after each generation; return false to stop the search.
using CmaesCallback = std::function<bool(const CmaesProgress&)>;

/// Minimises `objective` from x0 (dim n >= 1) within the box [lower, upper] (both dim n, lower <
/// upper; pass infinite bounds for an unbounded coordinate). Candidates outside the box are mapped
/// in by a boundary transformation (piecewise quadratic, as in Hansen's reference code), so every
/// evaluated point is inside the box. Deterministic for a given seed whatever the thread count.
/// Throws InvalidArgument on size mismatch, invalid options, or x0 outside the box.
CmaesSummary cmaes_minimize(const Objective& objective, const Eigen::VectorXd& x0,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const CmaesOptions& options = {},
                            const CmaesCallback& callback = nullptr);

}  // namespace drops::opt

namespace drops::opt {

/// Objective evaluated on a whole population at once: values[k] (to MINIMISE) for xs[k], each with
/// its own stream seed streams[k] (as for Objective). The callee parallelises as it likes but the
/// values must not depend on the thread count. values is resized by the callee to xs.size().
using BatchObjective = std::function<void(const std::vector<Eigen::VectorXd>& xs,
                                          const std::vector<std::uint64_t>& streams,
                                          std::vector<double>& values)>;

/// Same search as cmaes_minimize, but each generation's candidates (and uncertainty-handling
/// re-evaluations) are passed to `objective` in one call, so the callee can batch them (e.g.
/// batched GP predictions across rollouts). options.parallel is ignored (the callee decides).
CmaesSummary cmaes_minimize_batch(const BatchObjective& objective, const Eigen::VectorXd& x0,
                                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                  const CmaesOptions& options = {},
                                  const CmaesCallback& callback = nullptr);

}  // namespace drops::opt
