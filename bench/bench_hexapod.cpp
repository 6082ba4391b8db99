// Hexapod end-to-end costs as data grows (paper §V-B; 48-D state, 18-D action, 7 removed-leg
// priors):
//   BM_GpMiLearning/N         one GP-MI model learning (the model options of `drops run` on the
//                             hexapod: soft walls, length-scale ratio 10) on N transitions
//   BM_PolicyOptimization/N/T one policy optimization of 1000 CMA-ES evaluations (1 rollout each,
//                             H = 40) on the model learned on N transitions, with T threads;
//                             evals_per_s
//   BM_ModelStep/N            one batched model prediction (8 lanes, one thread) on the model
//                             learned on N transitions, at recorded (x, u): the cost of one step of
//                             a full-length model rollout (per_lane_step), whatever the policy
//   BM_GpMiLearningFast/N     GP-MI learning with a reduced budget (fast_options() below)
//   BM_PriorOnlyPolicyOptimization
//                             the same policy optimization on the prior alone (intact robot,
//                             deterministic): Algorithm 1's first episode
//   BM_PolicyEvaluations/N/T/E
//                             rollout throughput (issue 14): kGenerations CMA-ES-sized batches of
//                             14 policies (lambda of 36 parameters), 1 rollout of H = 40 each,
//                             through rollout::evaluate_policies on the model learned on N
//                             transitions (N = 0: the prior alone, intact robot), T threads, the
//                             prior's physics step E (0: DART's world step, 1: the dedicated rigid
//                             step, PriorEngine::kRigid); evals_per_s. The policies are uniform in [-0.5, 0.5]^36 (the box a
//                             large BIPOP run samples) from fixed seeds, the same every run.
// Data: N = 40 transitions per episode of the intact "real" robot (HexapodRealSystem with its
// default noise), episode 0 a tripod gait, the next ones uniform random theta in [-0.5, 0.5]^36
// (fixed seeds). Threads: all hardware threads (2 on the reference machine) except where T says.
// Run: bench_hexapod --benchmark_counters_tabular=true
// Built only when the drops::hexapod target exists (bench/CMakeLists.txt).
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/hexapod/plugin.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/task.hpp"

using namespace drops;

