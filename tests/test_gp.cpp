// Tests of drops::gp::Gp: posterior and likelihood against naive dense formulas, analytic gradient
// against finite differences, iRprop- recovery of known length scales, jitter and input validation.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <numbers>
#include <utility>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/gp/kernel.hpp"

namespace {

using drops::Rng;
using drops::gp::Gp;
using Eigen::MatrixXd;
using Eigen::VectorXd;

MatrixXd RandomMatrix(Rng& rng, int rows, int cols, double lo, double hi) {
  MatrixXd m(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) m(i, j) = rng.uniform(lo, hi);
  return m;
}

VectorXd RandomVector(Rng& rng, int n, double lo, double hi) {
  return RandomMatrix(rng, n, 1, lo, hi).col(0);
}

// Naive kernel k(a, b) from h in log space (independent of SquaredExpArd).
double NaiveKernel(const VectorXd& a, const VectorXd& b, const VectorXd& h) {
  const int D = static_cast<int>(a.size());
  double s = 0.0;
  for (int d = 0; d < D; ++d) {
    const double l = std::exp(h[d]);
    s += (a[d] - b[d]) * (a[d] - b[d]) / (l * l);
  }
  return std::exp(2.0 * h[D]) * std::exp(-0.5 * s);
}

MatrixXd NaiveK(const MatrixXd& X, const VectorXd& h, bool with_noise) {
  const int N = static_cast<int>(X.rows());
  const int D = static_cast<int>(X.cols());
  MatrixXd K(N, N);
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) K(i, j) = NaiveKernel(X.row(i).transpose(), X.row(j).transpose(), h);
  if (with_noise) K.diagonal().array() += std::exp(2.0 * h[D + 1]);
  return K;
}

VectorXd RandomH(Rng& rng, int D) {
  VectorXd h(D + 2);
  for (int d = 0; d < D; ++d) h[d] = rng.uniform(std::log(0.5), std::log(3.0));
  h[D] = rng.uniform(std::log(0.5), std::log(2.0));
  h[D + 1] = rng.uniform(std::log(0.05), std::log(0.3));
  return h;
}

TEST(Gp, DefaultsFollowSettings) {
  Gp gp(3);
  const VectorXd h = gp.h_params();
  ASSERT_EQ(h.size(), 5);
  EXPECT_NEAR(h.head(3).norm(), 0.0, 1e-15);        // l = 1
  EXPECT_NEAR(h[3], 0.0, 1e-15);                    // sigma_f^2 = 1
  EXPECT_NEAR(gp.noise_variance(), 0.01, 1e-15);    // sigma_n^2 = 0.01
  EXPECT_NEAR(h[4], 0.5 * std::log(0.01), 1e-15);
  EXPECT_THROW(Gp(0), drops::InvalidArgument);
}

TEST(Gp, KernelMatchesFormula) {
  drops::gp::SquaredExpArd k(2);
  k.length_scales << 0.5, 2.0;
  k.signal_variance = 1.7;
  VectorXd a(2), b(2);
  a << 0.3, -1.0;
  b << -0.2, 0.5;
  const double expected = 1.7 * std::exp(-0.5 * (0.25 / 0.25 + 2.25 / 4.0));
  EXPECT_NEAR(k(a, b), expected, 1e-14);
  EXPECT_THROW(k(a, VectorXd(3)), drops::InvalidArgument);
}

// 1. Posterior mean and variance equal a naive dense solve, for predict and predict_batch.
TEST(Gp, PosteriorMatchesNaiveDenseSolve) {
  Rng rng(1);
  // offset: inputs far from the origin must not lose accuracy (distance expansion is centred).
  for (const auto& [D, offset] : {std::pair{1, 0.0}, std::pair{3, 0.0}, std::pair{7, 0.0}, std::pair{7, 1e4}}) {
    const int N = 40, B = D == 7 ? 16 : 9;  // 16: no padding in predict_batch; 9: padded
    const MatrixXd X = (RandomMatrix(rng, N, D, -2.0, 2.0).array() + offset).matrix();
    const VectorXd y = RandomVector(rng, N, -1.0, 1.0);
    const VectorXd h = RandomH(rng, D);
    Gp gp(D);
    gp.set_h_params(h);
    gp.compute(X, y);

    const MatrixXd Kinv = NaiveK(X, h, true).fullPivLu().inverse();
    const MatrixXd Xq = (RandomMatrix(rng, B, D, -2.5, 2.5).array() + offset).matrix();
    VectorXd mean_b, var_b;
    gp.predict_batch(Xq, mean_b, var_b);
    ASSERT_EQ(mean_b.size(), B);
    ASSERT_EQ(var_b.size(), B);
    for (int q = 0; q < B; ++q) {
      const VectorXd x = Xq.row(q).transpose();
      VectorXd k(N);
      for (int i = 0; i < N; ++i) k[i] = NaiveKernel(x, X.row(i).transpose(), h);
      const double mean_naive = k.dot(Kinv * y);
      const double var_naive = std::exp(2.0 * h[D]) - k.dot(Kinv * k);
      double mean, var;
      gp.predict(x, mean, var);
      EXPECT_NEAR(mean, mean_naive, 1e-9) << "D=" << D << " q=" << q;
      EXPECT_NEAR(var, std::max(0.0, var_naive), 1e-9) << "D=" << D << " q=" << q;
      EXPECT_NEAR(mean_b[q], mean, 1e-10);
      EXPECT_NEAR(var_b[q], var, 1e-10);
    }
    // alpha = K^-1 y
    EXPECT_LT((gp.alpha() - Kinv * y).cwiseAbs().maxCoeff(), 1e-8);
  }
}

TEST(Gp, VarianceExcludesNoiseAndIsClampedAtZero) {
  Rng rng(2);
  const MatrixXd X = RandomMatrix(rng, 30, 2, -1.0, 1.0);
  const VectorXd y = RandomVector(rng, 30, -1.0, 1.0);
  Gp gp(2);
  VectorXd h = gp.h_params();
  h[3] = std::log(1e-4);  // almost no noise: variance at a training input ~ 0, not sigma_n^2
  gp.set_h_params(h);
  gp.compute(X, y);
  double mean, var;
  gp.predict(X.row(0).transpose(), mean, var);
  EXPECT_GE(var, 0.0);
  EXPECT_LT(var, 1e-6);
  EXPECT_NEAR(mean, y[0], 5e-3);
  // Far from the data: the prior variance sigma_f^2.
  gp.predict(VectorXd::Constant(2, 100.0), mean, var);
  EXPECT_NEAR(var, 1.0, 1e-12);
  EXPECT_NEAR(mean, 0.0, 1e-12);
}

// 2. Log marginal likelihood equals the naive formula (log det via LU).
TEST(Gp, LogLikelihoodMatchesNaiveFormula) {
  Rng rng(3);
  for (int D : {1, 4}) {
    const int N = 35;
    const MatrixXd X = RandomMatrix(rng, N, D, -2.0, 2.0);
    const VectorXd y = RandomVector(rng, N, -2.0, 2.0);
    const VectorXd h = RandomH(rng, D);
    Gp gp(D);
    gp.set_h_params(h);
    gp.compute(X, y);
    const MatrixXd K = NaiveK(X, h, true);
    const Eigen::FullPivLU<MatrixXd> lu(K);
    const double logdet = lu.matrixLU().diagonal().array().abs().log().sum();
    const double naive = -0.5 * y.dot(lu.solve(y)) - 0.5 * logdet - 0.5 * N * std::log(2 * std::numbers::pi);
    EXPECT_NEAR(gp.log_marginal_likelihood(), naive, 1e-9 * std::max(1.0, std::abs(naive)));
  }
}

// 3. Analytic gradient equals central finite differences for all D + 2 parameters.
TEST(Gp, GradientMatchesFiniteDifferences) {
  Rng rng(4);
  for (int D : {1, 3, 7}) {
    for (int rep = 0; rep < 2; ++rep) {
      const int N = 60;
      const MatrixXd X = RandomMatrix(rng, N, D, -2.0, 2.0).rowwise() + VectorXd::Constant(D, 5.0).transpose();
      const VectorXd y = RandomVector(rng, N, -1.5, 1.5);
      const VectorXd h = RandomH(rng, D);
      Gp gp(D);
      gp.set_h_params(h);
      gp.compute(X, y);
      const VectorXd g = gp.log_marginal_likelihood_gradient();
      ASSERT_EQ(g.size(), D + 2);
      const double eps = 1e-5;
      for (int j = 0; j < D + 2; ++j) {
        VectorXd hp = h, hm = h;
        hp[j] += eps;
        hm[j] -= eps;
        gp.set_h_params(hp);
        const double fp = gp.log_marginal_likelihood();
        gp.set_h_params(hm);
        const double fm = gp.log_marginal_likelihood();
        const double fd = (fp - fm) / (2 * eps);
        EXPECT_NEAR(g[j], fd, 1e-5 * std::max(1.0, std::abs(fd))) << "D=" << D << " j=" << j;
      }
    }
  }
}

// 4. iRprop- recovers the length scales of data drawn from a known GP (D = 2, l = (0.3, 3.0),
// sigma_f = 1, sigma_n^2 = 0.01, N = 200 in [-2, 2]^2). Over 30 seeds the maximum-likelihood estimate
// deviated from the truth by at most 13% (l_1) and 32% (l_2, poorly identified on a domain of width 4),
// hence the tolerances 20% and 35%; the default start (l = 1) is 233% / 67% away.
TEST(Gp, RpropRecoversLengthScales) {
  for (std::uint64_t seed : {20180521ULL, 2ULL, 3ULL}) {
    Rng rng(seed);
    const int N = 200, D = 2;
    const MatrixXd X = RandomMatrix(rng, N, D, -2.0, 2.0);
    VectorXd h_true(D + 2);
    h_true << std::log(0.3), std::log(3.0), 0.0, 0.5 * std::log(0.01);
    const Eigen::LLT<MatrixXd> chol(NaiveK(X, h_true, true));
    ASSERT_EQ(chol.info(), Eigen::Success);
    VectorXd z(N);
    for (int i = 0; i < N; ++i) z[i] = rng.normal();
    const VectorXd y = chol.matrixL() * z;

    Gp gp(D);
    gp.compute(X, y);
    const double initial = gp.log_marginal_likelihood();
    const drops::gp::RpropSummary s = gp.optimize_h_params();
    const VectorXd h = gp.h_params();
    const double l1 = std::exp(h[0]), l2 = std::exp(h[1]);
    EXPECT_NEAR(l1, 0.3, 0.20 * 0.3) << "seed " << seed << " h = " << h.transpose();
    EXPECT_NEAR(l2, 3.0, 0.35 * 3.0) << "seed " << seed << " h = " << h.transpose();
    EXPECT_NEAR(gp.noise_variance(), 0.01, 0.4 * 0.01) << "seed " << seed;
    EXPECT_GE(s.final_log_likelihood, initial);
    EXPECT_GT(s.final_log_likelihood, initial + 10.0);  // the default start is far from the optimum
    EXPECT_DOUBLE_EQ(s.initial_log_likelihood, initial);
    EXPECT_NEAR(gp.log_marginal_likelihood(), s.final_log_likelihood, 1e-9);
    EXPECT_GE(s.iterations, 1);
    EXPECT_LE(s.iterations, 300);
    EXPECT_EQ(s.cholesky_failures, 0);
    // At the optimum the gradient is small.
    EXPECT_LT(gp.log_marginal_likelihood_gradient().norm(), 1e-2) << "seed " << seed;
  }
}

TEST(Gp, RpropOptionsAndStopping) {
  drops::gp::RpropOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.eta_minus = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("eta_minus"), std::string::npos);
  o = {};
  o.max_iterations = 0;
  EXPECT_FALSE(o.IsValid(nullptr));

  Rng rng(5);
  const MatrixXd X = RandomMatrix(rng, 40, 2, -2.0, 2.0);
  VectorXd y(40);
  for (int i = 0; i < 40; ++i) y[i] = std::sin(2 * X(i, 0)) + 0.05 * rng.normal();
  Gp gp(2);
  EXPECT_THROW(gp.optimize_h_params(), drops::InvalidArgument);  // no data
  gp.compute(X, y);
  EXPECT_THROW(gp.optimize_h_params(o), drops::InvalidArgument);

  drops::gp::RpropOptions few;
  few.max_iterations = 5;
  EXPECT_EQ(gp.optimize_h_params(few).iterations, 5);

  drops::gp::RpropOptions early;
  early.max_iterations = 1000;
  early.tolerance = 1e-3;
  early.patience = 5;
  const auto s = gp.optimize_h_params(early);
  EXPECT_LT(s.iterations, 1000);
  EXPECT_GE(s.final_log_likelihood, s.initial_log_likelihood);
}

// A search stopped by max_iterations and continued with a state (RpropState) takes exactly the
// steps of the uninterrupted search: the same kernels bit for bit, the same likelihood and
// iteration count, also for a search that finishes by its tolerance within the continuation's
// budget; a finished search stays finished.
TEST(Gp, AContinuedRpropSearchEqualsTheUninterruptedOne) {
  Rng rng(11);
  const MatrixXd X = RandomMatrix(rng, 60, 3, -2.0, 2.0);
  VectorXd y(60);
  for (int i = 0; i < 60; ++i) y[i] = std::sin(2 * X(i, 0)) * X(i, 1) + 0.05 * rng.normal();
  for (const double tolerance : {0.0, 1e-3}) {
    drops::gp::RpropOptions all;
    all.max_iterations = 40;
    all.tolerance = tolerance;
    Gp straight(3);
    straight.compute(X, y);
    const auto s = straight.optimize_h_params(all);

    for (const int first : {1, 7, 20}) {
      Gp a(3);
      a.compute(X, y);
      drops::gp::RpropState state;
      drops::gp::RpropOptions part = all;
      part.max_iterations = first;
      const auto s1 = a.optimize_h_params(part, &state);
      EXPECT_TRUE(state.started);
      EXPECT_EQ(s1.iterations, std::min(first, s.iterations));
      Gp b(3);  // a new GP on the same data, another start: the state decides where it goes on
      b.compute(X, y);
      const auto s2 = b.optimize_h_params(all, &state);
      EXPECT_EQ(b.h_params(), straight.h_params()) << "tolerance " << tolerance << " first " << first;
      EXPECT_EQ(s2.final_log_likelihood, s.final_log_likelihood);
      EXPECT_EQ(s2.iterations, s.iterations);
      EXPECT_EQ(s2.initial_log_likelihood, s.initial_log_likelihood);
    }
  }
  // A finished search (tolerance) does not move when continued with a larger budget.
  drops::gp::RpropOptions early;
  early.max_iterations = 1000;
  early.tolerance = 1e-3;
  early.patience = 5;
  Gp gp(3);
  gp.compute(X, y);
  drops::gp::RpropState state;
  const auto s = gp.optimize_h_params(early, &state);
  ASSERT_LT(s.iterations, 1000);
  EXPECT_TRUE(state.finished);
  const VectorXd h = gp.h_params();
  early.max_iterations = 2000;
  EXPECT_EQ(gp.optimize_h_params(early, &state).iterations, s.iterations);
  EXPECT_EQ(gp.h_params(), h);
  // A state of another dimension is refused.
  Gp other(2);
  other.compute(X.leftCols(2), y);
  EXPECT_THROW(other.optimize_h_params(early, &state), drops::InvalidArgument);
}

// PILCO's soft walls (RpropOptions::penalty). Noise-free targets on 3 distinct inputs drive the
// plain fit to sigma_n at its floor (signal-to-noise ratio ~1e5); with the walls the ratio stays
// near max_snr (a soft wall: within 1.5x against 60 noise-free points) and the length scale near
// [s / ratio, ratio s]. The reported likelihood is the plain
// one, and the walls' value is reported separately.
TEST(Gp, RpropSoftWallsBoundTheSignalToNoiseRatioAndLengthScales) {
  MatrixXd X(60, 1);
  for (int i = 0; i < 60; ++i) X(i, 0) = std::floor(i / 20);
  VectorXd y(60);
  for (int i = 0; i < 60; ++i) y[i] = X(i, 0);
  const double s = std::sqrt((X.array() - X.mean()).square().sum() / 59.0);

  Gp plain(1);
  plain.compute(X, y);
  const auto sp = plain.optimize_h_params();
  const VectorXd hp = plain.h_params();
  EXPECT_GT(std::exp(hp[1] - hp[2]), 1e4) << hp.transpose();  // interpolates exactly
  EXPECT_EQ(sp.final_penalty, 0.0);

  drops::gp::RpropOptions o;
  o.penalty = true;
  o.max_snr = 50.0;
  o.max_length_scale_ratio = 2.0;
  Gp walled(1);
  walled.compute(X, y);
  const auto sw = walled.optimize_h_params(o);
  const VectorXd hw = walled.h_params();
  EXPECT_LT(std::exp(hw[1] - hw[2]), 50.0 * 1.5) << hw.transpose();
  EXPECT_GT(std::exp(hw[1] - hw[2]), 50.0 / 1.5) << hw.transpose();  // pushed against the wall
  EXPECT_GT(std::exp(hw[0]), s / 2.0 / 1.5);
  EXPECT_LT(std::exp(hw[0]), 2.0 * s * 1.5);
  EXPECT_NEAR(sw.final_log_likelihood, walled.log_marginal_likelihood(), 1e-9);
  EXPECT_LT(sw.final_log_likelihood, sp.final_log_likelihood);
  // The walls' value: sum_d ((log l_d - log s_d) / log ratio)^30 + ((log sf - log sn) / log snr)^30.
  const double expected = std::pow((hw[0] - std::log(s)) / std::log(2.0), 30) +
                          std::pow((hw[1] - hw[2]) / std::log(50.0), 30);
  EXPECT_NEAR(sw.final_penalty, expected, 1e-9 * (1.0 + expected));

  // Inside the walls they change nothing that matters: a well-posed fit ends where the plain one
  // does (the RpropRecoversLengthScales problem, l = (0.3, 3), sigma_f / sigma_n = 10).
  Rng rng(20180521ULL);
  const MatrixXd X2 = RandomMatrix(rng, 200, 2, -2.0, 2.0);
  VectorXd h_true(4);
  h_true << std::log(0.3), std::log(3.0), 0.0, 0.5 * std::log(0.01);
  const Eigen::LLT<MatrixXd> chol(NaiveK(X2, h_true, true));
  VectorXd z(200);
  for (int i = 0; i < 200; ++i) z[i] = rng.normal();
  const VectorXd y2 = chol.matrixL() * z;
  Gp a(2), b(2);
  a.compute(X2, y2);
  b.compute(X2, y2);
  a.optimize_h_params();
  o = {};
  o.penalty = true;
  b.optimize_h_params(o);
  EXPECT_LT((a.h_params() - b.h_params()).cwiseAbs().maxCoeff(), 1e-2)
      << a.h_params().transpose() << " vs " << b.h_params().transpose();

  o = {};
  o.power = 3;
  EXPECT_FALSE(o.IsValid(nullptr));
  o = {};
  o.max_snr = 1.0;
  EXPECT_FALSE(o.IsValid(nullptr));
}

TEST(Gp, RpropOnDegenerateDataStaysInTheBox) {
  // Many duplicated inputs and noise-free targets: the likelihood keeps increasing as sigma_n -> 0 and
  // sigma_f grows; the search must stay finite, inside its box (noise std >= 1e-5, |log| <= 10), and
  // keep the best iterate.
  Rng rng(6);
  MatrixXd X(60, 1);
  for (int i = 0; i < 60; ++i) X(i, 0) = std::floor(i / 20);  // 3 distinct inputs, 20 copies each
  VectorXd y(60);
  for (int i = 0; i < 60; ++i) y[i] = X(i, 0);  // exact, no noise
  Gp gp(1);
  gp.compute(X, y);
  const double initial = gp.log_marginal_likelihood();
  drops::gp::RpropSummary s;
  ASSERT_NO_THROW(s = gp.optimize_h_params());
  EXPECT_GE(s.final_log_likelihood, initial);
  EXPECT_NEAR(gp.log_marginal_likelihood(), s.final_log_likelihood, 1e-9);
  const VectorXd h = gp.h_params();
  EXPECT_GE(h[2], std::log(1e-5) - 1e-12);  // noise clamp
  EXPECT_LE(h.head(2).cwiseAbs().maxCoeff(), 10.0 + 1e-12);
  EXPECT_TRUE(h.allFinite());
}

// 5. Jitter and input validation.
TEST(Gp, DuplicatedInputsWithTinyNoiseFactorise) {
  MatrixXd X(6, 2);
  X << 0, 0, 0, 0, 1, 1, 1, 1, 0.5, 0.5, 0.5, 0.5;
  VectorXd y(6);
  y << 1, 1, 2, 2, 3, 3;
  Gp gp(2);
  VectorXd h = gp.h_params();
  h[3] = std::log(1e-12);  // sigma_n^2 = 1e-24: K is singular without jitter
  gp.set_h_params(h);
  ASSERT_NO_THROW(gp.compute(X, y));
  EXPECT_TRUE(gp.alpha().allFinite());
  double mean, var;
  gp.predict(X.row(0).transpose(), mean, var);
  EXPECT_NEAR(mean, 1.0, 1e-3);
  EXPECT_GE(var, 0.0);
  EXPECT_TRUE(std::isfinite(gp.log_marginal_likelihood()));
}

TEST(Gp, CholeskyFailureAfterJitterThrowsNumericalError) {
  // Huge signal variance with zero-ish noise and duplicates: jitter up to 1e-4 is not enough.
  MatrixXd X(4, 1);
  X << 0, 0, 0, 0;
  VectorXd y = VectorXd::Ones(4);
  Gp gp(1);
  VectorXd h(3);
  h << 0.0, 20.0, std::log(1e-12);  // sigma_f^2 = e^40
  gp.set_h_params(h);
  try {
    gp.compute(X, y);
    FAIL() << "expected NumericalError";
  } catch (const drops::NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("Cholesky"), std::string::npos);
  }
  EXPECT_EQ(gp.size(), 0);  // state untouched
}

TEST(Gp, InvalidInputsThrow) {
  Gp gp(2);
  MatrixXd X = MatrixXd::Zero(3, 2);
  X(1, 0) = 1.0;
  X(2, 1) = 1.0;
  VectorXd y = VectorXd::Ones(3);
  MatrixXd Xnan = X;
  Xnan(1, 1) = std::nan("");
  EXPECT_THROW(gp.compute(Xnan, y), drops::InvalidArgument);
  VectorXd ynan = y;
  ynan[2] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(gp.compute(X, ynan), drops::InvalidArgument);
  EXPECT_THROW(gp.compute(X, VectorXd::Ones(4)), drops::InvalidArgument);
  EXPECT_THROW(gp.compute(MatrixXd::Zero(3, 3), y), drops::InvalidArgument);
  try {
    gp.compute(X, VectorXd::Ones(4));
  } catch (const drops::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("expected size 3, got 4"), std::string::npos) << e.what();
  }
  gp.compute(X, y);
  EXPECT_THROW(gp.set_targets(VectorXd::Ones(2)), drops::InvalidArgument);
  EXPECT_THROW(gp.set_h_params(VectorXd::Zero(3)), drops::InvalidArgument);
  EXPECT_THROW(gp.set_h_params(VectorXd::Constant(4, std::nan(""))), drops::InvalidArgument);
  EXPECT_THROW(gp.set_h_params(VectorXd::Constant(4, 1000.0)), drops::InvalidArgument);
  double m, v;
  EXPECT_THROW(gp.predict(VectorXd::Zero(3), m, v), drops::InvalidArgument);
  VectorXd mb, vb;
  EXPECT_THROW(gp.predict_batch(MatrixXd::Zero(4, 3), mb, vb), drops::InvalidArgument);
}

// 6. set_targets gives the same alpha and likelihood as a full compute.
TEST(Gp, SetTargetsMatchesCompute) {
  Rng rng(7);
  const MatrixXd X = RandomMatrix(rng, 50, 3, -2.0, 2.0);
  const VectorXd y1 = RandomVector(rng, 50, -1.0, 1.0);
  const VectorXd y2 = RandomVector(rng, 50, -3.0, 3.0);
  Gp a(3), b(3);
  const VectorXd h = RandomH(rng, 3);
  a.set_h_params(h);
  b.set_h_params(h);
  a.compute(X, y1);
  a.set_targets(y2);
  b.compute(X, y2);
  EXPECT_LT((a.alpha() - b.alpha()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(a.log_marginal_likelihood(), b.log_marginal_likelihood(), 1e-10);
  EXPECT_LT((a.log_marginal_likelihood_gradient() - b.log_marginal_likelihood_gradient()).norm(), 1e-9);
  double ma, va, mb, vb;
  a.predict(VectorXd::Constant(3, 0.3), ma, va);
  b.predict(VectorXd::Constant(3, 0.3), mb, vb);
  EXPECT_NEAR(ma, mb, 1e-12);
  EXPECT_NEAR(va, vb, 1e-12);
  // and it really changed something
  Gp c(3);
  c.set_h_params(h);
  c.compute(X, y1);
  EXPECT_GT((c.alpha() - a.alpha()).norm(), 1e-3);
}

// Per-query weights: query q's mean is that of the GP of the targets whose weights it is given
// (oracle: a copy with set_targets, which refactorises nothing), its variance unchanged, for batch
// sizes that exercise every pack split and for a kernel without the SIMD path.
TEST(Gp, PredictionsWithAQuerysOwnWeightsAreThoseOfTheGpOfItsTargets) {
  Rng rng(11);
  const MatrixXd X = RandomMatrix(rng, 60, 3, -2.0, 2.0);
  const VectorXd y = RandomVector(rng, 60, -1.0, 1.0);
  const VectorXd y2 = RandomVector(rng, 60, -3.0, 3.0);
  const VectorXd h = RandomH(rng, 3);
  Gp se(3);
  se.set_h_params(h);
  Gp matern(drops::gp::Matern52(1.3, 0.8, 3));
  for (Gp* base : {&se, &matern}) {
    Gp& gp = *base;
    gp.compute(X, y);
    Gp other = gp;
    other.set_targets(y2);
    EXPECT_EQ(gp.solve(y), gp.alpha());  // the same solves, the same bits
    MatrixXd weights(60, 2);
    weights.col(0) = gp.alpha();
    weights.col(1) = gp.solve(y2);
    for (const int B : {1, 3, 8, 13}) {
      const MatrixXd Q = RandomMatrix(rng, B, 3, -2.5, 2.5);
      std::vector<int> columns(static_cast<std::size_t>(B));
      for (int q = 0; q < B; ++q) columns[static_cast<std::size_t>(q)] = (q * 7 + B) % 2;
      VectorXd m, v, m0, v0, m2, v2;
      gp.predict_batch(Q, weights, columns, m, v);
      gp.predict_batch(Q, m0, v0);
      other.predict_batch(Q, m2, v2);
      for (int q = 0; q < B; ++q) {
        const bool own = columns[static_cast<std::size_t>(q)] == 0;
        if (base == &se) {  // the SIMD kernel: the same operations, the same bits
          EXPECT_EQ(m[q], own ? m0[q] : m2[q]) << "B " << B << " query " << q;
        } else {  // Eigen's product against one dot product per query: round-off apart
          EXPECT_NEAR(m[q], own ? m0[q] : m2[q], 1e-12) << "B " << B << " query " << q;
        }
        EXPECT_EQ(v[q], v0[q]);
      }
      if (B == 13) EXPECT_GT((m2 - m0).cwiseAbs().maxCoeff(), 1e-3);  // the targets matter
    }
    VectorXd m, v;
    const MatrixXd Q = RandomMatrix(rng, 2, 3, -1.0, 1.0);
    EXPECT_THROW(gp.predict_batch(Q, weights, {0, 2}, m, v), drops::InvalidArgument);
    EXPECT_THROW(gp.predict_batch(Q, weights, {0}, m, v), drops::InvalidArgument);
    EXPECT_THROW(gp.predict_batch(Q, weights.topRows(59), {0, 1}, m, v), drops::InvalidArgument);
    EXPECT_THROW(gp.solve(VectorXd::Ones(59)), drops::InvalidArgument);
  }
}

// A GP with subset variances (got) at query batches of 1, 3, 8 and 13 random rows, through
// predict_batch, predict_batch with its own alpha as weights and predict: the means are the
// exact GP's (bit for bit in batches), the variances the oracle's to 1e-10 and never below the
// exact ones. Returns the largest growth of a variance over the exact one.
double ExpectSubsetPredictions(const Gp& got, const Gp& oracle, const Gp& exact, Rng& rng) {
  const int D = got.input_dim();
  const int N = got.size();
  double worse = 0.0;
  for (const int B : {1, 3, 8, 13}) {
    const MatrixXd Q = RandomMatrix(rng, B, D, -2.5, 2.5);
    VectorXd m, v, m_ex, v_ex, m_or, v_or, m_w, v_w;
    got.predict_batch(Q, m, v);
    exact.predict_batch(Q, m_ex, v_ex);
    oracle.predict_batch(Q, m_or, v_or);
    MatrixXd weights(N, 1);
    weights.col(0) = got.alpha();
    got.predict_batch(Q, weights, std::vector<int>(static_cast<std::size_t>(B), 0), m_w, v_w);
    for (int q = 0; q < B; ++q) {
      EXPECT_EQ(m[q], m_ex[q]) << "B " << B << " query " << q;  // means: every point
      EXPECT_NEAR(v[q], v_or[q], 1e-10) << "B " << B << " query " << q;
      EXPECT_GE(v[q], v_ex[q] - 1e-12) << "B " << B << " query " << q;
      EXPECT_EQ(v_w[q], v[q]);
      double pm = 0, pv = 0;
      got.predict(Q.row(q).transpose(), pm, pv);
      EXPECT_NEAR(pm, m_ex[q], 1e-12);
      EXPECT_NEAR(pv, v_or[q], 1e-10);
      worse = std::max(worse, v[q] - v_ex[q]);
    }
  }
  return worse;
}

// Subset-of-data variances (set_variance_points): the oracle is a GP with the same
// hyper-parameters on the last m points alone. Its variances are the subset GP's, the full GP's
// means are kept, no variance falls below the exact one, and with N <= m nothing changes (bits).
// Both the SIMD kernel (SE-ARD, batch sizes around its packs) and Eigen (Matern) paths, through
// predict, predict_batch and predict_batch with weights; the setting survives refactorisations.
TEST(Gp, SubsetVariancesAreThoseOfTheGpOfTheLastMPointsAndMeansStayExact) {
  Rng rng(12);
  const int N = 70, m = 25, D = 3;
  const MatrixXd X = RandomMatrix(rng, N, D, -2.0, 2.0);
  const VectorXd y = RandomVector(rng, N, -1.0, 1.0);
  Gp se(D);
  se.set_h_params(RandomH(rng, D));
  Gp matern(drops::gp::Matern52(1.3, 0.8, D));
  for (Gp* base : {&se, &matern}) {
    Gp exact = *base;
    exact.compute(X, y);
    Gp sub = exact;
    sub.set_variance_points(m);
    EXPECT_EQ(sub.variance_points(), m);
    Gp last = *base;  // the oracle: the last m points alone
    last.compute(X.bottomRows(m), y.tail(m));
    // the subset is not the whole: some variance must grow
    EXPECT_GT(ExpectSubsetPredictions(sub, last, exact, rng), 1e-3);
    // Refactorisations keep the subset: set_h_params, optimize_h_params, compute.
    Gp refit = sub;
    refit.optimize_h_params(drops::gp::RpropOptions{.max_iterations = 20});
    Gp refit_last = *base;
    refit_last.set_h_params(refit.h_params());
    refit_last.compute(X.bottomRows(m), y.tail(m));
    const MatrixXd Q = RandomMatrix(rng, 9, D, -2.0, 2.0);
    VectorXd m1, v1, m2, v2;
    refit.predict_batch(Q, m1, v1);
    refit_last.predict_batch(Q, m2, v2);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-10);
    // N <= m: the exact GP, bit for bit (predict_batch and predict).
    Gp small = *base;
    small.set_variance_points(N);
    small.compute(X, y);
    VectorXd m3, v3, m4, v4;
    small.predict_batch(Q, m3, v3);
    exact.predict_batch(Q, m4, v4);
    EXPECT_EQ(m3, m4);
    EXPECT_EQ(v3, v4);
    double a = 0, b = 0, c = 0, d = 0;
    small.predict(Q.row(0).transpose(), a, b);
    exact.predict(Q.row(0).transpose(), c, d);
    EXPECT_EQ(a, c);
    EXPECT_EQ(b, d);
    // Back to every point.
    sub.set_variance_points(0);
    VectorXd m5, v5;
    sub.predict_batch(Q, m5, v5);
    EXPECT_EQ(v5, v4);
  }
  EXPECT_THROW(se.set_variance_points(-1), drops::InvalidArgument);
}

// greedy_variance_subset against a naive greedy search: at each step every remaining row's
// latent variance given the rows chosen so far is recomputed from scratch (a dense solve per
// GP), in units of the GP's signal variance and summed; the largest is chosen. Two GPs with
// different kernels share the inputs. A repeated input (noise far below the tolerance) is not
// chosen twice, and with m at least the distinct rows the selection stops at them.
TEST(Gp, GreedyVarianceSubsetMatchesANaiveGreedySearch) {
  Rng rng(31);
  const int N = 30, D = 2, m = 9;
  const MatrixXd X = RandomMatrix(rng, N, D, -2, 2);
  std::vector<Gp> gps(2, Gp(D));
  std::vector<VectorXd> hs;
  for (auto& g : gps) {
    hs.push_back(RandomH(rng, D));
    g.set_h_params(hs.back());
  }
  const auto naive = [&](const MatrixXd& Xs, int count) {
    std::vector<int> chosen;
    for (int k = 0; k < count; ++k) {
      int best = -1;
      double best_score = -1.0;
      for (int j = 0; j < Xs.rows(); ++j) {
        if (std::find(chosen.begin(), chosen.end(), j) != chosen.end()) continue;
        double score = 0.0;
        for (const VectorXd& h : hs) {
          const double sf2 = std::exp(2.0 * h[D]);
          double v = sf2;
          if (!chosen.empty()) {
            MatrixXd S(static_cast<int>(chosen.size()), D);
            for (std::size_t c = 0; c < chosen.size(); ++c)
              S.row(static_cast<int>(c)) = Xs.row(chosen[c]);
            VectorXd kj(S.rows());
            for (int c = 0; c < S.rows(); ++c)
              kj[c] = NaiveKernel(S.row(c).transpose(), Xs.row(j).transpose(), h);
            v -= kj.dot(NaiveK(S, h, true).llt().solve(kj));
          }
          score += v / sf2;
        }
        if (score > best_score) best_score = score, best = j;
      }
      chosen.push_back(best);
    }
    std::sort(chosen.begin(), chosen.end());
    return chosen;
  };
  EXPECT_EQ(drops::gp::greedy_variance_subset(X, gps, m), naive(X, m));
  std::vector<int> all(N);
  for (int i = 0; i < N; ++i) all[static_cast<std::size_t>(i)] = i;
  EXPECT_EQ(drops::gp::greedy_variance_subset(X, gps, N), all);
  EXPECT_EQ(drops::gp::greedy_variance_subset(X, gps, 0), all);

  // Copies: 8 distinct rows, each repeated, with noise 1e-12 of the signal variance.
  MatrixXd R(24, D);
  for (int i = 0; i < 24; ++i) R.row(i) = X.row(i % 8);
  for (std::size_t g = 0; g < gps.size(); ++g) {
    hs[g][D + 1] = hs[g][D] - 0.5 * std::log(1e12);
    gps[g].set_h_params(hs[g]);
  }
  const std::vector<int> first8{0, 1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(drops::gp::greedy_variance_subset(R, gps, 20), first8);
  EXPECT_EQ(drops::gp::greedy_variance_subset(R, gps, 6), naive(R.topRows(8), 6));

  EXPECT_THROW(drops::gp::greedy_variance_subset(MatrixXd::Zero(12, 3), gps, 4),
               drops::InvalidArgument);
  EXPECT_THROW(drops::gp::greedy_variance_subset(X, gps, 4, -1.0), drops::InvalidArgument);
}

// Variances in mirror pairs (set_variance_pairs): the last 2h rows are h inputs and their
// reflections (signs flipped on some inputs, which leaves SE-ARD and Matern kernels unchanged).
// The oracle is set_variance_points(2 h), the dense subset: the same variances to round-off and
// the same means bit for bit, through predict, predict_batch (SIMD kernel and Eigen paths,
// batch sizes around the packs) and predict_batch with weights; with every row in pairs, the
// exact GP's variances. The setting survives refactorisations; rows that are not mirror pairs and
// h < 0 are refused with the GP unchanged.
TEST(Gp, PairedVariancesAreThoseOfTheDenseSubsetOfTheSameRows) {
  Rng rng(41);
  const int N0 = 23, h = 11, D = 3;
  const MatrixXd R = RandomMatrix(rng, N0, D, -2.0, 2.0);
  const MatrixXd P = RandomMatrix(rng, h, D, -2.0, 2.0);
  const VectorXd flip = (VectorXd(D) << -1.0, 1.0, -1.0).finished();
  const MatrixXd Pm = P * flip.asDiagonal();
  MatrixXd X(N0 + 2 * h, D);
  X << R, P, Pm;
  const int N = static_cast<int>(X.rows());
  const VectorXd y = RandomVector(rng, N, -1.0, 1.0);
  MatrixXd Xp(2 * h, D);  // every row in pairs
  Xp << P, Pm;
  const VectorXd yp = y.tail(2 * h);
  Gp se(D);
  se.set_h_params(RandomH(rng, D));
  Gp matern(drops::gp::Matern52(1.3, 0.8, D));
  for (Gp* base : {&se, &matern}) {
    Gp exact = *base;
    exact.compute(X, y);
    Gp dense = exact;
    dense.set_variance_points(2 * h);
    Gp paired = exact;
    paired.set_variance_pairs(h);
    EXPECT_EQ(paired.variance_pairs(), h);
    EXPECT_EQ(paired.variance_points(), 2 * h);
    EXPECT_GT(ExpectSubsetPredictions(paired, dense, exact, rng), 1e-3);  // a subset
    // Refactorisations keep the pairs.
    Gp refit = paired;
    refit.optimize_h_params(drops::gp::RpropOptions{.max_iterations = 20});
    EXPECT_EQ(refit.variance_pairs(), h);
    Gp refit_dense = dense;
    refit_dense.set_h_params(refit.h_params());
    const MatrixXd Q = RandomMatrix(rng, 9, D, -2.0, 2.0);
    VectorXd m1, v1, m2, v2;
    refit.predict_batch(Q, m1, v1);
    refit_dense.predict_batch(Q, m2, v2);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-10);
    // Every row in pairs: the exact variances, by blocks.
    Gp all = *base;
    all.compute(Xp, yp);
    Gp all_pairs = all;
    all_pairs.set_variance_pairs(h);
    VectorXd m3, v3, m4, v4;
    all_pairs.predict_batch(Q, m3, v3);
    all.predict_batch(Q, m4, v4);
    EXPECT_EQ(m3, m4);
    EXPECT_LT((v3 - v4).cwiseAbs().maxCoeff(), 1e-10);
    // set_variance_points ends the pairs.
    paired.set_variance_points(0);
    EXPECT_EQ(paired.variance_pairs(), 0);
    VectorXd m5, v5, m6, v6;
    paired.predict_batch(Q, m5, v5);
    exact.predict_batch(Q, m6, v6);
    EXPECT_EQ(v5, v6);
  }
  // Refused: h < 0, and rows that are not mirror pairs (the last 2h of the random rows R).
  Gp g = se;
  g.compute(R, y.head(N0));
  VectorXd m7, v7, m8, v8;
  const MatrixXd Q = RandomMatrix(rng, 5, D, -2.0, 2.0);
  g.predict_batch(Q, m7, v7);
  EXPECT_THROW(g.set_variance_pairs(-1), drops::InvalidArgument);
  try {
    g.set_variance_pairs(5);
    ADD_FAILURE() << "rows that are not mirror pairs were accepted";
  } catch (const drops::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("mirror images"), std::string::npos) << e.what();
  }
  EXPECT_EQ(g.variance_pairs(), 0);
  EXPECT_EQ(g.variance_points(), 0);
  g.predict_batch(Q, m8, v8);
  EXPECT_EQ(v7, v8);
}

// greedy_variance_pairs against a naive greedy search over pairs: at each step every remaining
// pair's latent variances (the row's and its image's) given the pairs chosen so far are
// recomputed from scratch (a dense solve per GP), in units of the GP's signal variance and
// summed; the largest is chosen.
TEST(Gp, GreedyVariancePairsMatchesANaiveGreedySearch) {
  Rng rng(37);
  const int n = 18, D = 3, h = 6;
  const MatrixXd P = RandomMatrix(rng, n, D, -2, 2);
  const VectorXd flip = (VectorXd(D) << 1.0, -1.0, -1.0).finished();
  MatrixXd X(2 * n, D);
  X << P, P * flip.asDiagonal();
  std::vector<Gp> gps(2, Gp(D));
  std::vector<VectorXd> hs;
  for (auto& g : gps) {
    hs.push_back(RandomH(rng, D));
    g.set_h_params(hs.back());
  }
  const auto latent = [&](const std::vector<int>& rows, int j, const VectorXd& hp) {
    const double sf2 = std::exp(2.0 * hp[D]);
    if (rows.empty()) return sf2;
    MatrixXd S(static_cast<int>(rows.size()), D);
    for (std::size_t c = 0; c < rows.size(); ++c) S.row(static_cast<int>(c)) = X.row(rows[c]);
    VectorXd kj(S.rows());
    for (int c = 0; c < S.rows(); ++c)
      kj[c] = NaiveKernel(S.row(c).transpose(), X.row(j).transpose(), hp);
    return sf2 - kj.dot(NaiveK(S, hp, true).llt().solve(kj));
  };
  std::vector<int> chosen, rows;
  for (int k = 0; k < h; ++k) {
    int best = -1;
    double best_score = -1.0;
    for (int j = 0; j < n; ++j) {
      if (std::find(chosen.begin(), chosen.end(), j) != chosen.end()) continue;
      double score = 0.0;
      for (const VectorXd& hp : hs)
        score += (latent(rows, j, hp) + latent(rows, n + j, hp)) / std::exp(2.0 * hp[D]);
      if (score > best_score) best_score = score, best = j;
    }
    chosen.push_back(best);
    rows.push_back(best);
    rows.push_back(n + best);
  }
  std::sort(chosen.begin(), chosen.end());
  EXPECT_EQ(drops::gp::greedy_variance_pairs(X, gps, h), chosen);
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  EXPECT_EQ(drops::gp::greedy_variance_pairs(X, gps, n), all);
  EXPECT_EQ(drops::gp::greedy_variance_pairs(X, gps, 0), all);
  EXPECT_THROW(drops::gp::greedy_variance_pairs(X.topRows(2 * n - 1), gps, 3),
               drops::InvalidArgument);
  EXPECT_THROW(drops::gp::greedy_variance_pairs(MatrixXd::Zero(12, 2), gps, 3),
               drops::InvalidArgument);
  EXPECT_THROW(drops::gp::greedy_variance_pairs(X, gps, 3, -1.0), drops::InvalidArgument);
}

// 7. N = 0 predicts the prior.
TEST(Gp, EmptyGpPredictsPrior) {
  Gp gp(3);
  VectorXd h = gp.h_params();
  h[3] = std::log(1.5);
  gp.set_h_params(h);
  gp.compute(MatrixXd(0, 3), VectorXd(0));
  EXPECT_EQ(gp.size(), 0);
  double m = -1, v = -1;
  gp.predict(VectorXd::Ones(3), m, v);
  EXPECT_EQ(m, 0.0);
  EXPECT_NEAR(v, 2.25, 1e-14);
  VectorXd mb, vb;
  gp.predict_batch(MatrixXd::Ones(4, 3), mb, vb);
  ASSERT_EQ(mb.size(), 4);
  EXPECT_EQ(mb.norm(), 0.0);
  EXPECT_NEAR((vb.array() - 2.25).abs().maxCoeff(), 0.0, 1e-14);
  EXPECT_EQ(gp.log_marginal_likelihood(), 0.0);
  EXPECT_EQ(gp.log_marginal_likelihood_gradient().norm(), 0.0);
  // Default-constructed GP (never computed) too.
  Gp fresh(2);
  fresh.predict(VectorXd::Zero(2), m, v);
  EXPECT_EQ(m, 0.0);
  EXPECT_NEAR(v, 1.0, 1e-15);
}

