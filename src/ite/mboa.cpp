// M-BOA: Bayesian optimisation over a MAP-Elites archive (Cully et al. 2015; baselines.md §3a).
#include "drops/ite/mboa.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drops/core/errors.hpp"

namespace drops::ite {

bool MboaOptions::IsValid(std::string* why) const {
  auto bad = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(length_scale)) {
    return bad("length_scale: expected > 0, got " + std::to_string(length_scale));
  }
  if (!positive(signal_variance)) {
    return bad("signal_variance: expected > 0, got " + std::to_string(signal_variance));
  }
  if (!positive(noise_variance)) {
    return bad("noise_variance: expected > 0, got " + std::to_string(noise_variance));
  }
  if (!(kappa >= 0.0) || !std::isfinite(kappa)) {
    return bad("kappa: expected >= 0, got " + std::to_string(kappa));
  }
  if (!(stop_ratio >= 0.0 && stop_ratio <= 1.0)) {
    return bad("stop_ratio: expected in (0, 1] or 0 (disabled), got " + std::to_string(stop_ratio));
  }
  if (max_trials < 1) return bad("max_trials: expected >= 1, got " + std::to_string(max_trials));
  return true;
}

std::string MboaSummary::BriefReport() const {
  std::string cell = "(";
  for (std::size_t d = 0; d < best_cell.size(); ++d) {
    cell += (d ? ", " : "") + std::to_string(best_cell[d]);
  }
  cell += ")";
  const char* reason = stop == MboaStop::kMaxPredictedValue ? "MaxPredictedValue"
                       : stop == MboaStop::kMaxTrials       ? "MaxTrials"
                                                            : "Continue";
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "m-boa: %d trials, best %.6g in cell ", trials, best_value);
  std::string s = buffer;
  std::snprintf(buffer, sizeof buffer, ", max mean %.6g (%s)", max_predicted_mean, reason);
  return s + cell + buffer;
}

Mboa::Mboa(const Archive& archive, const MboaOptions& options)
    : options_(options), grid_(archive.bins(), archive.param_dim()) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("MboaOptions: " + why);
  if (archive.empty()) throw InvalidArgument("Mboa: expected a non-empty archive, got 0 elites");
  kernel_.length_scale = options.length_scale;
  kernel_.signal_variance = options.signal_variance;

  elites_ = archive.elites();
  std::vector<std::int64_t> keys(elites_.size());
  for (std::size_t i = 0; i < elites_.size(); ++i) keys[i] = grid_.linear_index(elites_[i].cell);
  std::vector<std::size_t> order(elites_.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  std::vector<Elite> sorted;
  sorted.reserve(elites_.size());
  for (std::size_t i : order) {
    index_.emplace(keys[i], sorted.size());
    sorted.push_back(std::move(elites_[i]));
  }
  elites_ = std::move(sorted);

  const std::size_t n = elites_.size();
  points_.resize(static_cast<Eigen::Index>(n), archive.descriptor_dim());
  prior_.resize(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    points_.row(r) = options.use_cell_centres ? grid_.cell_centre(elites_[i].cell).transpose()
                                              : elites_[i].descriptor.transpose();
    prior_[r] = elites_[i].fitness;
  }
  update_posterior();
}

std::size_t Mboa::index_of(const Cell& cell) const {
  const auto it = index_.find(grid_.linear_index(cell));  // throws for an out-of-range cell
  if (it == index_.end()) {
    std::string s = "(";
    for (std::size_t d = 0; d < cell.size(); ++d) s += (d ? ", " : "") + std::to_string(cell[d]);
    throw InvalidArgument("Mboa: expected a filled cell of the archive, got empty cell " + s + ")");
  }
  return it->second;
}

const Elite& Mboa::elite(const Cell& cell) const { return elites_[index_of(cell)]; }
double Mboa::prior_mean(const Cell& cell) const {
  return prior_[static_cast<Eigen::Index>(index_of(cell))];
}
double Mboa::mean(const Cell& cell) const {
  return mean_[static_cast<Eigen::Index>(index_of(cell))];
}
double Mboa::variance(const Cell& cell) const {
  return variance_[static_cast<Eigen::Index>(index_of(cell))];
}
const Cell& Mboa::next_cell() const { return elites_[next_].cell; }
double Mboa::max_predicted_mean() const { return mean_.maxCoeff(); }

