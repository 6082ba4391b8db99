// Tests of drops::pilco's sine-sum moments (gTrig sin/cos augmentation, gSat squashing) and the
// saturating cost: against Monte Carlo (5 SE over 4e5 samples), against the closed forms of
// baselines.md §1a, and derivatives against central differences (step 1e-5, 1e-6 relative).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/pilco/cost.hpp"
#include "drops/pilco/trig.hpp"
#include "pilco_test_util.hpp"

namespace {

using drops::Rng;
using drops::pilco::Moments;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace pilco_test;

constexpr int kSamples = 400000;

// A p x p matrix as a 1 x p^2 row (column-major), like a Jacobian row.
MatrixXd detail_row(const MatrixXd& m) {
  return Eigen::Map<const Eigen::RowVectorXd>(m.data(), m.size());
}

VectorXd Vec(std::initializer_list<double> v) {
  VectorXd r(v.size());
  int k = 0;
  for (double x : v) r[k++] = x;
  return r;
}

// x = [v, theta1, theta2]: two correlated angles with large spread and a non-angle entry.
struct TrigProblem {
  VectorXd mu = Vec({0.3, 2.5, -1.0});
  MatrixXd sigma;
  TrigProblem() {
    Rng rng(31);
    sigma = RandomCovariance(rng, 3, 0.5, 0.9);
  }
};

TEST(PilcoTrig, MomentsMatchMonteCarlo) {
  const TrigProblem p;
  const Moments m = drops::pilco::trig_moments({1, 2}, p.mu, p.sigma);
  Rng rng(32);
  const MatrixXd X = SampleGaussian(rng, p.mu, p.sigma, kSamples);
  MatrixXd Y(kSamples, 4);
  Y.col(0) = X.col(1).array().sin();
  Y.col(1) = X.col(1).array().cos();
  Y.col(2) = X.col(2).array().sin();
  Y.col(3) = X.col(2).array().cos();
  const McStats mc = MonteCarloStats(X, Y);
  ExpectWithinSe("trig mean", m.mean, mc.mean, mc.mean_se, 5.0);
  ExpectWithinSe("trig cov", m.cov, mc.cov, mc.cov_se, 5.0);
  ExpectWithinSe("trig Sigma * cross", p.sigma * m.cross, mc.cross, mc.cross_se, 5.0);
}

TEST(PilcoTrig, ClosedForms) {
  const TrigProblem p;
  const Moments m = drops::pilco::trig_moments({1, 2}, p.mu, p.sigma);
  for (int k = 0; k < 2; ++k) {
    const double mk = p.mu[1 + k], v = p.sigma(1 + k, 1 + k);
    EXPECT_NEAR(m.mean[2 * k], std::exp(-v / 2) * std::sin(mk), 1e-14);
    EXPECT_NEAR(m.mean[2 * k + 1], std::exp(-v / 2) * std::cos(mk), 1e-14);
    EXPECT_NEAR(m.cov(2 * k, 2 * k),
                0.5 * (1 - std::exp(-2 * v) * std::cos(2 * mk)) -
                    std::exp(-v) * std::sin(mk) * std::sin(mk),
                1e-14);
    // cross: E[cos] at (theta, sin theta), -E[sin] at (theta, cos theta), zero elsewhere.
    EXPECT_NEAR(m.cross(1 + k, 2 * k), std::exp(-v / 2) * std::cos(mk), 1e-14);
    EXPECT_NEAR(m.cross(1 + k, 2 * k + 1), -std::exp(-v / 2) * std::sin(mk), 1e-14);
    EXPECT_EQ(m.cross(2 - k, 2 * k), 0.0);
    EXPECT_EQ(m.cross(0, 2 * k), 0.0);
  }
  // Cross-covariance of two correlated angles (baselines.md §1a, lq = -(v11 + v22) / 2).
  const double v11 = p.sigma(1, 1), v22 = p.sigma(2, 2), v12 = p.sigma(1, 2);
  const double lq = -(v11 + v22) / 2, m1 = p.mu[1], m2 = p.mu[2];
  EXPECT_NEAR(m.cov(0, 3),
              0.5 * ((std::exp(lq + v12) - std::exp(lq)) * std::sin(m1 - m2) +
                     (std::exp(lq - v12) - std::exp(lq)) * std::sin(m1 + m2)),
              1e-14);
  EXPECT_THROW(drops::pilco::trig_moments({3}, p.mu, p.sigma), drops::InvalidArgument);
}

TEST(PilcoTrig, DerivativesMatchFiniteDifferences) {
  const TrigProblem p;
  CheckInputDerivatives(
      "trig",
      [&](const VectorXd& m, const MatrixXd& S, bool d) {
        return drops::pilco::trig_moments({2, 1}, m, S, d);
      },
      p.mu, p.sigma, 1e-5, 1e-6);
}

TEST(PilcoSquash, MomentsMatchMonteCarloAndClosedForms) {
  Rng rng(33);
  const VectorXd mu = Vec({0.4, -1.2});
  const MatrixXd sigma = RandomCovariance(rng, 2, 0.5, 1.0);
  const VectorXd max_u = Vec({3.5, 2.0});
  const Moments m = drops::pilco::squash_moments(max_u, mu, sigma);
  const MatrixXd X = SampleGaussian(rng, mu, sigma, kSamples);
  MatrixXd Y(kSamples, 2);
  for (int i = 0; i < kSamples; ++i)
    for (int k = 0; k < 2; ++k) Y(i, k) = drops::pilco::squash(X(i, k), max_u[k]);
  const McStats mc = MonteCarloStats(X, Y);
  ExpectWithinSe("squash mean", m.mean, mc.mean, mc.mean_se, 5.0);
  ExpectWithinSe("squash cov", m.cov, mc.cov, mc.cov_se, 5.0);
  ExpectWithinSe("squash Sigma * cross", sigma * m.cross, mc.cross, mc.cross_se, 5.0);
  for (int k = 0; k < 2; ++k) {
    const double v = sigma(k, k), mk = mu[k];
    EXPECT_NEAR(
        m.mean[k],
        max_u[k] * (9 * std::exp(-v / 2) * std::sin(mk) + std::exp(-9 * v / 2) * std::sin(3 * mk)) /
            8,
        1e-14);
    // Sigma^-1 cov(x, u) = E[du/dx] (Stein's lemma): a diagonal matrix here.
    EXPECT_NEAR(
        m.cross(k, k),
        max_u[k] *
            (9 * std::exp(-v / 2) * std::cos(mk) + 3 * std::exp(-9 * v / 2) * std::cos(3 * mk)) / 8,
        1e-14);
    EXPECT_EQ(m.cross(1 - k, k), 0.0);
  }
  // The squashing reaches +-max_u at +-pi/2 and never exceeds it.
  EXPECT_NEAR(drops::pilco::squash(std::numbers::pi / 2, 3.5), 3.5, 1e-15);
  for (double x = -7.0; x < 7.0; x += 0.01) EXPECT_LE(std::abs(drops::pilco::squash(x, 3.5)), 3.5);
  EXPECT_THROW(drops::pilco::squash_moments(Vec({-1.0, 1.0}), mu, sigma), drops::InvalidArgument);
}

TEST(PilcoSquash, DerivativesMatchFiniteDifferences) {
  Rng rng(34);
  const VectorXd mu = Vec({0.4, -1.2});
  const MatrixXd sigma = RandomCovariance(rng, 2, 0.5, 1.0);
  CheckInputDerivatives(
      "squash",
      [&](const VectorXd& m, const MatrixXd& S, bool d) {
        return drops::pilco::squash_moments(Vec({3.5, 2.0}), m, S, d);
      },
      mu, sigma, 1e-5, 1e-6);
}

// A saturating cost on 4 dimensions with a rank-2 weight (as the pendubot's tip distance).
drops::pilco::SaturatingCost RandomCost(Rng& rng) {
  const MatrixXd C = RandomMatrix(rng, 2, 4, -1.0, 1.0);
  drops::pilco::SaturatingCost c;
  c.weight = C.transpose() * C / (0.7 * 0.7);
  c.target = RandomVector(rng, 4, -0.5, 0.5);
  return c;
}

TEST(PilcoCost, ExpectationAndVarianceMatchMonteCarlo) {
  Rng rng(35);
  const drops::pilco::SaturatingCost cost = RandomCost(rng);
  const VectorXd mu = RandomVector(rng, 4, -0.5, 0.5);
  const MatrixXd sigma = RandomCovariance(rng, 4, 0.2, 0.6);
  const drops::pilco::CostMoments c = drops::pilco::expected_cost(cost, mu, sigma);
  const MatrixXd X = SampleGaussian(rng, mu, sigma, kSamples);
  VectorXd y(kSamples);
  for (int i = 0; i < kSamples; ++i) y[i] = cost(X.row(i).transpose());
  const McStats mc = MonteCarloStats(X, y);
  ExpectWithinSe("cost mean", VectorXd::Constant(1, c.mean), mc.mean, mc.mean_se, 5.0);
  ExpectWithinSe("cost variance", MatrixXd::Constant(1, 1, c.variance), mc.cov, mc.cov_se, 5.0);
  EXPECT_GT(c.mean, 0.1);  // not a trivial corner of [0, 1)
  EXPECT_LT(c.mean, 0.9);
  // Sigma = 0: c(mu), no variance.
  const drops::pilco::CostMoments z = drops::pilco::expected_cost(cost, mu, MatrixXd::Zero(4, 4));
  EXPECT_NEAR(z.mean, cost(mu), 1e-15);
  EXPECT_EQ(z.variance, 0.0);
}

TEST(PilcoCost, DerivativesMatchFiniteDifferences) {
  Rng rng(36);
  const drops::pilco::SaturatingCost cost = RandomCost(rng);
  const VectorXd mu = RandomVector(rng, 4, -0.5, 0.5);
  const MatrixXd sigma = RandomCovariance(rng, 4, 0.2, 0.6);
  const drops::pilco::CostMoments c = drops::pilco::expected_cost(cost, mu, sigma, true);
  auto value = [&](const VectorXd& m, const MatrixXd& S) {
    return VectorXd::Constant(1, drops::pilco::expected_cost(cost, m, S).mean);
  };
  ExpectJacobian("cost dE/dmu", c.dmean_dmu.transpose(),
                 FdJacobian([&](const VectorXd& m) { return value(m, sigma); }, mu, 1e-5), 1e-6);
  ExpectJacobian("cost dE/dSigma", detail_row(c.dmean_dsigma),
                 FdJacobianSym([&](const MatrixXd& S) { return value(mu, S); }, sigma, 1e-5), 1e-6);
}

}  // namespace
