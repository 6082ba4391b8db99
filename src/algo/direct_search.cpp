#include "drops/algo/direct_search.hpp"

#include <chrono>
#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"

namespace drops::algo {
namespace {
/// Stream tag of the direct search (derive_seed(seed, {tag})), kept from the first `drops direct`
/// so that its searches are reproduced.
constexpr std::uint64_t kDirectSearch = 0xD12EC7;
}  // namespace

bool DirectSearchOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(theta_bound > 0)) return fail("theta_bound must be > 0");
  if (start.size() && !start.allFinite()) return fail("start must be finite");
  std::string w;
  if (!cmaes.IsValid(&w)) return fail("cmaes: " + w);
  return true;
}

DirectSearch::DirectSearch(const DirectSearchOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("direct search options: " + why);
}

RunSummary DirectSearch::run(const Problem& problem, const Callbacks& callbacks,
                             const RunState* resume) const {
  if (resume) throw InvalidArgument("a direct search cannot be resumed; start it again");
  problem.check();
  const auto t0 = std::chrono::steady_clock::now();
  const int n = problem.policy->param_dim();
  const double b = options_.theta_bound;
  const VectorXd lower = VectorXd::Constant(n, -b), upper = VectorXd::Constant(n, b);
  VectorXd x0 = VectorXd::Zero(n);
  if (options_.start.size()) {
    check_size("direct search: start vs policy parameters", n, options_.start.size());
    if ((options_.start.array().abs() > b).any())
      throw InvalidArgument("direct search: the start lies outside the policy box [-b, b]");
    x0 = options_.start;
  }
  opt::CmaesOptions co = options_.cmaes;
  co.seed = derive_seed(options_.seed, {kDirectSearch});
  if (co.sigma0 <= 0) co.sigma0 = b;  // as the policy search on the model (settings.md §5)
  co.evaluate_start = options_.start.size() > 0;

  RunSummary summary;
  const rollout::Task& task = *problem.task;
  const double episode_time = task.horizon() * task.dt();
  auto episode = [&](const VectorXd& theta, std::uint64_t stream) {
    std::unique_ptr<policy::Policy> p = problem.policy->clone();
    p->set_params(theta);
    Rng rng(stream);
    return rollout::run_episode(task, *problem.real, *p, rng);
  };
  bool stopped = false;
  auto objective = [&](const std::vector<VectorXd>& xs, const std::vector<std::uint64_t>& streams,
                       std::vector<double>& values) {
    std::vector<rollout::Trajectory> trajectories(xs.size());
    parallel_for(xs.size(), [&](std::size_t k) { trajectories[k] = episode(xs[k], streams[k]); });
    values.resize(xs.size());
    for (std::size_t k = 0; k < xs.size(); ++k) {
      EpisodeRecord rec;
      rec.episode = ++summary.episodes_done;
      rec.interaction_time = rec.episode * episode_time;
      rec.real = std::move(trajectories[k]);
      rec.real_return = rec.real.total_return();
      rec.solved = rollout::episode_solved(task, rec.real);
      rec.theta = xs[k];
      rec.predicted_return = std::numeric_limits<double>::quiet_NaN();
      rec.selected = "candidate";
      rec.evaluations = 1;
      rec.keep_trajectories = rec.real_return > summary.best_real_return || rec.episode == 1;
      if (rec.episode == 1 || rec.real_return > summary.best_real_return)
        summary.best_real_return = rec.real_return;
      if (rec.solved && !summary.first_solved_episode)
        summary.first_solved_episode = rec.episode;
      values[k] = -rec.real_return;
      if (callbacks.on_episode) callbacks.on_episode(rec);
    }
  };
  auto on_gen = [&](const opt::CmaesProgress& p) {
    if (callbacks.on_status)
      callbacks.on_status(Status{summary.episodes_done, "policy", p.evaluations, -p.best_value});
    if (callbacks.should_stop && callbacks.should_stop()) {
      stopped = true;
      return false;
    }
    return true;
  };
  summary.search = opt::cmaes_minimize_batch(objective, x0, lower, upper, co, on_gen);
  summary.interrupted = stopped;
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace drops::algo
