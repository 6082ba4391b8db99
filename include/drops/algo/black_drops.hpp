#pragma once
/// \file Black-DROPS with priors and GP-MI: paper Algorithm 1, read top-down in run_black_drops().

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

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
  /// final mean) with many rollouts on common random numbers and return the best mean.
  kReevaluate,
};

/// Options of Algorithm 1. Defaults follow settings.md §1 and §5.
struct BlackDropsOptions {
  int episodes = 10;              ///< real episodes in total, including the first one, >= 1
  std::uint64_t seed = 1;         ///< the run's single seed; every random stream derives from it
  double theta_bound = 5.0;       ///< policy parameters searched in [-b, b], > 0
  model::ModelOptions model;      ///< which model variant and its settings
  opt::CmaesOptions cmaes;        ///< policy optimizer (seed and sigma0 are set per episode)
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
  /// How the returned policy is chosen among the evaluated ones.
  PolicySelection selection = PolicySelection::kReevaluate;
  /// kReevaluate: Monte-Carlo rollouts per re-evaluated candidate (>= 1).
  int reevaluation_rollouts = 50;
  /// kReevaluate: best distinct evaluated points re-evaluated, besides the start and the runs'
  /// final means (>= 1).
  int reevaluation_candidates = 10;
  /// Monte-Carlo rollouts used to report the model's predicted return of each executed policy.
  int predicted_rollouts = 20;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Everything recorded about one real episode. Complete when the on_episode callback receives it.
struct EpisodeRecord {
  int episode = 0;                  ///< 1-based
  double interaction_time = 0;      ///< cumulated real interaction time at the end of it, s
  rollout::Trajectory real;         ///< on the system
  rollout::Trajectory predicted;    ///< mean-propagated rollout on the model that chose the policy
  VectorXd theta;                   ///< policy parameters run (dim param_dim)
  double real_return = 0;
  double predicted_return = 0;      ///< mean over predicted_rollouts MC rollouts (NaN if random)
  bool solved = false;
  bool random_policy = false;       ///< episode 1 without a prior: random theta
  VectorXd phi;                     ///< prior parameters of the model that chose the policy
  model::ModelSummary model;        ///< the learning that preceded this episode (empty for ep. 1)
  opt::CmaesSummary policy_search;  ///< the optimization that chose theta
  /// Where theta came from: "start" (the start policy was kept), "best_seen" (a best single
  /// evaluation), "run_mean" (a CMA-ES run's final mean), "random" (episode 1 without a prior).
  std::string selected;
  /// kReevaluate: the chosen policy's mean return over the re-evaluation rollouts (NaN otherwise).
  double reevaluated_return = 0;
  int reevaluated_candidates = 0;   ///< kReevaluate: size of the short list
  double model_seconds = 0;         ///< model learning time before this episode, s
  double policy_seconds = 0;        ///< policy optimization time, s
  long evaluations = 0;             ///< policy evaluations (model rollouts / rollouts per eval)
  long nonfinite_model_steps = 0;   ///< rollout steps stopped by non-finite model predictions
};

/// Algorithm 1 between two episodes: everything the next episodes depend on. Every random stream
/// is derived from (seed, episode, ...), so a run continued from the state saved after episode k
/// produces exactly the episodes k+1.. of an uninterrupted run (drops run --resume).
struct BlackDropsState {
  int episodes_done = 0;             ///< completed real episodes (>= 0)
  std::vector<Transition> data;      ///< every real transition so far, in order
  VectorXd best_theta;               ///< policy of the best real episode (empty before episode 1)
  double best_return = -std::numeric_limits<double>::infinity();  ///< its real return
  int first_solved_episode = 0;      ///< 0 when never solved
  model::ModelState model;           ///< the model's warm starts after the last learn()
};

/// Live status for progress displays.
struct Status {
  int episode = 0;                  ///< episode being prepared (1-based)
  std::string phase;                ///< "model", "policy" or "episode"
  long evaluations = 0;             ///< evaluations in this phase so far
  double best = 0;                  ///< best score in this phase (model score / predicted return)
};

/// Hooks through which the caller observes and steers a run. All are called on the caller's thread.
struct BlackDropsCallbacks {
  /// After each real episode, with its full record. Persist it here.
  std::function<void(const EpisodeRecord&)> on_episode;
  /// Frequently during model learning and policy search.
  std::function<void(const Status&)> on_status;
  /// Polled often; returning true interrupts the run after the current step (nothing recorded
  /// is lost: on_episode has already been called for every finished episode).
  std::function<bool()> should_stop;
  /// After on_episode, with the state needed to continue the run from there. Persist it to
  /// make the run resumable.
  std::function<void(const BlackDropsState&)> on_state;
};

/// Result of run_black_drops.
struct BlackDropsSummary {
  int episodes_done = 0;
  bool interrupted = false;
  int first_solved_episode = 0;   ///< 0 when never solved
  double best_real_return = 0;
  double seconds = 0;
};

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

/// What optimize_policy chose and how.
struct PolicySearchResult {
  opt::CmaesSummary search;  ///< the CMA-ES search (best_x / best_value: its best single evaluation)
  VectorXd theta;            ///< the returned policy parameters (dim n, inside the box)
  /// The returned policy's value on the model: with kReevaluate the mean return of the
  /// re-evaluation rollouts, else its single evaluation's return (not negated).
  double value = 0;
  std::string selected;      ///< "start", "best_seen" or "run_mean" (see EpisodeRecord::selected)
  int candidates = 0;        ///< kReevaluate: size of the short list (0 otherwise)
};

/// Maximises the mean model return (paper §IV-C) over theta in [-b, b]^n with BIPOP-aCMA-ES
/// starting from theta0 (dim n, clamped into the box), then selects the returned policy per
/// options.selection (a search that on_gen stopped returns its best single evaluation, without
/// re-evaluation). With options.keep_start_point, theta0 is evaluated first and is a candidate
/// like any other. Deterministic for a given seed whatever the thread count. Throws
/// InvalidArgument on size mismatch. Exposed for benchmarks and tests.
PolicySearchResult optimize_policy(const rollout::Task& task, const model::DynamicsModel& model,
                                   const policy::Policy& policy, const VectorXd& theta0,
                                   const BlackDropsOptions& options, std::uint64_t seed,
                                   const std::function<bool(const opt::CmaesProgress&)>& on_gen,
                                   long* nonfinite_steps);

}  // namespace drops::algo
