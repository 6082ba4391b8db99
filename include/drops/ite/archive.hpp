#pragma once
/// \file The MAP-Elites grid archive of IT&E (Mouret & Clune 2015; Cully et al. 2015): one elite
/// (parameters theta, fitness, behaviour descriptor) per cell of a grid over [0, 1]^k, keyed by
/// integer cell indices, with ONE binning convention used everywhere (archive building, the file
/// format of drops/ite/archive_io.hpp, M-BOA in drops/ite/mboa.hpp). docs/ite.md.
///
/// Binning convention ("floor"): with n_d bins in dimension d, a descriptor value b_d in [0, 1]
/// falls in cell_d = min(floor(b_d * n_d), n_d - 1), i.e. n_d bins of equal width 1 / n_d,
/// [0, 1/n), [1/n, 2/n), ..., [(n-1)/n, 1] (the last one closed), with centres (cell_d + 0.5) /
/// n_d. Why this one: every bin has the same width and contains its centre, so the
/// distance-to-centre tie-break and the cell centres used by M-BOA describe the same grid as the
/// binning itself. The sferes2 rule min(round(b n), n - 1) gives uneven bins and measures the
/// distance to centres of another grid; the Nature 2015 archives are keyed by round((n - 1) b)
/// (bins centred on 0, 1/(n-1), ..., 1, half-width at the edges). Archives built with those
/// conventions must be re-binned, not reinterpreted (baselines.md §3c).

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "drops/core/types.hpp"

namespace drops::ite {

/// Integer cell indices, one per descriptor dimension: cell[d] in [0, bins[d]).
using Cell = std::vector<int>;

/// The bin of a descriptor value b in [0, 1] among n >= 1 equal bins: min(floor(b n), n - 1).
/// Throws InvalidArgument when b is not finite or outside [0, 1], or n < 1. Thread-safe (pure).
int bin_index(double b, int n);

/// Centre (i + 0.5) / n of bin i in [0, n) among n >= 1 equal bins of [0, 1].
/// Throws InvalidArgument when i or n is out of range. Thread-safe (pure).
double bin_centre(int i, int n);

/// One elite of the archive.
struct Elite {
  Cell cell;            ///< its cell (dim k); always the cell of `descriptor`
  VectorXd descriptor;  ///< behaviour descriptor b (dim k), in [0, 1]^k
  double fitness = 0;   ///< performance to maximise (finite), in the task's unit
  VectorXd theta;       ///< parameters (dim param_dim) that produced it
};

/// How a candidate competes with the elite of an occupied cell (baselines.md §3a).
enum class InsertionRule {
  /// Strict elitism: replace only when strictly fitter (ties keep the incumbent), so a cell's
  /// fitness never decreases.
  kStrict,
  /// The reference (sferes2 map_elites, epsilon 0.05 for the 6-legged robot of Cully et al. 2015): replace when f_new - f_old >
  /// epsilon,
  /// or when |f_new - f_old| <= epsilon and the new descriptor is strictly closer (Euclidean) to
  /// the
  /// cell centre. A cell's fitness may then decrease by up to epsilon per replacement.
  kEpsilon,
};

/// What Archive::insert did with a candidate.
enum class InsertOutcome {
  kNewCell,   ///< the cell was empty: the candidate fills it
  kReplaced,  ///< the candidate replaced the cell's elite
  kRejected,  ///< the cell's elite was kept
};

/// A grid archive over [0, 1]^k with bins[d] cells in dimension d, holding at most one elite per
/// cell. Elites are stored in the order their cells were first filled (a replacement keeps the
/// slot), which is the order parents are drawn from and the order of the archive file, so that a
/// reloaded archive continues exactly like the original. Not thread-safe for insert(); concurrent
/// const use is safe.
class Archive {
 public:
  /// bins: cells per dimension (dim k >= 1, each >= 1; product <= 2^62); param_dim: dim theta
  /// (>= 1). Throws InvalidArgument otherwise.
  Archive(std::vector<int> bins, int param_dim);
  /// k dimensions of n bins each.
  Archive(int descriptor_dim, int bins_per_dim, int param_dim)
      : Archive(std::vector<int>(descriptor_dim > 0 ? descriptor_dim : 0, bins_per_dim),
                param_dim) {}

  int descriptor_dim() const { return static_cast<int>(bins_.size()); }  ///< k
  int param_dim() const { return param_dim_; }                           ///< dim theta
  const std::vector<int>& bins() const { return bins_; }                 ///< cells per dimension
  std::int64_t total_cells() const { return total_cells_; }              ///< prod_d bins[d]
  std::size_t size() const { return elites_.size(); }                    ///< filled cells
  bool empty() const { return elites_.empty(); }
  /// Filled cells / total cells, in [0, 1].
  double coverage() const;

  /// The cell of descriptor b (dim k, in [0, 1]^k) under the floor convention (file comment).
  /// Throws InvalidArgument on wrong size, non-finite or out-of-range values.
  Cell cell_of(const VectorXd& descriptor) const;
  /// Centre of `cell` in descriptor space (dim k): (cell_d + 0.5) / bins_d.
  /// Throws InvalidArgument when the cell is out of range.
  VectorXd cell_centre(const Cell& cell) const;
  /// Row-major linear index of `cell` (the last dimension varies fastest), in [0, total_cells()).
  /// Throws InvalidArgument when the cell is out of range.
  std::int64_t linear_index(const Cell& cell) const;
  /// Inverse of linear_index. Throws InvalidArgument when out of range.
  Cell cell_from_linear(std::int64_t index) const;

  /// The elite of `cell`, or nullptr when the cell is empty (or out of range).
  const Elite* find(const Cell& cell) const;
  /// Every elite, in the order the cells were first filled.
  const std::vector<Elite>& elites() const { return elites_; }
  /// The elite of highest fitness (the first one in elites() order on ties).
  /// Throws InvalidArgument when the archive is empty.
  const Elite& best() const;

  /// Offers a candidate (theta: dim param_dim; fitness: finite; descriptor: dim k in [0, 1]^k) to
  /// the cell of its descriptor under `rule` (epsilon >= 0 for kEpsilon, ignored for kStrict).
  /// Throws InvalidArgument on wrong sizes, non-finite values or an out-of-range descriptor (run
  /// drivers count such individuals and never offer them).
  InsertOutcome insert(const VectorXd& theta, double fitness, const VectorXd& descriptor,
                       InsertionRule rule = InsertionRule::kStrict, double epsilon = 0.0);
  /// Appends an elite exactly as given (the file reader): its cell must be empty and equal to
  /// cell_of(descriptor). Throws InvalidArgument otherwise (message says which check failed).
  void restore(Elite elite);

  /// Same bins, parameter dimension and elites (bit-identical values, same order).
  bool operator==(const Archive& other) const;

 private:
  void check_cell(const Cell& cell) const;
  std::vector<int> bins_;
  int param_dim_;
  std::int64_t total_cells_ = 1;
  std::vector<Elite> elites_;
  std::unordered_map<std::int64_t, std::size_t> slot_;  // linear index -> position in elites_
};

}  // namespace drops::ite
