// MAP-Elites (Mouret & Clune 2015) as used by IT&E (Cully et al. 2015); baselines.md §3a.
#include "drops/ite/map_elites.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"

namespace drops::ite {

bool MapElitesOptions::IsValid(std::string* why) const {
  auto bad = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (max_evaluations < 1) {
    return bad("max_evaluations: expected >= 1, got " + std::to_string(max_evaluations));
  }
  if (initial_population < 1) {
    return bad("initial_population: expected >= 1, got " + std::to_string(initial_population));
  }
  if (batch_size < 1) return bad("batch_size: expected >= 1, got " + std::to_string(batch_size));
  if (!(mutation_rate >= 0.0 && mutation_rate <= 1.0)) {
    return bad("mutation_rate: expected in [0, 1], got " + std::to_string(mutation_rate));
  }
  if (!(polynomial_eta > 0.0) || !std::isfinite(polynomial_eta)) {
    return bad("polynomial_eta: expected > 0, got " + std::to_string(polynomial_eta));
  }
  if (!(gaussian_sigma > 0.0) || !std::isfinite(gaussian_sigma)) {
    return bad("gaussian_sigma: expected > 0, got " + std::to_string(gaussian_sigma));
  }
  if (grid_levels < 2) return bad("grid_levels: expected >= 2, got " + std::to_string(grid_levels));
  if (!(crossover_rate >= 0.0 && crossover_rate <= 1.0)) {
    return bad("crossover_rate: expected in [0, 1], got " + std::to_string(crossover_rate));
  }
  if (!(sbx_eta > 0.0) || !std::isfinite(sbx_eta)) {
    return bad("sbx_eta: expected > 0, got " + std::to_string(sbx_eta));
  }
  if (!(epsilon >= 0.0) || !std::isfinite(epsilon)) {
    return bad("epsilon: expected >= 0, got " + std::to_string(epsilon));
  }
  return true;
}

std::string MapElitesSummary::BriefReport() const {
  char buffer[320];
  std::snprintf(
      buffer, sizeof buffer,
      "map-elites: %ld evaluations, %zu cells (%.1f%%), best %.6g, %ld dead, %ld invalid, "
      "%ld out of range, %.2f s (%s)",
      evaluations, filled, 100.0 * coverage, best_fitness, dead, invalid, out_of_range, seconds,
      termination == MapElitesTermination::kCallback ? "Callback" : "MaxEvaluations");
  return buffer;
}

namespace {

// Variation operators on a box [lo, hi] (per gene); every result stays inside the box.
class Variation {
 public:
  Variation(const MapElitesOptions& o, const VectorXd& lo, const VectorXd& hi)
      : o_(o), lo_(lo), hi_(hi) {}

  VectorXd random_individual(Rng& rng) const {
    VectorXd x(lo_.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      if (o_.mutation == Mutation::kResample) {
        x[i] = level(i, static_cast<int>(rng() % static_cast<std::uint64_t>(o_.grid_levels)));
      } else {
        x[i] = std::min(rng.uniform(lo_[i], hi_[i]), hi_[i]);
      }
    }
    return x;
  }

  // Simulated binary crossover (Deb & Agrawal 1995), each gene with probability 1/2.
  void crossover(VectorXd& a, VectorXd& b, Rng& rng) const {
    for (Eigen::Index i = 0; i < a.size(); ++i) {
      if (rng.uniform() >= 0.5) continue;
      const double u = rng.uniform();
      const double beta = u <= 0.5 ? std::pow(2.0 * u, 1.0 / (o_.sbx_eta + 1.0))
                                   : std::pow(1.0 / (2.0 * (1.0 - u)), 1.0 / (o_.sbx_eta + 1.0));
      const double x1 = a[i], x2 = b[i];
      a[i] = clip(i, 0.5 * ((1.0 + beta) * x1 + (1.0 - beta) * x2));
      b[i] = clip(i, 0.5 * ((1.0 - beta) * x1 + (1.0 + beta) * x2));
      if (o_.mutation == Mutation::kResample) {
        a[i] = snap(i, a[i]);
        b[i] = snap(i, b[i]);
      }
    }
  }

