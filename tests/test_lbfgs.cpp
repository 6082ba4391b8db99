// L-BFGS (opt::lbfgs_minimize) on problems with known minima, its stopping rules, and the
// objective's exceptions reaching the caller with their message; opt::check_gradient.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "drops/core/errors.hpp"
#include "drops/opt/lbfgs.hpp"
#include "drops/opt/objective.hpp"

namespace {

using drops::opt::LbfgsOptions;
using drops::opt::LbfgsTermination;
using Eigen::VectorXd;

/// The n-dimensional Rosenbrock function sum_i 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2: minimum 0 at
/// x = (1, ..., 1).
double rosenbrock(const VectorXd& x, VectorXd* g) {
  const Eigen::Index n = x.size();
  double f = 0;
  if (g) g->setZero(n);
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    const double a = x[i + 1] - x[i] * x[i], b = 1 - x[i];
    f += 100 * a * a + b * b;
    if (g) {
      (*g)[i] += -400 * a * x[i] - 2 * b;
      (*g)[i + 1] += 200 * a;
    }
  }
  return f;
}

}  // namespace

TEST(Lbfgs, FindsTheMinimumOfRosenbrockFromTheClassicStart) {
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  LbfgsOptions o;
  o.max_evaluations = 500;
  const auto s = drops::opt::lbfgs_minimize(rosenbrock, x0, o);
  EXPECT_NEAR(s.x[0], 1.0, 1e-5);
  EXPECT_NEAR(s.x[1], 1.0, 1e-5);
  EXPECT_LT(s.value, 1e-10);
  EXPECT_NEAR(s.initial_value, 24.2, 1e-12);
  EXPECT_LE(s.evaluations, 500);
  EXPECT_NE(s.termination, LbfgsTermination::kMaxEvaluations) << s.BriefReport();
}

TEST(Lbfgs, FindsTheMinimumOfA20DimensionalRosenbrock) {
  const VectorXd x0 = VectorXd::Constant(20, -0.5);
  LbfgsOptions o;
  o.max_evaluations = 2000;
  const auto s = drops::opt::lbfgs_minimize(rosenbrock, x0, o);
  EXPECT_LT((s.x - VectorXd::Ones(20)).cwiseAbs().maxCoeff(), 1e-4) << s.BriefReport();
}

TEST(Lbfgs, SolvesAnIllConditionedQuadraticToItsClosedFormMinimum) {
  // f = 1/2 x^T A x - b^T x, minimum at A^-1 b; condition number 1e4.
  const int n = 8;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) A(i, i) = std::pow(10.0, 4.0 * i / (n - 1));
  A(0, 1) = A(1, 0) = 0.5;
  VectorXd b = VectorXd::LinSpaced(n, -1, 1);
  auto f = [&](const VectorXd& x, VectorXd* g) {
    if (g) *g = A * x - b;
    return 0.5 * x.dot(A * x) - b.dot(x);
  };
  LbfgsOptions o;
  o.max_evaluations = 1000;
  const auto s = drops::opt::lbfgs_minimize(f, VectorXd::Zero(n), o);
  const VectorXd xs = A.ldlt().solve(b);
  EXPECT_LT((s.x - xs).cwiseAbs().maxCoeff(), 1e-6) << s.BriefReport();
}

TEST(Lbfgs, RespectsBoxBoundsAndStopsOnTheActiveBound) {
  // Rosenbrock restricted to x_1 <= 0.5: the constrained minimum is at (0.5, 0.25).
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  LbfgsOptions o;
  o.max_evaluations = 1000;
  o.lower = VectorXd::Constant(2, -2.0);
  o.upper = VectorXd::Constant(2, 2.0);
  o.upper[0] = 0.5;
  const auto s = drops::opt::lbfgs_minimize(rosenbrock, x0, o);
  EXPECT_NEAR(s.x[0], 0.5, 1e-6);
  EXPECT_NEAR(s.x[1], 0.25, 1e-4);
}

TEST(Lbfgs, AnExceptionOfTheObjectiveReachesTheCallerWithItsTypeAndMessage) {
  int calls = 0;
  auto f = [&](const VectorXd& x, VectorXd* g) {
    if (++calls == 4) throw drops::NumericalError("Cholesky failed at evaluation 4");
    return rosenbrock(x, g);
  };
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  try {
    drops::opt::lbfgs_minimize(f, x0);
    FAIL() << "no exception";
  } catch (const drops::NumericalError& e) {
    EXPECT_STREQ(e.what(), "Cholesky failed at evaluation 4");
  }
  EXPECT_EQ(calls, 4);  // the search stopped at the failing evaluation
  // Any exception type, not only drops's.
  auto g = [](const VectorXd&, VectorXd*) -> double { throw std::logic_error("not drops's"); };
  EXPECT_THROW(drops::opt::lbfgs_minimize(g, x0), std::logic_error);
}

