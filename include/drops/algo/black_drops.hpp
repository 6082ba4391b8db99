#pragma once
/// \file Black-DROPS with priors and GP-MI: paper Algorithm 1, read top-down in run_black_drops().

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/algo/policy_search.hpp"
#include "drops/control/balance.hpp"
#include "drops/core/problem.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/opt/cmaes.hpp"
#include "drops/policy/policy.hpp"
#include "drops/rollout/rollout.hpp"

namespace drops::algo {

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
  model::ModelOptions model = black_drops_model_defaults();  ///< which model variant and its settings
  /// The model's factory (empty: model::make_model of model.type). When the model uses the
  /// prior (uses_prior()), episode 1 plans on the prior alone (model::make_prior_only_model).
  ModelFactory model_factory;
  /// Whether the model of model_factory uses the simulator prior (ignored without a factory:
  /// model::uses_prior(model.type) then decides). Without it the factory gets a null prior.
  bool model_factory_uses_prior = true;
  /// The policy search of every episode (the bound, CMA-ES, the rollouts, the start kept as a
  /// candidate, the selection by re-evaluation).
  PolicySearchOptions search;
  /// With a prior: number of successive optimizations on the prior alone for episode 1 (the second
  /// restarts from the first's best), >= 1. The reference did 2.
  int prior_optimizations = 2;
  /// From episode 2 on, search only near the best real policy (TrustRegion; off by default, a
  /// task may turn it on through optimizer.trust_region).
  TrustRegionOptions trust_region;
  /// Catch and balance (control/balance.hpp): with mode kLqr, every episode that plans on a model
  /// (the prior alone in episode 1) computes an LQR on that model's mean linearised at the task's
  /// goal (Task::goal; required), and the policy search, the prediction and the real episode run
  /// the hybrid policy (control::BalancePolicy) with the searched theta. The gain is recomputed
  /// after each learning step from the new model, deterministically (a resumed run recomputes
  /// it); each episode's K, closed-loop spectral radius on the model and the real episode's steps
  /// under the LQR are recorded in EpisodeRecord::details ("balance_*").
  control::BalanceOptions balance;
  /// Recorded transitions (a real robot's logs, experiment::read_log) that join the data before
  /// episode 1: every model learns from them and from the real episodes' transitions after
  /// them, in this order. Empty: none (the algorithm as in the paper).
  std::vector<Transition> recorded_data;
  /// With recorded_data: false (default), episode 1 learns the model on the recorded data and
  /// plans on it; true, episode 1 stays the episode without a learned model (a random policy, or
  /// one planned on the prior alone) and the recorded data join the model from episode 2 on.
  /// Ignored without recorded_data.
  bool keep_first_episode = false;
  /// Monte-Carlo rollouts used to report the model's predicted return of each executed policy
  /// (always their mean, whatever search.rollouts.statistic), >= 1.
  int predicted_rollouts = 20;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
  /// Whether the model learned uses the simulator prior (see model_factory_uses_prior).
  bool uses_prior() const {
    return model_factory ? model_factory_uses_prior : model::uses_prior(model.type);
  }
};

/// Black-DROPS's own part of a RunState (in RunState::extra), written and read only by
/// run_black_drops.
struct BlackDropsOwnState {
  /// The trust region's radius after the last episode, in (0, 1] (TrustRegion::radius); empty
  /// when the trust region is off.
  std::optional<double> trust_region_radius;
  /// Its entries of RunState::extra (none when there is nothing to keep).
  StateVectors save() const;
  /// Reads it back from RunState::extra (fields without an entry stay empty). Throws
  /// InvalidArgument naming the entry when it holds other than one value. Thread-safe.
  static BlackDropsOwnState load(const StateVectors& extra);
};

/// Black-DROPS's names for the shared types of algorithm.hpp.
using BlackDropsState = RunState;
using BlackDropsCallbacks = Callbacks;
using BlackDropsSummary = RunSummary;

/// Paper Algorithm 1 with the model variant of options.model.type:
///   episode 1: with a prior, optimise the policy on the prior alone; without, random theta;
///   then, for each next episode: learn the model on all transitions, optimise the policy on the
///   model (optimize_policy from the best real episode's theta), predict its return, run it.
/// With options.recorded_data, the data start with them, and (unless keep_first_episode)
/// episode 1 is an episode like the next ones: the model learned on the recorded data alone.
/// task, real system and policy prototype are borrowed for the call. prior may be null only when
/// the model uses none (options.uses_prior()). With `resume` (a state from on_state of a run with
/// the same options), the run continues after resume->episodes_done; the summary then covers the
/// whole run but `seconds` only this call. A real episode whose system returns a non-finite state
/// ends at that step (Trajectory::nonfinite_step), is not solved and adds only its finite
/// transitions to the data. Throws InvalidArgument on invalid options, mismatched dimensions or a
/// resume state that does not fit; Error when a model is to be learned and no finite real
/// transition exists, and Error before the first real episode when the prior's mean propagation of
/// the policy chosen on it goes non-finite (the prior cannot simulate it: nothing runs on the real
/// system); exceptions from callbacks propagate. Not thread-safe (uses parallel_for internally).
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

}  // namespace drops::algo
