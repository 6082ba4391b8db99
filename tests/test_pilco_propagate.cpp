// Tests of drops::pilco::propagate (PILCO's one-step propagation), state_cost and ExpectedCost
// (value.m) on a small random problem: x = [v, theta1, theta2] with both angles augmented, an
// 8-centre RBF policy with 2 squashed controls, 3 GPs on 7-D inputs.
//
// Oracles:
// - Stage-wise Monte Carlo: each block's appended moments are checked against 2e5 samples drawn
//   from the Gaussian over the entries that block sees (taken from the step's joint): given
//   Gaussian inputs, every block and the chaining rule Cov[z_j, f(z_i)] = S_ji S_ii^-1
//   Cov[z_i, f(z_i)] are exact, so every entry must be within 5 SE.
// - Particle Monte Carlo of the true next-state distribution: PILCO re-approximates by a Gaussian
//   at each block, so this agrees only approximately (tolerances stated at the test).
// - Fourth-order central differences (step 3e-4 on mu, Sigma; 1e-4 on theta) for the step
//   Jacobians and dJ/dtheta, relative tolerance 1e-6. A whole step evaluates with a round-off of
//   ~1e-12 relative, so second-order differences bottom out at ~1e-7 (h = 1e-5); the fourth-order
//   stencil reaches ~1e-8, and its errors shrink as h^4 for larger h (measured: the derivatives
//   are exact, not merely close).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/pilco/propagate.hpp"
#include "drops/pilco/trig.hpp"
#include "pilco_test_util.hpp"

namespace {

using drops::Rng;
using drops::gp::Gp;
using drops::pilco::PropagationConfig;
using drops::pilco::RbfPolicy;
using drops::pilco::StepDerivatives;
using drops::pilco::StepMoments;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace pilco_test;

constexpr double kPi = std::numbers::pi;
constexpr int kStateCostSamples = 400000;

VectorXd Vec(std::initializer_list<double> v) {
  VectorXd r(v.size());
  int k = 0;
  for (double x : v) r[k++] = x;
  return r;
}

// A p x p matrix as a 1 x p^2 row (column-major), like a Jacobian row.
MatrixXd Row(const MatrixXd& m) { return Eigen::Map<const Eigen::RowVectorXd>(m.data(), m.size()); }

// [v, sin th1, cos th1, sin th2, cos th2] of a state [v, th1, th2].
VectorXd Features(const VectorXd& x) {
  return Vec({x[0], std::sin(x[1]), std::cos(x[1]), std::sin(x[2]), std::cos(x[2])});
}

struct Problem {
  PropagationConfig config;
  std::vector<Gp> gps;
  drops::pilco::SeModel model;
  RbfPolicy policy{5, 8, 2};
  drops::pilco::SaturatingCost cost;
  VectorXd mu;
  MatrixXd sigma;

  Problem() {
    config.state_dim = 3;
    config.angles = {1, 2};
    config.policy_inputs = {0, 3, 4, 5, 6};
    config.dynamics_inputs = {0, 3, 4, 5, 6};
    config.max_u = Vec({1.5, 1.0});
    Rng rng(41);
    // GP data: random states and controls, smooth "dynamics" differences plus noise.
    const int N = 30;
    MatrixXd X(N, 7), Y(N, 3);
    for (int i = 0; i < N; ++i) {
      const VectorXd x = Vec({rng.uniform(-1, 1), rng.uniform(-kPi, kPi), rng.uniform(-kPi, kPi)});
      const VectorXd u = Vec({rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0)});
      X.row(i) << Features(x).transpose(), u.transpose();
      Y(i, 0) = 0.2 * (u[0] - std::sin(x[1])) + 0.02 * rng.normal();
      Y(i, 1) = 0.1 * x[0] + 0.05 * u[1] + 0.02 * rng.normal();
      Y(i, 2) = 0.1 * std::sin(x[2] - x[1]) + 0.05 * u[0] * u[1] + 0.02 * rng.normal();
    }
    for (int a = 0; a < 3; ++a) {
      Gp gp(7);
      VectorXd h(9);
      h.head(7) = RandomVector(rng, 7, std::log(0.8), std::log(2.0));
      h[7] = std::log(rng.uniform(0.1, 0.4));
      h[8] = std::log(0.02);
      gp.set_h_params(h);
      gp.compute(X, Y.col(a));
      gps.push_back(std::move(gp));
    }
    model = drops::pilco::gp_model(gps);
    MatrixXd targets(8, 2);
    for (int i = 0; i < 8; ++i) targets.row(i) << 0.7 * rng.normal(), 0.7 * rng.normal();
    MatrixXd centres(8, 5);
    for (int i = 0; i < 8; ++i) {
      const VectorXd x =
          Vec({rng.uniform(-0.5, 0.5), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)});
      centres.row(i) = Features(x).transpose();
    }
    policy.set(centres, targets, RandomMatrix(rng, 5, 2, std::log(0.7), std::log(1.5)));
    // Cost on the augmented state: a "tip distance" from (sin, cos) of both angles.
    MatrixXd C = MatrixXd::Zero(2, 7);
    C << 0, 0, 0, 0.5, 0, 0.5, 0, 0, 0, 0, 0, 0.5, 0, 0.5;
    cost.weight = C.transpose() * C / (0.5 * 0.5);
    cost.target = Vec({0, 0, 0, 0, 1, 0, 1});
    mu = Vec({0.1, 0.4, -0.6});
    sigma = RandomCovariance(rng, 3, 0.1, 0.3);
  }
};

