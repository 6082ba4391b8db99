#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <numbers>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/opt/cmaes.hpp"

namespace {

using drops::opt::cmaes_minimize;
using drops::opt::CmaesOptions;
using drops::opt::CmaesProgress;
using drops::opt::CmaesSummary;
using drops::opt::CmaesTermination;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();

VectorXd Unbounded(int n, double sign) { return VectorXd::Constant(n, sign * kInf); }

double Sphere(const VectorXd& x) { return x.squaredNorm(); }

double Rosenbrock(const VectorXd& x) {
  double f = 0;
  for (Eigen::Index i = 0; i + 1 < x.size(); ++i) {
    const double a = x(i + 1) - x(i) * x(i), b = 1.0 - x(i);
    f += 100.0 * a * a + b * b;
  }
  return f;
}

double Rastrigin(const VectorXd& x) {
  double f = 10.0 * static_cast<double>(x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i)
    f += x(i) * x(i) - 10.0 * std::cos(2.0 * std::numbers::pi * x(i));
  return f;
}

bool BitEqual(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

bool BitEqual(const VectorXd& a, const VectorXd& b) {
  if (a.size() != b.size()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i)
    if (!BitEqual(a(i), b(i))) return false;
  return true;
}

TEST(Cmaes, SolvesSphere10D) {
  CmaesOptions opt;
  opt.sigma0 = 0.5;
  opt.max_evaluations = 20000;
  opt.max_restarts = 0;
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Sphere(x); },
                                VectorXd::Ones(10), Unbounded(10, -1), Unbounded(10, 1), opt);
  EXPECT_LE(s.best_value, 1e-8) << s.BriefReport();
  EXPECT_LE(s.best_x.norm(), 1e-4);
  EXPECT_DOUBLE_EQ(s.best_value, Sphere(s.best_x));
  ASSERT_EQ(s.run_stop_reasons.size(), 1u);
  EXPECT_EQ(s.termination, CmaesTermination::kMaxRestarts) << s.run_stop_reasons[0];
  EXPECT_LT(s.evaluations, 20000);
}

TEST(Cmaes, SolvesRosenbrock10D) {
  CmaesOptions opt;
  opt.sigma0 = 0.5;
  opt.max_evaluations = 100000;
  opt.stop_fitness = 1e-10;
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rosenbrock(x); },
                                VectorXd::Zero(10), Unbounded(10, -1), Unbounded(10, 1), opt);
  EXPECT_LE(s.best_value, 1e-8) << s.BriefReport();
  EXPECT_EQ(s.termination, CmaesTermination::kStopFitness);
  EXPECT_LE((s.best_x - VectorXd::Ones(10)).cwiseAbs().maxCoeff(), 1e-3);
}

