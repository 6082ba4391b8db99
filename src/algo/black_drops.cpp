#include "drops/algo/black_drops.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"

namespace drops::algo {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Stream tags: each random stream of a run is derive_seed(seed, {episode, tag, ...}).
enum StreamTag : std::uint64_t { kRealEpisode = 1, kPolicySearch = 2, kRandomPolicy = 3,
                                 kPredicted = 4, kPhiSamples = 5 };

// BlackDropsOwnState's entry of RunState::extra (checkpoint.json "extra").
constexpr const char* kTrustRegionKey = "trust_region_radius";

// What Algorithm 1 carries from one episode to the next: the content of its checkpoint.
struct Progress {
  std::vector<Transition> data;  // every real transition so far
  VectorXd best_theta;           // the best real episode's policy (empty before episode 1)
  double best_return = -std::numeric_limits<double>::infinity();
  int first_solved_episode = 0;
  int episodes_done = 0;
  TrustRegion region;
};

Progress start_or_resume(const BlackDropsOptions& options, int n, model::DynamicsModel& model,
                         const BlackDropsState* resume) {
  Progress p{{}, {}, -std::numeric_limits<double>::infinity(), 0, 0,
             TrustRegion(options.trust_region)};
  if (!resume) {
    p.data = options.recorded_data;  // the recorded transitions come first
    return p;
  }
  if (resume->episodes_done < 1 || resume->episodes_done > options.episodes)
    throw InvalidArgument("resume: episodes_done = " + std::to_string(resume->episodes_done) +
                          " is outside [1, " + std::to_string(options.episodes) + "]");
  check_size("resume: best_theta vs policy parameters", n, resume->best_theta.size());
  if (resume->data.empty()) throw InvalidArgument("resume: the state holds no transitions");
  model.restore(resume->model);
  p.data = resume->data;
  p.best_theta = resume->best_theta;
  p.best_return = resume->best_return;
  p.first_solved_episode = resume->first_solved_episode;
  if (resume->data.size() < options.recorded_data.size())
    throw InvalidArgument("resume: the state holds fewer transitions than the recorded data");
  p.episodes_done = resume->episodes_done;
  if (options.trust_region.enabled) {
    const BlackDropsOwnState own = BlackDropsOwnState::load(resume->extra);
    if (!own.trust_region_radius)
      throw InvalidArgument(std::string("resume: the state has no '") + kTrustRegionKey +
                            "' although the trust region is on");
    p.region = TrustRegion(options.trust_region, *own.trust_region_radius);  // checks (0, 1]
  }
  return p;
}

BlackDropsState checkpoint(const Progress& p, const model::DynamicsModel& model) {
  BlackDropsState st;
  st.episodes_done = p.episodes_done;
  st.data = p.data;
  st.best_theta = p.best_theta;
  st.best_return = p.best_return;
  st.first_solved_episode = p.first_solved_episode;
  st.model = model.state();
  BlackDropsOwnState own;
  if (p.region.enabled()) own.trust_region_radius = p.region.radius();
  st.extra = own.save();
  return st;
}

VectorXd random_theta(const BlackDropsOptions& options, int n, std::uint64_t episode) {
  Rng rng(derive_seed(options.seed, {episode, kRandomPolicy}));
  VectorXd theta(n);
  const double b = options.search.theta_bound;
  for (int i = 0; i < n; ++i) theta[i] = rng.uniform(-b, b);
  return theta;
}

// Step 2 of an episode: the policy search on `planning` (on the prior alone, episode 1 runs
// options.prior_optimizations searches in a row, each from the previous one's choice). Fills
// rec's theta and search record; returns false when the caller stopped the search.
bool search_policy(const rollout::Task& task, const model::DynamicsModel& planning,
                   const policy::Policy& policy, const BlackDropsOptions& options,
                   const Progress& p, EpisodeRecord& rec, bool on_prior_alone,
                   const std::function<bool(const opt::CmaesProgress&)>& on_gen) {
  const std::uint64_t ep = static_cast<std::uint64_t>(rec.episode);
  SearchStart start;
  start.theta0 = p.best_theta.size() ? p.best_theta : random_theta(options, policy.param_dim(), ep);
  start.region = p.region.search_radius(p.best_theta.size() > 0);
  if (p.region.enabled()) rec.details.numbers["trust_region_radius"] = start.region;
  const int searches = on_prior_alone ? options.prior_optimizations : 1;
  bool stopped = false;  // on_gen said stop (even in a generation that ended the search)
  auto gen = [&](const opt::CmaesProgress& g) { return on_gen(g) || (stopped = true, false); };
  double chosen_value = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < searches; ++k) {
    start.seed = derive_seed(options.seed, {ep, kPolicySearch, static_cast<std::uint64_t>(k)});
    auto s = optimize_policy(task, planning, policy, options.search, start, gen);
    rec.evaluations += s.search.evaluations;
    rec.nonfinite_model_steps += s.nonfinite_model_steps;
    if (stopped) return false;
    if (k == 0 || s.value > chosen_value) {
      chosen_value = s.value;
      rec.theta = s.theta;
      rec.selected = s.selected;
      rec.reevaluated_candidates = s.candidates;
      rec.reevaluated_return = s.candidates > 0 ? s.value : kNaN;
      rec.policy_search = std::move(s.search);
    }
    start.theta0 = rec.theta;
  }
  return true;
}