// MC moments of the block appended at [begin, begin + q) of `joint`, from samples of the Gaussian
// over its first `begin` entries, against the joint's entries (mean, cov, cross-cov with all
// earlier entries). f maps a sample of the first `begin` entries to the block's value; fvar (may
// be empty) to a per-output conditional variance added by the law of total covariance.
void CheckStage(const std::string& what, const StepMoments& s, int begin, int q,
                const std::function<VectorXd(const VectorXd&)>& f,
                const std::function<VectorXd(const VectorXd&)>& fvar, std::uint64_t seed) {
  const int N = 200000;
  Rng rng(seed);
  const MatrixXd Z =
      SampleGaussian(rng, s.joint_mean.head(begin), s.joint_cov.topLeftCorner(begin, begin), N);
  MatrixXd Y(N, q), V = MatrixXd::Zero(N, q);
  for (int i = 0; i < N; ++i) {
    const VectorXd z = Z.row(i).transpose();
    Y.row(i) = f(z).transpose();
    if (fvar) V.row(i) = fvar(z).transpose();
  }
  const McStats mc = MonteCarloStats(Z, Y);
  ExpectWithinSe(what + " mean", s.joint_mean.segment(begin, q), mc.mean, mc.mean_se, 5.0);
  MatrixXd cov = mc.cov, se = mc.cov_se;
  if (fvar) {
    const VectorXd ev = V.colwise().mean().transpose();
    const VectorXd ev_se =
        ((V.rowwise() - ev.transpose()).array().square().colwise().sum() / (N - 1.0)).sqrt() /
        std::sqrt(N);
    cov.diagonal() += ev;
    se.diagonal() += ev_se.transpose();
  }
  ExpectWithinSe(what + " cov", s.joint_cov.block(begin, begin, q, q), cov, se, 5.0);
  ExpectWithinSe(what + " cross-covariance with the earlier entries",
                 s.joint_cov.block(0, begin, begin, q), mc.cross, mc.cross_se, 5.0);
}

