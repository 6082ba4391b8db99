#pragma once
/// \file Black-DROPS with priors and GP-MI: paper Algorithm 1, read top-down in run_black_drops().

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/opt/cmaes.hpp"
#include "drops/policy/policy.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/rollout/task.hpp"

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

/// The model settings of Black-DROPS runs: ModelOptions' defaults with Rprop stopping early when
/// the log-likelihood gains less than 1e-3 over 10 iterations. Thread-safe.
model::ModelOptions black_drops_model_defaults();

/// Builds the dynamics model Algorithm 1 learns (called once per run, before episode 1). The
/// default, model::make_model, gives the four variants of model.type; a custom factory plugs in a
/// model of your own (any DynamicsModel) without touching the algorithm.
using ModelFactory = std::function<std::unique_ptr<model::DynamicsModel>(
    const model::ModelOptions& options, std::shared_ptr<const rollout::Task> task,
    std::shared_ptr<const model::MeanFunction> prior, const model::PriorParameters& parameters)>;

/// Options of Algorithm 1. Defaults follow settings.md §1 and §5 (and are the defaults of the
/// drops command line unless a task changes them).
struct BlackDropsOptions {
  int episodes = 10;              ///< real episodes in total, including the first one, >= 1
  std::uint64_t seed = 1;         ///< the run's single seed; every random stream derives from it
  double theta_bound = 5.0;       ///< policy parameters searched in [-b, b], > 0
  model::ModelOptions model = black_drops_model_defaults();  ///< which model variant and its settings
  /// The model's factory (empty: model::make_model). With a prior, episode 1 still plans on the
  /// prior alone (model::make_prior_only_model).
  ModelFactory model_factory;
  /// Policy optimizer (seed and sigma0 are set per episode).
  opt::CmaesOptions cmaes = policy_search_cmaes_defaults();
  rollout::RolloutOptions rollouts;  ///< Monte-Carlo rollouts per policy evaluation
  /// With a prior: number of successive optimizations on the prior alone for episode 1 (the second
  /// restarts from the first's best), >= 1. The reference did 2.
  int prior_optimizations = 2;
  /// The best policy so far is the start and a candidate: each search starts from the policy of the
  /// best real episode (episode 1: from the previous prior optimization), evaluates it on the
  /// current model like any candidate, and returns it unless something evaluated beats it, so the
  /// returned policy is never worse on the model than the start (as in the reference's CMA-ES
  /// wrapper). False: the start only centres the first CMA-ES run.
  bool keep_start_point = true;
  /// No third identical run: when the policy of the best real episode has been run again and the
  /// system gave the same return (|difference| <= 1e-9 max(1, |return|): the system is
  /// deterministic there, so another run adds the same transitions) and it did not solve the task,
  /// the next search still starts from it and evaluates it, but runs the best other candidate
  /// instead. A solved best policy, or one whose replays differ (a noisy system), is run again as
  /// usual. Off by default: measured on a deterministic task, it freed one stuck run and cost
  /// about as much elsewhere (docs/decisions/pendubot-skip-known-replays.md).
  bool skip_known_replays = false;
  /// A trust region around the best real policy (off by default). From episode 2 on, the search
  /// box is theta_best +- r b, intersected with [-b, b], and CMA-ES's sigma0 is scaled by r. The
  /// radius r starts at 1 (the whole box). After an episode that ran a new policy, r doubles (up to
  /// 1) when that policy's real return beat the best before it, and halves (down to
  /// trust_region_min) when it did not: the success/failure rule of TuRBO (Eriksson et al. 2019,
  /// with one success or one failure) applied to the real episodes, so that a model that keeps
  /// overrating policies far from its data is only searched near the best one that was run.
  /// Episodes that run the best policy again leave r unchanged.
  bool trust_region = false;
  /// The smallest trust-region radius r, as a fraction of the box half-width b, in (0, 1].
  double trust_region_min = 0.125;
  /// A required improvement (return units, >= 0; 0 = off, the default). From episode 2 on, with
  /// keep_start_point and selection kReevaluate, when the re-evaluation chose a policy other than
  /// the start (the best real episode's), a paired check on reevaluation_rollouts fresh streams
  /// decides: the start and the chosen policy are rolled out once per stream, stream i shared by
  /// both (common random numbers), and the chosen policy is run only if the median of the
  /// per-stream return differences (chosen - start) exceeds this margin; otherwise the start is
  /// run again. Fresh streams remove the winner's curse of picking the best of many noisy
  /// values; the median of paired differences is not decided by the few streams in which one of
  /// the two falls into an absorbing penalty (which can dominate the means even for a policy
  /// that never failed on the real system; docs/decisions/hexapod-improvement-margin.md), but a
  /// policy that falls in more streams than the start loses them.
  /// Episode 1 (the start is not a real policy) and a start that may not be chosen
  /// (skip_known_replays) are unaffected.
  double improvement_margin = 0;
  /// A largest believable improvement (return units, >= 0; 0 = off, the default): the same
  /// paired check as improvement_margin (it runs when either is on), and the start is run again
  /// also when the median per-stream difference exceeds this cap. A gain that large over a policy
  /// the real system ran well usually means the model made that policy fail (an absorbing
  /// penalty on at least half the streams), not that the new one is better
  /// (docs/decisions/hexapod-improvement-cap.md). Same episodes as improvement_margin.
  double improvement_cap = 0;
  /// A limit on the cap's re-runs (>= 0; 0 = none, the default): improvement_cap is off in an
  /// episode when the real system has already run the best real policy this many times, so that
  /// the cap cannot lock a run on one policy that the model keeps making fail (2: the cap may run
  /// a policy once more, then the model, which has now seen it twice, is believed;
  /// docs/decisions/hexapod-improvement-cap-run-limit.md).
  int improvement_cap_max_runs = 0;
  /// Whether the paired check of improvement_margin / improvement_cap is on.
  bool paired_check() const { return improvement_margin > 0 || improvement_cap > 0; }
  /// How the returned policy is chosen among the evaluated ones.
  PolicySelection selection = PolicySelection::kReevaluate;
  /// kReevaluate: Monte-Carlo rollouts per re-evaluated candidate (>= 1), on common random
  /// numbers; the candidate of the best value (RolloutOptions::statistic) is returned.
  int reevaluation_rollouts = 50;
  /// kReevaluate: best distinct evaluated points re-evaluated, besides the start and the runs'
  /// final means (>= 1).
  int reevaluation_candidates = 10;
  /// Monte-Carlo rollouts used to report the model's predicted return of each executed policy
  /// (always their mean, whatever rollouts.statistic).
  int predicted_rollouts = 20;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Black-DROPS's names for the shared types of algorithm.hpp.
using BlackDropsState = RunState;
using BlackDropsCallbacks = Callbacks;
using BlackDropsSummary = RunSummary;

/// Paper Algorithm 1 with the model variant of options.model.type:
///   episode 1: with a prior, optimise the policy on the prior alone; without, random theta;
///   then, for each next episode: learn the model on all transitions, optimise the policy on the
///   model (mean return of MC rollouts, BIPOP-aCMA-ES from the best real episode's theta), run it.
/// task, real system and policy prototype are borrowed for the call. prior may be null only for
/// model type gp. With `resume` (a state from on_state of a run with the same options), the run
/// continues after resume->episodes_done; the summary then covers the whole run but `seconds`
/// only this call. Throws InvalidArgument on invalid options, mismatched dimensions or a resume
/// state that does not fit; exceptions from callbacks propagate. Not thread-safe (uses
/// parallel_for internally).
BlackDropsSummary run_black_drops(std::shared_ptr<const rollout::Task> task,
                                  const rollout::System& real, const policy::Policy& policy,
                                  std::shared_ptr<const model::MeanFunction> prior,
                                  const model::PriorParameters& prior_parameters,
                                  const BlackDropsOptions& options,
                                  const BlackDropsCallbacks& callbacks = {},
                                  const BlackDropsState* resume = nullptr);

/// Algorithm 1 behind the Algorithm interface: run() calls run_black_drops with the problem's
/// task, real system, policy and prior.
class BlackDrops final : public Algorithm {
 public:
  /// Throws InvalidArgument when options are invalid (the reason from IsValid).
  explicit BlackDrops(const BlackDropsOptions& options);
  std::string name() const override { return "black_drops"; }
  int episodes() const override { return options_.episodes; }
  RunSummary run(const Problem& problem, const Callbacks& callbacks,
                 const RunState* resume = nullptr) const override;
  const BlackDropsOptions& options() const { return options_; }

