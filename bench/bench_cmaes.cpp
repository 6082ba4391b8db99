// Overhead of the optimizer itself per generation (sampling, boundary transformation, ranking,
// covariance update, eigendecomposition) at the policy-search size of the paper: n = 81 parameters,
// lambda = 17, box [-1, 1]^81, with a trivial objective so that the optimizer dominates.

#include <benchmark/benchmark.h>

#include "drops/core/parallel.hpp"
#include "drops/opt/cmaes.hpp"

namespace {

void BM_CmaesGeneration(benchmark::State& state) {
  const int n = 81;
  const int generations = 200;
  const bool parallel = state.range(0) != 0;
  drops::opt::CmaesOptions opt;
  opt.lambda = 17;
  opt.sigma0 = 0.5;
  opt.max_evaluations = static_cast<long>(opt.lambda) * generations;
  opt.max_restarts = 0;
  opt.tol_fun = opt.tol_hist_fun = opt.tol_x = 0.0;  // run the whole budget
  opt.parallel = parallel;
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(n, -1.0),
                        hi = Eigen::VectorXd::Constant(n, 1.0);
  const Eigen::VectorXd x0 = Eigen::VectorXd::Constant(n, 0.3);
  auto f = [](const Eigen::VectorXd& x, std::uint64_t) { return (x.array() - 0.1).square().sum(); };
  long total_generations = 0;
  for (auto _ : state) {
    const auto s = drops::opt::cmaes_minimize(f, x0, lo, hi, opt);
    benchmark::DoNotOptimize(s.best_value);
    total_generations += s.generations;
  }
  state.SetItemsProcessed(total_generations);
  // Wall time per generation, in seconds (shown with an SI prefix, e.g. 60u = 60 microseconds).
  state.counters["time_per_generation"] =
      benchmark::Counter(static_cast<double>(total_generations),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_CmaesGeneration)->Arg(0)->Arg(1)->ArgName("parallel")->Unit(benchmark::kMillisecond);

}  // namespace