TEST(PilcoPropagate, EachBlockMatchesStagewiseMonteCarlo) {
  const Problem p;
  const StepMoments s = drops::pilco::propagate(p.config, p.model, p.policy, p.mu, p.sigma);
  ASSERT_EQ(s.joint_mean.size(), 3 + 4 + 2 + 2 + 3);
  // Layout: x 0..2, trig 3..6, u~ 7..8, u 9..10, Delta 11..13.
  EXPECT_LE((s.joint_mean.head(3) - p.mu).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LE((s.joint_cov.topLeftCorner(3, 3) - p.sigma).cwiseAbs().maxCoeff(), 0.0);
  CheckStage(
      "trig", s, 3, 4,
      [](const VectorXd& z) {
        return Vec({std::sin(z[1]), std::cos(z[1]), std::sin(z[2]), std::cos(z[2])});
      },
      nullptr, 401);
  CheckStage(
      "policy", s, 7, 2,
      [&](const VectorXd& z) {
        VectorXd in(5);
        for (int k = 0; k < 5; ++k) in[k] = z[p.config.policy_inputs[k]];
        return p.policy.action(in);
      },
      // The policy's 1e-6 output jitter, as a conditional variance.
      [](const VectorXd&) { return VectorXd::Constant(2, RbfPolicy::kOutputJitter); }, 402);
  CheckStage(
      "squash", s, 9, 2,
      [&](const VectorXd& z) {
        return Vec({drops::pilco::squash(z[7], 1.5), drops::pilco::squash(z[8], 1.0)});
      },
      nullptr, 403);
  auto gp_input = [&](const VectorXd& z) {
    VectorXd in(7);
    for (int k = 0; k < 5; ++k) in[k] = z[p.config.dynamics_inputs[k]];
    in.tail(2) = z.segment(9, 2);
    return in;
  };
  CheckStage(
      "GP", s, 11, 3,
      [&](const VectorXd& z) {
        VectorXd out(3);
        double m, v;
        for (int a = 0; a < 3; ++a) {
          p.gps[a].predict(gp_input(z), m, v);
          out[a] = m;
        }
        return out;
      },
      [&](const VectorXd& z) {
        VectorXd out(3);
        double m, v;
        for (int a = 0; a < 3; ++a) {
          p.gps[a].predict(gp_input(z), m, v);
          out[a] = v;
        }
        return out;
      },
      404);
  // x' = x + Delta, exactly.
  MatrixXd P = MatrixXd::Zero(3, 14);
  P.leftCols(3).setIdentity();
  P.rightCols(3).setIdentity();
  EXPECT_LE((s.mean - P * s.joint_mean).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LE((s.cov - P * s.joint_cov * P.transpose()).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(PilcoPropagate, StepIsCloseToParticleMonteCarlo) {
  // The true distribution of x' (no re-approximation): particles through trig, policy, squash and
  // the GP (Delta drawn from the posterior). PILCO's Gaussian re-approximation at each block makes
  // the moments differ at second order in the spread. Measured at this spread (state SD 0.1-0.3,
  // a strongly non-linear random policy): mean errors <= 0.015 SD of x', variance errors <= 10 %
  // (the first state entry, driven by the squashed control). Tolerances 0.05 SD and 25 %: a sanity
  // check of the approximation, not an oracle (the stage-wise test above is).
  const Problem p;
  const StepMoments s = drops::pilco::propagate(p.config, p.model, p.policy, p.mu, p.sigma);
  const int N = 100000;
  Rng rng(405);
  const MatrixXd X = SampleGaussian(rng, p.mu, p.sigma, N);
  MatrixXd Xn(N, 3);
  for (int i = 0; i < N; ++i) {
    const VectorXd x = X.row(i).transpose();
    const VectorXd ut = p.policy.action(Features(x));
    const VectorXd u = Vec({drops::pilco::squash(ut[0], 1.5), drops::pilco::squash(ut[1], 1.0)});
    VectorXd in(7);
    in << Features(x), u;
    for (int a = 0; a < 3; ++a) {
      double m, v;
      p.gps[a].predict(in, m, v);
      Xn(i, a) = x[a] + m + std::sqrt(v) * rng.normal();
    }
  }
  const McStats mc = MonteCarloStats(X, Xn);
  const VectorXd sd = mc.cov.diagonal().cwiseSqrt();
  const VectorXd mean_err = (s.mean - mc.mean).cwiseAbs().cwiseQuotient(sd);
  const VectorXd var_err =
      (s.cov.diagonal() - mc.cov.diagonal()).cwiseAbs().cwiseQuotient(mc.cov.diagonal());
  std::cout << "[ measured ] one step vs particles: |mean error| / SD = " << mean_err.transpose()
            << ", relative variance error = " << var_err.transpose() << "\n";
  EXPECT_LE(mean_err.maxCoeff(), 0.05);
  EXPECT_LE(var_err.maxCoeff(), 0.25);
}

TEST(PilcoPropagate, StepDerivativesMatchFiniteDifferences) {
  const Problem p;
  const StepMoments s = drops::pilco::propagate(p.config, p.model, p.policy, p.mu, p.sigma,
                                                StepDerivatives::kStateAndPolicy);
  auto flat = [&](const RbfPolicy& pol, const VectorXd& m, const MatrixXd& S) {
    const StepMoments t = drops::pilco::propagate(p.config, p.model, pol, m, S);
    VectorXd v(12);
    v << t.mean, Eigen::Map<const VectorXd>(t.cov.data(), 9);
    return v;
  };
  const MatrixXd Jm =
      FdJacobian([&](const VectorXd& m) { return flat(p.policy, m, p.sigma); }, p.mu, 3e-4, 4);
  const MatrixXd Js =
      FdJacobianSym([&](const MatrixXd& S) { return flat(p.policy, p.mu, S); }, p.sigma, 3e-4, 4);
  const MatrixXd Jt = FdJacobian(
      [&](const VectorXd& theta) {
        RbfPolicy q = p.policy;
        q.set_params(theta);
        return flat(q, p.mu, p.sigma);
      },
      p.policy.params(), 1e-4, 4);
  ExpectJacobian("step dM/dmu", s.dmean_dmu, Jm.topRows(3), 1e-6);
  ExpectJacobian("step dM/dSigma", s.dmean_dsigma, Js.topRows(3), 1e-6);
  ExpectJacobian("step dS/dmu", s.dcov_dmu, Jm.bottomRows(9), 1e-6);
  ExpectJacobian("step dS/dSigma", s.dcov_dsigma, Js.bottomRows(9), 1e-6);
  ExpectJacobian("step dM/dtheta", s.dmean_dtheta, Jt.topRows(3), 1e-6);
  ExpectJacobian("step dS/dtheta", s.dcov_dtheta, Jt.bottomRows(9), 1e-6);
  // kState gives the same state derivatives; kNone the same moments.
  const StepMoments st =
      drops::pilco::propagate(p.config, p.model, p.policy, p.mu, p.sigma, StepDerivatives::kState);
  EXPECT_LE((st.dcov_dsigma - s.dcov_dsigma).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(st.dmean_dtheta.size(), 0);
  const StepMoments s0 = drops::pilco::propagate(p.config, p.model, p.policy, p.mu, p.sigma);
  EXPECT_LE((s0.cov - s.cov).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(s0.dmean_dmu.size(), 0);
}

TEST(PilcoCost, StateCostAugmentsAnglesAndItsDerivativesMatch) {
  // x = [v, theta1, theta2]; cost on [x, sin th1, cos th1, sin th2, cos th2] (7-D).
  drops::pilco::PropagationConfig config;
  config.state_dim = 3;
  config.angles = {1, 2};
  config.policy_inputs = {0};
  config.max_u = Vec({1.0});
  Rng rng(37);
  MatrixXd C = MatrixXd::Zero(2, 7);
  C << 0, 0, 0, 0.5, 0, 0.4, 0, 0.1, 0, 0, 0, 0.5, 0, 0.4;
  drops::pilco::SaturatingCost cost;
  cost.weight = C.transpose() * C / 0.25;
  cost.target = Vec({0, 0, 0, 0, 1, 0, 1});
  const VectorXd mu = Vec({0.2, 0.5, -0.3});
  const MatrixXd sigma = RandomCovariance(rng, 3, 0.2, 0.5);
  const drops::pilco::CostMoments c = drops::pilco::state_cost(config, cost, mu, sigma, true);
  // MC over the state itself.
  const MatrixXd X = SampleGaussian(rng, mu, sigma, kStateCostSamples);
  VectorXd y(kStateCostSamples);
  for (int i = 0; i < kStateCostSamples; ++i) {
    VectorXd a(7);
    a << X.row(i).transpose(), std::sin(X(i, 1)), std::cos(X(i, 1)), std::sin(X(i, 2)),
        std::cos(X(i, 2));
    y[i] = cost(a);
  }
  const McStats mc = MonteCarloStats(X, y);
  // The augmented vector is treated as Gaussian with the exact moments of [x, sin, cos] (PILCO's
  // approximation), so this is close, not exact: 0.01 absolute for E[c] ~ 0.12 (measured ~0.002,
  // printed; 10 SE).
  std::cout << "[ measured ] state cost: analytic " << c.mean << ", MC " << mc.mean[0] << " +- "
            << mc.mean_se[0] << "\n";
  EXPECT_NEAR(c.mean, mc.mean[0], 0.01);
  EXPECT_GT(c.mean, 0.05);
  // Without angles it is expected_cost itself.
  drops::pilco::PropagationConfig plain = config;
  plain.angles.clear();
  drops::pilco::SaturatingCost cost3;
  cost3.weight = cost.weight.topLeftCorner(3, 3) + MatrixXd::Identity(3, 3);
  cost3.target = Vec({0.1, 0.2, 0.3});
  EXPECT_EQ(drops::pilco::state_cost(plain, cost3, mu, sigma).mean,
            drops::pilco::expected_cost(cost3, mu, sigma).mean);
  EXPECT_THROW(drops::pilco::state_cost(config, cost3, mu, sigma), drops::InvalidArgument);
  auto value = [&](const VectorXd& m, const MatrixXd& S) {
    return VectorXd::Constant(1, drops::pilco::state_cost(config, cost, m, S).mean);
  };
  ExpectJacobian("state cost dE/dmu", c.dmean_dmu.transpose(),
                 FdJacobian([&](const VectorXd& m) { return value(m, sigma); }, mu, 1e-5), 1e-6);
  ExpectJacobian("state cost dE/dSigma", Row(c.dmean_dsigma),
                 FdJacobianSym([&](const MatrixXd& S) { return value(mu, S); }, sigma, 1e-5), 1e-6);
}

TEST(PilcoExpectedCost, GradientMatchesFiniteDifferences) {
  const Problem p;
  const int H = 6;
  const drops::pilco::ExpectedCost J(p.config, p.model, p.policy, p.cost, p.mu, p.sigma, H, 0.95);
  ASSERT_EQ(J.num_params(), 8 * 5 + 8 * 2 + 5 * 2);
  const VectorXd theta = p.policy.params();
  VectorXd g;
  const double value = J(theta, &g);
  EXPECT_EQ(value, J(theta));  // with and without the gradient: the same moments
  const MatrixXd fd =
      FdJacobian([&](const VectorXd& t) { return VectorXd::Constant(1, J(t)); }, theta, 1e-4, 4);
  ExpectJacobian("dJ/dtheta (H = 6, gamma = 0.95)", g.transpose(), fd, 1e-6);
  // The value is the discounted sum of the predicted expected costs.
  const drops::pilco::PredictedTrajectory tr = J.predict(theta);
  ASSERT_EQ(tr.means.size(), static_cast<std::size_t>(H + 1));
  double sum = 0.0, w = 1.0;
  for (int t = 0; t < H; ++t) {
    w *= 0.95;
    sum += w * tr.expected_costs[t];
  }
  EXPECT_NEAR(tr.total, value, 1e-15);
  EXPECT_NEAR(sum, value, 1e-14);
  EXPECT_GT(value, 0.5);  // not a saturated corner: costs in (0, 1) with gradient
  // A small step against the gradient decreases J (the gradient is usable by a descent method).
  EXPECT_LT(J(theta - 1e-3 / g.norm() * g), value);
  // The NLopt adapter returns the same value and gradient.
  VectorXd g2(theta.size());
  const double v2 = drops::pilco::ExpectedCost::nlopt_objective(
      static_cast<unsigned>(theta.size()), theta.data(), g2.data(),
      const_cast<void*>(static_cast<const void*>(&J)));
  EXPECT_EQ(v2, value);
  EXPECT_EQ(g2, g);
  EXPECT_EQ(drops::pilco::ExpectedCost::nlopt_objective(
                static_cast<unsigned>(theta.size()), theta.data(), nullptr,
                const_cast<void*>(static_cast<const void*>(&J))),
            value);
}

TEST(PilcoPropagate, ConfigurationChecks) {
  const Problem p;
  std::string why;
  EXPECT_TRUE(p.config.IsValid(&why)) << why;
  PropagationConfig c = p.config;
  c.angles = {1, 3};
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("angles"), std::string::npos) << why;
  c = p.config;
  c.policy_inputs = {0, 7};
  EXPECT_FALSE(c.IsValid(&why));
  c = p.config;
  c.dynamics_inputs = {0, 0};
  EXPECT_FALSE(c.IsValid(&why));
  c = p.config;
  c.max_u = Vec({1.0, 0.0});
  EXPECT_FALSE(c.IsValid(&why));
  c = p.config;
  c.max_u = Vec({1.0});  // the policy has 2 outputs
  EXPECT_THROW(drops::pilco::propagate(c, p.model, p.policy, p.mu, p.sigma),
               drops::InvalidArgument);
  c = p.config;
  c.dynamics_inputs = {0, 3, 4, 5};  // the GP has 7 inputs
  EXPECT_THROW(drops::pilco::propagate(c, p.model, p.policy, p.mu, p.sigma),
               drops::InvalidArgument);
  EXPECT_THROW(drops::pilco::propagate(p.config, p.model, p.policy, Vec({0, 0}), p.sigma),
               drops::InvalidArgument);
  EXPECT_THROW(drops::pilco::ExpectedCost(p.config, p.model, p.policy, p.cost, p.mu, p.sigma, 0),
               drops::InvalidArgument);
  EXPECT_THROW(
      drops::pilco::ExpectedCost(p.config, p.model, p.policy, p.cost, p.mu, p.sigma, 5, 1.5),
      drops::InvalidArgument);
  drops::pilco::SaturatingCost small = p.cost;
  small.target = Vec({0, 0, 0});
  EXPECT_THROW(drops::pilco::ExpectedCost(p.config, p.model, p.policy, small, p.mu, p.sigma, 5),
               drops::InvalidArgument);
}

}  // namespace