// BIPOP's restarts find the global optimum of 10-D Rastrigin, in at least 4 of 5 independent runs.
// The claim is over seeds because one run is a chaotic trajectory: a change in the last bit of the
// covariance's eigendecomposition or products (Eigen hands them to OpenBLAS/LAPACKE, whose
// rounding depends on its thread count and on the CPU's kernels) leads to another run. Measured
// with this budget on seeds 1-60: 59 solved with OpenBLAS on one thread (the test main's setting,
// use_single_threaded_blas) and 59 with two OpenBLAS threads; the failures (seed 38 on one thread,
// seed 6 on two) ended at a local minimum f = 0.995 with the budget spent. Seed 7, the one seed
// this test used to run, takes 243,001 evaluations on one OpenBLAS thread and 42,273 on two. With
// p = 0.98 per run, 3 or fewer of 5 happen with probability about 0.4 %.
TEST(Cmaes, BipopSolvesRastrigin10D) {
  const int n = 10;
  drops::Rng rng(2024);
  VectorXd x0(n);
  for (int i = 0; i < n; ++i) x0(i) = rng.uniform(-5.0, 5.0);
  int solved = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    CmaesOptions opt;
    opt.sigma0 = 2.0;
    opt.max_evaluations = 400000;
    opt.max_restarts = 9;
    opt.stop_fitness = 1e-6;
    opt.seed = seed;
    std::vector<int> lambdas;
    const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rastrigin(x); },
                                  x0, VectorXd::Constant(n, -5.0), VectorXd::Constant(n, 5.0), opt,
                                  [&](const CmaesProgress& p) {
                                    if (lambdas.empty() || lambdas.back() != p.lambda)
                                      lambdas.push_back(p.lambda);
                                    return true;
                                  });
    std::string trace;
    for (int l : lambdas) trace += std::to_string(l) + " ";
    SCOPED_TRACE("seed " + std::to_string(seed) + ": " + s.BriefReport() + " lambdas: " + trace);
    EXPECT_EQ(static_cast<int>(s.run_stop_reasons.size()), s.restarts + 1);
    // The global optimum (0, ..., 0), not a local one (local minima are near integer points != 0).
    const bool global = s.best_value < 1e-5 && s.best_x.cwiseAbs().maxCoeff() < 1e-3;
    if (!global) continue;
    ++solved;
    EXPECT_EQ(s.termination, CmaesTermination::kStopFitness);
    EXPECT_GE(s.restarts, 1);  // a single default-population run does not solve Rastrigin
  }
  EXPECT_GE(solved, 4);
}

// A run's budget below its population (here 7 < lambda = 10) still gives each run one generation:
// before, every run ended before its first and the search evaluated nothing (issue 18: `drops
// direct --evaluations 30` recorded no episode).
TEST(Cmaes, ARunBudgetBelowThePopulationStillEvaluatesAGenerationPerRun) {
  CmaesOptions opt;
  opt.sigma0 = 1.0;
  opt.lambda = 10;
  opt.max_evaluations = 30;
  opt.max_run_evaluations = 7;
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return x.squaredNorm(); },
                                VectorXd::Constant(4, 1.0), VectorXd::Constant(4, -5.0),
                                VectorXd::Constant(4, 5.0), opt);
  EXPECT_GE(s.evaluations, 10) << s.BriefReport();
  EXPECT_LE(s.evaluations, 30) << s.BriefReport();
  ASSERT_FALSE(s.runs.empty());
  EXPECT_EQ(s.runs.front().evaluations, 10);
  EXPECT_EQ(s.runs.front().generations, 1);
}

TEST(Cmaes, IpopDoublesPopulation) {
  CmaesOptions opt;
  opt.sigma0 = 2.0;
  opt.bipop = false;
  opt.max_restarts = 3;
  opt.max_evaluations = 200000;
  opt.tol_fun = 1e-3;  // short runs
  opt.tol_hist_fun = 1e-3;
  std::vector<int> lambdas;
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rastrigin(x); },
                                VectorXd::Constant(5, 3.0), VectorXd::Constant(5, -5.0),
                                VectorXd::Constant(5, 5.0), opt,
                                [&](const CmaesProgress& p) {
                                  if (lambdas.empty() || lambdas.back() != p.lambda)
                                    lambdas.push_back(p.lambda);
                                  return true;
                                });
  EXPECT_EQ(s.termination, CmaesTermination::kMaxRestarts) << s.BriefReport();
  EXPECT_EQ(s.restarts, 3);
  EXPECT_EQ(lambdas, (std::vector<int>{8, 16, 32, 64}));  // default lambda for n = 5 is 8
}

