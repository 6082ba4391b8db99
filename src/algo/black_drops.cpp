#include "drops/algo/black_drops.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"

namespace drops::algo {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Stream tags: each random stream of a run is derive_seed(seed, {episode, tag, ...}).
enum StreamTag : std::uint64_t { kRealEpisode = 1, kPolicySearch = 2, kRandomPolicy = 3,
                                 kPredicted = 4, kReevaluation = 5, kImprovementCheck = 6 };

// RunState::extra's record of the best policy's replays: [replayed identically, solved] as 0/1.
constexpr const char* kBestPolicyKey = "best_policy_replays";
// The trust region's radius after the last episode (BlackDropsOptions::trust_region).
constexpr const char* kTrustRegionKey = "trust_region_radius";
// The real runs of the best policy (BlackDropsOptions::improvement_cap_max_runs).
constexpr const char* kBestRunsKey = "best_policy_runs";

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

model::ModelOptions black_drops_model_defaults() {
  model::ModelOptions o;
  o.rprop.tolerance = 1e-3;
  return o;
}

bool BlackDropsOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (episodes < 1) return fail("episodes must be >= 1");
  if (!(theta_bound > 0)) return fail("theta_bound must be > 0");
  if (prior_optimizations < 1) return fail("prior_optimizations must be >= 1");
  if (predicted_rollouts < 1) return fail("predicted_rollouts must be >= 1");
  if (reevaluation_rollouts < 1) return fail("reevaluation_rollouts must be >= 1");
  if (reevaluation_candidates < 1) return fail("reevaluation_candidates must be >= 1");
  if (rollouts.rollouts < 1) return fail("rollouts.rollouts must be >= 1");
  if (rollouts.batch < 1) return fail("rollouts.batch must be >= 1");
  if (!(trust_region_min > 0 && trust_region_min <= 1))
    return fail("trust_region_min must be in (0, 1]");
  if (!(improvement_margin >= 0 && std::isfinite(improvement_margin)))
    return fail("improvement_margin must be finite and >= 0");
  if (!(improvement_cap >= 0 && std::isfinite(improvement_cap)))
    return fail("improvement_cap must be finite and >= 0");
  if (improvement_cap > 0 && !(improvement_cap > improvement_margin))
    return fail("improvement_cap must exceed improvement_margin (or be 0, off)");
  if (improvement_cap_max_runs < 0) return fail("improvement_cap_max_runs must be >= 0");
  std::string w;
  if (!cmaes.IsValid(&w)) return fail("cmaes: " + w);
  if (!model.IsValid(&w)) return fail("model: " + w);
  if (!rollouts.IsValid(&w)) return fail("rollouts: " + w);
  return true;
}

BlackDrops::BlackDrops(const BlackDropsOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("Black-DROPS options: " + why);
}

