// Pendubot end-to-end costs as data grows (issue 2 targets; results in docs/benchmarks.md):
//   BM_RolloutThroughput/N   policy evaluations per second on a GP model with the simulator prior
//   BM_GpMiLearning/N        one GP-MI model learning (default options) on N transitions
//   BM_PolicyOptimization/N  one policy optimization (default budget) on the learned GP-MI model
// N = transitions (50 per episode). Threads: all hardware threads (2 on the reference machine).
#include <benchmark/benchmark.h>

#include "drops/algo/black_drops.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"
#include "drops/pendubot/pendubot.hpp"

using namespace drops;

namespace {

/// The built-in algorithms and the pendubot, as the drops command line registers them.
const experiment::Registry& registry() {
  static experiment::Registry registry;
  if (registry.task_names().empty()) {
    experiment::register_builtin_algorithms(registry);
    pendubot::register_task(registry);
  }
  return registry;
}

/// The default pendubot experiment of the drops command line.
experiment::Experiment default_experiment() {
  return experiment::make_experiment(registry(), experiment::load_settings(registry(), "", {}));
}

struct Setup {
  experiment::Experiment e = default_experiment();
  algo::BlackDropsOptions algo = experiment::black_drops_options(registry(), e.settings);
  std::shared_ptr<const rollout::Task> task = e.setup.task;
  std::shared_ptr<const model::MeanFunction> prior = e.setup.prior;
  std::unique_ptr<policy::Policy> pol = e.setup.policy->clone();
  std::vector<Transition> data;

  explicit Setup(int transitions) {
    const rollout::System& real = *e.setup.real;
    Rng rng(42);
    while (static_cast<int>(data.size()) < transitions) {
      VectorXd theta(pol->param_dim());
      for (int i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1.5, 1.5);
      pol->set_params(theta);
      for (auto& t : rollout::run_episode(*task, real, *pol, rng).transitions())
        if (static_cast<int>(data.size()) < transitions) data.push_back(t);
    }
  }
  std::unique_ptr<model::DynamicsModel> learned(model::ModelType type = model::ModelType::kGpMi) {
    model::ModelOptions o = algo.model;
    o.type = type;
    auto m = model::make_model(o, task, prior, e.setup.prior_parameters);
    m->learn(data);
    return m;
  }
};

void BM_RolloutThroughput(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)));
  auto m = s.learned();
  Rng rng(7);
  const int lambda = 17;  // a CMA-ES generation for 81 parameters
  std::vector<VectorXd> thetas(lambda, VectorXd(81));
  std::vector<std::uint64_t> seeds(lambda);
  VectorXd returns;
  long evaluations = 0;
  for (auto _ : state) {
    for (int k = 0; k < lambda; ++k) {
      for (int i = 0; i < 81; ++i) thetas[static_cast<std::size_t>(k)][i] = rng.uniform(-5, 5);
      seeds[static_cast<std::size_t>(k)] = rng();
    }
    rollout::evaluate_policies(*s.task, *m, *s.pol, thetas, seeds, s.algo.search.rollouts, returns);
    evaluations += lambda;
  }
  state.counters["evals_per_s"] = benchmark::Counter(static_cast<double>(evaluations),
                                                     benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RolloutThroughput)->Arg(50)->Arg(100)->Arg(250)->Arg(500)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_GpMiLearning(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto m = model::make_model(s.algo.model, s.task, s.prior, s.e.setup.prior_parameters);
    const auto summary = m->learn(s.data);
    state.counters["phi_evals"] = summary.phi_evaluations;
    state.counters["m2"] = summary.phi[1];
    state.counters["rounds"] = summary.rounds;
    state.counters["rprop_its"] = static_cast<double>(summary.rprop_iterations);
  }
}
BENCHMARK(BM_GpMiLearning)->Arg(50)->Arg(100)->Arg(250)->Arg(500)->UseRealTime()->Iterations(1)->Unit(benchmark::kSecond);

void BM_PolicyOptimization(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)));
  auto m = s.learned();
  for (auto _ : state) {
    const auto summary =
        algo::optimize_policy(*s.task, *m, *s.pol, s.algo.search, {VectorXd::Zero(81), 123});
    state.counters["evals"] = static_cast<double>(summary.search.evaluations);
    state.counters["predicted_return"] = summary.value;
  }
}
BENCHMARK(BM_PolicyOptimization)->Arg(50)->Arg(100)->Arg(250)->Arg(500)->UseRealTime()->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