TEST(Cmaes, EveryEvaluationInsideBoxAndOptimumOnBound) {
  const int n = 6;
  std::atomic<bool> outside{false};
  std::atomic<long> calls{0};
  const VectorXd lo = VectorXd::Constant(n, -1.0), hi = VectorXd::Constant(n, 1.0);
  auto f = [&](const VectorXd& x, std::uint64_t) {
    ++calls;
    if ((x.array() < -1.0).any() || (x.array() > 1.0).any()) outside = true;
    return (x.array() - 10.0).square().sum();
  };
  CmaesOptions opt;
  opt.sigma0 = 3.0;  // large compared with the box: many raw samples fall outside
  opt.max_evaluations = 20000;
  const auto s = cmaes_minimize(f, VectorXd::Zero(n), lo, hi, opt);
  EXPECT_FALSE(outside.load());
  EXPECT_EQ(calls.load(), s.evaluations);
  EXPECT_TRUE((s.best_x.array() >= -1.0).all() && (s.best_x.array() <= 1.0).all());
  EXPECT_LT((s.best_x - hi).cwiseAbs().maxCoeff(), 1e-6) << s.best_x.transpose();
  EXPECT_NEAR(s.best_value, n * 81.0, 1e-5);
}

TEST(Cmaes, MixedAndOneSidedBounds) {
  // x0 in [0, inf), x1 in (-inf, 2], x2 in [-3, 3], x3 unbounded; optimum at (0, 2, 1, -4) with
  // x0,x1 on their bounds.
  VectorXd lo(4), hi(4), target(4), expect(4);
  lo << 0.0, -kInf, -3.0, -kInf;
  hi << kInf, 2.0, 3.0, kInf;
  target << -5.0, 7.0, 1.0, -4.0;
  expect << 0.0, 2.0, 1.0, -4.0;
  std::atomic<bool> outside{false};
  auto f = [&](const VectorXd& x, std::uint64_t) {
    if (x(0) < 0.0 || x(1) > 2.0 || x(2) < -3.0 || x(2) > 3.0) outside = true;
    return (x - target).squaredNorm();
  };
  CmaesOptions opt;
  opt.sigma0 = 5.0;
  opt.max_evaluations = 20000;
  VectorXd x0(4);
  x0 << 0.0, 2.0, -3.0, 0.0;  // on the bounds is allowed
  const auto s = cmaes_minimize(f, x0, lo, hi, opt);
  EXPECT_FALSE(outside.load());
  EXPECT_LT((s.best_x - expect).cwiseAbs().maxCoeff(), 1e-5) << s.best_x.transpose();
}

CmaesSummary RunNoisy(int threads, bool parallel, bool uh) {
  drops::ThreadLimit limit(threads);
  CmaesOptions opt;
  opt.sigma0 = 1.0;
  opt.max_evaluations = 6000;
  opt.max_restarts = 2;
  opt.seed = 12345;
  opt.parallel = parallel;
  opt.uncertainty_handling = uh;
  opt.tol_fun = 1e-6;
  opt.tol_hist_fun = 1e-6;
  auto f = [](const VectorXd& x, std::uint64_t stream) {
    drops::Rng r(stream);
    return Rastrigin(x) + 0.1 * r.normal();
  };
  return cmaes_minimize(f, VectorXd::Constant(8, 2.0), VectorXd::Constant(8, -5.0),
                        VectorXd::Constant(8, 5.0), opt);
}

TEST(Cmaes, DeterministicAcrossThreadCounts) {
  for (bool uh : {false, true}) {
    const auto a = RunNoisy(1, true, uh);
    const auto b = RunNoisy(2, true, uh);
    const auto c = RunNoisy(2, false, uh);
    const auto d = RunNoisy(2, true, uh);
    for (const auto* o : {&b, &c, &d}) {
      EXPECT_TRUE(BitEqual(a.best_x, o->best_x)) << "uh=" << uh;
      EXPECT_TRUE(BitEqual(a.best_value, o->best_value)) << "uh=" << uh;
      EXPECT_EQ(a.evaluations, o->evaluations);
      EXPECT_EQ(a.generations, o->generations);
      EXPECT_EQ(a.restarts, o->restarts);
      EXPECT_EQ(a.run_stop_reasons, o->run_stop_reasons);
    }
    EXPECT_LE(a.evaluations, 6000);
  }
  // A different seed gives a different search.
  drops::ThreadLimit limit(2);
  CmaesOptions opt;
  opt.max_evaluations = 500;
  auto f = [](const VectorXd& x, std::uint64_t) { return Sphere(x); };
  opt.seed = 1;
  const auto s1 = cmaes_minimize(f, VectorXd::Ones(5), Unbounded(5, -1), Unbounded(5, 1), opt);
  opt.seed = 2;
  const auto s2 = cmaes_minimize(f, VectorXd::Ones(5), Unbounded(5, -1), Unbounded(5, 1), opt);
  EXPECT_FALSE(BitEqual(s1.best_x, s2.best_x));
}

