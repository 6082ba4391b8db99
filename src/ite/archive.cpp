// The MAP-Elites grid archive (Mouret & Clune 2015) with the "floor" binning convention.
#include "drops/ite/archive.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "drops/core/errors.hpp"

namespace drops::ite {

namespace {

std::string cell_string(const Cell& cell) {
  std::string s = "(";
  for (std::size_t d = 0; d < cell.size(); ++d) s += (d ? ", " : "") + std::to_string(cell[d]);
  return s + ")";
}

}  // namespace

int bin_index(double b, int n) {
  if (n < 1) throw InvalidArgument("bin_index: expected n >= 1 bins, got " + std::to_string(n));
  if (!(b >= 0.0 && b <= 1.0)) {
    throw InvalidArgument("bin_index: expected a descriptor value in [0, 1], got " +
                          std::to_string(b));
  }
  const int i = static_cast<int>(std::floor(b * n));
  return i < n ? i : n - 1;
}

double bin_centre(int i, int n) {
  if (n < 1 || i < 0 || i >= n) {
    throw InvalidArgument("bin_centre: expected 0 <= i < n, got i = " + std::to_string(i) +
                          ", n = " + std::to_string(n));
  }
  return (i + 0.5) / n;
}

Archive::Archive(std::vector<int> bins, int param_dim)
    : bins_(std::move(bins)), param_dim_(param_dim) {
  if (bins_.empty()) {
    throw InvalidArgument("Archive: expected a descriptor dimension >= 1, got 0 bins");
  }
  if (param_dim_ < 1) {
    throw InvalidArgument("Archive: expected param_dim >= 1, got " + std::to_string(param_dim_));
  }
  constexpr std::int64_t kMaxCells = std::int64_t{1} << 62;
  for (std::size_t d = 0; d < bins_.size(); ++d) {
    if (bins_[d] < 1) {
      throw InvalidArgument("Archive: expected bins >= 1 in every dimension, got " +
                            std::to_string(bins_[d]) + " in dimension " + std::to_string(d));
    }
    if (total_cells_ > kMaxCells / bins_[d]) {
      throw InvalidArgument("Archive: expected at most 2^62 cells, got more (" +
                            std::to_string(bins_.size()) + " dimensions)");
    }
    total_cells_ *= bins_[d];
  }
}

double Archive::coverage() const {
  return static_cast<double>(elites_.size()) / static_cast<double>(total_cells_);
}

Cell Archive::cell_of(const VectorXd& descriptor) const {
  check_size("Archive::cell_of: descriptor", descriptor_dim(), descriptor.size());
  Cell cell(bins_.size());
  for (std::size_t d = 0; d < bins_.size(); ++d) {
    const double b = descriptor[static_cast<Eigen::Index>(d)];
    if (!(b >= 0.0 && b <= 1.0)) {
      throw InvalidArgument("Archive::cell_of: expected descriptor values in [0, 1], got " +
                            std::to_string(b) + " in dimension " + std::to_string(d));
    }
    cell[d] = bin_index(b, bins_[d]);
  }
  return cell;
}

void Archive::check_cell(const Cell& cell) const {
  check_size("Archive: cell", descriptor_dim(), static_cast<long>(cell.size()));
  for (std::size_t d = 0; d < bins_.size(); ++d) {
    if (cell[d] < 0 || cell[d] >= bins_[d]) {
      throw InvalidArgument("Archive: expected cell indices in [0, bins), got " +
                            cell_string(cell));
    }
  }
}

VectorXd Archive::cell_centre(const Cell& cell) const {
  check_cell(cell);
  VectorXd c(descriptor_dim());
  for (std::size_t d = 0; d < bins_.size(); ++d) {
    c[static_cast<Eigen::Index>(d)] = bin_centre(cell[d], bins_[d]);
  }
  return c;
}

std::int64_t Archive::linear_index(const Cell& cell) const {
  check_cell(cell);
  std::int64_t index = 0;
  for (std::size_t d = 0; d < bins_.size(); ++d) index = index * bins_[d] + cell[d];
  return index;
}

Cell Archive::cell_from_linear(std::int64_t index) const {
  if (index < 0 || index >= total_cells_) {
    throw InvalidArgument("Archive::cell_from_linear: expected an index in [0, " +
                          std::to_string(total_cells_) + "), got " + std::to_string(index));
  }
  Cell cell(bins_.size());
  for (std::size_t d = bins_.size(); d-- > 0;) {
    cell[d] = static_cast<int>(index % bins_[d]);
    index /= bins_[d];
  }
  return cell;
}

const Elite* Archive::find(const Cell& cell) const {
  if (cell.size() != bins_.size()) return nullptr;
  for (std::size_t d = 0; d < bins_.size(); ++d) {
    if (cell[d] < 0 || cell[d] >= bins_[d]) return nullptr;
  }
  const auto it = slot_.find(linear_index(cell));
  return it == slot_.end() ? nullptr : &elites_[it->second];
}

const Elite& Archive::best() const {
  if (elites_.empty()) throw InvalidArgument("Archive::best: expected a non-empty archive");
  std::size_t best = 0;
  for (std::size_t i = 1; i < elites_.size(); ++i) {
    if (elites_[i].fitness > elites_[best].fitness) best = i;
  }
  return elites_[best];
}

InsertOutcome Archive::insert(const VectorXd& theta, double fitness, const VectorXd& descriptor,
                              InsertionRule rule, double epsilon) {
  check_size("Archive::insert: theta", param_dim_, theta.size());
  if (!std::isfinite(fitness)) {
    throw InvalidArgument("Archive::insert: expected a finite fitness, got " +
                          std::to_string(fitness));
  }
  if (!theta.allFinite()) throw InvalidArgument("Archive::insert: expected a finite theta");
  if (rule == InsertionRule::kEpsilon && !(epsilon >= 0.0)) {
    throw InvalidArgument("Archive::insert: expected epsilon >= 0, got " + std::to_string(epsilon));
  }
  Cell cell = cell_of(descriptor);
  const std::int64_t key = linear_index(cell);
  const auto it = slot_.find(key);
  if (it == slot_.end()) {
    slot_.emplace(key, elites_.size());
    elites_.push_back(Elite{std::move(cell), descriptor, fitness, theta});
    return InsertOutcome::kNewCell;
  }
  Elite& incumbent = elites_[it->second];
  bool replace = false;
  if (rule == InsertionRule::kStrict) {
    replace = fitness > incumbent.fitness;
  } else {
    const double gain = fitness - incumbent.fitness;
    if (gain > epsilon) {
      replace = true;
    } else if (std::abs(gain) <= epsilon) {
      const VectorXd centre = cell_centre(cell);
      replace = (descriptor - centre).squaredNorm() < (incumbent.descriptor - centre).squaredNorm();
    }
  }
  if (!replace) return InsertOutcome::kRejected;
  incumbent.descriptor = descriptor;
  incumbent.fitness = fitness;
  incumbent.theta = theta;
  return InsertOutcome::kReplaced;
}

void Archive::restore(Elite elite) {
  check_size("Archive::restore: theta", param_dim_, elite.theta.size());
  if (!std::isfinite(elite.fitness) || !elite.theta.allFinite()) {
    throw InvalidArgument("Archive::restore: expected a finite fitness and theta in cell " +
                          cell_string(elite.cell));
  }
  check_cell(elite.cell);
  const Cell expected = cell_of(elite.descriptor);
  if (expected != elite.cell) {
    throw InvalidArgument("Archive::restore: expected the descriptor to bin into its cell " +
                          cell_string(elite.cell) + " (floor convention), got cell " +
                          cell_string(expected));
  }
  const std::int64_t key = linear_index(elite.cell);
  if (slot_.count(key)) {
    throw InvalidArgument("Archive::restore: expected each cell at most once, got cell " +
                          cell_string(elite.cell) + " twice");
  }
  slot_.emplace(key, elites_.size());
  elites_.push_back(std::move(elite));
}

bool Archive::operator==(const Archive& other) const {
  if (bins_ != other.bins_ || param_dim_ != other.param_dim_ ||
      elites_.size() != other.elites_.size()) {
    return false;
  }
  for (std::size_t i = 0; i < elites_.size(); ++i) {
    const Elite& a = elites_[i];
    const Elite& b = other.elites_[i];
    // Exact comparison (sizes are equal: both archives validated them).
    if (a.cell != b.cell || a.fitness != b.fitness || a.descriptor != b.descriptor ||
        a.theta != b.theta) {
      return false;
    }
  }
  return true;
}

}  // namespace drops::ite