RunSummary BlackDrops::run(const Problem& problem, const Callbacks& callbacks,
                           const RunState* resume) const {
  problem.check();
  return run_black_drops(problem.task, *problem.real, *problem.policy, problem.prior,
                         problem.prior_parameters, options_, callbacks, resume);
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
                                   const policy::Policy& policy, const VectorXd& theta0,
                                   const BlackDropsOptions& options, std::uint64_t seed,
                                   const std::function<bool(const opt::CmaesProgress&)>& on_gen,
                                   long* nonfinite_steps, bool start_may_be_chosen,
                                   double region) {
  const int n = policy.param_dim();
  check_size("optimize_policy: theta0 vs policy parameters", n, theta0.size());
  if (!(region > 0 && region <= 1))
    throw InvalidArgument("optimize_policy: trust region " + std::to_string(region) +
                          " is outside (0, 1]");
  VectorXd lower = VectorXd::Constant(n, -options.theta_bound);
  VectorXd upper = VectorXd::Constant(n, options.theta_bound);
  if (region < 1) {
    const VectorXd centre = theta0.cwiseMax(lower).cwiseMin(upper);
    trust_region_box(centre, options.theta_bound, region, lower, upper);
  }
  opt::CmaesOptions co = options.cmaes;
  co.seed = seed;
  if (co.sigma0 <= 0) co.sigma0 = options.theta_bound;  // settings.md §5: sigma0 = b
  if (region < 1) co.sigma0 *= region;
  co.evaluate_start = options.keep_start_point;
  const bool reevaluate = options.selection == PolicySelection::kReevaluate;
  if (reevaluate) co.keep_best = std::max(co.keep_best, options.reevaluation_candidates);
  if (!start_may_be_chosen) co.keep_best = std::max(co.keep_best, 2);  // the best after the start
  rollout::RolloutStats stats;
  auto objective = [&](const std::vector<VectorXd>& xs, const std::vector<std::uint64_t>& streams,
                       std::vector<double>& values) {
    VectorXd returns;
    rollout::evaluate_policies(task, model, policy, xs, streams, options.rollouts, returns, &stats);
    values.resize(xs.size());
    for (std::size_t k = 0; k < xs.size(); ++k) values[k] = -returns[static_cast<Eigen::Index>(k)];
  };
  const VectorXd start = theta0.cwiseMax(lower).cwiseMin(upper);
  PolicySearchResult result;
  result.search = opt::cmaes_minimize_batch(objective, start, lower, upper, co, on_gen);
  const opt::CmaesSummary& cs = result.search;
  auto same = [](const VectorXd& a, const VectorXd& b) { return (a.array() == b.array()).all(); };
  // A search stopped by its caller (e.g. Ctrl-C) is not worth re-evaluating: its policy is not run.
  if (!reevaluate || cs.termination == opt::CmaesTermination::kCallback) {
    result.theta = cs.best_x;
    result.value = -cs.best_value;
    if (!start_may_be_chosen && same(cs.best_x, start)) {
      for (const auto& c : cs.best_candidates)
        if (!same(c.x, start)) {
          result.theta = c.x;
          result.value = -c.value;
          break;
        }
    }
    result.selected = options.keep_start_point && same(result.theta, start) ? "start" : "best_seen";
  } else {
    // The short list, without repeats: the start, the best single evaluations, the runs' means.
    std::vector<VectorXd> list;
    std::vector<std::string> origin;
    auto add = [&](const VectorXd& x, const char* from) {
      if (x.size() != n || !x.allFinite() || (!start_may_be_chosen && same(x, start))) return;
      for (const auto& y : list)
        if (same(x, y)) return;
      list.push_back(x);
      origin.emplace_back(from);
    };
    if (options.keep_start_point) add(start, "start");
    for (const auto& c : cs.best_candidates) add(c.x, "best_seen");
    for (const auto& r : cs.runs) add(r.final_mean, "run_mean");
    if (list.empty()) {  // nothing but the start was evaluated: it is all there is to run
      list.push_back(start);
      origin.emplace_back("start");
    }
    // Common random numbers: every candidate gets the same rollout streams, so that the
    // differences between candidates are not drowned in the rollouts' own noise.
    rollout::RolloutOptions ro = options.rollouts;
    ro.rollouts = options.reevaluation_rollouts;
    const std::vector<std::uint64_t> streams(list.size(), derive_seed(seed, {kReevaluation}));
    VectorXd means;
    rollout::evaluate_policies(task, model, policy, list, streams, ro, means, &stats);
    Eigen::Index best = 0;
    for (Eigen::Index k = 1; k < means.size(); ++k)
      if (means[k] > means[best] || (std::isnan(means[best]) && !std::isnan(means[k]))) best = k;
    if (origin.front() == "start") {
      result.start_value = means[0];
      if (best != 0 && options.paired_check()) {
        // The paired check (BlackDropsOptions::improvement_margin, improvement_cap): the start
        // and the chosen candidate on R fresh streams, one rollout each, stream i shared by both.
        const auto R = static_cast<std::size_t>(options.reevaluation_rollouts);
        std::vector<VectorXd> pair(2 * R);
        std::vector<std::uint64_t> pair_streams(2 * R);
        for (std::size_t i = 0; i < R; ++i) {
          pair[i] = list[0];
          pair[R + i] = list[static_cast<std::size_t>(best)];
          pair_streams[i] = pair_streams[R + i] = derive_seed(seed, {kImprovementCheck, i});
        }
        rollout::RolloutOptions one = options.rollouts;
        one.rollouts = 1;
        VectorXd r;
        rollout::evaluate_policies(task, model, policy, pair, pair_streams, one, r, &stats);
        std::vector<double> d(R);
        for (std::size_t i = 0; i < R; ++i) {
          d[i] = r[static_cast<Eigen::Index>(R + i)] - r[static_cast<Eigen::Index>(i)];
          if (std::isnan(d[i])) d[i] = -std::numeric_limits<double>::infinity();  // counts against
        }
        std::sort(d.begin(), d.end());
        result.paired_improvement = R % 2 ? d[R / 2] : 0.5 * (d[R / 2 - 1] + d[R / 2]);
        if (!(result.paired_improvement > options.improvement_margin)) {
          best = 0;
          result.kept_by_margin = true;
        } else if (options.improvement_cap > 0 &&
                   result.paired_improvement > options.improvement_cap) {
          best = 0;
          result.kept_by_cap = true;
        }
      }
    }
    result.theta = list[static_cast<std::size_t>(best)];
    result.value = means[best];
    result.selected = origin[static_cast<std::size_t>(best)];
    result.candidates = static_cast<int>(list.size());
  }
  if (nonfinite_steps) *nonfinite_steps += stats.nonfinite_steps;
  return result;
}

