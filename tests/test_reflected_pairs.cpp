// gp::reflected_pairs_log_likelihood and gp::fit_reflected_pairs against the oracle they replace:
// an exact Gp on all 2N points (the N inputs and their reflections, targets y and sign * y).
#include <gtest/gtest.h>

#include <Eigen/Core>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/gp/reflected_pairs.hpp"

using namespace drops;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

struct Pairs {
  MatrixXd X, X2;
  VectorXd flip, y, y2;
};

/// N inputs in D dimensions, flips alternating, targets a smooth function made even or odd
/// under the reflection by `sign`, plus noise.
Pairs make_pairs(int N, int D, double sign, std::uint64_t seed) {
  Rng rng(seed);
  Pairs p;
  p.X.resize(N, D);
  for (int i = 0; i < N; ++i)
    for (int d = 0; d < D; ++d) p.X(i, d) = rng.uniform(-2, 2);
  p.flip.resize(D);
  for (int d = 0; d < D; ++d) p.flip[d] = d % 2 == 0 ? -1.0 : 1.0;
  p.y.resize(N);
  for (int i = 0; i < N; ++i) {
    const VectorXd x = p.X.row(i).transpose();
    const VectorXd r = x.cwiseProduct(p.flip);
    const double f = std::sin(x[0]) + 0.5 * x[1] * x[0] + 0.3 * std::cos(x[D - 1]);
    const double fr = std::sin(r[0]) + 0.5 * r[1] * r[0] + 0.3 * std::cos(r[D - 1]);
    p.y[i] = 0.5 * (f + sign * fr) + 0.05 * rng.uniform(-1, 1);
  }
  p.X2.resize(2 * N, D);
  p.X2 << p.X, p.X * p.flip.asDiagonal();
  p.y2.resize(2 * N);
  p.y2 << p.y, sign * p.y;
  return p;
}

}  // namespace

TEST(ReflectedPairs, LikelihoodAndGradientAreThoseOfTheGpOnAllPoints) {
  for (double sign : {1.0, -1.0}) {
    const Pairs p = make_pairs(40, 4, sign, 3);
    gp::Gp g(4);
    VectorXd h(6);
    h << 0.3, -0.2, 0.5, 0.1, -0.4, std::log(0.1);
    g.set_h_params(h);
    g.compute(p.X2, p.y2);
    VectorXd grad;
    const double ll = gp::reflected_pairs_log_likelihood(h, p.X, p.flip, p.y, sign, &grad);
    EXPECT_NEAR(ll, g.log_marginal_likelihood(), 1e-9 * (1 + std::abs(ll))) << sign;
    const VectorXd want = g.log_marginal_likelihood_gradient();
    EXPECT_LT((grad - want).cwiseAbs().maxCoeff(), 1e-8 * (1 + want.cwiseAbs().maxCoeff()))
        << sign << "\n" << grad.transpose() << "\n" << want.transpose();
    // Without the gradient, the same value.
    EXPECT_EQ(gp::reflected_pairs_log_likelihood(h, p.X, p.flip, p.y, sign), ll);
  }
}

TEST(ReflectedPairs, TheFitFindsTheKernelsOfTheFitOnAllPoints) {
  for (double sign : {1.0, -1.0}) {
    const Pairs p = make_pairs(60, 3, sign, 11);
    gp::RpropOptions o;
    o.max_iterations = 150;
    gp::Gp g(3);
    g.compute(p.X2, p.y2);
    const gp::RpropSummary want = g.optimize_h_params(o);
    VectorXd h = gp::Gp(3).h_params();
    const gp::RpropSummary got = gp::fit_reflected_pairs(h, p.X, p.flip, p.y, sign, o);
    EXPECT_NEAR(got.final_log_likelihood, want.final_log_likelihood,
                1e-6 * (1 + std::abs(want.final_log_likelihood)));
    EXPECT_GT(got.final_log_likelihood, got.initial_log_likelihood + 1);  // it did fit
    EXPECT_LT((h - g.h_params()).cwiseAbs().maxCoeff(), 1e-4)
        << h.transpose() << "\n" << g.h_params().transpose();
  }
}

TEST(ReflectedPairs, BadInputIsRefused) {
  const Pairs p = make_pairs(5, 2, 1.0, 1);
  const VectorXd h = VectorXd::Zero(4);
  EXPECT_THROW(gp::reflected_pairs_log_likelihood(h, p.X, p.flip, p.y, 0.5), InvalidArgument);
  EXPECT_THROW(gp::reflected_pairs_log_likelihood(h, p.X, VectorXd::Constant(2, 0.5), p.y, 1),
               InvalidArgument);
  EXPECT_THROW(gp::reflected_pairs_log_likelihood(VectorXd::Zero(3), p.X, p.flip, p.y, 1),
               InvalidArgument);
  EXPECT_THROW(gp::reflected_pairs_log_likelihood(h, p.X, p.flip, VectorXd::Zero(4), 1),
               InvalidArgument);
}
