// Micro-benchmarks of drops::gp::Gp: single and batched (B = 16) prediction at N = 50, 100, 500
// training points with D = 7 inputs (the pendubot GP input size), and iRprop- hyper-parameter fits
// (300 iterations at most) at N = 100 and 500; and 48 output GPs of the hexapod model's size
// predicting batches of 1 to 16 queries at N = 40 and 400.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"

namespace {

constexpr int kD = 7;
constexpr int kBatch = 16;

Eigen::MatrixXd RandomInputs(drops::Rng& rng, int rows) {
  Eigen::MatrixXd X(rows, kD);
  for (int j = 0; j < kD; ++j)
    for (int i = 0; i < rows; ++i) X(i, j) = rng.uniform(-2.0, 2.0);
  return X;
}

// Smooth target with noise, so that the fit is a realistic problem.
Eigen::VectorXd Targets(drops::Rng& rng, const Eigen::MatrixXd& X) {
  Eigen::VectorXd y(X.rows());
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    y[i] = std::sin(X(i, 0)) + 0.5 * std::cos(2.0 * X(i, 1)) + 0.1 * X(i, 2) * X(i, 3) +
           0.05 * rng.normal();
  }
  return y;
}

drops::gp::Gp MakeGp(int n) {
  drops::Rng rng(42);
  const Eigen::MatrixXd X = RandomInputs(rng, n);
  drops::gp::Gp gp(kD);
  gp.compute(X, Targets(rng, X));
  return gp;
}

void BM_Predict(benchmark::State& state) {
  const drops::gp::Gp gp = MakeGp(static_cast<int>(state.range(0)));
  drops::Rng rng(7);
  const Eigen::MatrixXd Xq = RandomInputs(rng, 64);
  Eigen::VectorXd x(kD);
  double mean = 0, var = 0;
  int q = 0;
  for (auto _ : state) {
    x = Xq.row(q).transpose();
    q = (q + 1) & 63;
    gp.predict(x, mean, var);
    benchmark::DoNotOptimize(mean);
    benchmark::DoNotOptimize(var);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Predict)->Arg(50)->Arg(100)->Arg(500);

void BM_PredictBatch16(benchmark::State& state) {
  const drops::gp::Gp gp = MakeGp(static_cast<int>(state.range(0)));
  drops::Rng rng(7);
  const Eigen::MatrixXd Xq = RandomInputs(rng, kBatch);
  Eigen::VectorXd mean(kBatch), var(kBatch);
  for (auto _ : state) {
    gp.predict_batch(Xq, mean, var);
    benchmark::DoNotOptimize(mean.data());
    benchmark::DoNotOptimize(var.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kBatch);  // items = query points
}
BENCHMARK(BM_PredictBatch16)->Arg(50)->Arg(100)->Arg(500);

// The hexapod's model step without its prior: 48 output GPs of 63 inputs (45 observed state
// dimensions and 18 joint targets) at N training points, each predicting a batch of B queries.
// Items are lanes (one query through all 48 outputs); per_lane_us is the time per lane and step.
void BM_PredictHexapodSizedBatch(benchmark::State& state) {
  constexpr int kOutputs = 48, kInputs = 63;
  const int n = static_cast<int>(state.range(0));
  const int batch = static_cast<int>(state.range(1));
  drops::Rng rng(11);
  Eigen::MatrixXd X(n, kInputs);
  for (int j = 0; j < kInputs; ++j)
    for (int i = 0; i < n; ++i) X(i, j) = rng.uniform(-1.0, 1.0);
  std::vector<drops::gp::Gp> gps;
  for (int o = 0; o < kOutputs; ++o) {
    Eigen::VectorXd y(n), h(kInputs + 2);
    for (int i = 0; i < n; ++i) y[i] = std::sin(X(i, o % kInputs)) + 0.05 * rng.normal();
    gps.emplace_back(kInputs);
    for (int d = 0; d < kInputs; ++d) h[d] = std::log(rng.uniform(2.0, 8.0));  // log l_d
    h[kInputs] = 0.0;                                                         // log sigma_f
    h[kInputs + 1] = std::log(0.05);                                          // log sigma_n
    gps.back().compute(X, y);
    gps.back().set_h_params(h);
  }
  Eigen::MatrixXd Xq(batch, kInputs);
  for (int j = 0; j < kInputs; ++j)
    for (int i = 0; i < batch; ++i) Xq(i, j) = rng.uniform(-1.0, 1.0);
  Eigen::VectorXd mean(batch), var(batch);
  for (auto _ : state) {
    for (const drops::gp::Gp& gp : gps) {
      gp.predict_batch(Xq, mean, var);
      benchmark::DoNotOptimize(mean.data());
      benchmark::DoNotOptimize(var.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * batch);
  state.counters["per_lane_us"] = benchmark::Counter(
      static_cast<double>(state.iterations() * batch),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert, benchmark::Counter::kIs1000);
}
BENCHMARK(BM_PredictHexapodSizedBatch)
    ->ArgsProduct({{40, 400}, {1, 6, 8, 14, 16}})
    ->Unit(benchmark::kMicrosecond);

void BM_OptimizeHParams(benchmark::State& state) {
  drops::gp::Gp gp = MakeGp(static_cast<int>(state.range(0)));
  const Eigen::VectorXd h0 = gp.h_params();
  drops::gp::RpropOptions options;  // 300 iterations, settings.md §3
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    gp.set_h_params(h0);  // same start every time (optimize warm-starts from the current h)
    state.ResumeTiming();
    const drops::gp::RpropSummary s = gp.optimize_h_params(options);
    iterations = s.iterations;
    benchmark::DoNotOptimize(s.final_log_likelihood);
  }
  state.counters["rprop_iterations"] = iterations;
}
BENCHMARK(BM_OptimizeHParams)->Arg(100)->Arg(500)->Unit(benchmark::kMillisecond);

}  // namespace
