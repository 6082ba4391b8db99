// Tests of drops::pilco::RbfPolicy (PILCO's congp/gp2 policy): the deterministic action against a
// gp::Gp posterior mean through the same pseudo-observations (independent code), its moments
// against Monte Carlo, and the input and parameter derivatives against central differences.
// Tolerances: as test_pilco_moments.cpp (5 SE over 2e5 samples; 1e-6 relative for derivatives with
// step 1e-5).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/pilco/rbf_policy.hpp"
#include "pilco_test_util.hpp"

namespace {

using drops::Rng;
using drops::pilco::Moments;
using drops::pilco::RbfPolicy;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace pilco_test;

RbfPolicy RandomPolicy(Rng& rng, int d, int n, int E) {
  RbfPolicy p(d, n, E);
  MatrixXd targets(n, E);
  for (int a = 0; a < E; ++a)
    for (int i = 0; i < n; ++i) targets(i, a) = 0.5 * rng.normal();
  p.set(RandomMatrix(rng, n, d, -1.5, 1.5), targets,
        RandomMatrix(rng, d, E, std::log(0.5), std::log(1.5)));
  return p;
}

TEST(PilcoRbfPolicy, ActionIsTheGpPosteriorMeanOfItsPseudoObservations) {
  Rng rng(21);
  const int d = 3, n = 15, E = 2;
  const RbfPolicy p = RandomPolicy(rng, d, n, E);
  for (int a = 0; a < E; ++a) {
    drops::gp::Gp gp(d);
    VectorXd h(d + 2);
    h << p.log_length_scales().col(a), 0.0, std::log(0.01);  // alpha = 1, sigma_n = 0.01
    gp.set_h_params(h);
    gp.compute(p.centres(), p.targets().col(a));
    for (int k = 0; k < 5; ++k) {
      const VectorXd x = RandomVector(rng, d, -2.0, 2.0);
      double mean, var;
      gp.predict(x, mean, var);
      EXPECT_NEAR(p.action(x)[a], mean, 1e-9 * (1.0 + std::abs(mean)));
    }
  }
}

TEST(PilcoRbfPolicy, MomentsMatchMonteCarlo) {
  Rng rng(22);
  const int d = 3, n = 15, E = 2;
  const RbfPolicy p = RandomPolicy(rng, d, n, E);
  const VectorXd mu = RandomVector(rng, d, -0.5, 0.5);
  const MatrixXd sigma = RandomCovariance(rng, d, 0.3, 0.8);
  const Moments m = p.moments(mu, sigma);
  const int N = 200000;
  const MatrixXd X = SampleGaussian(rng, mu, sigma, N);
  MatrixXd U(N, E);
  for (int i = 0; i < N; ++i) U.row(i) = p.action(X.row(i).transpose()).transpose();
  const McStats mc = MonteCarloStats(X, U);
  ExpectWithinSe("policy mean", m.mean, mc.mean, mc.mean_se, 5.0);
  const MatrixXd cov = m.cov - RbfPolicy::kOutputJitter * MatrixXd::Identity(E, E);
  ExpectWithinSe("policy cov (without the 1e-6 jitter)", cov, mc.cov, mc.cov_se, 5.0);
  ExpectWithinSe("policy Sigma * cross", sigma * m.cross, mc.cross, mc.cross_se, 5.0);
  // Sigma = 0: the action, zero spread but the jitter.
  const Moments z = p.moments(mu, MatrixXd::Zero(d, d));
  EXPECT_LE((z.mean - p.action(mu)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((z.cov - RbfPolicy::kOutputJitter * MatrixXd::Identity(E, E)).cwiseAbs().maxCoeff(),
            1e-12);
}

TEST(PilcoRbfPolicy, InputDerivativesMatchFiniteDifferences) {
  Rng rng(23);
  const RbfPolicy p = RandomPolicy(rng, 3, 12, 2);
  const VectorXd mu = RandomVector(rng, 3, -0.5, 0.5);
  const MatrixXd sigma = RandomCovariance(rng, 3, 0.3, 0.8);
  CheckInputDerivatives(
      "policy", [&](const VectorXd& m, const MatrixXd& S, bool dd) { return p.moments(m, S, dd); },
      mu, sigma, 1e-5, 1e-6);
}

void CheckParamDerivatives(int d, int n, int E, std::uint64_t seed) {
  Rng rng(seed);
  const RbfPolicy p = RandomPolicy(rng, d, n, E);
  const VectorXd mu = RandomVector(rng, d, -0.5, 0.5);
  const MatrixXd sigma = RandomCovariance(rng, d, 0.3, 0.8);
  const Moments m = p.moments(mu, sigma, false, true);
  ASSERT_EQ(m.dmean_dtheta.cols(), p.num_params());
  MatrixXd analytic(m.dmean_dtheta.rows() + m.dcov_dtheta.rows() + m.dcross_dtheta.rows(),
                    p.num_params());
  analytic << m.dmean_dtheta, m.dcov_dtheta, m.dcross_dtheta;
  const MatrixXd fd = FdJacobian(
      [&](const VectorXd& theta) {
        RbfPolicy q = p;
        q.set_params(theta);
        return FlatMoments(q.moments(mu, sigma));
      },
      p.params(), 1e-5);
  const std::string what = "policy (d " + std::to_string(d) + ", n " + std::to_string(n) + ", E " +
                           std::to_string(E) + ") d(mean, cov, cross)/dtheta";
  ExpectJacobian(what, analytic, fd, 1e-6);
  // Each parameter group separately (a small group must not hide behind a large one).
  const int nd = n * d, nE = n * E;
  ExpectJacobian(what + " [centres]", analytic.leftCols(nd), fd.leftCols(nd), 1e-6);
  ExpectJacobian(what + " [targets]", analytic.middleCols(nd, nE), fd.middleCols(nd, nE), 1e-6);
  ExpectJacobian(what + " [log length scales]", analytic.rightCols(d * E), fd.rightCols(d * E),
                 1e-6);
}

TEST(PilcoRbfPolicy, ParameterDerivativesMatchFiniteDifferences) {
  CheckParamDerivatives(3, 10, 1, 24);
  CheckParamDerivatives(2, 8, 2, 25);
}

TEST(PilcoRbfPolicy, ParamsRoundTripAndLayout) {
  Rng rng(26);
  const RbfPolicy p = RandomPolicy(rng, 3, 5, 2);
  EXPECT_EQ(p.num_params(), 5 * 3 + 5 * 2 + 3 * 2);
  const VectorXd theta = p.params();
  EXPECT_EQ(theta[1 + 5 * 2], p.centres()(1, 2));
  EXPECT_EQ(theta[15 + 3 + 5 * 1], p.targets()(3, 1));
  EXPECT_EQ(theta[25 + 2 + 3 * 1], p.log_length_scales()(2, 1));
  RbfPolicy q(3, 5, 2);
  q.set_params(theta);
  EXPECT_EQ(q.params(), theta);
  EXPECT_EQ(q.weights(), p.weights());
  EXPECT_THROW(q.set_params(VectorXd::Zero(3)), drops::InvalidArgument);
  VectorXd bad = theta;
  bad[0] = std::nan("");
  EXPECT_THROW(q.set_params(bad), drops::InvalidArgument);
  EXPECT_EQ(q.params(), theta);  // unchanged after a failed set
  EXPECT_THROW(RbfPolicy(0, 5, 1), drops::InvalidArgument);
  EXPECT_THROW(p.action(VectorXd::Zero(2)), drops::InvalidArgument);
}

}  // namespace