void Mboa::observe(const Cell& cell, double value) {
  const std::size_t i = index_of(cell);
  if (!std::isfinite(value)) {
    throw InvalidArgument("Mboa::observe: expected a finite performance, got " +
                          std::to_string(value));
  }
  observations_.push_back({elites_[i].cell, value});
  observed_.push_back(i);
  if (best_ < 0 || value > observations_[static_cast<std::size_t>(best_)].value) {
    best_ = static_cast<int>(observations_.size()) - 1;
  }
  update_posterior();
}

void Mboa::update_posterior() {
  const Eigen::Index n = points_.rows();
  const auto t = static_cast<Eigen::Index>(observed_.size());
  mean_ = prior_;
  variance_ = VectorXd::Constant(n, kernel_.signal_variance);
  if (t > 0) {
    MatrixXd K(t, t);
    VectorXd residual(t);
    for (Eigen::Index a = 0; a < t; ++a) {
      const auto ia = static_cast<Eigen::Index>(observed_[a]);
      residual[a] = observations_[a].value - prior_[ia];
      for (Eigen::Index b = 0; b <= a; ++b) {
        const auto ib = static_cast<Eigen::Index>(observed_[b]);
        K(a, b) = K(b, a) = kernel_.of_distance((points_.row(ia) - points_.row(ib)).norm());
      }
    }
    K.diagonal().array() += options_.noise_variance;
    // Bounded jitter retries (repeated cells with a tiny noise make K nearly singular).
    Eigen::LLT<MatrixXd> llt(K);
    double jitter = 1e-10 * kernel_.signal_variance;
    for (int attempt = 0; llt.info() != Eigen::Success; ++attempt, jitter *= 10.0) {
      if (attempt == 6) {
        throw NumericalError("Mboa: Cholesky of the kernel matrix failed after jitter up to " +
                             std::to_string(jitter / 10.0));
      }
      MatrixXd Kj = K;
      Kj.diagonal().array() += jitter;
      llt.compute(Kj);
    }
    const VectorXd alpha = llt.solve(residual);
    const MatrixXd L = llt.matrixL();
    MatrixXd ks(t, n);  // k(b_a, point_i)
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index a = 0; a < t; ++a) {
        const auto ia = static_cast<Eigen::Index>(observed_[a]);
        ks(a, i) = kernel_.of_distance((points_.row(ia) - points_.row(i)).norm());
      }
    }
    mean_ += ks.transpose() * alpha;
    const MatrixXd v = L.triangularView<Eigen::Lower>().solve(ks);
    variance_ -= v.colwise().squaredNorm().transpose();
    variance_ = variance_.cwiseMax(0.0);
  }
  // Exhaustive UCB maximisation; strict > keeps the lowest linear index on ties.
  const double kappa = options_.kappa;
  next_ = 0;
  double best = mean_[0] + kappa * std::sqrt(variance_[0]);
  for (Eigen::Index i = 1; i < n; ++i) {
    const double ucb = mean_[i] + kappa * std::sqrt(variance_[i]);
    if (ucb > best) {
      best = ucb;
      next_ = static_cast<std::size_t>(i);
    }
  }
}

MboaStop Mboa::stop_reason() const {
  if (static_cast<int>(observations_.size()) >= options_.max_trials) return MboaStop::kMaxTrials;
  if (best_ >= 0 && options_.stop_ratio > 0.0 &&
      observations_[static_cast<std::size_t>(best_)].value >=
          options_.stop_ratio * max_predicted_mean()) {
    return MboaStop::kMaxPredictedValue;
  }
  return MboaStop::kContinue;
}

MboaSummary Mboa::summary() const {
  MboaSummary s;
  s.trials = static_cast<int>(observations_.size());
  if (best_ >= 0) {
    s.best_cell = observations_[static_cast<std::size_t>(best_)].cell;
    s.best_value = observations_[static_cast<std::size_t>(best_)].value;
  }
  s.max_predicted_mean = max_predicted_mean();
  s.stop = stop_reason();
  return s;
}

MboaSummary run_mboa(Mboa& mboa, const std::function<double(const Elite&)>& trial) {
  if (!trial) throw InvalidArgument("run_mboa: expected a trial function, got none");
  while (!mboa.should_stop()) {
    const Cell cell = mboa.next_cell();
    mboa.observe(cell, trial(mboa.elite(cell)));
  }
  return mboa.summary();
}

}  // namespace drops::ite