TEST(Cmaes, BatchObjectiveMatchesSingleObjective) {
  auto single = [](const VectorXd& x, std::uint64_t stream) {
    drops::Rng r(stream);
    return Rastrigin(x) + 0.1 * r.normal();
  };
  std::vector<std::size_t> batch_sizes;
  auto batch = [&](const std::vector<VectorXd>& xs, const std::vector<std::uint64_t>& streams,
                   std::vector<double>& values) {
    EXPECT_EQ(xs.size(), streams.size());
    batch_sizes.push_back(xs.size());
    values.resize(xs.size());
    for (std::size_t k = 0; k < xs.size(); ++k) values[k] = single(xs[k], streams[k]);
  };
  CmaesOptions opt;
  opt.sigma0 = 1.0;
  opt.max_evaluations = 3001;
  opt.uncertainty_handling = true;
  opt.seed = 99;
  const VectorXd lo = VectorXd::Constant(6, -5.0), hi = VectorXd::Constant(6, 5.0);
  const auto a = cmaes_minimize(single, VectorXd::Constant(6, 1.0), lo, hi, opt);
  const auto b = drops::opt::cmaes_minimize_batch(batch, VectorXd::Constant(6, 1.0), lo, hi, opt);
  EXPECT_TRUE(BitEqual(a.best_x, b.best_x));
  EXPECT_TRUE(BitEqual(a.best_value, b.best_value));
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.generations, b.generations);
  EXPECT_EQ(a.run_stop_reasons, b.run_stop_reasons);
  long total = 0;
  for (std::size_t sz : batch_sizes) total += static_cast<long>(sz);
  EXPECT_EQ(total, b.evaluations);
  // Default lambda for n = 6 is 9: batches of 9 candidates and 1 re-evaluation (UH).
  EXPECT_EQ(batch_sizes[0], 9u);
  EXPECT_EQ(batch_sizes[1], 1u);

  auto wrong = [](const std::vector<VectorXd>& xs, const std::vector<std::uint64_t>&,
                  std::vector<double>& values) { values.assign(xs.size() + 1, 0.0); };
  EXPECT_THROW(drops::opt::cmaes_minimize_batch(wrong, VectorXd::Zero(6), lo, hi, opt),
               drops::InvalidArgument);
  EXPECT_THROW(drops::opt::cmaes_minimize_batch(nullptr, VectorXd::Zero(6), lo, hi, opt),
               drops::InvalidArgument);
}

TEST(Cmaes, StreamsAreDistinctPerEvaluation) {
  std::vector<std::uint64_t> streams;
  std::mutex mu;
  CmaesOptions opt;
  opt.max_evaluations = 400;
  opt.uncertainty_handling = true;
  opt.seed = 3;
  const auto s = cmaes_minimize(
      [&](const VectorXd& x, std::uint64_t stream) {
        std::lock_guard<std::mutex> lock(mu);
        streams.push_back(stream);
        return Sphere(x);
      },
      VectorXd::Ones(4), Unbounded(4, -1), Unbounded(4, 1), opt);
  EXPECT_EQ(static_cast<long>(streams.size()), s.evaluations);
  std::sort(streams.begin(), streams.end());
  EXPECT_EQ(std::adjacent_find(streams.begin(), streams.end()), streams.end());
  // The first candidate of the first generation of the first run has the documented stream.
  EXPECT_TRUE(std::binary_search(streams.begin(), streams.end(), drops::derive_seed(3, {0, 0, 0})));
}