// Step 3: the chosen policy on the model that chose it: the mean propagation (the predicted
// trajectory) and the returns of options.predicted_rollouts Monte-Carlo rollouts (their mean is
// the predicted return; their spread, what the model is unsure of: algo::calibration).
void predict(const rollout::Task& task, const model::DynamicsModel& planning,
             const policy::Policy& policy, const BlackDropsOptions& options, EpisodeRecord& rec) {
  rollout::RolloutOptions mean_only = options.search.rollouts;
  mean_only.sample = false;
  rollout::ModelSystem ms(planning, mean_only);
  auto run = policy.clone();
  run->set_params(rec.theta);
  Rng unused(0);
  rec.predicted = rollout::run_episode(task, ms, *run, unused);
  rollout::RolloutOptions mc = options.search.rollouts;
  mc.rollouts = options.predicted_rollouts;
  mc.statistic = rollout::ReturnStatistic::kMean;  // the reported prediction: the expected return
  VectorXd ret;
  MatrixXd each;
  rollout::evaluate_policies(
      task, planning, policy, {rec.theta},
      {derive_seed(options.seed, {static_cast<std::uint64_t>(rec.episode), kPredicted})}, mc, ret,
      nullptr, &each);
  rec.predicted_return = ret[0];
  rec.predicted_returns = each.row(0).transpose();
}

// Step 4: the chosen policy on the real system; its transitions join the data, and the best real
// policy and the trust region learn from its return.
void run_on_real_system(const rollout::Task& task, const rollout::System& real,
                        const policy::Policy& policy, const BlackDropsOptions& options,
                        Progress& p, EpisodeRecord& rec) {
  auto run = policy.clone();
  run->set_params(rec.theta);
  Rng rng(derive_seed(options.seed, {static_cast<std::uint64_t>(rec.episode), kRealEpisode}));
  rec.real = rollout::run_episode(task, real, *run, rng);
  if (const auto* hybrid = dynamic_cast<const control::BalancePolicy*>(run.get())) {
    rec.details.numbers["balance_steps"] = hybrid->balance_steps();
    rec.details.numbers["balance_first_step"] = hybrid->first_balance_step();
  }
  rec.real_return = rec.real.total_return();
  rec.solved = rollout::episode_solved(task, rec.real);
  rec.interaction_time = rec.episode * task.horizon() * task.dt();
  for (auto& t : rec.real.transitions()) p.data.push_back(std::move(t));
  const bool improved = rec.real_return > p.best_return;
  const bool replay = p.best_theta.size() && (p.best_theta.array() == rec.theta.array()).all();
  rec.replay = replay;
  if (p.best_theta.size() && !replay && !rec.random_policy) p.region.update(improved);
  if (improved) {
    p.best_return = rec.real_return;
    p.best_theta = rec.theta;
  }
  if (rec.solved && p.first_solved_episode == 0) p.first_solved_episode = rec.episode;
  p.episodes_done = rec.episode;
}

