#pragma once
/// \file M-BOA, the online stage of IT&E (Cully et al. 2015, Methods; baselines.md §3a "Online"):
/// Bayesian optimisation over the cells of a MAP-Elites archive, with the archive's fitness as the
/// GP's prior mean, a Matern 5/2 kernel on the descriptor distance and UCB maximised by exhaustive
/// search over every filled cell. One trial at a time: the caller runs the chosen cell's
/// parameters on the robot (a real episode it records) and reports the performance. docs/ite.md.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include "drops/core/types.hpp"
#include "drops/gp/kernel.hpp"
#include "drops/ite/archive.hpp"

namespace drops::ite {

/// Options of Mboa. Defaults: the Nature 2015 code (baselines.md §3b), tuned for a performance in
/// metres in [0, 2.5]; the kernel's signal_variance and kappa must match the scale of the
/// performance (rescale it, or set them: baselines.md §3c).
struct MboaOptions {
  /// Matern 5/2 length scale l (> 0), in descriptor units ([0, 1]^k). Nature and ite_v2: 0.4.
  double length_scale = 0.4;
  /// Signal variance sigma_f^2 (> 0) of the GP on performance - prior, in squared performance
  /// units. Reference: 1.
  double signal_variance = 1.0;
  /// Observation-noise variance sigma_n^2 (> 0), squared performance units. Nature: 0.001
  /// (ite_v2: 1e-10).
  double noise_variance = 1e-3;
  /// UCB exploration weight kappa (>= 0): UCB(b) = mu(b) + kappa sigma(b). Nature: 0.05 (ite_v2:
  /// 0.2).
  double kappa = 0.05;
  /// Stop when the best observation >= stop_ratio * the highest posterior mean over the archive
  /// (limbo's MaxPredictedValue; Nature: 0.9), in (0, 1]; 0 disables the rule (only max_trials).
  /// Meant for a non-negative performance: with negative values the rule never or always fires.
  double stop_ratio = 0.9;
  /// Maximum number of trials (>= 1). Nature: 20; ite_v2: 10.
  int max_trials = 20;
  /// Where each cell sits in the kernel: false = its elite's descriptor (what the behaviour was, as
  /// in the Nature code), true = the cell centre under the floor convention.
  bool use_cell_centres = false;
  /// Returns true when every field is valid; otherwise false and the reason in *why (if not null).
  bool IsValid(std::string* why) const;
};

/// Whether, and why, the adaptation should stop.
enum class MboaStop {
  kContinue,           ///< neither rule fired
  kMaxPredictedValue,  ///< best observation >= stop_ratio * max posterior mean
  kMaxTrials,          ///< max_trials trials done
};

/// One trial: the cell tried and the performance observed.
struct MboaObservation {
  Cell cell;     ///< cell of the archive (dim k)
  double value;  ///< observed performance (finite)
};

/// State of an adaptation (Mboa::summary()).
struct MboaSummary {
  int trials = 0;                       ///< observations so far
  Cell best_cell;                       ///< cell of the best observation (empty before the first)
  double best_value = 0;                ///< best observation (0 before the first)
  double max_predicted_mean = 0;        ///< max over the archive of the posterior mean
  MboaStop stop = MboaStop::kContinue;  ///< should_stop()'s reason
  /// One line, e.g. "m-boa: 4 trials, best 1.83 in cell (1, 3, 0, 4, 2, 2), max mean 1.91
  /// (MaxPredictedValue)".
  std::string BriefReport() const;
};

/// M-BOA over an archive. The archive is copied at construction (cells sorted by linear index,
/// each with its point in descriptor space, prior mean P(b) = elite fitness and parameters), so
/// the archive may change or go away afterwards. After t observations (b_i, y_i):
///   mu(b) = P(b) + k(b)^T (K + sigma_n^2 I)^-1 (y - P(b_1..t)),
///   sigma^2(b) = k(b, b) - k(b)^T (K + sigma_n^2 I)^-1 k(b),
/// k the Matern 5/2 kernel on the Euclidean distance between points; next_cell() maximises
/// mu + kappa sigma over every cell (ties: lowest linear index). An exact Cholesky solve on the t
/// observations; posteriors for all cells are recomputed after each observe() (O(N t (k + t)) for
/// N cells). Deterministic. Not thread-safe for observe(); const members are.
class Mboa {
 public:
  /// Throws InvalidArgument when options are invalid or the archive is empty.
  explicit Mboa(const Archive& archive, const MboaOptions& options = {});

  std::size_t num_cells() const { return elites_.size(); }  ///< N, filled cells of the archive
  /// The candidate elites, sorted by linear cell index (each with cell, descriptor, prior fitness
  /// and parameters).
  const std::vector<Elite>& elites() const { return elites_; }
  /// The elite of `cell`. Throws InvalidArgument when the cell was not filled in the archive.
  const Elite& elite(const Cell& cell) const;
  /// The cell to try next: argmax_b UCB(b). With no observation sigma is the same everywhere, so
  /// this is the archive's best cell. Still answers after should_stop().
  const Cell& next_cell() const;
  /// Records the performance `value` (finite) observed when running `cell`'s parameters. The same
  /// cell may be observed more than once. Throws InvalidArgument for a cell not in the archive or
  /// a non-finite value, NumericalError if the Cholesky factorisation fails after jitter retries.
  void observe(const Cell& cell, double value);
  /// True when max_trials trials were done or the MaxPredictedValue rule fires (after >= 1 trial).
  bool should_stop() const { return stop_reason() != MboaStop::kContinue; }
  /// Why should_stop() is true (kMaxTrials wins when both rules hold).
  MboaStop stop_reason() const;

  /// Prior mean P(b) (the archive fitness) of `cell`. Throws as elite().
  double prior_mean(const Cell& cell) const;
  /// Posterior mean mu(b) of `cell`. Throws as elite().
  double mean(const Cell& cell) const;
  /// Posterior variance sigma^2(b) of `cell` (without observation noise). Throws as elite().
  double variance(const Cell& cell) const;
  /// max_b mu(b) over every cell.
  double max_predicted_mean() const;
  /// The observations so far, in order.
  const std::vector<MboaObservation>& observations() const { return observations_; }
  /// Trials, best observation and stop state.
  MboaSummary summary() const;
  /// The kernel in use (length scale and signal variance from the options).
  const gp::Matern52& kernel() const { return kernel_; }

 private:
  std::size_t index_of(const Cell& cell) const;
  void update_posterior();

  MboaOptions options_;
  gp::Matern52 kernel_;
  std::vector<Elite> elites_;                            // sorted by linear index
  std::unordered_map<std::int64_t, std::size_t> index_;  // linear index -> position
  Archive grid_;                                         // empty archive: the cell arithmetic
  MatrixXd points_;                                      // N x k, kernel inputs
  VectorXd prior_;                                       // N
  VectorXd mean_, variance_;                             // N, posterior
  std::size_t next_ = 0;
  std::vector<MboaObservation> observations_;
  std::vector<std::size_t> observed_;  // cell positions of the observations
  int best_ = -1;                      // observation with the highest value
};

/// Runs the adaptation to its end: while !mboa.should_stop(), trial(elite of next_cell()) gives the
/// performance, which is observed. trial is called on the calling thread, once per trial, in order.
/// Returns mboa.summary(). Throws what observe() or trial throws.
MboaSummary run_mboa(Mboa& mboa, const std::function<double(const Elite&)>& trial);

}  // namespace drops::ite