TEST(Cmaes, BestNeverWorsensAndCallbackStops) {
  std::vector<CmaesProgress> log;
  CmaesOptions opt;
  opt.sigma0 = 2.0;
  opt.max_evaluations = 30000;
  opt.max_restarts = 5;
  auto f = [](const VectorXd& x, std::uint64_t stream) {
    drops::Rng r(stream);
    return Rastrigin(x) + 0.5 * r.normal();  // noisy: per-generation values fluctuate
  };
  const auto s = cmaes_minimize(f, VectorXd::Constant(6, 3.0), VectorXd::Constant(6, -5.0),
                                VectorXd::Constant(6, 5.0), opt, [&](const CmaesProgress& p) {
                                  log.push_back(p);
                                  return true;
                                });
  ASSERT_GT(log.size(), 10u);
  for (std::size_t i = 1; i < log.size(); ++i) {
    EXPECT_LE(log[i].best_value, log[i - 1].best_value) << "generation " << i;
    EXPECT_GE(log[i].evaluations, log[i - 1].evaluations);
    EXPECT_EQ(log[i].generation, log[i - 1].generation + 1);
  }
  EXPECT_EQ(s.best_value, log.back().best_value);
  EXPECT_EQ(static_cast<int>(log.size()), s.generations);

  // Stop after 5 generations.
  int calls = 0;
  const auto t = cmaes_minimize(f, VectorXd::Constant(6, 3.0), VectorXd::Constant(6, -5.0),
                                VectorXd::Constant(6, 5.0), opt, [&](const CmaesProgress& p) {
                                  ++calls;
                                  return p.generation < 5;
                                });
  EXPECT_EQ(t.termination, CmaesTermination::kCallback);
  EXPECT_EQ(calls, 5);
  EXPECT_EQ(t.generations, 5);
  EXPECT_EQ(t.evaluations, 5 * (4 + static_cast<long>(std::floor(3 * std::log(6.0)))));
  ASSERT_EQ(t.run_stop_reasons.size(), 1u);
  EXPECT_EQ(t.run_stop_reasons[0], "Callback");
  EXPECT_NE(t.BriefReport().find("(Callback)"), std::string::npos) << t.BriefReport();
}

TEST(Cmaes, ElitismKeepsBestInPopulationUnderNoise) {
  // With elitism the runs should not end worse than without it on a smooth problem; mainly checks
  // that the re-injection keeps the update consistent (no divergence, still converges).
  CmaesOptions opt;
  opt.sigma0 = 0.5;
  opt.max_evaluations = 20000;
  opt.max_restarts = 0;
  for (bool elitism : {true, false}) {
    opt.elitism = elitism;
    const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rosenbrock(x); },
                                  VectorXd::Zero(5), Unbounded(5, -1), Unbounded(5, 1), opt);
    EXPECT_LE(s.best_value, 1e-8) << "elitism=" << elitism << " " << s.BriefReport();
  }
}

TEST(Cmaes, UncertaintyHandlingOnNoisySphere) {
  CmaesOptions opt;
  opt.sigma0 = 1.0;
  opt.max_evaluations = 5000;
  opt.uncertainty_handling = true;
  std::atomic<long> calls{0};
  std::vector<double> sigmas;
  auto f = [&](const VectorXd& x, std::uint64_t stream) {
    ++calls;
    drops::Rng r(stream);
    return Sphere(x) + 0.01 * r.normal();
  };
  const auto s = cmaes_minimize(f, VectorXd::Constant(5, 2.0), Unbounded(5, -1), Unbounded(5, 1),
                                opt, [&](const CmaesProgress& p) {
                                  sigmas.push_back(p.sigma);
                                  return true;
                                });
  EXPECT_EQ(calls.load(), s.evaluations);
  EXPECT_LE(s.evaluations, 5000);
  EXPECT_LT(Sphere(s.best_x), 0.05) << s.best_x.transpose();
  // The noise floor keeps sigma from collapsing to 0 (UH raises it when ranks are noise).
  EXPECT_GT(sigmas.back(), 1e-6);
}