// Before the first real episode: the prior must simulate the policy it chose (its mean
// propagation, step 3). One that cannot (a stiff setting its integrator diverges on, a parameter
// it cannot handle) would otherwise fail only after an episode on the real system.
void check_prior_simulates(const rollout::Task& task, const model::PriorParameters& parameters,
                           const EpisodeRecord& rec) {
  if (rec.predicted.nonfinite_step < 0) return;
  std::ostringstream phi;
  for (Eigen::Index i = 0; i < rec.phi.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    phi << (i ? ", " : "") << (k < parameters.names.size() ? parameters.names[k] + "=" : "")
        << rec.phi[i];
  }
  throw Error("episode 1: the simulator prior cannot simulate the policy chosen on it: its state "
              "became non-finite at step " + std::to_string(rec.predicted.nonfinite_step + 1) +
              " of " + std::to_string(task.horizon()) + " (phi = [" + phi.str() +
              "]); nothing was run on the real system. Check the prior's parameters and time "
              "step");
}

// Catch and balance: the LQR of options.balance on the planning model, recorded in rec.details,
// and the hybrid policy that runs it (null when the mode is off or there is no planning model).
std::unique_ptr<control::BalancePolicy> make_hybrid(const rollout::Task& task,
                                                    const model::DynamicsModel* planning,
                                                    const policy::Policy& policy,
                                                    const BlackDropsOptions& options,
                                                    EpisodeRecord& rec) {
  if (options.balance.mode == control::BalanceMode::kOff || !planning) return nullptr;
  auto c = std::make_shared<const control::BalanceController>(
      control::make_balance_controller(task, *planning, options.balance));
  auto& n = rec.details.numbers;
  n["balance_usable"] = c->usable() ? 1 : 0;
  n["balance_dare_iterations"] = c->dare.iterations;
  n["balance_closed_loop_radius"] = c->dare.closed_loop_radius;
  n["balance_drift_norm"] = c->linearization.drift.norm();
  for (Eigen::Index i = 0; i < c->dare.K.rows(); ++i)
    for (Eigen::Index j = 0; j < c->dare.K.cols(); ++j)
      n["balance_k_" + std::to_string(i) + "_" + std::to_string(j)] = c->dare.K(i, j);
  return std::make_unique<control::BalancePolicy>(policy.clone(), task.state_dim(), std::move(c),
                                                  options.balance);
}

}  // namespace

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
  if (prior_optimizations < 1) return fail("prior_optimizations must be >= 1");
  if (predicted_rollouts < 1) return fail("predicted_rollouts must be >= 1");
  std::string w;
  if (!search.IsValid(&w)) return fail("search: " + w);
  if (!trust_region.IsValid(&w)) return fail("trust_region: " + w);
  if (!model.IsValid(&w)) return fail("model: " + w);
  if (!balance.IsValid(&w)) return fail("balance: " + w);
  return true;
}

StateVectors BlackDropsOwnState::save() const {
  StateVectors v;
  if (trust_region_radius) v[kTrustRegionKey] = VectorXd::Constant(1, *trust_region_radius);
  return v;
}

