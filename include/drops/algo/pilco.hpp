#pragma once
/// \file PILCO (Deisenroth & Rasmussen 2011) and PILCO with priors (Cutler & How 2015), the
/// paper's analytic, gradient-based baselines (baselines.md §1-2), behind the Algorithm interface:
/// run_pilco() reads top-down. The analytic machinery (moment matching, the RBF policy, the
/// saturating cost, J(theta) and its gradient) is drops::pilco; docs/pilco.md describes both.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/gp/gp.hpp"
#include "drops/opt/lbfgs.hpp"
#include "drops/pilco/task_model.hpp"

namespace drops::algo {

/// The hyper-parameter search of PILCO's dynamics GPs: iRprop- with PILCO's soft walls (hypCurb as
/// train.m calls it: length scales within 100x the input's spread, signal-to-noise ratio at most
/// 1000, power 30), 300 iterations (PILCO: 300 line searches of BFGS), stopping early when the
/// log-likelihood gains less than 1e-3 over 10 iterations (as Black-DROPS's fits). Thread-safe.
gp::RpropOptions pilco_rprop_defaults();

/// The L-BFGS settings of PILCO's policy optimisation: 150 evaluations of J and its gradient,
/// ftol_rel 1e-8 on J, xtol_rel 1e-8. Thread-safe.
opt::LbfgsOptions pilco_lbfgs_defaults();

/// Options of PILCO and PILCO with priors. Defaults follow pilco-matlab's double-pendulum
/// swing-up scenario (baselines.md §1b) where drops can, and say where it does not.
struct PilcoOptions {
  /// PILCO with priors (Cutler & How 2015; baselines.md §2): PILCO on the simulator prior first,
  /// then PILCO on the real system with the simulator GPs' means as the model's prior mean and the
  /// simulator policy as the first real episode's policy.
  bool with_prior = false;
  int episodes = 15;       ///< real episodes in total, including the random ones, >= 1
  std::uint64_t seed = 1;  ///< the run's single seed; every random stream derives from it
  /// J: episodes with uniformly random actions before the first learned policy (baselines.md §1a;
  /// pilco-matlab: 1), >= 1. With a prior they begin the simulation phase; the real phase has
  /// none (its first episode runs the simulator policy).
  int random_rollouts = 1;
  /// With a prior: PILCO episodes on the simulator, the random ones included (paper §V-A: 40),
  /// > random_rollouts.
  int sim_episodes = 40;
  /// Centres (pseudo-inputs) of the RBF policy (paper §V-A and pilco-matlab: 200), >= 1.
  int centres = 200;
  /// Width w of the saturating cost (units of the task's distance, e.g. m), > 0; 0 = the task's
  /// reward width (TaskModel::reward_width: then PILCO optimises exactly the task's expected
  /// return; 0.5 m in the paper's swing-up, Black-DROPS's sigma_c; pilco-matlab's scenario uses
  /// 0.25).
  double cost_width = 0.0;
  /// Discount gamma of J = sum_t gamma^t E[c(x_t)], in (0, 1] (pilco-matlab: 1).
  double discount = 1.0;
  /// L-BFGS on J(theta) per policy optimisation (warm-started from the previous policy): budget of
  /// evaluations (J and its gradient) and stopping tolerances. pilco-matlab runs BFGS for 150 line
  /// searches (<= 20 evaluations each); drops' default 150 evaluations (see docs/pilco.md).
  opt::LbfgsOptions lbfgs = pilco_lbfgs_defaults();
  /// GP training (per output, warm-started from the previous episode's hyper-parameters).
  gp::RpropOptions rprop = pilco_rprop_defaults();
  /// Sparse GP beyond this many points: FITC with max_points inducing inputs, a random subset of
  /// the training inputs (pilco-matlab's swing-up: 300 inducing inputs, which it also optimises;
  /// drops keeps them fixed and fits the kernel on that subset), >= 1.
  int max_points = 300;

  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// PILCO (baselines.md §1a) on the real system, or with options.with_prior PILCO with priors
/// (§2a) on the simulator `prior` at prior_parameters.values, then on the real system:
///   1. (with a prior) simulation phase: PILCO for sim_episodes episodes on the simulator (its
///   first
///      random_rollouts with random actions); keeps the last GPs (the ones that chose the last
///      policy) as the prior mean m_a(x) (their posterior means, an RBF network each) and that
///      policy theta_sim; reported through on_phase ("simulation"), then saved (on_state with
///      episodes_done = 0);
///   2. real episodes 1..random_rollouts (without a prior): uniformly random actions in
///      [-max_u, max_u] at every step;
///   3. every other real episode: train one GP per output on all real transitions (inputs
///      [x_aug[dynamics_inputs], u], targets dx - m(x); Rprop with PILCO's soft walls,
///      warm-started; FITC beyond max_points), optimise the RBF policy on J(theta) with L-BFGS from
///      the current policy, run it on the system; with a prior, the first real episode runs
///      theta_sim planned on the simulation model (there is no real data yet).
/// Each episode's record holds the real trajectory, the policy run (theta, dim 1406 for the
/// paper's swing-up; empty for random actions), the model's predicted trajectory (state means,
/// control means, expected rewards) and predicted return sum_t (1 - E[c_{reward_width}(x_t)]) (NaN
/// when the task gives no reward width), and details (points, sparse, L-BFGS counts and stop
/// reason, J before/after). The run's state after each episode (data, GP hyper-parameters, theta,
/// the prior blocks) goes to on_state: a run resumed from it continues exactly. Interaction time
/// counts real episodes only. Throws InvalidArgument on invalid options, a task model that does not
/// fit the task, a missing prior when with_prior, or a resume state that does not fit;
/// NumericalError from the GP and moment matching; exceptions from callbacks propagate. Not
/// thread-safe (uses parallel_for); the results do not depend on the thread count.
RunSummary run_pilco(std::shared_ptr<const rollout::Task> task, const rollout::System& real,
                     std::shared_ptr<const model::MeanFunction> prior,
                     const model::PriorParameters& prior_parameters,
                     const pilco::TaskModel& task_model, const PilcoOptions& options,
                     const Callbacks& callbacks = {}, const RunState* resume = nullptr);

/// run_pilco behind the Algorithm interface (name "pilco", or "pilco_prior" with a prior). The
/// problem's policy is not used: PILCO has its own RBF policy.
class Pilco final : public Algorithm {
 public:
  /// Throws InvalidArgument when options or the task model are invalid.
  Pilco(const PilcoOptions& options, pilco::TaskModel task_model);
  std::string name() const override { return options_.with_prior ? "pilco_prior" : "pilco"; }
  int episodes() const override { return options_.episodes; }
  RunSummary run(const Problem& problem, const Callbacks& callbacks,
                 const RunState* resume = nullptr) const override;
  const PilcoOptions& options() const { return options_; }

 private:
  PilcoOptions options_;
  pilco::TaskModel task_model_;
};

}  // namespace drops::algo