// evaluate_start: on a deterministic objective the returned point is never worse than the start,
// however small the budget; the start is the first evaluation (its own stream) and counted.
TEST(Cmaes, EvaluatedStartIsNeverBeatenByAWorsePoint) {
  const int n = 8;
  int returned_start = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    CmaesOptions opt;
    opt.sigma0 = 2.0;  // wide samples around a good start: most are worse
    opt.max_evaluations = 25;
    opt.evaluate_start = true;
    opt.seed = seed;
    const VectorXd x0 = VectorXd::Constant(n, 0.05);
    std::vector<std::uint64_t> streams;
    std::mutex mu;
    const auto s = cmaes_minimize(
        [&](const VectorXd& x, std::uint64_t stream) {
          std::lock_guard<std::mutex> lock(mu);
          streams.push_back(stream);
          return Rastrigin(x);
        },
        x0, VectorXd::Constant(n, -5.0), VectorXd::Constant(n, 5.0), opt);
    EXPECT_LE(s.best_value, Rastrigin(x0)) << "seed " << seed;
    EXPECT_EQ(s.start_value, Rastrigin(x0));
    EXPECT_EQ(s.evaluations, 25);
    ASSERT_FALSE(streams.empty());
    EXPECT_EQ(streams.front(), drops::derive_seed(seed, {drops::opt::kCmaesStartStream}));
    if (BitEqual(s.best_x, x0)) ++returned_start;
    ASSERT_FALSE(s.best_candidates.empty());
    EXPECT_TRUE(BitEqual(s.best_candidates.front().x, s.best_x));
  }
  EXPECT_GT(returned_start, 10);  // the start was the best point in most searches
  // Without it the same searches return the best sample, worse than the start.
  CmaesOptions opt;
  opt.sigma0 = 2.0;
  opt.max_evaluations = 25;
  const VectorXd x0 = VectorXd::Constant(n, 0.05);
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rastrigin(x); }, x0,
                                VectorXd::Constant(n, -5.0), VectorXd::Constant(n, 5.0), opt);
  EXPECT_GT(s.best_value, Rastrigin(x0));
  EXPECT_TRUE(std::isnan(s.start_value));
}

// Restarts happen when the runs' stopping criteria are on the scale of the objective: Rastrigin's
// local minima are converged to within tol_fun long before the budget.
TEST(Cmaes, RestartsHappenOnRastriginWithATolFunOnTheObjectivesScale) {
  const int n = 10;
  CmaesOptions opt;
  opt.sigma0 = 2.0;
  opt.max_evaluations = 30000;
  opt.max_restarts = 3;
  opt.tol_fun = opt.tol_hist_fun = 1e-2;
  const auto s = cmaes_minimize([](const VectorXd& x, std::uint64_t) { return Rastrigin(x); },
                                VectorXd::Constant(n, 3.0), VectorXd::Constant(n, -5.0),
                                VectorXd::Constant(n, 5.0), opt);
  ASSERT_GE(s.restarts, 3) << s.BriefReport();
  ASSERT_EQ(s.runs.size(), s.run_stop_reasons.size());
  long total = 0;
  for (std::size_t r = 0; r < s.runs.size(); ++r) {
    const auto& run = s.runs[r];
    EXPECT_EQ(run.stop_reason, s.run_stop_reasons[r]);
    EXPECT_NE(run.stop_reason, "MaxFunEvals") << "run " << r;
    EXPECT_EQ(run.final_mean.size(), n);
    EXPECT_LE(run.final_mean.cwiseAbs().maxCoeff(), 5.0);
    EXPECT_GE(run.best_value, s.best_value);
    total += run.evaluations;
  }
  EXPECT_EQ(total, s.evaluations);
  // With the tutorial's 1e-12 the first run alone would have spent more.
  EXPECT_LT(s.runs[0].evaluations, 10000);
}

