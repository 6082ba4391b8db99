#include "drops/algo/algorithm.hpp"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "drops/core/errors.hpp"

namespace drops::algo {

void Problem::check() const {
  if (!task) throw InvalidArgument("Problem: task is null");
  if (!real) throw InvalidArgument("Problem: real system is null");
  if (!policy) throw InvalidArgument("Problem: policy is null");
  check_size("Problem: policy observation_dim vs task observation_dim", task->observation_dim(),
             policy->observation_dim());
  check_size("Problem: policy action_dim vs task action_dim", task->action_dim(),
             policy->action_dim());
  if (prior) {
    check_size("Problem: prior state_dim vs task state_dim", task->state_dim(), prior->state_dim());
    check_size("Problem: prior action_dim vs task action_dim", task->action_dim(),
               prior->action_dim());
  }
}

std::string RunSummary::BriefReport() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%d episodes, best return %.2f, ", episodes_done,
                best_real_return);
  std::string s = buf;
  s += first_solved_episode ? "first solved at episode " + std::to_string(first_solved_episode)
                            : std::string("never solved");
  std::snprintf(buf, sizeof buf, ", %.1f s", seconds);
  s += buf;
  if (interrupted) s += " (interrupted)";
  return s;
}

std::optional<Calibration> calibration(const EpisodeRecord& rec) {
  const Eigen::Index n = rec.predicted_returns.size();
  if (n == 0) return std::nullopt;
  std::vector<double> r(rec.predicted_returns.data(), rec.predicted_returns.data() + n);
  std::sort(r.begin(), r.end());
  const double y = rec.real_return;
  const auto below = std::lower_bound(r.begin(), r.end(), y) - r.begin();
  const auto equal = std::upper_bound(r.begin(), r.end(), y) - r.begin() - below;
  // The p-quantile at the plotting position p (n + 1) (Hyndman & Fan 1996, definition 6): the
  // k-th smallest of n draws has E[F(r_(k))] = k / (n + 1), so a new draw from the same
  // distribution falls between the 5 % and 95 % quantiles with probability about 0.90 for n >= 19
  // (exactly for a uniform distribution). Definition 7's positions (n - 1) p + 1 would cover
  // 0.9 (n - 1) / (n + 1): 81 % with 20 rollouts. Positions outside [1, n] take the extreme draw.
  auto quantile = [&](double p) {
    const double h = std::clamp(p * static_cast<double>(n + 1), 1.0, static_cast<double>(n)) - 1;
    const auto lo = static_cast<std::size_t>(h);
    const std::size_t hi = std::min(lo + 1, r.size() - 1);
    return r[lo] + (h - static_cast<double>(lo)) * (r[hi] - r[lo]);
  };
  Calibration c;
  c.quantile = (static_cast<double>(below) + 0.5 * static_cast<double>(equal)) /
               static_cast<double>(n);
  c.band_low = quantile(0.05);
  c.band_high = quantile(0.95);
  c.inside_band = c.band_low <= y && y <= c.band_high;
  c.gap = rec.predicted_return - y;
  return c;
}

}  // namespace drops::algo
