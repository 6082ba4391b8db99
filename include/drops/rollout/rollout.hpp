#pragma once
/// \file Episodes on a System and Monte-Carlo policy evaluation on a learned model (paper §IV-C).

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/policy/policy.hpp"

namespace drops::rollout {

/// Runs one episode of task.horizon() steps from task.initial_state() on `system` with `policy`,
/// through one session s = system.begin_episode(x_0) (the stateless default for model systems):
/// u_t = pi(observe(x_t), t * dt), x_{t+1} = s.step(u_t), r_t = reward(x_{t+1}) +
/// action_reward(u_t) (Task::action_reward, when the task has one).
/// A non-finite state ends the episode early (Trajectory::nonfinite_step): the remaining states
/// repeat the last finite one and earn reward 0, and *nonfinite_steps (if given) is incremented.
/// Thread-safe if system is.
Trajectory run_episode(const Task& task, const System& system, const policy::Policy& policy,
                       Rng& rng, long* nonfinite_steps = nullptr);

/// Whether an episode solved the task: task.solved(trajectory), and never an episode that the
/// system ended with a non-finite state (its last rows repeat a frozen state, which the task's
/// criterion could take for success). Thread-safe.
bool episode_solved(const Task& task, const Trajectory& trajectory);

/// How the returns of a policy's Monte-Carlo rollouts combine into its value on the model.
enum class ReturnStatistic {
  kMean,    ///< the mean return: the expected return of Black-DROPS (paper Eq. 3 and 8)
  kMedian,  ///< the median return (the mean of the two middle ones for an even count): a value
            ///< that a minority of rollouts (e.g. rare predicted falls) cannot move far
};

/// How a model rollout draws the next state difference from the predictive N(mu, sigma^2).
struct RolloutOptions {
  /// Monte-Carlo rollouts per policy evaluation (>= 1; the reference used 1), combined by
  /// `statistic`.
  int rollouts = 1;
  /// How the rollouts' returns combine into the policy's value (the mean by default).
  ReturnStatistic statistic = ReturnStatistic::kMean;
  /// Draw dx ~ N(mu, sigma^2) per output; false propagates the mean only (deterministic).
  bool sample = true;
  /// Clip each standard-normal draw to [-clip, clip] (the reference clips at 1, i.e. mu +- sigma);
  /// 0 disables clipping.
  double clip = 1.0;
  /// Rollouts advanced together through batched GP predictions (>= 1). Results do not depend on
  /// the thread count; they may differ from batch = 1 by round-off only.
  int batch = 8;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// The learned model wrapped as a System, so imagined and real episodes share run_episode().
/// step(): x + mu + sigma * z with z ~ N(0, 1) clipped as in options (or x + mu without sampling).
class ModelSystem final : public System {
 public:
  ModelSystem(const model::DynamicsModel& model, const RolloutOptions& options)
      : model_(model), options_(options) {}
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override;

 private:
  const model::DynamicsModel& model_;
  RolloutOptions options_;
};

/// Counts kept while evaluating policies on a model (summed over threads after the loop).
struct RolloutStats {
  long rollouts = 0;         ///< model rollouts performed
  long nonfinite_steps = 0;  ///< steps whose prediction was NaN/inf (the rollout stopped there)
  long absorbed = 0;         ///< rollouts that reached an absorbing state (Task::absorbing)
};

/// The value (options.statistic: mean or median) of the returns of options.rollouts Monte-Carlo
/// rollouts on `model` for each policy parameter vector
/// (the policy gets the time t * task.dt() at step t, as in run_episode)
/// thetas[k] (dim policy.param_dim()), using the random stream seeds[k] (rollout r uses
/// derive_seed(seeds[k], {r}); with a model that has phi samples, DynamicsModel::phi_samples()
/// = S > 0, rollout r runs under sample r mod S: predict_batch_sampled). Rollouts are batched
/// (options.batch) and run in parallel; the result is independent of the thread count. Non-finite predictions stop that rollout (remaining
/// rewards 0) and are counted in *stats; a rollout that reaches an absorbing state
/// (Task::absorbing) stops there and gets that state's reward (not an action's) for every
/// remaining step. Each step's reward includes Task::action_reward of its action. Stopped
/// rollouts leave the batch: the model predicts the running ones only. returns: resized to
/// thetas.size(). rollout_returns (when not null): resized to thetas.size() x options.rollouts,
/// row k holding each rollout's return of thetas[k] in rollout order (what `returns` combines).
/// Throws InvalidArgument on size mismatch.
void evaluate_policies(const Task& task, const model::DynamicsModel& model,
                       const policy::Policy& policy, const std::vector<VectorXd>& thetas,
                       const std::vector<std::uint64_t>& seeds, const RolloutOptions& options,
                       VectorXd& returns, RolloutStats* stats = nullptr,
                       MatrixXd* rollout_returns = nullptr);

}  // namespace drops::rollout
