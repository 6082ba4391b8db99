// Benchmarks of drops::pilco at the pendubot sizes of baselines.md §1a: GP input D = 7 (6 state
// features + u), E = 4 outputs, N = 250 training points, an RBF policy with 200 centres (1406
// parameters), horizon H = 50. Random data of the right shapes (the cost does not depend on the
// values): one propagation step (moments; with state derivatives; with state and policy
// derivatives), the GP and policy moments alone, and the objective J(theta) with and without its
// gradient.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <vector>

#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/pilco/propagate.hpp"

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace pilco = drops::pilco;

constexpr double kPi = std::numbers::pi;

VectorXd Features(const VectorXd& x) {
  VectorXd f(6);
  f << x[0], x[1], std::sin(x[2]), std::cos(x[2]), std::sin(x[3]), std::cos(x[3]);
  return f;
}

// E = 4 SE-ARD GPs on N random pendubot-like transitions (input: 6 state features + u).
std::vector<drops::gp::Gp> PendubotGps(int N, drops::Rng& rng) {
  MatrixXd X(N, 7), Y(N, 4);
  for (int i = 0; i < N; ++i) {
    VectorXd x(4);
    x << 3 * rng.normal(), 3 * rng.normal(), rng.uniform(-kPi, kPi), rng.uniform(-kPi, kPi);
    const double u = rng.uniform(-3.5, 3.5);
    X.row(i) << Features(x).transpose(), u;
    Y(i, 0) = 0.05 * (u - 9.8 * std::sin(x[2])) + 0.01 * rng.normal();
    Y(i, 1) = 0.05 * (-9.8 * std::sin(x[3]) + 0.1 * x[0] * x[1]) + 0.01 * rng.normal();
    Y(i, 2) = 0.05 * x[0] + 0.01 * rng.normal();
    Y(i, 3) = 0.05 * x[1] + 0.01 * rng.normal();
  }
  std::vector<drops::gp::Gp> gps;
  for (int a = 0; a < 4; ++a) {
    drops::gp::Gp gp(7);
    VectorXd h(9);
    for (int d = 0; d < 7; ++d) h[d] = std::log(rng.uniform(1.0, 4.0));
    h[7] = std::log(0.5);
    h[8] = std::log(0.01);
    gp.set_h_params(h);
    gp.compute(X, Y.col(a));
    gps.push_back(std::move(gp));
  }
  return gps;
}

struct Pendubot {
  pilco::PropagationConfig config;
  pilco::SeModel model;
  pilco::RbfPolicy policy{6, 200, 1};
  pilco::SaturatingCost cost;
  VectorXd m0;
  MatrixXd S0;
  VectorXd mid_mean;  // the state distribution after 10 steps
  MatrixXd mid_cov;

  Pendubot() {
    drops::Rng rng(1);
    config.state_dim = 4;
    config.angles = {2, 3};
    config.policy_inputs = {0, 1, 4, 5, 6, 7};
    config.dynamics_inputs = {0, 1, 4, 5, 6, 7};
    config.max_u = VectorXd::Constant(1, 3.5);
    model = pilco::gp_model(PendubotGps(250, rng));
    // PILCO's initialisation (settings_pendubot.m): centres around the start, targets 0.1 randn.
    m0 = VectorXd(4);
    m0 << 0, 0, kPi, kPi;
    VectorXd var0(4);
    var0 << 0.01, 0.01, 1e-4, 1e-4;
    S0 = var0.asDiagonal();
    MatrixXd centres(200, 6), targets(200, 1);
    for (int i = 0; i < 200; ++i) {
      VectorXd x = m0;
      for (int k = 0; k < 4; ++k) x[k] += std::sqrt(S0(k, k)) * rng.normal();
      centres.row(i) = Features(x).transpose();
      targets(i, 0) = 0.1 * rng.normal();
    }
    MatrixXd log_l(6, 1);
    log_l << 0, 0, std::log(0.7), std::log(0.7), std::log(0.7), std::log(0.7);
    policy.set(centres, targets, log_l);
    // Squared tip distance on [sin th1, cos th1, sin th2, cos th2], width 0.25.
    MatrixXd C = MatrixXd::Zero(2, 8);
    C(0, 4) = C(0, 6) = C(1, 5) = C(1, 7) = 0.5;
    cost.weight = C.transpose() * C / (0.25 * 0.25);
    cost.target = VectorXd::Zero(8);
    cost.target[5] = cost.target[7] = 1.0;
    mid_mean = m0;
    mid_cov = S0;
    for (int t = 0; t < 10; ++t) {
      const pilco::StepMoments s = pilco::propagate(config, model, policy, mid_mean, mid_cov);
      mid_mean = s.mean;
      mid_cov = s.cov;
    }
  }
};