// On a noisy objective the tolerances never fire; the per-run budget and Stagnation end the runs,
// restarts begin from the start (small runs) or from random points (large runs) under kMixed.
TEST(Cmaes, PerRunBudgetAndStagnationRestartANoisySearch) {
  const int n = 6;
  auto noisy = [](const VectorXd& x, std::uint64_t stream) {
    drops::Rng r(stream);
    return Sphere(x) + 0.5 * r.normal();
  };
  CmaesOptions opt;
  opt.sigma0 = 1.0;
  opt.max_evaluations = 12000;
  opt.max_run_evaluations = 3000;
  opt.max_restarts = 2;
  opt.restart_start = drops::opt::CmaesRestartStart::kMixed;
  opt.seed = 3;
  const VectorXd x0 = VectorXd::Constant(n, 1.0);
  const auto s = cmaes_minimize(noisy, x0, VectorXd::Constant(n, -4.0), VectorXd::Constant(n, 4.0),
                                opt);
  ASSERT_GE(s.runs.size(), 3u) << s.BriefReport();
  bool stagnation = false, run_budget = false, small_from_start = false, large_from_random = false;
  for (std::size_t r = 0; r < s.runs.size(); ++r) {
    const auto& run = s.runs[r];
    EXPECT_LE(run.evaluations, 3000) << "run " << r;
    stagnation |= run.stop_reason == "Stagnation";
    run_budget |= run.stop_reason == "MaxRunEvals" || run.stop_reason == "RunBudget";
    if (r > 0 && run.small) small_from_start |= run.from_start;
    if (r > 0 && !run.small) large_from_random |= !run.from_start;
    if (r > 0) EXPECT_EQ(run.from_start, run.small) << "run " << r;
  }
  EXPECT_TRUE(stagnation) << s.BriefReport();
  EXPECT_TRUE(run_budget) << s.BriefReport();
  EXPECT_TRUE(small_from_start);
  EXPECT_TRUE(large_from_random);
}

TEST(Cmaes, KeepBestListsTheBestDistinctPointsInOrder) {
  CmaesOptions opt;
  opt.sigma0 = 0.5;
  opt.max_evaluations = 300;
  opt.keep_best = 7;
  std::vector<std::pair<double, VectorXd>> all;
  std::mutex mu;
  const auto s = cmaes_minimize(
      [&](const VectorXd& x, std::uint64_t) {
        std::lock_guard<std::mutex> lock(mu);
        all.emplace_back(Sphere(x), x);
        return Sphere(x);
      },
      VectorXd::Constant(4, 1.0), Unbounded(4, -1), Unbounded(4, 1), opt);
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  ASSERT_EQ(s.best_candidates.size(), 7u);
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(s.best_candidates[k].value, all[k].first) << k;
    EXPECT_TRUE(BitEqual(s.best_candidates[k].x, all[k].second)) << k;
  }
}

TEST(Cmaes, NonFiniteValuesAreWorst) {
  CmaesOptions opt;
  opt.sigma0 = 0.5;
  opt.max_evaluations = 5000;
  opt.max_restarts = 0;
  auto f = [](const VectorXd& x, std::uint64_t) {
    if (x(0) < 0.5) return std::numeric_limits<double>::quiet_NaN();
    return Sphere(x);
  };
  const auto s = cmaes_minimize(f, VectorXd::Ones(3), Unbounded(3, -1), Unbounded(3, 1), opt);
  EXPECT_TRUE(std::isfinite(s.best_value));
  EXPECT_NEAR(s.best_x(0), 0.5, 1e-3);
  EXPECT_NEAR(s.best_value, 0.25, 1e-3);
}