BlackDropsSummary run_black_drops(std::shared_ptr<const rollout::Task> task,
                                  const rollout::System& real, const policy::Policy& policy,
                                  std::shared_ptr<const model::MeanFunction> prior,
                                  const model::PriorParameters& prior_parameters,
                                  const BlackDropsOptions& options,
                                  const BlackDropsCallbacks& callbacks,
                                  const BlackDropsState* resume) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("Black-DROPS options: " + why);
  if (!task) throw InvalidArgument("run_black_drops: task is null");
  check_size("policy observation_dim vs task observation_dim", task->observation_dim(),
             policy.observation_dim());
  const auto t_run = Clock::now();
  const bool with_prior = model::uses_prior(options.model.type);
  auto model = options.model_factory
                   ? options.model_factory(options.model, task, prior, prior_parameters)
                   : model::make_model(options.model, task, prior, prior_parameters);
  if (!model) throw InvalidArgument("run_black_drops: the model factory returned no model");

  BlackDropsSummary summary;
  std::vector<Transition> data;
  VectorXd best_theta;
  double best_return = -std::numeric_limits<double>::infinity();
  const int n = policy.param_dim();
  // The best policy's replays (options.skip_known_replays): whether a run of it again gave the
  // same return, and whether its best episode solved the task.
  bool best_replayed_identically = false, best_solved = false;
  int best_runs = 0;  // real runs of best_theta
  double region = 1.0;  // the trust region's radius, a fraction of theta_bound
  int first_episode = 1;
  if (resume) {
    if (resume->episodes_done < 1 || resume->episodes_done > options.episodes)
      throw InvalidArgument("resume: episodes_done = " + std::to_string(resume->episodes_done) +
                            " is outside [1, " + std::to_string(options.episodes) + "]");
    check_size("resume: best_theta vs policy parameters", n, resume->best_theta.size());
    if (resume->data.empty()) throw InvalidArgument("resume: the state holds no transitions");
    model->restore(resume->model);
    data = resume->data;
    best_theta = resume->best_theta;
    best_return = resume->best_return;
    summary.first_solved_episode = resume->first_solved_episode;
    summary.episodes_done = resume->episodes_done;
    summary.best_real_return = best_return;
    first_episode = resume->episodes_done + 1;
    // A checkpoint from before skip_known_replays has no record: no identical replay known yet.
    const auto it = resume->extra.find(kBestPolicyKey);
    if (it != resume->extra.end()) {
      if (it->second.size() != 2)
        throw InvalidArgument(std::string("resume: extra.") + kBestPolicyKey + " must hold 2 values");
      best_replayed_identically = it->second[0] != 0;
      best_solved = it->second[1] != 0;
    }
    // A checkpoint from before improvement_cap_max_runs: the best policy was run once.
    best_runs = 1;
    const auto br = resume->extra.find(kBestRunsKey);
    if (br != resume->extra.end()) {
      if (br->second.size() != 1 || !(br->second[0] >= 1))
        throw InvalidArgument(std::string("resume: extra.") + kBestRunsKey +
                              " must hold 1 value >= 1");
      best_runs = static_cast<int>(br->second[0]);
    }
    // A checkpoint without a radius (no trust region, or from before it existed): the whole box.
    const auto tr = resume->extra.find(kTrustRegionKey);
    if (tr != resume->extra.end()) {
      if (tr->second.size() != 1 || !(tr->second[0] > 0 && tr->second[0] <= 1))
        throw InvalidArgument(std::string("resume: extra.") + kTrustRegionKey +
                              " must hold one value in (0, 1]");
      region = tr->second[0];
    }
  }
  auto stop = [&] { return callbacks.should_stop && callbacks.should_stop(); };
  auto status = [&](int episode, const char* phase, long evals, double best) {
    if (callbacks.on_status) callbacks.on_status(Status{episode, phase, evals, best});
  };

  for (int episode = first_episode; episode <= options.episodes; ++episode) {
    if (stop()) {
      summary.interrupted = true;
      break;
    }
    EpisodeRecord rec;
    rec.episode = episode;
    const std::uint64_t ep = static_cast<std::uint64_t>(episode);
    std::unique_ptr<model::DynamicsModel> prior_only;
    const model::DynamicsModel* planning_model = model.get();

    // 1. Model: learn on all data (from episode 2 on); episode 1 plans on the prior alone.
    if (episode == 1) {
      if (with_prior) {
        prior_only = model::make_prior_only_model(prior, prior_parameters);
        planning_model = prior_only.get();
      }
    } else {
      status(episode, "model", 0, 0);
      rec.model = model->learn(data, [&](const std::string&, int evals, double best) {
        status(episode, "model", evals, best);
      });
      rec.model_seconds = rec.model.seconds;
    }
    rec.phi = planning_model == model.get() ? model->phi() : prior_parameters.values;

    // 2. Policy: optimise on the model (or draw at random without any model).
    auto policy_copy = policy.clone();
    const auto t_policy = Clock::now();
    bool interrupted_search = false;
    auto on_gen = [&](const opt::CmaesProgress& p) {
      status(episode, "policy", p.evaluations, -p.best_value);
      if (stop()) {
        interrupted_search = true;
        return false;
      }
      return true;
    };
    if (episode == 1 && !with_prior) {
      Rng rng(derive_seed(options.seed, {ep, kRandomPolicy}));
      rec.theta.resize(n);
      for (int i = 0; i < n; ++i) rec.theta[i] = rng.uniform(-options.theta_bound, options.theta_bound);
      rec.random_policy = true;
      rec.selected = "random";
      rec.reevaluated_return = std::numeric_limits<double>::quiet_NaN();
    } else {
      VectorXd theta0;
      if (best_theta.size()) {
        theta0 = best_theta;
      } else {
        Rng rng(derive_seed(options.seed, {ep, kRandomPolicy}));
        theta0.resize(n);
        for (int i = 0; i < n; ++i) theta0[i] = rng.uniform(-options.theta_bound, options.theta_bound);
      }
      const int runs = episode == 1 ? options.prior_optimizations : 1;
      // The trust region applies once a real policy centres it.
      const double search_region = options.trust_region && best_theta.size() ? region : 1.0;
      if (options.trust_region) rec.details.numbers["trust_region_radius"] = search_region;
      const bool skip_replay = options.skip_known_replays && best_theta.size() &&
                               best_replayed_identically && !best_solved;
      if (skip_replay) rec.details.numbers["replay_skipped"] = 1;
      // The paired check guards a real policy only (episode 1 starts from a guess).
      BlackDropsOptions search_options = options;
      if (!best_theta.size()) {
        search_options.improvement_margin = 0;
        search_options.improvement_cap = 0;
      }
      // The cap may not run the best real policy again once it has been run this often.
      if (search_options.improvement_cap > 0 && options.improvement_cap_max_runs > 0) {
        rec.details.numbers["best_policy_runs"] = best_runs;
        if (best_runs >= options.improvement_cap_max_runs) search_options.improvement_cap = 0;
      }
      double chosen_value = -std::numeric_limits<double>::infinity();
      for (int run = 0; run < runs && !interrupted_search; ++run) {
        auto s = optimize_policy(*task, *planning_model, policy, theta0, search_options,
                                 derive_seed(options.seed, {ep, kPolicySearch,
                                                            static_cast<std::uint64_t>(run)}),
                                 on_gen, &rec.nonfinite_model_steps, !skip_replay, search_region);
        rec.evaluations += s.search.evaluations;
        if (run == 0 || s.value > chosen_value) {
          chosen_value = s.value;
          rec.policy_search = std::move(s.search);
          rec.theta = std::move(s.theta);
          rec.selected = s.selected;
          rec.reevaluated_candidates = s.candidates;
          rec.reevaluated_return = s.candidates > 0 ? s.value
                                                    : std::numeric_limits<double>::quiet_NaN();
          if (search_options.paired_check() && !std::isnan(s.start_value)) {
            rec.details.numbers["start_reevaluated_return"] = s.start_value;
            rec.details.numbers["kept_by_margin"] = s.kept_by_margin ? 1 : 0;
            if (search_options.improvement_cap > 0)
              rec.details.numbers["kept_by_cap"] = s.kept_by_cap ? 1 : 0;
            if (!std::isnan(s.paired_improvement))
              rec.details.numbers["paired_improvement"] = s.paired_improvement;
          }
        }
        theta0 = rec.theta;
      }
    }
    rec.policy_seconds = seconds_since(t_policy);
    if (interrupted_search) {
      summary.interrupted = true;
      break;  // the half-optimised policy is not run: nothing partial is recorded
    }
    policy_copy->set_params(rec.theta);

    // 3. Predicted behaviour on the planning model (mean propagation + MC estimate of the return).
    if (!rec.random_policy) {
      rollout::RolloutOptions mean_only = options.rollouts;
      mean_only.sample = false;
      rollout::ModelSystem ms(*planning_model, mean_only);
      Rng unused(0);
      rec.predicted = rollout::run_episode(*task, ms, *policy_copy, unused);
      rollout::RolloutOptions mc = options.rollouts;
      mc.rollouts = options.predicted_rollouts;
      mc.statistic = rollout::ReturnStatistic::kMean;  // the reported prediction: the expected return
      VectorXd ret;
      rollout::evaluate_policies(*task, *planning_model, policy, {rec.theta},
                                 {derive_seed(options.seed, {ep, kPredicted})}, mc, ret);
      rec.predicted_return = ret[0];
    } else {
      rec.predicted_return = std::numeric_limits<double>::quiet_NaN();
    }

    // 4. Run on the real system and record.
    status(episode, "episode", 0, 0);
    Rng real_rng(derive_seed(options.seed, {ep, kRealEpisode}));
    rec.real = rollout::run_episode(*task, real, *policy_copy, real_rng);
    rec.real_return = rec.real.total_return();
    rec.solved = task->solved(rec.real);
    rec.interaction_time = episode * task->horizon() * task->dt();
    for (auto& t : rec.real.transitions()) data.push_back(std::move(t));
    const bool replay = best_theta.size() == rec.theta.size() && best_theta.size() &&
                        (best_theta.array() == rec.theta.array()).all();
    if (replay && std::abs(rec.real_return - best_return) <=
                      1e-9 * std::max(1.0, std::abs(best_return)))
      best_replayed_identically = true;
    else if (rec.real_return > best_return)
      best_replayed_identically = false;
    // The trust region learns from every new policy run from it: TuRBO's success / failure rule.
    if (options.trust_region && best_theta.size() && !replay && !rec.random_policy)
      region = rec.real_return > best_return ? std::min(1.0, 2 * region)
                                             : std::max(options.trust_region_min, region / 2);
    if (replay) ++best_runs;
    if (rec.real_return > best_return) {
      if (!replay) best_runs = 1;
      best_return = rec.real_return;
      best_theta = rec.theta;
      best_solved = rec.solved;
    }
    if (rec.solved && summary.first_solved_episode == 0) summary.first_solved_episode = episode;
    summary.episodes_done = episode;
    summary.best_real_return = best_return;
    if (callbacks.on_episode) callbacks.on_episode(rec);
    if (callbacks.on_state) {
      BlackDropsState st;
      st.episodes_done = episode;
      st.data = data;
      st.best_theta = best_theta;
      st.best_return = best_return;
      st.first_solved_episode = summary.first_solved_episode;
      st.model = model->state();
      st.extra[kBestPolicyKey] = Eigen::Vector2d(best_replayed_identically ? 1 : 0,
                                                 best_solved ? 1 : 0);
      st.extra[kBestRunsKey] = VectorXd::Constant(1, best_runs);
      if (options.trust_region) st.extra[kTrustRegionKey] = VectorXd::Constant(1, region);
      callbacks.on_state(st);
    }
  }
  summary.seconds = seconds_since(t_run);
  return summary;
}

}  // namespace drops::algo