  void mutate(VectorXd& x, Rng& rng) const {
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      if (!(rng.uniform() < o_.mutation_rate)) continue;
      const double width = hi_[i] - lo_[i];
      switch (o_.mutation) {
        case Mutation::kPolynomial: {
          // Deb's bounded polynomial mutation (as in NSGA-II).
          const double d1 = (x[i] - lo_[i]) / width;
          const double d2 = (hi_[i] - x[i]) / width;
          const double r = rng.uniform();
          const double p = 1.0 / (o_.polynomial_eta + 1.0);
          double dq;
          if (r < 0.5) {
            const double v =
                2.0 * r + (1.0 - 2.0 * r) * std::pow(1.0 - d1, o_.polynomial_eta + 1.0);
            dq = std::pow(v, p) - 1.0;
          } else {
            const double v =
                2.0 * (1.0 - r) + 2.0 * (r - 0.5) * std::pow(1.0 - d2, o_.polynomial_eta + 1.0);
            dq = 1.0 - std::pow(v, p);
          }
          x[i] = clip(i, x[i] + dq * width);
          break;
        }
        case Mutation::kGaussian:
          x[i] = clip(i, x[i] + o_.gaussian_sigma * width * rng.normal());
          break;
        case Mutation::kResample:
          x[i] = level(i, static_cast<int>(rng() % static_cast<std::uint64_t>(o_.grid_levels)));
          break;
      }
    }
  }

 private:
  double clip(Eigen::Index i, double v) const { return std::clamp(v, lo_[i], hi_[i]); }
  double level(Eigen::Index i, int j) const {
    if (j == o_.grid_levels - 1) return hi_[i];
    return lo_[i] + (hi_[i] - lo_[i]) * j / (o_.grid_levels - 1);
  }
  double snap(Eigen::Index i, double v) const {
    const double t = (v - lo_[i]) / (hi_[i] - lo_[i]) * (o_.grid_levels - 1);
    return level(i, std::clamp(static_cast<int>(std::lround(t)), 0, o_.grid_levels - 1));
  }

  const MapElitesOptions& o_;
  const VectorXd& lo_;
  const VectorXd& hi_;
};

// Evaluates thetas[j] with stream derive_seed(seed, {kEvaluationStream, batch, j}), in parallel
// over contiguous chunks (cheap evaluations would drown in per-item scheduling otherwise).
std::vector<Evaluation> evaluate_batch(const EvaluationFunction& evaluate,
                                       const std::vector<VectorXd>& thetas, std::uint64_t seed,
                                       int batch, bool parallel) {
  const std::size_t n = thetas.size();
  std::vector<Evaluation> results(n);
  auto one = [&](std::size_t j) {
    results[j] = evaluate(
        thetas[j], derive_seed(seed, {kEvaluationStream, static_cast<std::uint64_t>(batch), j}));
  };
  if (!parallel) {
    for (std::size_t j = 0; j < n; ++j) one(j);
    return results;
  }
  const std::size_t chunks = std::min<std::size_t>(n, 64);
  parallel_for(chunks, [&](std::size_t c) {
    for (std::size_t j = c * n / chunks; j < (c + 1) * n / chunks; ++j) one(j);
  });
  return results;
}

}  // namespace