TEST(Cmaes, BudgetIsExact) {
  CmaesOptions opt;
  opt.max_evaluations = 1003;  // not a multiple of lambda
  opt.max_restarts = 100;
  opt.tol_fun = 0;
  opt.tol_hist_fun = 0;
  long calls = 0;
  opt.parallel = false;
  const auto s = cmaes_minimize(
      [&](const VectorXd& x, std::uint64_t) {
        ++calls;
        return Rastrigin(x);
      },
      VectorXd::Constant(3, 1.0), VectorXd::Constant(3, -5.0), VectorXd::Constant(3, 5.0), opt);
  EXPECT_EQ(s.evaluations, 1003);
  EXPECT_EQ(calls, 1003);
  EXPECT_EQ(s.termination, CmaesTermination::kMaxEvaluations);
  EXPECT_NE(s.BriefReport().find("after 1003 evaluations"), std::string::npos) << s.BriefReport();
}

TEST(Cmaes, InvalidArgumentsThrow) {
  auto f = [](const VectorXd& x, std::uint64_t) { return Sphere(x); };
  const VectorXd lo = VectorXd::Constant(10, -5.0), hi = VectorXd::Constant(10, 5.0);
  auto message = [&](const VectorXd& x0, const VectorXd& l, const VectorXd& h,
                     const CmaesOptions& o) -> std::string {
    try {
      cmaes_minimize(f, x0, l, h, o);
    } catch (const drops::InvalidArgument& e) {
      return e.what();
    }
    return "no throw";
  };
  EXPECT_EQ(message(VectorXd::Zero(9), lo, hi, {}), "x0: expected size 10, got 9");
  EXPECT_EQ(message(VectorXd::Zero(10), lo, VectorXd::Constant(11, 5.0), {}),
            "upper: expected size 10, got 11");
  VectorXd bad = VectorXd::Zero(10);
  bad(3) = 7.0;
  EXPECT_EQ(message(bad, lo, hi, {}), "x0[3] = 7 is outside [lower, upper] = [-5, 5]");
  bad(3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(bad, lo, hi, {}).find("x0[3]"), std::string::npos);
  VectorXd lo2 = lo;
  lo2(2) = 5.0;
  EXPECT_NE(message(VectorXd::Zero(10), lo2, hi, {}).find("bounds[2]"), std::string::npos);
  EXPECT_NE(message(VectorXd(), VectorXd(), VectorXd(), {}), "no throw");

  std::string why;
  CmaesOptions o;
  EXPECT_TRUE(o.IsValid(&why));
  const auto invalid = [&](auto mutate, const char* field) {
    CmaesOptions b;
    mutate(b);
    EXPECT_FALSE(b.IsValid(&why)) << field;
    EXPECT_NE(why.find(field), std::string::npos) << why;
    const std::string m = message(VectorXd::Zero(10), lo, hi, b);
    EXPECT_NE(m.find(field), std::string::npos) << m;
  };
  invalid([](CmaesOptions& b) { b.sigma0 = -1; }, "sigma0");
  invalid([](CmaesOptions& b) { b.sigma0 = std::nan(""); }, "sigma0");
  invalid([](CmaesOptions& b) { b.lambda = 1; }, "lambda");
  invalid([](CmaesOptions& b) { b.max_evaluations = 0; }, "max_evaluations");
  invalid([](CmaesOptions& b) { b.max_restarts = -1; }, "max_restarts");
  invalid([](CmaesOptions& b) { b.tol_x = -1; }, "tol_x");
  invalid([](CmaesOptions& b) { b.max_condition = 0.5; }, "max_condition");
  EXPECT_THROW(cmaes_minimize(nullptr, VectorXd::Zero(10), lo, hi), drops::InvalidArgument);
}

}  // namespace
