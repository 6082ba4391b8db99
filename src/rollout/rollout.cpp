#include "drops/rollout/rollout.hpp"

#include <algorithm>
#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"

namespace drops::rollout {

bool RolloutOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (rollouts < 1) return fail("rollouts must be >= 1");
  if (!(clip >= 0)) return fail("clip must be >= 0");
  if (batch < 1) return fail("batch must be >= 1");
  return true;
}


Trajectory run_episode(const Task& task, const System& system, const policy::Policy& policy,
                       Rng& rng, long* nonfinite_steps) {
  const int H = task.horizon(), E = task.state_dim(), U = task.action_dim();
  check_size("policy observation_dim vs task", task.observation_dim(), policy.observation_dim());
  check_size("policy action_dim vs task", U, policy.action_dim());
  Trajectory tr;
  tr.states.resize(H + 1, E);
  tr.actions.setZero(H, U);
  tr.rewards.setZero(H);
  VectorXd x = task.initial_state(), obs(task.observation_dim()), u(U);
  tr.states.row(0) = x.transpose();
  const std::unique_ptr<EpisodeSession> session = system.begin_episode(x);
  if (!session) throw InvalidArgument("run_episode: System::begin_episode returned null");
  const double dt = task.dt();
  const bool action_reward = task.has_action_reward();
  bool alive = true;
  for (int t = 0; t < H; ++t) {
    if (alive) {
      task.observe(x, obs);
      policy.act(obs, t * dt, u);
      VectorXd next = session->step(u, rng);
      check_size("run_episode: state from System", E, next.size());
      if (!next.allFinite()) {
        alive = false;
        tr.nonfinite_step = t;
        if (nonfinite_steps) ++*nonfinite_steps;
      } else {
        x = std::move(next);
        tr.rewards[t] = task.reward(x);
        if (action_reward) tr.rewards[t] += task.action_reward(u);
      }
      tr.actions.row(t) = u.transpose();
    }
    tr.states.row(t + 1) = x.transpose();
  }
  return tr;
}

bool episode_solved(const Task& task, const Trajectory& trajectory) {
  return trajectory.nonfinite_step < 0 && task.solved(trajectory);
}

namespace {
inline double draw(Rng& rng, double clip) {
  const double z = rng.normal();
  return clip > 0 ? std::clamp(z, -clip, clip) : z;
}
}  // namespace

VectorXd ModelSystem::step(const VectorXd& x, const VectorXd& u, Rng& rng) const {
  Prediction p;
  model_.predict(x, u, p);
  VectorXd next = x + p.mean;
  if (options_.sample)
    for (Eigen::Index i = 0; i < next.size(); ++i)
      next[i] += std::sqrt(std::max(0.0, p.var[i])) * draw(rng, options_.clip);
  return next;
}