const Pendubot& Problem() {
  static const Pendubot p;
  return p;
}

void BM_PilcoStep(benchmark::State& state) {
  const Pendubot& p = Problem();
  const drops::ThreadLimit limit(static_cast<int>(state.range(1)));
  const auto which = static_cast<pilco::StepDerivatives>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        pilco::propagate(p.config, p.model, p.policy, p.mid_mean, p.mid_cov, which));
  }
}
// First argument 0: moments only, 1: + state derivatives, 2: + policy derivatives; second: threads.
BENCHMARK(BM_PilcoStep)
    ->ArgsProduct({{0, 1, 2}, {1, 2}})
    ->ArgNames({"derivatives", "threads"})
    ->Unit(benchmark::kMillisecond);

void BM_PilcoGpMoments(benchmark::State& state) {
  const Pendubot& p = Problem();
  const drops::ThreadLimit limit(static_cast<int>(state.range(1)));
  const pilco::StepMoments s = pilco::propagate(p.config, p.model, p.policy, p.mid_mean, p.mid_cov);
  const std::vector<int> in = {0, 1, 4, 5, 6, 7, 9};  // GP input in the step's joint
  VectorXd m(7);
  MatrixXd S(7, 7);
  for (int k = 0; k < 7; ++k) {
    m[k] = s.joint_mean[in[k]];
    for (int l = 0; l < 7; ++l) S(k, l) = s.joint_cov(in[k], in[l]);
  }
  for (auto _ : state) benchmark::DoNotOptimize(pilco::se_moments(p.model, m, S, state.range(0)));
}
BENCHMARK(BM_PilcoGpMoments)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->ArgNames({"derivatives", "threads"})
    ->Unit(benchmark::kMillisecond);

void BM_PilcoObjective(benchmark::State& state) {
  const Pendubot& p = Problem();
  const drops::ThreadLimit limit(static_cast<int>(state.range(1)));
  const pilco::ExpectedCost J(p.config, p.model, p.policy, p.cost, p.m0, p.S0, 50);
  const VectorXd theta = p.policy.params();
  VectorXd g;
  for (auto _ : state) benchmark::DoNotOptimize(J(theta, state.range(0) ? &g : nullptr));
}
// 0: J(theta) over H = 50, 1: J and dJ/dtheta; second argument: threads.
BENCHMARK(BM_PilcoObjective)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->ArgNames({"gradient", "threads"})
    ->Unit(benchmark::kMillisecond);

// J(theta) and dJ/dtheta (H = 50) as the real data grow, as in a PILCO run (first argument 0: one
// GP block per output on N points) and a PILCO-with-priors run (1: [the simulator GPs' mean on 300
// points (the simulation phase's cap), a residual GP on N points] per output); 2 threads. N = 300
// is the exact GP's cap (FITC with 300 inducing inputs costs the same beyond).
void BM_PilcoObjectiveAsDataGrow(benchmark::State& state) {
  const Pendubot& p = Problem();
  const bool with_prior = state.range(0) != 0;
  const int N = static_cast<int>(state.range(1));
  const drops::ThreadLimit limit(2);
  drops::Rng rng(2);
  const std::vector<drops::gp::Gp> real = PendubotGps(N, rng);
  const pilco::SeModel model = with_prior
                                   ? pilco::gp_model_with_prior_mean(PendubotGps(300, rng), real)
                                   : pilco::gp_model(real);
  const pilco::ExpectedCost J(p.config, model, p.policy, p.cost, p.m0, p.S0, 50);
  const VectorXd theta = p.policy.params();
  VectorXd g;
  for (auto _ : state) benchmark::DoNotOptimize(J(theta, &g));
}
BENCHMARK(BM_PilcoObjectiveAsDataGrow)
    ->ArgsProduct({{0, 1}, {50, 150, 300}})
    ->ArgNames({"prior", "N"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