MapElitesSummary run_map_elites(const EvaluationFunction& evaluate, const VectorXd& lower,
                                const VectorXd& upper, const MapElitesOptions& options,
                                Archive& archive, const MapElitesCallback& callback,
                                const MapElitesCursor* resume) {
  const auto start_time = std::chrono::steady_clock::now();
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("MapElitesOptions: " + why);
  if (!evaluate) throw InvalidArgument("run_map_elites: expected an evaluation function, got none");
  check_size("run_map_elites: lower bounds (archive param_dim)", archive.param_dim(), lower.size());
  check_size("run_map_elites: upper bounds (archive param_dim)", archive.param_dim(), upper.size());
  for (Eigen::Index i = 0; i < lower.size(); ++i) {
    if (!std::isfinite(lower[i]) || !std::isfinite(upper[i]) || !(lower[i] < upper[i])) {
      throw InvalidArgument("run_map_elites: expected finite bounds with lower < upper, got [" +
                            std::to_string(lower[i]) + ", " + std::to_string(upper[i]) +
                            "] for parameter " + std::to_string(i));
    }
  }
  const Variation variation(options, lower, upper);
  const int k = archive.descriptor_dim();
  MapElitesSummary summary;

  MapElitesCursor cursor;
  if (resume != nullptr) {
    cursor = *resume;
    if (cursor.evaluations < 0 || cursor.batches < 0 || cursor.generations < 0 ||
        cursor.initial_drawn < 0 || cursor.initial_left < 0) {
      throw InvalidArgument("run_map_elites: expected a cursor with counts >= 0, got evaluations " +
                            std::to_string(cursor.evaluations) + ", batches " +
                            std::to_string(cursor.batches) + ", generations " +
                            std::to_string(cursor.generations) + ", initial " +
                            std::to_string(cursor.initial_drawn) + " drawn and " +
                            std::to_string(cursor.initial_left) + " left");
    }
  } else {
    cursor.initial_left = archive.empty() ? options.initial_population : 0;
  }
  long& initial_left = cursor.initial_left;
  long& initial_index = cursor.initial_drawn;
  long& generation = cursor.generations;
  std::vector<VectorXd> thetas;
  while (cursor.evaluations < options.max_evaluations) {
    const long room = options.max_evaluations - cursor.evaluations;
    thetas.clear();
    if (initial_left > 0 || archive.empty()) {
      // Initial population (also used again if no individual of it was valid).
      const long n = std::min<long>(
          {room, options.batch_size, initial_left > 0 ? initial_left : options.batch_size});
      for (long j = 0; j < n; ++j, ++initial_index) {
        Rng rng(
            derive_seed(options.seed, {kInitialStream, static_cast<std::uint64_t>(initial_index)}));
        thetas.push_back(variation.random_individual(rng));
      }
      initial_left = std::max<long>(0, initial_left - n);
    } else {
      const long n = std::min<long>(room, options.batch_size);
      const auto& elites = archive.elites();
      const std::uint64_t filled = elites.size();
      for (long pair = 0; 2 * pair < n; ++pair) {
        Rng rng(derive_seed(options.seed, {kVariationStream, static_cast<std::uint64_t>(generation),
                                           static_cast<std::uint64_t>(pair)}));
        VectorXd a = elites[rng() % filled].theta;
        VectorXd b = elites[rng() % filled].theta;
        if (rng.uniform() < options.crossover_rate) variation.crossover(a, b, rng);
        variation.mutate(a, rng);
        variation.mutate(b, rng);
        thetas.push_back(std::move(a));
        if (2 * pair + 1 < n) thetas.push_back(std::move(b));
      }
      ++generation;
    }

    const std::vector<Evaluation> results =
        evaluate_batch(evaluate, thetas, options.seed, cursor.batches, options.parallel);

    MapElitesProgress progress;
    for (std::size_t j = 0; j < results.size(); ++j) {
      const Evaluation& r = results[j];
      if (r.descriptor.size() != k) {
        throw InvalidArgument("run_map_elites: evaluation " + std::to_string(j) + " of batch " +
                              std::to_string(cursor.batches) + ": expected a descriptor of size " +
                              std::to_string(k) + ", got " + std::to_string(r.descriptor.size()));
      }
      if (!r.alive) {
        ++summary.dead;
        continue;
      }
      if (!std::isfinite(r.fitness) || !r.descriptor.allFinite()) {
        ++summary.invalid;
        continue;
      }
      if ((r.descriptor.array() < 0.0).any() || (r.descriptor.array() > 1.0).any()) {
        ++summary.out_of_range;
        continue;
      }
      switch (
          archive.insert(thetas[j], r.fitness, r.descriptor, options.insertion, options.epsilon)) {
        case InsertOutcome::kNewCell:
          ++progress.batch_new_cells;
          break;
        case InsertOutcome::kReplaced:
          ++progress.batch_replacements;
          break;
        case InsertOutcome::kRejected:
          ++summary.rejected;
          break;
      }
    }
    summary.evaluations += static_cast<long>(thetas.size());
    ++summary.batches;
    cursor.evaluations += static_cast<long>(thetas.size());
    ++cursor.batches;
    summary.new_cells += progress.batch_new_cells;
    summary.replacements += progress.batch_replacements;

    if (callback) {
      progress.evaluations = summary.evaluations;
      progress.batch = summary.batches;
      progress.cursor = cursor;
      progress.filled = archive.size();
      progress.coverage = archive.coverage();
      progress.best_fitness =
          archive.empty() ? -std::numeric_limits<double>::infinity() : archive.best().fitness;
      if (!callback(progress, archive)) {
        summary.termination = MapElitesTermination::kCallback;
        break;
      }
    }
  }

  summary.cursor = cursor;
  summary.filled = archive.size();
  summary.coverage = archive.coverage();
  if (!archive.empty()) summary.best_fitness = archive.best().fitness;
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

}  // namespace drops::ite
