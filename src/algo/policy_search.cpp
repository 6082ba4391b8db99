#include "drops/algo/policy_search.hpp"

#include <algorithm>
#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"

namespace drops::algo {
namespace {

// The re-evaluation's stream: derive_seed(search seed, {kReevaluation}).
constexpr std::uint64_t kReevaluation = 5;

bool same(const VectorXd& a, const VectorXd& b) { return (a.array() == b.array()).all(); }

// The short list of PolicySelection::kReevaluate, without repeats: the start (when kept), the
// best single evaluations, each run's final mean.
struct ShortList {
  std::vector<VectorXd> theta;
  std::vector<std::string> origin;
  void add(const VectorXd& x, const char* from) {
    if (!x.allFinite()) return;
    for (const auto& y : theta)
      if (same(x, y)) return;
    theta.push_back(x);
    origin.emplace_back(from);
  }
};

// Chooses among the short list by re-evaluating every candidate on the same rollout streams
// (common random numbers: differences between candidates are not drowned in the rollouts' noise).
void select_by_reevaluation(const rollout::Task& task, const model::DynamicsModel& model,
                            const policy::Policy& policy, const PolicySearchOptions& options,
                            const VectorXd& start, std::uint64_t seed, PolicySearchResult& result,
                            rollout::RolloutStats& stats) {
  const opt::CmaesSummary& cs = result.search;
  ShortList list;
  if (options.keep_start_point) list.add(start, "start");
  for (const auto& c : cs.best_candidates) list.add(c.x, "best_seen");
  for (const auto& r : cs.runs) list.add(r.final_mean, "run_mean");
  if (list.theta.empty()) list.add(start, "start");  // nothing else was evaluated
  rollout::RolloutOptions ro = options.rollouts;
  ro.rollouts = options.reevaluation.rollouts;
  const std::vector<std::uint64_t> streams(list.theta.size(), derive_seed(seed, {kReevaluation}));
  VectorXd values;
  rollout::evaluate_policies(task, model, policy, list.theta, streams, ro, values, &stats);
  Eigen::Index best = 0;
  for (Eigen::Index k = 1; k < values.size(); ++k)
    if (values[k] > values[best] || (std::isnan(values[best]) && !std::isnan(values[k]))) best = k;
  result.theta = list.theta[static_cast<std::size_t>(best)];
  result.value = values[best];
  result.selected = list.origin[static_cast<std::size_t>(best)];
  result.candidates = static_cast<int>(list.theta.size());
}

}  // namespace

opt::CmaesOptions policy_search_cmaes_defaults() {
  opt::CmaesOptions o;
  o.max_evaluations = 10000;
  o.max_run_evaluations = o.max_evaluations / 4;
  o.tol_fun = o.tol_hist_fun = 0.01;
  o.stagnation = true;
  o.restart_start = opt::CmaesRestartStart::kMixed;
  return o;
}

bool PolicySearchOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(theta_bound > 0) || !std::isfinite(theta_bound)) return fail("theta_bound must be > 0");
  if (reevaluation.rollouts < 1) return fail("reevaluation.rollouts must be >= 1");
  if (reevaluation.candidates < 1) return fail("reevaluation.candidates must be >= 1");
  std::string w;
  if (!cmaes.IsValid(&w)) return fail("cmaes: " + w);
  if (!rollouts.IsValid(&w)) return fail("rollouts: " + w);
  return true;
}

void trust_region_box(const VectorXd& centre, double b, double region, VectorXd& lower,
                      VectorXd& upper) {
  if (!(region > 0 && region <= 1))
    throw InvalidArgument("trust region: radius " + std::to_string(region) + " is outside (0, 1]");
  if (!(b > 0)) throw InvalidArgument("trust region: the box half-width must be > 0");
  lower = (centre.array() - region * b).cwiseMax(-b).matrix();
  upper = (centre.array() + region * b).cwiseMin(b).matrix();
}

PolicySearchResult optimize_policy(const rollout::Task& task, const model::DynamicsModel& model,
                                   const policy::Policy& policy, const PolicySearchOptions& options,
                                   const SearchStart& start,
                                   const std::function<bool(const opt::CmaesProgress&)>& on_gen) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("optimize_policy: " + why);
  const int n = policy.param_dim();
  check_size("optimize_policy: theta0 vs policy parameters", n, start.theta0.size());
  if (!(start.region > 0 && start.region <= 1))
    throw InvalidArgument("optimize_policy: trust region " + std::to_string(start.region) +
                          " is outside (0, 1]");
  const double b = options.theta_bound;
  VectorXd lower = VectorXd::Constant(n, -b), upper = VectorXd::Constant(n, b);
  const VectorXd theta0 = start.theta0.cwiseMax(lower).cwiseMin(upper);
  if (start.region < 1) trust_region_box(theta0, b, start.region, lower, upper);

  opt::CmaesOptions co = options.cmaes;
  co.seed = start.seed;
  if (co.sigma0 <= 0) co.sigma0 = b;  // settings.md §5: sigma0 = b
  co.sigma0 *= start.region;
  co.evaluate_start = options.keep_start_point;
  const bool reevaluate = options.selection == PolicySelection::kReevaluate;
  if (reevaluate) co.keep_best = std::max(co.keep_best, options.reevaluation.candidates);

  rollout::RolloutStats stats;
  auto objective = [&](const std::vector<VectorXd>& xs, const std::vector<std::uint64_t>& streams,
                       std::vector<double>& values) {
    VectorXd returns;
    rollout::evaluate_policies(task, model, policy, xs, streams, options.rollouts, returns, &stats);
    values.resize(xs.size());
    for (std::size_t k = 0; k < xs.size(); ++k) values[k] = -returns[static_cast<Eigen::Index>(k)];
  };
  PolicySearchResult result;
  result.search = opt::cmaes_minimize_batch(objective, theta0, lower, upper, co, on_gen);
  // A search stopped by its caller (e.g. Ctrl-C) is not worth re-evaluating: its policy is not run.
  if (reevaluate && result.search.termination != opt::CmaesTermination::kCallback) {
    select_by_reevaluation(task, model, policy, options, theta0, start.seed, result, stats);
  } else {
    result.theta = result.search.best_x;
    result.value = -result.search.best_value;
    result.selected =
        options.keep_start_point && same(result.theta, theta0) ? "start" : "best_seen";
  }
  result.nonfinite_model_steps = stats.nonfinite_steps;
  return result;
}

bool TrustRegionOptions::IsValid(std::string* why) const {
  if (min_radius > 0 && min_radius <= 1) return true;
  if (why) *why = "min_radius must be in (0, 1]";
  return false;
}

TrustRegion::TrustRegion(const TrustRegionOptions& options, double radius)
    : options_(options), radius_(radius) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("trust region: " + why);
  if (!(radius > 0 && radius <= 1))
    throw InvalidArgument("trust region: radius " + std::to_string(radius) + " is outside (0, 1]");
}

double TrustRegion::search_radius(bool have_real_policy) const {
  return options_.enabled && have_real_policy ? radius_ : 1.0;
}

void TrustRegion::update(bool improved) {
  if (!options_.enabled) return;
  radius_ = improved ? std::min(1.0, 2 * radius_) : std::max(options_.min_radius, radius_ / 2);
}

}  // namespace drops::algo