namespace {

constexpr long kPolicyBudget = 1000;

/// The first `transitions` transitions of real episodes (see the file comment), cached per size.
const std::vector<Transition>& real_data(int transitions) {
  static std::map<int, std::vector<Transition>> cache;
  auto it = cache.find(transitions);
  if (it != cache.end()) return it->second;
  const hexapod::HexapodRealSystem real;
  const hexapod::HexapodTask task;
  hexapod::HexapodGaitPolicy policy;
  std::vector<Transition> data;
  for (int e = 0; static_cast<int>(data.size()) < transitions; ++e) {
    Rng rng(derive_seed(42, {static_cast<std::uint64_t>(e)}));
    VectorXd theta(36);
    if (e == 0) {
      theta = policy.theta_of(hexapod::tripod_gait());
    } else {
      for (int i = 0; i < 36; ++i) theta[i] = rng.uniform(-0.5, 0.5);
    }
    policy.set_params(theta);
    for (auto& t : rollout::run_episode(task, real, policy, rng).transitions())
      if (static_cast<int>(data.size()) < transitions) data.push_back(t);
  }
  return cache.emplace(transitions, std::move(data)).first->second;
}

/// The model options a `drops run` of the hexapod uses (the config defaults of task: hexapod, with
/// their task-dependent values: soft walls on, length-scale ratio 10), so that the benchmark times
/// what the runs do.
model::ModelOptions run_model_options() {
  experiment::Registry registry;
  experiment::register_builtin_algorithms(registry);
  hexapod::register_task(registry);
  return experiment::black_drops_options(registry,
                                         experiment::load_settings(registry, "task: hexapod\n", {}))
      .model;
}

/// The prior with the given physics step (PriorEngine: DART's world step or the dedicated rigid
/// step).
std::shared_ptr<hexapod::HexapodPrior> make_prior(
    hexapod::PriorEngine engine = hexapod::PriorEngine::kDart) {
  hexapod::HexapodPriorOptions o;
  o.simulator.engine = engine;
  return std::make_shared<hexapod::HexapodPrior>(o);
}

std::unique_ptr<model::DynamicsModel> make_hexapod_model(
    const model::ModelOptions& o, hexapod::PriorEngine engine = hexapod::PriorEngine::kDart) {
  return model::make_model(o, std::make_shared<hexapod::HexapodTask>(), make_prior(engine),
                           hexapod::HexapodPrior::prior_parameters());
}

/// Models learned by BM_GpMiLearning (run_model_options()), reused by BM_PolicyOptimization.
std::map<int, std::unique_ptr<model::DynamicsModel>>& learned_models() {
  static std::map<int, std::unique_ptr<model::DynamicsModel>> models;
  return models;
}

void report(benchmark::State& state, const model::ModelSummary& s) {
  state.counters["phi"] = s.phi[0];
  state.counters["rounds"] = s.rounds;
  state.counters["phi_evals"] = s.phi_evaluations;
  state.counters["rprop_its"] = static_cast<double>(s.rprop_iterations);
  state.counters["score"] = s.score;
}

void BM_GpMiLearning(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& data = real_data(n);
  for (auto _ : state) {
    auto m = make_hexapod_model(run_model_options());
    report(state, m->learn(data));
    learned_models()[n] = std::move(m);
  }
}
BENCHMARK(BM_GpMiLearning)
    ->Arg(40)
    ->Arg(120)
    ->Arg(200)
    ->Arg(400)
    ->UseRealTime()
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

/// The timed policy optimization of both policy benchmarks: kPolicyBudget CMA-ES evaluations of
/// one rollout each on `model`, from theta = 0, with fixed seeds.
void optimize_on(benchmark::State& state, const model::DynamicsModel& model) {
  const hexapod::HexapodTask task;
  const hexapod::HexapodGaitPolicy policy;
  algo::PolicySearchOptions o;
  o.theta_bound = hexapod::HexapodGaitPolicyOptions{}.theta_bound;
  o.cmaes.max_evaluations = kPolicyBudget;
  o.rollouts.rollouts = 1;
  long evaluations = 0, nonfinite = 0;
  for (auto _ : state) {
    const auto s = algo::optimize_policy(task, model, policy, o, {VectorXd::Zero(36), 123});
    nonfinite += s.nonfinite_model_steps;
    evaluations += s.search.evaluations;
    state.counters["predicted_return"] = s.value;
  }
  state.counters["evals"] = static_cast<double>(evaluations);
  // Model rollouts stopped early by a non-finite (or guarded) prediction: they cost less.
  state.counters["stopped"] = static_cast<double>(nonfinite);
  state.counters["evals_per_s"] =
      benchmark::Counter(static_cast<double>(evaluations), benchmark::Counter::kIsRate);
}

void BM_PolicyOptimization(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const ThreadLimit limit(static_cast<int>(state.range(1)));
  auto& model = learned_models()[n];
  if (!model) {
    model = make_hexapod_model(run_model_options());
    model->learn(real_data(n));
  }
  optimize_on(state, *model);
}
BENCHMARK(BM_PolicyOptimization)
    ->Args({40, 2})
    ->Args({120, 2})
    ->Args({200, 2})
    ->Args({400, 2})
    ->Args({40, 1})
    ->UseRealTime()
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

void BM_PriorOnlyPolicyOptimization(benchmark::State& state) {
  const auto model = model::make_prior_only_model(std::make_shared<hexapod::HexapodPrior>(),
                                                  hexapod::HexapodPrior::prior_parameters());
  optimize_on(state, *model);
}
BENCHMARK(BM_PriorOnlyPolicyOptimization)->UseRealTime()->Iterations(1)->Unit(benchmark::kSecond);

constexpr int kGenerations = 10;
constexpr int kLambda = 14;  // 4 + floor(3 ln 36)

void BM_PolicyEvaluations(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const ThreadLimit limit(static_cast<int>(state.range(1)));
  const auto engine =
      state.range(2) == 0 ? hexapod::PriorEngine::kDart : hexapod::PriorEngine::kRigid;
  std::unique_ptr<model::DynamicsModel> prior_only;
  const model::DynamicsModel* model = nullptr;
  if (n == 0) {
    prior_only =
        model::make_prior_only_model(make_prior(engine), hexapod::HexapodPrior::prior_parameters());
    model = prior_only.get();
  } else if (engine == hexapod::PriorEngine::kDart) {
    auto& learned = learned_models()[n];
    if (!learned) {
      learned = make_hexapod_model(run_model_options());
      learned->learn(real_data(n));
    }
    model = learned.get();
  } else {
    // Learned with the same prior engine (GP-MI's choice of phi and the GP see its predictions).
    prior_only = make_hexapod_model(run_model_options(), engine);
    prior_only->learn(real_data(n));
    model = prior_only.get();
  }
  const hexapod::HexapodTask task;
  const hexapod::HexapodGaitPolicy policy;
  std::vector<std::vector<VectorXd>> thetas(kGenerations);
  std::vector<std::vector<std::uint64_t>> seeds(kGenerations);
  Rng rng(2024);
  for (int g = 0; g < kGenerations; ++g) {
    for (int k = 0; k < kLambda; ++k) {
      VectorXd theta(36);
      for (int i = 0; i < 36; ++i) theta[i] = rng.uniform(-0.5, 0.5);
      thetas[g].push_back(theta);
      seeds[g].push_back(
          derive_seed(7, {static_cast<std::uint64_t>(g), static_cast<std::uint64_t>(k)}));
    }
  }
  rollout::RolloutOptions ro;
  ro.sample = n > 0;
  long evaluations = 0;
  double sum = 0;
  rollout::RolloutStats stats;
  VectorXd returns;
  for (auto _ : state) {
    for (int g = 0; g < kGenerations; ++g) {
      rollout::evaluate_policies(task, *model, policy, thetas[g], seeds[g], ro, returns, &stats);
      evaluations += kLambda;
      sum += returns.sum();
    }
  }
  state.counters["mean_return"] = sum / static_cast<double>(evaluations);
  state.counters["stopped"] = static_cast<double>(stats.nonfinite_steps);
  state.counters["evals_per_s"] =
      benchmark::Counter(static_cast<double>(evaluations), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PolicyEvaluations)
    ->Args({0, 2, 0})
    ->Args({40, 2, 0})
    ->Args({400, 2, 0})
    ->Args({0, 1, 0})
    ->Args({40, 1, 0})
    ->Args({0, 2, 1})
    ->Args({40, 2, 1})
    ->Args({400, 2, 1})
    ->Args({0, 1, 1})
    ->Args({40, 1, 1})
    ->UseRealTime()
    ->MinTime(5.0)
    ->Unit(benchmark::kSecond);

void BM_ModelStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& data = real_data(n);
  auto& model = learned_models()[n];
  if (!model) {
    model = make_hexapod_model(run_model_options());
    model->learn(data);
  }
  constexpr int kLanes = 8;  // rollout::RolloutOptions::batch
  MatrixXd x(kLanes, hexapod::kStateDim), u(kLanes, hexapod::kNumJoints), mean, var;
  std::size_t next = 0;
  long lane_steps = 0;
  for (auto _ : state) {
    for (int b = 0; b < kLanes; ++b, ++next) {
      const Transition& t = data[next % data.size()];
      x.row(b) = t.x.transpose();
      u.row(b) = t.u.transpose();
    }
    model->predict_batch(x, u, mean, var);
    lane_steps += kLanes;
  }
  // Seconds per lane and step (shown with a time unit, e.g. "650us").
  state.counters["per_lane_step"] = benchmark::Counter(
      static_cast<double>(lane_steps), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ModelStep)
    ->Arg(40)
    ->Arg(120)
    ->Arg(200)
    ->Arg(400)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

/// A reduced GP-MI budget: the phi search on at most 120 transitions with 20 inner Rprop
/// iterations, and a final fit of 100 Rprop iterations (runs: all data, 50, 300), else as a run.
model::ModelOptions fast_options() {
  model::ModelOptions o = run_model_options();
  o.gp_mi.max_points = 120;
  o.gp_mi.inner_rprop_iterations = 20;
  o.rprop.max_iterations = 100;
  return o;
}

void BM_GpMiLearningFast(benchmark::State& state) {
  const auto& data = real_data(static_cast<int>(state.range(0)));
  for (auto _ : state) report(state, make_hexapod_model(fast_options())->learn(data));
}
BENCHMARK(BM_GpMiLearningFast)
    ->Arg(200)
    ->Arg(400)
    ->UseRealTime()
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace
