// Tests of drops::pilco::se_moments (PILCO's gp0 moment matching, with and without an RBF-network
// prior mean): against Monte Carlo, against gp::Gp::predict in the Sigma -> 0 limit, the zero-data
// limit of PILCO with priors, finite-difference derivatives, and argument checks.
//
// Monte-Carlo tolerances: 2e5 samples of x ~ N(mu, Sigma) with a fixed seed; the MC oracle uses
// gp::Gp::predict_batch (independent code) and the law of total covariance
// (E[m(x)], Cov[m(x)] + E[diag sigma^2(x)], Cov[x, m(x)] = Sigma V). Each entry must be within
// 5 standard errors of the MC estimate (SE from the sample itself): a correct implementation fails
// such a bound with probability < 1e-5 per entry; a wrong term (e.g. a missing tr(K^-1 Q), the
// plug-in mean) is off by tens to hundreds of SEs (checked below).
// Derivatives: central differences with step 1e-5 (truncation ~1e-10, round-off ~1e-11 relative);
// tolerance 1e-6 on max |analytic - FD| / max |FD| per Jacobian.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/pilco/se_model.hpp"
#include "pilco_test_util.hpp"

namespace {

using drops::Rng;
using drops::gp::Gp;
using drops::pilco::Moments;
using drops::pilco::se_moments;
using drops::pilco::SeModel;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace pilco_test;

constexpr int kMcSamples = 200000;
constexpr double kZ = 5.0;
constexpr double kFdStep = 1e-5;
constexpr double kFdTol = 1e-6;

// E GPs on N random points in [-2, 2]^D with smooth targets, random hyper-parameters.
std::vector<Gp> RandomGps(Rng& rng, int D, int E, int N, double sf_lo, double sf_hi) {
  const MatrixXd X = RandomMatrix(rng, N, D, -2.0, 2.0);
  std::vector<Gp> gps;
  for (int a = 0; a < E; ++a) {
    const VectorXd w = RandomVector(rng, D, -1.5, 1.5);
    VectorXd y = (X * w).array().sin().matrix() + 0.3 * X.col(a % D).cwiseAbs2();
    for (int i = 0; i < N; ++i) y[i] += 0.05 * rng.normal();
    Gp gp(D);
    VectorXd h(D + 2);
    h.head(D) = RandomVector(rng, D, std::log(0.6), std::log(1.5));
    h[D] = std::log(rng.uniform(sf_lo, sf_hi));
    h[D + 1] = std::log(rng.uniform(0.05, 0.2));
    gp.set_h_params(h);
    gp.compute(X, y);
    gps.push_back(std::move(gp));
  }
  return gps;
}

struct McMoments {
  McStats stats;                   // of the summed posterior means
  VectorXd mean_var, mean_var_se;  // E[sigma^2(x)] per output (0 when no variance)
};

// MC of f_a(x) = sum over `means` of their posterior means + the posterior variance of `variances`.
McMoments MonteCarlo(const std::vector<std::vector<const Gp*>>& means,
                     const std::vector<const Gp*>& variances, const VectorXd& mu,
                     const MatrixXd& sigma, std::uint64_t seed) {
  Rng rng(seed);
  const MatrixXd X = SampleGaussian(rng, mu, sigma, kMcSamples);
  const int E = static_cast<int>(means.size());
  MatrixXd Y = MatrixXd::Zero(kMcSamples, E);
  McMoments out;
  out.mean_var = VectorXd::Zero(E);
  out.mean_var_se = VectorXd::Zero(E);
  VectorXd m, v;
  for (int a = 0; a < E; ++a) {
    for (const Gp* gp : means[a]) {
      gp->predict_batch(X, m, v);
      Y.col(a) += m;
    }
    if (variances[a] != nullptr) {
      variances[a]->predict_batch(X, m, v);
      out.mean_var[a] = v.mean();
      out.mean_var_se[a] =
          std::sqrt((v.array() - v.mean()).square().sum() / (kMcSamples - 1.0) / kMcSamples);
    }
  }
  out.stats = MonteCarloStats(X, Y);
  return out;
}

void ExpectMatchesMonteCarlo(const std::string& what, const Moments& m, const McMoments& mc,
                             const MatrixXd& sigma) {
  ExpectWithinSe(what + " mean", m.mean, mc.stats.mean, mc.stats.mean_se, kZ);
  const MatrixXd S = mc.stats.cov + MatrixXd(mc.mean_var.asDiagonal());
  MatrixXd se = mc.stats.cov_se;
  se.diagonal() += mc.mean_var_se;  // conservative: SEs added, not in quadrature
  ExpectWithinSe(what + " cov", m.cov, S, se, kZ);
  ExpectWithinSe(what + " Sigma * cross = Cov[x, f]", sigma * m.cross, mc.stats.cross,
                 mc.stats.cross_se, kZ);
}

struct Problem {
  std::vector<Gp> gps;
  VectorXd mu;
  MatrixXd sigma;
};

Problem GpProblem() {
  Rng rng(11);
  Problem p;
  p.gps = RandomGps(rng, 3, 3, 40, 0.5, 1.2);
  p.mu = RandomVector(rng, 3, -1.0, 1.0);
  p.sigma = RandomCovariance(rng, 3, 0.3, 0.8);
  return p;
}

// A model of PILCO with priors: E "simulator" GPs on n_prior points as prior mean, E residual GPs
// on n_residual points, and an input Gaussian, drawn in that order from Rng(seed), D = 3.
struct PriorProblem {
  std::vector<Gp> prior, residual;
  SeModel model;
  VectorXd mu;
  MatrixXd sigma;
};

PriorProblem MakePriorProblem(std::uint64_t seed, int E, int n_prior, int n_residual) {
  Rng rng(seed);
  const int D = 3;
  PriorProblem p;
  p.prior = RandomGps(rng, D, E, n_prior, 0.8, 1.5);
  p.residual = RandomGps(rng, D, E, n_residual, 0.2, 0.5);
  p.model = drops::pilco::gp_model_with_prior_mean(p.prior, p.residual);
  p.mu = RandomVector(rng, D, -1.0, 1.0);
  p.sigma = RandomCovariance(rng, D, 0.3, 0.8);
  return p;
}

TEST(PilcoGpMoments, MatchMonteCarloWithCorrelatedInput) {
  const Problem p = GpProblem();
  const Moments m = se_moments(drops::pilco::gp_model(p.gps), p.mu, p.sigma);
  std::vector<std::vector<const Gp*>> means;
  std::vector<const Gp*> vars;
  for (const Gp& gp : p.gps) {
    means.push_back({&gp});
    vars.push_back(&gp);
  }
  const McMoments mc = MonteCarlo(means, vars, p.mu, p.sigma, 101);
  ExpectMatchesMonteCarlo("GP", m, mc, p.sigma);
  // Off-diagonal covariances are non-trivial (outputs correlated through x).
  EXPECT_GT(std::abs(m.cov(0, 1)), 20.0 * mc.stats.cov_se(0, 1));

  // The test can fail: the plug-in prediction (Sigma ignored) is far outside the tolerance.
  double worst = 0.0;
  for (int a = 0; a < 3; ++a) {
    double mean, var;
    p.gps[a].predict(p.mu, mean, var);
    worst = std::max(worst, std::abs(mean - mc.stats.mean[a]) / mc.stats.mean_se[a]);
  }
  EXPECT_GT(worst, 20.0);
}

TEST(PilcoGpMoments, WithRbfPriorMeanMatchMonteCarlo) {
  const PriorProblem p = MakePriorProblem(12, 2, 60, 25);
  const std::vector<Gp>& prior = p.prior;
  const std::vector<Gp>& residual = p.residual;
  const VectorXd& mu = p.mu;
  const MatrixXd& sigma = p.sigma;
  const SeModel& model = p.model;
  ASSERT_EQ(model.outputs[0].blocks.size(), 2u);
  const Moments m = se_moments(model, mu, sigma);
  const McMoments mc = MonteCarlo({{&prior[0], &residual[0]}, {&prior[1], &residual[1]}},
                                  {&residual[0], &residual[1]}, mu, sigma, 102);
  ExpectMatchesMonteCarlo("GP + prior mean", m, mc, sigma);
  // Dropping the prior's cross terms would be detected: the prior alone is far off.
  const Moments prior_only = se_moments(drops::pilco::gp_model(prior), mu, sigma);
  EXPECT_GT((prior_only.mean - mc.stats.mean).cwiseQuotient(mc.stats.mean_se).cwiseAbs().maxCoeff(),
            20.0);
}

TEST(PilcoGpMoments, SigmaZeroIsTheGpPosterior) {
  const Problem p = GpProblem();
  const int D = 3;
  const MatrixXd zero = MatrixXd::Zero(D, D);
  const Moments m = se_moments(drops::pilco::gp_model(p.gps), p.mu, zero);
  for (int a = 0; a < 3; ++a) {
    double mean, var;
    p.gps[a].predict(p.mu, mean, var);
    EXPECT_NEAR(m.mean[a], mean, 1e-10 * (1.0 + std::abs(mean)));
    EXPECT_NEAR(m.cov(a, a), var, 1e-10);
    for (int b = 0; b < 3; ++b)
      if (b != a) EXPECT_NEAR(m.cov(a, b), 0.0, 1e-10);
    // cross = Sigma^-1 Cov[x, f] -> the gradient of the posterior mean at mu (Stein's lemma).
    const MatrixXd g = FdJacobian(
        [&](const VectorXd& x) {
          double mm, vv;
          p.gps[a].predict(x, mm, vv);
          return VectorXd::Constant(1, mm);
        },
        p.mu, 1e-5);
    EXPECT_LE(RelErr(m.cross.col(a).transpose(), g), 1e-7);
  }
  // Tiny Sigma: continuous.
  const Moments small = se_moments(drops::pilco::gp_model(p.gps), p.mu, 1e-10 * p.sigma);
  EXPECT_LE((small.mean - m.mean).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LE((small.cov - m.cov).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(PilcoGpMoments, SigmaZeroWithPriorIsPriorMeanPlusResidualPosterior) {
  Rng rng(13);
  const int D = 3, E = 2;
  const std::vector<Gp> prior = RandomGps(rng, D, E, 50, 0.8, 1.5);
  const std::vector<Gp> residual = RandomGps(rng, D, E, 20, 0.2, 0.5);
  const VectorXd mu = RandomVector(rng, D, -1.0, 1.0);
  const Moments m =
      se_moments(drops::pilco::gp_model_with_prior_mean(prior, residual), mu, MatrixXd::Zero(D, D));
  for (int a = 0; a < E; ++a) {
    double pm, pv, rm, rv;
    prior[a].predict(mu, pm, pv);
    residual[a].predict(mu, rm, rv);
    EXPECT_NEAR(m.mean[a], pm + rm, 1e-10);
    EXPECT_NEAR(m.cov(a, a), rv, 1e-10);  // the residual GP's variance only
  }
  EXPECT_NEAR(m.cov(0, 1), 0.0, 1e-10);
}

// baselines.md §2d: with zero real data, PILCO with priors predicts the simulator GP's mean with
// the residual GP's prior variance alpha_r^2 (no tr term) on the diagonal.
TEST(PilcoGpMoments, PriorWithZeroRealDataIsTheSimulatorMeanPlusPriorVariance) {
  Rng rng(14);
  const int D = 3, E = 3;
  const std::vector<Gp> prior = RandomGps(rng, D, E, 50, 0.8, 1.5);
  std::vector<Gp> empty;
  VectorXd alpha2(E);
  for (int a = 0; a < E; ++a) {
    Gp gp(D);
    VectorXd h = VectorXd::Zero(D + 2);
    h[D] = std::log(0.3 + 0.1 * a);
    h[D + 1] = std::log(0.1);
    gp.set_h_params(h);
    gp.compute(MatrixXd(0, D), VectorXd(0));
    alpha2[a] = gp.kernel().variance();
    empty.push_back(std::move(gp));
  }
  const SeModel model = drops::pilco::gp_model_with_prior_mean(prior, empty);
  const VectorXd mu = RandomVector(rng, D, -1.0, 1.0);
  const MatrixXd sigma = RandomCovariance(rng, D, 0.3, 0.8);
  const Moments m = se_moments(model, mu, sigma);

  // The simulator GPs' means as plain RBF networks (gp2 moments), plus alpha_r^2.
  SeModel sim;
  sim.input_dim = D;
  for (const Gp& gp : prior) sim.outputs.push_back({{drops::pilco::gp_mean_block(gp)}});
  const Moments s = se_moments(sim, mu, sigma);
  EXPECT_LE((m.mean - s.mean).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((m.cov - s.cov - MatrixXd(alpha2.asDiagonal())).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((m.cross - s.cross).cwiseAbs().maxCoeff(), 1e-12);

  // Independent oracle: MC over the simulator GPs' posterior means, alpha_r^2 added.
  McMoments mc = MonteCarlo({{&prior[0]}, {&prior[1]}, {&prior[2]}}, {nullptr, nullptr, nullptr},
                            mu, sigma, 103);
  mc.mean_var = alpha2;
  ExpectMatchesMonteCarlo("prior, zero real data", m, mc, sigma);

  // Sigma = 0: the simulator GP's posterior mean and variance alpha_r^2.
  const Moments z = se_moments(model, mu, MatrixXd::Zero(D, D));
  for (int a = 0; a < E; ++a) {
    double pm, pv;
    prior[a].predict(mu, pm, pv);
    EXPECT_NEAR(z.mean[a], pm, 1e-10);
    EXPECT_NEAR(z.cov(a, a), alpha2[a], 1e-12);
  }
}

TEST(PilcoGpMoments, InputDerivativesMatchFiniteDifferences) {
  const Problem p = GpProblem();
  const SeModel model = drops::pilco::gp_model(p.gps);
  CheckInputDerivatives(
      "GP",
      [&](const VectorXd& mu, const MatrixXd& S, bool d) { return se_moments(model, mu, S, d); },
      p.mu, p.sigma, kFdStep, kFdTol);
}

TEST(PilcoGpMoments, InputDerivativesWithPriorMatchFiniteDifferences) {
  const PriorProblem p = MakePriorProblem(15, 2, 30, 15);
  CheckInputDerivatives(
      "GP + prior mean",
      [&](const VectorXd& m, const MatrixXd& S, bool d) { return se_moments(p.model, m, S, d); },
      p.mu, p.sigma, kFdStep, kFdTol);
}

// se_moments runs the output pairs (and the outputs of the first moments) in parallel; each pair
// sums its block pairs in the serial order, so every field is the same bits with 1 and 2 threads.
// A model with two blocks per output (prior mean + residual) and E = 3 outputs (6 pairs) exercises
// the grouping; the derivatives are compared too.
TEST(PilcoGpMoments, SameBitsWithOneAndTwoThreads) {
  const PriorProblem p = MakePriorProblem(17, 3, 50, 30);
  auto run = [&](int threads) {
    const drops::ThreadLimit limit(threads);
    return se_moments(p.model, p.mu, p.sigma, true);
  };
  const Moments one = run(1);
  for (int repeat = 0; repeat < 5; ++repeat) {
    const Moments two = run(2);
    EXPECT_EQ(one.mean, two.mean);
    EXPECT_EQ(one.cov, two.cov);
    EXPECT_EQ(one.cross, two.cross);
    EXPECT_EQ(one.dmean_dmu, two.dmean_dmu);
    EXPECT_EQ(one.dmean_dsigma, two.dmean_dsigma);
    EXPECT_EQ(one.dcov_dmu, two.dcov_dmu);
    EXPECT_EQ(one.dcov_dsigma, two.dcov_dsigma);
    EXPECT_EQ(one.dcross_dmu, two.dcross_dmu);
    EXPECT_EQ(one.dcross_dsigma, two.dcross_dsigma);
  }
  // The compared fields are not trivially equal: the outputs' covariances are non-zero.
  EXPECT_GT(one.cov.cwiseAbs().minCoeff(), 0.0);
}

TEST(PilcoGpMoments, DerivativesAtSingularSigma) {
  // A rank-1 input covariance (e.g. a deterministic start propagated once): no Sigma^-1 is needed.
  const Problem p = GpProblem();
  const SeModel model = drops::pilco::gp_model(p.gps);
  const VectorXd v = VectorXd::LinSpaced(3, 0.3, 0.7);
  const MatrixXd sigma = v * v.transpose();
  const Moments m = se_moments(model, p.mu, sigma, true);
  EXPECT_TRUE(m.cov.allFinite());
  EXPECT_TRUE(m.dcov_dsigma.allFinite());
  const MatrixXd Jm = FdJacobian(
      [&](const VectorXd& x) { return FlatMoments(se_moments(model, x, sigma)); }, p.mu, kFdStep);
  ExpectJacobian("GP at singular Sigma dcov/dmu", m.dcov_dmu, Jm.middleRows(3, 9), kFdTol);
}

TEST(PilcoGpMoments, RejectsBadArguments) {
  const Problem p = GpProblem();
  const SeModel model = drops::pilco::gp_model(p.gps);
  EXPECT_THROW(se_moments(model, VectorXd::Zero(2), p.sigma), drops::InvalidArgument);
  EXPECT_THROW(se_moments(model, p.mu, MatrixXd::Zero(3, 2)), drops::InvalidArgument);
  MatrixXd asym = p.sigma;
  asym(0, 1) += 1e-3;
  EXPECT_THROW(se_moments(model, p.mu, asym), drops::InvalidArgument);
  EXPECT_THROW(se_moments(model, p.mu, -10.0 * MatrixXd::Identity(3, 3)), drops::NumericalError);
  SeModel bad = model;
  bad.outputs[1].blocks[0].length_scales[0] = -1.0;
  EXPECT_THROW(se_moments(bad, p.mu, p.sigma), drops::InvalidArgument);
  bad = model;
  bad.outputs[0].blocks[0].weights.resize(3);
  EXPECT_THROW(se_moments(bad, p.mu, p.sigma), drops::InvalidArgument);
  try {
    se_moments(model, VectorXd::Zero(2), p.sigma);
  } catch (const drops::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("expected size 3, got 2"), std::string::npos) << e.what();
  }
}

TEST(PilcoGpAccessors, TrainingInputsAndInverseCovariance) {
  Rng rng(16);
  const std::vector<Gp> gps = RandomGps(rng, 2, 1, 12, 0.5, 1.0);
  const Gp& gp = gps[0];
  const MatrixXd& X = gp.training_inputs();
  ASSERT_EQ(X.rows(), 12);
  // Naive K + sigma_n^2 I from the kernel.
  MatrixXd K(12, 12);
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) K(i, j) = gp.kernel()(X.row(i).transpose(), X.row(j).transpose());
  K.diagonal().array() += gp.noise_variance();
  const MatrixXd Kinv = gp.inverse_covariance();
  EXPECT_LE((Kinv * K - MatrixXd::Identity(12, 12)).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LE((Kinv - Kinv.transpose()).cwiseAbs().maxCoeff(), 0.0);
  Gp empty(2);
  EXPECT_EQ(empty.inverse_covariance().size(), 0);
  EXPECT_EQ(empty.training_inputs().rows(), 0);
}

}  // namespace
