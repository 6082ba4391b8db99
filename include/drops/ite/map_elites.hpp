#pragma once
/// \file MAP-Elites (Mouret & Clune 2015), the offline stage of IT&E (Cully et al. 2015;
/// baselines.md §3a): fill a grid archive (drops/ite/archive.hpp) with the best parameters found
/// for each region of a behaviour space. Generic: the task plugs in through an evaluation
/// function theta -> (fitness, descriptor, alive). docs/ite.md.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include "drops/core/types.hpp"
#include "drops/ite/archive.hpp"

namespace drops::ite {

/// Result of evaluating one parameter vector.
struct Evaluation {
  /// Performance to maximise (task unit). Non-finite: the individual is counted as invalid and
  /// not inserted.
  double fitness = std::numeric_limits<double>::quiet_NaN();
  /// Behaviour descriptor b (dim k of the archive), expected in [0, 1]^k. Non-finite values:
  /// counted as invalid; finite values outside [0, 1]: counted as out of range; neither is
  /// inserted.
  VectorXd descriptor;
  /// False for an individual the task rejects (e.g. a robot that fell: the reference's "dead"
  /// flag); counted as dead and not inserted.
  bool alive = true;
};

/// The task: evaluates theta (dim param_dim, inside the search box). `stream` is a seed unique to
/// this evaluation, derive_seed(options.seed, {kEvaluationStream, batch, index in batch}), for
/// stochastic evaluations (e.g. noisy simulators), so that results do not depend on the thread
/// count. Called concurrently from several threads when options.parallel: must be thread-safe.
/// A descriptor of the wrong size is a programming error: InvalidArgument is thrown from
/// run_map_elites.
using EvaluationFunction = std::function<Evaluation(const VectorXd& theta, std::uint64_t stream)>;

/// Stream tags of run_map_elites (first element of each derive_seed path).
inline constexpr std::uint64_t kInitialStream = 0x1417;     ///< {tag, i}: i-th random individual
inline constexpr std::uint64_t kVariationStream = 0x7A21;   ///< {tag, generation, pair}
inline constexpr std::uint64_t kEvaluationStream = 0xE7A1;  ///< {tag, batch, index}

/// Mutation operator applied gene by gene (each gene with probability mutation_rate).
enum class Mutation {
  /// Deb's bounded polynomial mutation (Deb & Goyal 1996; as in NSGA-II and sferes2's EvoFloat),
  /// distribution index polynomial_eta; stays inside the box.
  kPolynomial,
  /// theta_i += gaussian_sigma * (upper_i - lower_i) * N(0, 1), clipped to the box.
  kGaussian,
  /// The reference 6-legged robot archive of Cully et al. 2015 (sferes2 gen::Sampled): genes live on a grid of grid_levels
  /// equally spaced values of [lower_i, upper_i]; a mutated gene is re-drawn uniformly from it.
  /// Initial individuals are drawn from the grid too, and crossover children are snapped to it.
  kResample,
};

/// Options of run_map_elites. Defaults follow the reference settings of Cully et al. 2015 (a 6-legged robot) where they exist
/// (baselines.md §3b): 200 initial individuals, 400 offspring per generation (200 pairs), no
/// crossover, strict elitism (the reference used the epsilon rule; see InsertionRule).
struct MapElitesOptions {
  /// Total budget of evaluations, initial population included (>= 1). The last batch is shortened
  /// to fit.
  long max_evaluations = 100000;
  /// Random individuals (uniform in the box) evaluated first when the archive is empty (>= 1).
  /// Ignored when run_map_elites is given a non-empty archive (the run continues it).
  int initial_population = 200;
  /// Offspring per generation (>= 1): batch_size / 2 pairs of parents drawn uniformly from the
  /// filled cells (an odd last child is dropped); evaluated together, in parallel.
  int batch_size = 400;
  /// Mutation operator.
  Mutation mutation = Mutation::kPolynomial;
  /// Probability that each gene of an offspring is mutated, in [0, 1] (reference: 0.05 for the
  /// 36-gene gait of Cully et al. 2015; about 1/param_dim is usual).
  double mutation_rate = 0.1;
  /// Distribution index eta_m of kPolynomial (> 0; larger = smaller steps).
  double polynomial_eta = 15.0;
  /// Standard deviation of kGaussian as a fraction of the box width (> 0).
  double gaussian_sigma = 0.1;
  /// Number of values per gene of kResample (>= 2; reference: 21, i.e. steps of 0.05 on [0, 1]).
  int grid_levels = 21;
  /// Probability that a pair of parents is crossed by SBX before mutation, in [0, 1] (reference: 0,
  /// the children are copies of the parents before mutation).
  double crossover_rate = 0.0;
  /// Distribution index eta_c of the simulated binary crossover (Deb & Agrawal 1995), > 0.
  double sbx_eta = 10.0;
  /// Insertion rule (InsertionRule); kStrict keeps every cell's fitness non-decreasing.
  InsertionRule insertion = InsertionRule::kStrict;
  /// epsilon of InsertionRule::kEpsilon (>= 0), in fitness units (Cully et al. 2015: 0.05 m).
  double epsilon = 0.05;
  /// Seed of every random stream of the run (initial population, variation, evaluations).
  std::uint64_t seed = 1;
  /// Evaluate each batch in parallel with drops::parallel_for. Results do not depend on it.
  bool parallel = true;
  /// Returns true when every field is valid; otherwise false and the reason in *why (if not null).
  bool IsValid(std::string* why) const;
};

/// Why run_map_elites ended.
enum class MapElitesTermination {
  kMaxEvaluations,  ///< the budget was used
  kCallback,        ///< the callback asked to stop
};

/// Where a MAP-Elites run stands after a batch: everything besides the archive that its next
/// batches depend on. Giving run_map_elites the cursor of a run that stopped (and the archive as
/// it was then, e.g. saved and read back) continues it exactly: the same batches, streams and
/// archive as an uninterrupted run (tested).
struct MapElitesCursor {
  long evaluations = 0;   ///< evaluations done so far (counted against max_evaluations), >= 0
  int batches = 0;        ///< batches done (the batch index of the evaluation streams), >= 0
  long generations = 0;   ///< generations of offspring done (the variation streams' index), >= 0
  long initial_drawn = 0; ///< random individuals drawn so far (the initial streams' index), >= 0
  /// Random individuals still to draw before the first generation (>= 0; the initial population
  /// minus initial_drawn for a run that began with an empty archive, 0 for one that continued an
  /// archive).
  long initial_left = 0;
};

/// Result of run_map_elites (counts are for this call).
struct MapElitesSummary {
  long evaluations = 0;    ///< evaluations performed (initial population included)
  int batches = 0;         ///< batches evaluated (initial-population batches included)
  long new_cells = 0;      ///< insertions into an empty cell
  long replacements = 0;   ///< insertions that replaced an elite
  long rejected = 0;       ///< valid individuals the occupied cell's elite beat
  long dead = 0;           ///< individuals with alive == false
  long invalid = 0;        ///< alive, but non-finite fitness or descriptor
  long out_of_range = 0;   ///< alive and finite, but a descriptor value outside [0, 1]
  std::size_t filled = 0;  ///< filled cells at the end
  double coverage = 0;     ///< filled / total cells at the end
  double best_fitness = -std::numeric_limits<double>::infinity();  ///< best elite at the end
  double seconds = 0;                                              ///< wall-clock time of the call
  MapElitesTermination termination = MapElitesTermination::kMaxEvaluations;
  /// Where the run stands at its end (for run_map_elites' `resume`): evaluations counts every
  /// call of the run, not only this one.
  MapElitesCursor cursor;
  /// One line, e.g. "map-elites: 100000 evaluations, 338 cells (84.5%), best -1.2e-05, 0 dead,
  /// 0 invalid, 0 out of range, 0.06 s (MaxEvaluations)".
  std::string BriefReport() const;
};

/// Progress after each batch (passed to the callback).
struct MapElitesProgress {
  long evaluations = 0;         ///< evaluations so far in this call
  int batch = 0;                ///< batches done so far (1 after the first)
  std::size_t filled = 0;       ///< filled cells
  double coverage = 0;          ///< filled / total cells
  double best_fitness = 0;      ///< best elite's fitness
  long batch_new_cells = 0;     ///< cells filled by this batch
  long batch_replacements = 0;  ///< elites replaced by this batch
  /// Where the run stands after this batch (with the archive passed to the callback, what
  /// continues the run exactly; cursor.evaluations counts every call of the run).
  MapElitesCursor cursor;
};

/// Called after each batch has been inserted, with the archive as it now is (e.g. to save a
/// snapshot with write_archive); return false to stop. Called on the calling thread.
using MapElitesCallback = std::function<bool(const MapElitesProgress&, const Archive&)>;

/// Runs MAP-Elites on `archive` (param_dim = dim of the box) in the box [lower, upper] (dim
/// param_dim, finite, lower < upper):
///  1. if the archive is empty, options.initial_population random individuals, in batches of
///     batch_size;
///  2. then generations of batch_size offspring: pairs of parents drawn uniformly from the filled
///     cells, crossed (SBX) with probability crossover_rate, each child mutated gene by gene;
///  3. each batch is evaluated (in parallel), then inserted in order under options.insertion; dead,
///     invalid and out-of-range individuals are counted and never inserted;
/// until max_evaluations or the callback stops it. With `resume` (the cursor of a run with the same
/// options that stopped, MapElitesProgress::cursor or MapElitesSummary::cursor, and `archive` as it
/// was then), the run continues exactly where it stopped, max_evaluations counting the
/// evaluations of every call. Variation of pair p in generation g draws from
/// derive_seed(seed, {kVariationStream, g, p}), initial individual i from derive_seed(seed,
/// {kInitialStream, i}): the archive is identical whatever the thread count. A non-empty archive is
/// continued (give another seed to avoid repeating the streams of the run that built it).
/// Throws InvalidArgument on invalid options, sizes or bounds, a cursor with negative counts, or a
/// descriptor of the wrong size;
/// rethrows what `evaluate` throws (the archive then holds the batches inserted before).
/// Source: Mouret & Clune 2015; sferes2 map_elites as described in baselines.md §3a.
MapElitesSummary run_map_elites(const EvaluationFunction& evaluate, const VectorXd& lower,
                                const VectorXd& upper, const MapElitesOptions& options,
                                Archive& archive, const MapElitesCallback& callback = nullptr,
                                const MapElitesCursor* resume = nullptr);

}  // namespace drops::ite