TEST(Gp, SetHParamsRefactorisesAndPredictBatchHandlesLargeBatches) {
  Rng rng(8);
  const MatrixXd X = RandomMatrix(rng, 120, 7, -1.0, 1.0);
  const VectorXd y = RandomVector(rng, 120, -1.0, 1.0);
  const VectorXd h = RandomH(rng, 7);
  Gp a(7), b(7);
  a.compute(X, y);
  a.set_h_params(h);  // after compute
  b.set_h_params(h);  // before compute
  b.compute(X, y);
  EXPECT_NEAR(a.log_marginal_likelihood(), b.log_marginal_likelihood(), 1e-10);
  EXPECT_LT((a.h_params() - h).norm(), 1e-14);
  const MatrixXd Xq = RandomMatrix(rng, 100, 7, -1.5, 1.5);
  VectorXd mb, vb;
  a.predict_batch(Xq, mb, vb);
  for (int q = 0; q < 100; ++q) {
    double m, v;
    a.predict(Xq.row(q).transpose(), m, v);
    EXPECT_NEAR(mb[q], m, 1e-10);
    EXPECT_NEAR(vb[q], v, 1e-10);
  }
}

}  // namespace

// Resume relies on it: a GP rebuilt from h_params() on the same data predicts bit for bit like the
// original, whatever h is (log(exp(h)) would not round-trip exactly on every instruction set).
TEST(Gp, HParamsRoundTripIsExact) {
  Rng rng(11);
  const MatrixXd X = RandomMatrix(rng, 40, 3, -2, 2);
  const VectorXd y = RandomVector(rng, 40, -1, 1);
  const MatrixXd Xq = RandomMatrix(rng, 9, 3, -2, 2);
  for (int trial = 0; trial < 20; ++trial) {
    const VectorXd h = RandomVector(rng, 5, -1.5, 1.0);
    Gp a(3);
    a.set_h_params(h);
    EXPECT_EQ(a.h_params(), h);
    a.compute(X, y);
    a.optimize_h_params({});  // Rprop leaves the GP at its best iterate
    Gp b(3);
    b.set_h_params(a.h_params());
    b.compute(X, y);
    EXPECT_EQ(b.h_params(), a.h_params());
    VectorXd ma, va, mb, vb;
    a.predict_batch(Xq, ma, va);
    b.predict_batch(Xq, mb, vb);
    EXPECT_EQ(ma, mb) << "trial " << trial;
    EXPECT_EQ(va, vb) << "trial " << trial;
    EXPECT_EQ(a.log_marginal_likelihood(), b.log_marginal_likelihood());
  }
}