TEST(Lbfgs, StopsAtTheBudgetOrWhenTheCallbackSaysSoAndReturnsTheBestPoint) {
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  LbfgsOptions o;
  o.max_evaluations = 7;
  double lowest = INFINITY;
  auto f = [&](const VectorXd& x, VectorXd* g) {
    const double v = rosenbrock(x, g);
    lowest = std::min(lowest, v);
    return v;
  };
  const auto s = drops::opt::lbfgs_minimize(f, x0, o);
  EXPECT_EQ(s.evaluations, 7);
  EXPECT_EQ(s.termination, LbfgsTermination::kMaxEvaluations);
  EXPECT_EQ(s.value, lowest);
  EXPECT_EQ(rosenbrock(s.x, nullptr), s.value);

  o.max_evaluations = 100;
  const auto t = drops::opt::lbfgs_minimize(
      rosenbrock, x0, o, [](const drops::opt::LbfgsProgress& p) { return p.evaluations < 3; });
  EXPECT_EQ(t.evaluations, 3);
  EXPECT_EQ(t.termination, LbfgsTermination::kStopped);
}

TEST(Lbfgs, ANonFiniteValueStopsTheSearchAtTheBestFinitePoint) {
  int calls = 0;
  auto f = [&](const VectorXd& x, VectorXd* g) {
    const double v = rosenbrock(x, g);
    return ++calls >= 5 ? NAN : v;
  };
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  const auto s = drops::opt::lbfgs_minimize(f, x0);
  EXPECT_EQ(s.termination, LbfgsTermination::kNonFinite);
  EXPECT_EQ(s.evaluations, 5);
  EXPECT_TRUE(std::isfinite(s.value));
  EXPECT_LE(s.value, s.initial_value);
}

TEST(Lbfgs, RejectsInvalidOptionsAndStartsWithAMessage) {
  VectorXd x0(2);
  x0 << 0, 0;
  LbfgsOptions o;
  o.max_evaluations = 0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_evaluations"), std::string::npos);
  EXPECT_THROW(drops::opt::lbfgs_minimize(rosenbrock, x0, o), drops::InvalidArgument);
  o = {};
  o.lower = VectorXd::Constant(2, 1.0);
  o.upper = VectorXd::Constant(2, 2.0);
  EXPECT_THROW(drops::opt::lbfgs_minimize(rosenbrock, x0, o), drops::InvalidArgument);  // outside
  EXPECT_THROW(drops::opt::lbfgs_minimize(rosenbrock, VectorXd(0), {}), drops::InvalidArgument);
  x0[1] = NAN;
  EXPECT_THROW(drops::opt::lbfgs_minimize(rosenbrock, x0, {}), drops::InvalidArgument);
  auto wrong = [](const VectorXd&, VectorXd* g) {
    if (g) g->setZero(3);
    return 0.0;
  };
  try {
    drops::opt::lbfgs_minimize(wrong, VectorXd::Zero(2));
    FAIL();
  } catch (const drops::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("expected size 2, got 3"), std::string::npos) << e.what();
  }
}

TEST(CheckGradient, AcceptsRosenbrocksGradientAndCatchesAWrongOne) {
  VectorXd x(5);
  x << -1.2, 1.0, 0.3, -0.7, 2.0;
  const auto c = drops::opt::check_gradient(rosenbrock, x);
  EXPECT_LT(c.relative_error, 1e-7);
  auto wrong = [](const VectorXd& y, VectorXd* g) {
    const double v = rosenbrock(y, g);
    if (g) (*g)[3] *= 1.01;
    return v;
  };
  const auto w = drops::opt::check_gradient(wrong, x);
  EXPECT_GT(w.relative_error, 1e-4);
  EXPECT_EQ(w.worst, 3);
}