BlackDropsOwnState BlackDropsOwnState::load(const StateVectors& extra) {
  BlackDropsOwnState own;
  if (const auto it = extra.find(kTrustRegionKey); it != extra.end()) {
    if (it->second.size() != 1)
      throw InvalidArgument(std::string("resume: the state's '") + kTrustRegionKey + "' holds " +
                            std::to_string(it->second.size()) + " values, expected 1");
    own.trust_region_radius = it->second[0];
  }
  return own;
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
  for (std::size_t i = 0; i < options.recorded_data.size(); ++i) {
    const Transition& t = options.recorded_data[i];
    if (t.x.size() != task->state_dim() || t.dx.size() != task->state_dim() ||
        t.u.size() != task->action_dim() || !t.x.allFinite() || !t.u.allFinite() ||
        !t.dx.allFinite())
      throw InvalidArgument("run_black_drops: recorded transition " + std::to_string(i) +
                            " is not finite or has other dimensions than the task's state (" +
                            std::to_string(task->state_dim()) + ") and action (" +
                            std::to_string(task->action_dim()) + ")");
  }
  const auto t_run = Clock::now();
  if (options.uses_prior() && !prior)
    throw InvalidArgument("run_black_drops: the model uses a simulator prior but prior is null");
  auto model = options.model_factory
                   ? options.model_factory(options.model, task,
                                           options.uses_prior() ? prior : nullptr, prior_parameters)
                   : model::make_model(options.model, task, prior, prior_parameters);
  if (!model) throw InvalidArgument("run_black_drops: the model factory returned no model");
  Progress p = start_or_resume(options, policy.param_dim(), *model, resume);
  const std::unique_ptr<model::DynamicsModel> prior_only =
      options.uses_prior() ? model::make_prior_only_model(prior, prior_parameters) : nullptr;
  // Catch and balance: the policy's input gains the raw state (control::BalanceTask).
  std::shared_ptr<const rollout::Task> balance_task;
  if (options.balance.mode != control::BalanceMode::kOff) {
    const auto goal = task->goal();
    if (!goal)
      throw InvalidArgument("run_black_drops: balance mode " +
                            control::to_string(options.balance.mode) + " needs a goal state, and "
                            "the task '" + task->name() + "' declares none (Task::goal)");
    goal->check(task->state_dim(), task->action_dim());
    balance_task = std::make_shared<control::BalanceTask>(task);
  }
  auto stop = [&] { return callbacks.should_stop && callbacks.should_stop(); };
  auto status = [&](int episode, const char* phase, long evals, double best) {
    if (callbacks.on_status) callbacks.on_status(Status{episode, phase, evals, best});
  };

  BlackDropsSummary summary;
  for (int episode = p.episodes_done + 1; episode <= options.episodes && !summary.interrupted;
       ++episode) {
    if (stop()) {
      summary.interrupted = true;
      break;
    }
    EpisodeRecord rec;
    rec.episode = episode;
    // 1. Learn the model on all real transitions; episode 1 plans on the prior alone (if any).
    const model::DynamicsModel* planning = model.get();
    // Episode 1 learns no model, unless recorded data are there to learn from.
    const bool model_free =
        episode == 1 && (options.recorded_data.empty() || options.keep_first_episode);
    if (model_free) {
      planning = prior_only.get();
      rec.phi = planning ? prior_parameters.values : model->phi();
    } else {
      if (p.data.empty())
        throw Error("episode " + std::to_string(episode) +
                    ": no real transition to learn from: the real system returned a non-finite "
                    "state at the first step of every episode so far (check its parameters)");
      status(episode, "model", 0, 0);
      rec.model = model->learn(p.data, [&](const std::string&, int evals, double best) {
        status(episode, "model", evals, best);
      });
      // Rollouts over phi's posterior (model.gp_mi.rollout_phi): one draw per rollout index of
      // the evaluation with the most rollouts (rollout r of any evaluation uses draw r mod S).
      const int draws = std::max({options.search.rollouts.rollouts,
                                  options.search.reevaluation.rollouts, options.predicted_rollouts});
      rec.model.phi_sampling = model->draw_phi_samples(
          draws,
          derive_seed(options.seed, {static_cast<std::uint64_t>(episode), kPhiSamples}));
      rec.model_seconds = rec.model.seconds;
      rec.phi = model->phi();
    }
    // With catch and balance, the hybrid of the learned policy and the LQR on this model is
    // what the search, the prediction and the real episode run.
    const auto hybrid = make_hybrid(*task, planning, policy, options, rec);
    const rollout::Task& run_task = hybrid ? *balance_task : *task;
    const policy::Policy& run_policy = hybrid ? *hybrid : policy;
    // 2. Optimise the policy on the model (no model yet: a random policy).
    const auto t_policy = Clock::now();
    if (!planning) {
      rec.theta = random_theta(options, policy.param_dim(), 1);
      rec.random_policy = true;
      rec.selected = "random";
    } else if (!search_policy(run_task, *planning, run_policy, options, p, rec, model_free,
                              [&](const opt::CmaesProgress& g) {
                                status(episode, "policy", g.evaluations, -g.best_value);
                                return !stop();
                              })) {
      summary.interrupted = true;  // the half-optimised policy is not run: nothing is recorded
      break;
    }
    rec.policy_seconds = seconds_since(t_policy);
    // 3. Predict its behaviour on that model.
    rec.predicted_return = kNaN;
    if (planning) predict(run_task, *planning, run_policy, options, rec);
    if (model_free && planning) check_prior_simulates(*task, prior_parameters, rec);
    // 4. Run it on the real system; its transitions join the data.
    status(episode, "episode", 0, 0);
    run_on_real_system(run_task, real, run_policy, options, p, rec);
    if (callbacks.on_episode) callbacks.on_episode(rec);
    if (callbacks.on_state) callbacks.on_state(checkpoint(p, *model));
  }
  summary.episodes_done = p.episodes_done;
  summary.first_solved_episode = p.first_solved_episode;
  if (p.episodes_done > 0) summary.best_real_return = p.best_return;
  summary.seconds = seconds_since(t_run);
  return summary;
}

}  // namespace drops::algo
