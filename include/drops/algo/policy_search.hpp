#pragma once
/// \file Black-DROPS's policy search (paper §IV-C): BIPOP-aCMA-ES on the mean model return of
/// Monte-Carlo rollouts, the start policy kept as a candidate, the choice of the policy to run by
/// re-evaluation, and the trust region that bounds where the search looks.

#include <cstdint>
#include <functional>
#include <string>

#include "drops/algo/algorithm.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/opt/cmaes.hpp"
#include "drops/policy/policy.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/core/problem.hpp"

namespace drops::algo {

/// How the policy search picks the policy it returns among the points it evaluated.
enum class PolicySelection {
  /// The best single evaluation (the paper's reference; with 1 rollout per evaluation on a noisy
  /// model this favours lucky draws).
  kBestSeen,
  /// Re-evaluate a short list (the start, the best distinct evaluated points, each CMA-ES run's
  /// final mean) with many rollouts on common random numbers and return the best value (the mean or
  /// the median of the rollouts' returns: RolloutOptions::statistic).
  kReevaluate,
};

/// The CMA-ES settings of Black-DROPS's policy search (settings.md §5, with the stopping criteria
/// on the scale of the return that make restarts happen on a noisy objective): BIPOP-aCMA-ES,
/// 10,000 evaluations in all and 2,500 per run, tol_fun = tol_hist_fun = 0.01, Stagnation,
/// small-population restarts from the start and large ones from random points. Thread-safe.
opt::CmaesOptions policy_search_cmaes_defaults();

/// The re-evaluation of PolicySelection::kReevaluate.
struct ReevaluationOptions {
  /// Monte-Carlo rollouts per re-evaluated candidate (>= 1), on common random numbers; the
  /// candidate of the best value (RolloutOptions::statistic) is returned.
  int rollouts = 50;
  /// Best distinct evaluated points re-evaluated, besides the start and the runs' final means
  /// (>= 1).
  int candidates = 10;
};

/// Options of one policy search (optimize_policy). Defaults follow settings.md §5.
struct PolicySearchOptions {
  double theta_bound = 5.0;  ///< policy parameters searched in [-b, b], > 0
  /// Policy optimizer (seed is set per search; sigma0 <= 0 means theta_bound).
  opt::CmaesOptions cmaes = policy_search_cmaes_defaults();
  rollout::RolloutOptions rollouts;  ///< Monte-Carlo rollouts per policy evaluation
  /// The start is a candidate: it is evaluated first, like any candidate, and returned unless
  /// something evaluated beats it, so the returned policy is never worse on the model than the
  /// start (as in the reference's CMA-ES wrapper). False: the start only centres the first run.
  bool keep_start_point = true;
  PolicySelection selection = PolicySelection::kReevaluate;  ///< how the returned policy is chosen
  ReevaluationOptions reevaluation;                           ///< with kReevaluate
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Where one search starts and how far it may go.
struct SearchStart {
  VectorXd theta0;             ///< start policy parameters (dim n), clamped into the box
  std::uint64_t seed = 0;      ///< the search's random stream (CMA-ES and rollouts)
  /// Trust-region radius, a fraction of theta_bound in (0, 1]: the search box is
  /// trust_region_box(theta0, b, region) and CMA-ES's sigma0 is scaled by it; 1 = the whole box.
  double region = 1.0;
};

/// What optimize_policy chose and how.
struct PolicySearchResult {
  opt::CmaesSummary search;  ///< the CMA-ES search (best_x / best_value: its best single evaluation)
  VectorXd theta;            ///< the returned policy parameters (dim n, inside the box)
  /// The returned policy's value on the model: with kReevaluate the value of the re-evaluation
  /// rollouts, else its single evaluation's return (not negated).
  double value = 0;
  std::string selected;      ///< "start", "best_seen" or "run_mean" (see EpisodeRecord::selected)
  int candidates = 0;        ///< kReevaluate: size of the short list (0 otherwise)
  long nonfinite_model_steps = 0;  ///< rollout steps stopped by non-finite model predictions
};

/// Maximises the model return of a policy (paper §IV-C: the mean of Monte-Carlo rollouts, or
/// options.rollouts.statistic) over theta in the box with BIPOP-aCMA-ES from start.theta0, then
/// selects the returned policy per options.selection. A search that on_gen stopped (it returned
/// false) returns its best single evaluation, without re-evaluation. Deterministic for a given
/// seed whatever the thread count. Throws InvalidArgument on invalid options, a theta0 of the
/// wrong size or a region outside (0, 1]. Not reentrant (uses parallel_for).
PolicySearchResult optimize_policy(const rollout::Task& task, const model::DynamicsModel& model,
                                   const policy::Policy& policy, const PolicySearchOptions& options,
                                   const SearchStart& start,
                                   const std::function<bool(const opt::CmaesProgress&)>& on_gen = {});

/// The search box of a trust region of radius `region` (a fraction of b, in (0, 1]) around
/// `centre` (dim n): [max(-b, centre - region b), min(b, centre + region b)] per coordinate, written
/// to lower and upper (resized to n). Throws InvalidArgument when region is outside (0, 1] or
/// b <= 0. Thread-safe.
void trust_region_box(const VectorXd& centre, double b, double region, VectorXd& lower,
                      VectorXd& upper);

/// Options of the trust region around the best real policy (TrustRegion).
struct TrustRegionOptions {
  bool enabled = false;      ///< off: every search covers the whole box
  double min_radius = 0.125;  ///< the smallest radius, a fraction of theta_bound, in (0, 1]
  bool IsValid(std::string* why) const;
};

/// A trust region around the best real policy: TuRBO's success/failure rule (Eriksson et al.
/// 2019, with one success or one failure) applied to the real episodes, so that a model that
/// keeps overrating policies far from its data is only searched near the best one that was run.
/// The radius r starts at 1 (the whole box); after an episode that ran a new policy from the
/// region, r doubles (up to 1) when that policy's real return beat the best before it and halves
/// (down to min_radius) when it did not. Episodes that run the best policy again leave r as it is.
/// Not thread-safe (one per run).
class TrustRegion {
 public:
  /// Throws InvalidArgument when options are invalid or radius is outside (0, 1].
  explicit TrustRegion(const TrustRegionOptions& options, double radius = 1.0);
  bool enabled() const { return options_.enabled; }
  /// The radius the next search uses: r when enabled and a real policy centres the region
  /// (have_real_policy), else 1.
  double search_radius(bool have_real_policy) const;
  /// After a real episode that ran a new policy searched in the region: improved = its return
  /// beat the best real return before it.
  void update(bool improved);
  double radius() const { return radius_; }  ///< r, in [min_radius, 1]

 private:
  TrustRegionOptions options_;
  double radius_ = 1.0;
};

}  // namespace drops::algo