 private:
  BlackDropsOptions options_;
};

/// What optimize_policy chose and how.
struct PolicySearchResult {
  opt::CmaesSummary search;  ///< the CMA-ES search (best_x / best_value: its best single evaluation)
  VectorXd theta;            ///< the returned policy parameters (dim n, inside the box)
  /// The returned policy's value on the model: with kReevaluate the mean return of the
  /// re-evaluation rollouts, else its single evaluation's return (not negated).
  double value = 0;
  std::string selected;      ///< "start", "best_seen" or "run_mean" (see EpisodeRecord::selected)
  int candidates = 0;        ///< kReevaluate: size of the short list (0 otherwise)
  /// kReevaluate with the start on the short list: the start's re-evaluated value (NaN otherwise).
  double start_value = std::numeric_limits<double>::quiet_NaN();
  /// The start was returned because the chosen candidate failed the paired check of
  /// BlackDropsOptions::improvement_margin (it would have been returned without the check).
  bool kept_by_margin = false;
  /// The start was returned because the chosen candidate's paired improvement exceeded
  /// BlackDropsOptions::improvement_cap.
  bool kept_by_cap = false;
  /// The paired check's median per-stream return difference, chosen - start (NaN when no check
  /// ran).
  double paired_improvement = std::numeric_limits<double>::quiet_NaN();
};

/// The search box of a trust region of radius `region` (a fraction of b, in (0, 1]) around
/// `centre` (dim n): [max(-b, centre - region b), min(b, centre + region b)] per coordinate, written
/// to lower and upper (resized to n). optimize_policy searches the whole box at region = 1.
/// Throws InvalidArgument when region is outside (0, 1] or b <= 0. Thread-safe.
void trust_region_box(const VectorXd& centre, double b, double region, VectorXd& lower,
                      VectorXd& upper);

/// Maximises the mean model return (paper §IV-C) over theta in [-b, b]^n with BIPOP-aCMA-ES
/// starting from theta0 (dim n, clamped into the box), then selects the returned policy per
/// options.selection (a search that on_gen stopped returns its best single evaluation, without
/// re-evaluation). With options.keep_start_point, theta0 is evaluated first and is a candidate
/// like any other. With start_may_be_chosen false the start still centres the search and is
/// evaluated (with keep_start_point), but the returned policy is the best other one (the start
/// only when nothing else was evaluated); see BlackDropsOptions::skip_known_replays. With
/// region < 1 (BlackDropsOptions::trust_region) the search runs in trust_region_box(theta0, b,
/// region) with sigma0 scaled by region. With kReevaluate and options.improvement_margin > 0, a
/// candidate chosen over the start (when it may be chosen) must also pass the paired check
/// described there, or the start is returned.
/// Deterministic for a given seed whatever the thread count. Throws InvalidArgument on size
/// mismatch or a region outside (0, 1]. Exposed for benchmarks and tests.
PolicySearchResult optimize_policy(const rollout::Task& task, const model::DynamicsModel& model,
                                   const policy::Policy& policy, const VectorXd& theta0,
                                   const BlackDropsOptions& options, std::uint64_t seed,
                                   const std::function<bool(const opt::CmaesProgress&)>& on_gen,
                                   long* nonfinite_steps, bool start_may_be_chosen = true,
                                   double region = 1.0);

}  // namespace drops::algo