TEST(Lbfgs, RestartsFromTheBestPointAfterAFailedLineSearch) {
  // Rosenbrock whose gradient is reversed for four evaluations (3 to 6): the quasi-Newton
  // memory then holds wrong curvature and a line search fails (measured: stops at f = 8.39 after
  // 25 evaluations). A restart from the best point with a cleared memory reaches the minimum
  // (measured: f < 1e-24 after 75 evaluations, 1 restart).
  int calls = 0;
  auto f = [&](const VectorXd& x, VectorXd* g) {
    ++calls;
    const double v = rosenbrock(x, g);
    if (g && calls >= 3 && calls < 7) *g = -*g;
    return v;
  };
  VectorXd x0(2);
  x0 << -1.2, 1.0;
  LbfgsOptions o;
  o.max_evaluations = 500;
  const auto once = drops::opt::lbfgs_minimize(f, x0, o);
  EXPECT_EQ(once.termination, LbfgsTermination::kFailure) << once.BriefReport();
  EXPECT_GT(once.value, 1.0);
  calls = 0;
  o.max_restarts = 5;
  const auto again = drops::opt::lbfgs_minimize(f, x0, o);
  EXPECT_EQ(again.restarts, 1) << again.BriefReport();
  EXPECT_LT(again.value, 1e-10);
  EXPECT_NEAR(again.x[0], 1.0, 1e-5);
}

TEST(Lbfgs, ARestartThatDoesNotImproveEndsTheSearch) {
  // A kink at the minimum (x_0 = 1 of |x - 0.5|^2 + 10 |x_0 - 1|): every line search near it
  // fails; one restart is tried, it does not improve, and the search ends (no loop).
  auto f = [](const VectorXd& x, VectorXd* g) {
    double v = (x.array() - 0.5).square().sum() + 10 * std::abs(x[0] - 1);
    if (g) {
      *g = 2 * (x.array() - 0.5).matrix();
      (*g)[0] += x[0] > 1 ? 10 : -10;
    }
    return v;
  };
  LbfgsOptions o;
  o.max_evaluations = 2000;
  o.max_restarts = 50;
  const auto s = drops::opt::lbfgs_minimize(f, VectorXd::LinSpaced(5, -2, 3), o);
  EXPECT_LE(s.restarts, 1) << s.BriefReport();
  EXPECT_LT(s.evaluations, 2000);
  EXPECT_NEAR(s.value, 0.25, 1e-6);  // f(1, 0.5, 0.5, 0.5, 0.5), the minimum at the kink
}

TEST(Lbfgs, ScalingTheFirstStepFindsTheNarrowValleyOfASaturatingCost) {
  // sum_i 1 - exp(-(x_i - 1)^2 / w^2), w = 1e-3, from x_i = 1 + w / 2 (|g| ~ 1.7e3, like PILCO's
  // J on the pendubot): NLopt's first trial step -g lands on the flat part, 10 reductions do not
  // come back to the valley and the search fails at the start (measured: f stays 1.106 after 12
  // evaluations). With the first step of minimize.m, it converges (measured: 6 evaluations).
  const double w = 1e-3;
  auto f = [&](const VectorXd& x, VectorXd* g) {
    double v = 0;
    if (g) g->resize(x.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double d = x[i] - 1, e = std::exp(-d * d / (w * w));
      v += 1 - e;
      if (g) (*g)[i] = 2 * d / (w * w) * e;
    }
    return v;
  };
  const VectorXd x0 = VectorXd::Constant(5, 1 + 0.5 * w);
  LbfgsOptions o;
  o.max_evaluations = 200;
  const auto plain = drops::opt::lbfgs_minimize(f, x0, o);
  EXPECT_EQ(plain.termination, LbfgsTermination::kFailure) << plain.BriefReport();
  EXPECT_EQ(plain.value, plain.initial_value);
  o.scale_first_step = true;
  const auto scaled = drops::opt::lbfgs_minimize(f, x0, o);
  EXPECT_LT(scaled.value, 1e-12) << scaled.BriefReport();
  EXPECT_LT((scaled.x.array() - 1).abs().maxCoeff(), 1e-6);
  // The values and gradients reported are f's, not the scaled ones.
  EXPECT_NEAR(scaled.initial_value, plain.initial_value, 1e-15);
  // The start is evaluated once for the scale and not again by NLopt.
  int calls = 0;
  auto counted = [&](const VectorXd& x, VectorXd* g) {
    ++calls;
    return f(x, g);
  };
  const auto c = drops::opt::lbfgs_minimize(counted, x0, o);
  EXPECT_EQ(calls, c.evaluations);
}