void evaluate_policies(const Task& task, const model::DynamicsModel& model,
                       const policy::Policy& policy, const std::vector<VectorXd>& thetas,
                       const std::vector<std::uint64_t>& seeds, const RolloutOptions& options,
                       VectorXd& returns, RolloutStats* stats, MatrixXd* rollout_returns) {
  check_size("evaluate_policies seeds vs thetas", static_cast<long>(thetas.size()),
             static_cast<long>(seeds.size()));
  if (options.rollouts < 1 || options.batch < 1)
    throw InvalidArgument("evaluate_policies: rollouts and batch must be >= 1");
  const int H = task.horizon(), E = task.state_dim(), U = task.action_dim(),
            O = task.observation_dim();
  const std::size_t K = thetas.size();
  const std::size_t R = static_cast<std::size_t>(options.rollouts);
  const std::size_t lanes = K * R;
  const std::size_t B = static_cast<std::size_t>(options.batch);
  const std::size_t chunks = (lanes + B - 1) / B;
  const int samples = model.phi_samples();
  std::vector<double> lane_return(lanes, 0.0);
  std::vector<long> chunk_bad(chunks, 0), chunk_absorbed(chunks, 0);
  parallel_for(chunks, [&](std::size_t c) {
    const std::size_t begin = c * B, end = std::min(lanes, begin + B);
    const Eigen::Index n = static_cast<Eigen::Index>(end - begin);
    std::vector<std::unique_ptr<policy::Policy>> pols;
    std::vector<Rng> rngs;
    for (std::size_t l = begin; l < end; ++l) {
      const std::size_t k = l / R, r = l % R;
      auto p = policy.clone();
      p->set_params(thetas[k]);
      pols.push_back(std::move(p));
      rngs.emplace_back(derive_seed(seeds[k], {r}));
    }
    MatrixXd X(n, E), Uc, mean, var, Xa, Obs, Xn;
    std::vector<int> sample;
    VectorXd rewards;
    const VectorXd x0 = task.initial_state();
    for (Eigen::Index b = 0; b < n; ++b) X.row(b) = x0.transpose();
    // The running lanes, in lane order; while every lane runs, the batch is X itself.
    std::vector<Eigen::Index> running(static_cast<std::size_t>(n));
    for (Eigen::Index b = 0; b < n; ++b) running[static_cast<std::size_t>(b)] = b;
    // The finite lanes of a step and their rows of Uc, and the lanes still running after it:
    // cleared each step, allocated once per chunk.
    std::vector<Eigen::Index> finite, finite_row, still;
    finite.reserve(running.size());
    finite_row.reserve(running.size());
    still.reserve(running.size());
    VectorXd x(E), obs(O), u(U);
    const double dt = task.dt();
    const bool action_reward = task.has_action_reward();
    for (int t = 0; t < H && !running.empty(); ++t) {
      const auto m = static_cast<Eigen::Index>(running.size());
      const bool all = m == n;
      if (!all) {
        Xa.resize(m, E);
        for (Eigen::Index j = 0; j < m; ++j) Xa.row(j) = X.row(running[static_cast<std::size_t>(j)]);
      }
      const MatrixXd& Xb = all ? X : Xa;
      Uc.resize(m, U);
      task.observe_batch(Xb, Obs);  // one call per batch and step (a Python task: one lock)
      for (Eigen::Index j = 0; j < m; ++j) {
        obs = Obs.row(j).transpose();
        pols[static_cast<std::size_t>(running[static_cast<std::size_t>(j)])]->act(obs, t * dt, u);
        Uc.row(j) = u.transpose();
      }
      if (samples > 0) {  // rollout r of every policy under the model's phi sample r mod S
        sample.resize(static_cast<std::size_t>(m));
        const auto S = static_cast<std::size_t>(samples);
        for (Eigen::Index j = 0; j < m; ++j) {
          const auto jj = static_cast<std::size_t>(j);
          const std::size_t lane = begin + static_cast<std::size_t>(running[jj]);
          sample[jj] = static_cast<int>(lane % R % S);
        }
        model.predict_batch_sampled(Xb, Uc, sample, mean, var);
      } else {
        model.predict_batch(Xb, Uc, mean, var);
      }
      // The next states of the lanes (in order, so each lane's draws are its own), then the
      // rewards of the finite ones in one call.
      finite.clear();
      finite_row.clear();
      Xn.resize(m, E);
      for (Eigen::Index j = 0; j < m; ++j) {
        const Eigen::Index b = running[static_cast<std::size_t>(j)];
        Rng& rng = rngs[static_cast<std::size_t>(b)];
        for (int i = 0; i < E; ++i) {
          double d = mean(j, i);
          if (options.sample) d += std::sqrt(std::max(0.0, var(j, i))) * draw(rng, options.clip);
          x[i] = X(b, i) + d;
        }
        if (!x.allFinite()) {
          ++chunk_bad[c];
          continue;  // stopped: remaining rewards 0
        }
        X.row(b) = x.transpose();
        Xn.row(static_cast<Eigen::Index>(finite.size())) = x.transpose();
        finite.push_back(b);
        finite_row.push_back(j);
      }
      Xn.conservativeResize(static_cast<Eigen::Index>(finite.size()), E);
      if (!finite.empty()) task.reward_batch(Xn, rewards);
      still.clear();
      for (std::size_t j = 0; j < finite.size(); ++j) {
        const Eigen::Index b = finite[j];
        x = X.row(b).transpose();
        const double r = rewards[static_cast<Eigen::Index>(j)];
        double& total = lane_return[begin + static_cast<std::size_t>(b)];
        total += r;
        if (action_reward) {
          u = Uc.row(finite_row[j]).transpose();
          total += task.action_reward(u);
        }
        if (task.absorbing(x)) {
          total += r * (H - 1 - t);  // the state and its reward repeat to the end
          ++chunk_absorbed[c];
          continue;
        }
        still.push_back(b);
      }
      running.swap(still);
    }
  });
  if (rollout_returns) {
    rollout_returns->resize(static_cast<Eigen::Index>(K), static_cast<Eigen::Index>(R));
    for (std::size_t l = 0; l < lanes; ++l)
      (*rollout_returns)(static_cast<Eigen::Index>(l / R), static_cast<Eigen::Index>(l % R)) =
          lane_return[l];
  }
  returns.resize(static_cast<Eigen::Index>(K));
  for (std::size_t k = 0; k < K; ++k) {
    const auto first = lane_return.begin() + static_cast<std::ptrdiff_t>(k * R);
    const auto last = first + static_cast<std::ptrdiff_t>(R);
    double value = 0;
    if (options.statistic == ReturnStatistic::kMedian) {
      // Upper middle, then (even R) the largest of the lower half: their mean is the median.
      const auto mid = first + static_cast<std::ptrdiff_t>(R / 2);
      std::nth_element(first, mid, last);
      value = *mid;
      if (R % 2 == 0) value = 0.5 * (value + *std::max_element(first, mid));
    } else {
      for (auto it = first; it != last; ++it) value += *it;
      value /= static_cast<double>(R);
    }
    returns[static_cast<Eigen::Index>(k)] = value;
  }
  if (stats) {
    stats->rollouts += static_cast<long>(lanes);
    for (long b : chunk_bad) stats->nonfinite_steps += b;
    for (long a : chunk_absorbed) stats->absorbed += a;
  }
}

}  // namespace drops::rollout
