// The FITC sparse GP block (pilco::fitc_block), the values of a block (pilco::block_values) and
// PILCO's task description (pilco::TaskModel), against closed forms and dense oracles.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/gp.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "drops/pilco/se_model.hpp"
#include "drops/pilco/task_model.hpp"
#include "pilco_test_util.hpp"

namespace {

using drops::Rng;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace pilco_test;

MatrixXd Se(const MatrixXd& A, const MatrixXd& B, const VectorXd& l, double sf2) {
  MatrixXd K(A.rows(), B.rows());
  for (int i = 0; i < A.rows(); ++i)
    for (int j = 0; j < B.rows(); ++j)
      K(i, j) =
          sf2 * std::exp(-0.5 * ((A.row(i) - B.row(j)).transpose().cwiseQuotient(l)).squaredNorm());
  return K;
}

struct Problem {
  MatrixXd X, Xq;
  VectorXd y, l;
  double sf2 = 0.8, sn2 = 0.01;
};

Problem MakeProblem(int N, int D, std::uint64_t seed) {
  Rng rng(seed);
  Problem p;
  p.X = RandomMatrix(rng, N, D, -2.0, 2.0);
  p.Xq = RandomMatrix(rng, 7, D, -2.5, 2.5);
  p.y = (p.X.rowwise().sum()).array().sin().matrix();
  for (int i = 0; i < N; ++i) p.y[i] += 0.1 * rng.normal();
  p.l = RandomVector(rng, D, 0.7, 1.4);
  return p;
}

}  // namespace

TEST(PilcoFitc, WithEveryTrainingInputAsInducingInputIsTheFullGp) {
  const Problem p = MakeProblem(40, 3, 1);
  const auto b = drops::pilco::fitc_block(p.X, p.y, p.X, p.l, p.sf2, p.sn2, 0.0);
  drops::gp::Gp gp(3);
  VectorXd h(5);
  h << p.l.array().log().matrix(), 0.5 * std::log(p.sf2), 0.5 * std::log(p.sn2);
  gp.set_h_params(h);
  gp.compute(p.X, p.y);
  const auto full = drops::pilco::gp_block(gp);
  EXPECT_LT((b.weights - full.weights).cwiseAbs().maxCoeff(),
            1e-7 * full.weights.cwiseAbs().maxCoeff());
  EXPECT_LT((b.k_inverse - full.k_inverse).cwiseAbs().maxCoeff(),
            1e-7 * full.k_inverse.cwiseAbs().maxCoeff());
}

TEST(PilcoFitc, MatchesTheDenseFitcPredictiveMeanAndVariance) {
  // Snelson & Ghahramani (2006) written with explicit inverses: Q = Knm Kmm^-1 Kmn,
  // Lambda = diag(K - Q) + sigma_n^2 I, mean = k*m (Kmm + Kmn Lambda^-1 Knm)^-1 Kmn Lambda^-1 y,
  // variance = k** - k*m (Kmm^-1 - (Kmm + Kmn Lambda^-1 Knm)^-1) km*.
  const Problem p = MakeProblem(60, 2, 2);
  const MatrixXd Z = p.X.topRows(12);
  const double jitter = 1e-6;
  const auto b = drops::pilco::fitc_block(p.X, p.y, Z, p.l, p.sf2, p.sn2, jitter);
  MatrixXd Kmm = Se(Z, Z, p.l, p.sf2);
  Kmm.diagonal().array() += jitter * p.sf2;
  const MatrixXd Kmn = Se(Z, p.X, p.l, p.sf2);
  const MatrixXd Kmm_inv = Kmm.inverse();
  const VectorXd lam =
      (VectorXd::Constant(60, p.sf2) - (Kmn.transpose() * Kmm_inv * Kmn).diagonal()).array() +
      p.sn2;
  const MatrixXd Sig = (Kmm + Kmn * lam.cwiseInverse().asDiagonal() * Kmn.transpose()).inverse();
  const VectorXd w = Sig * Kmn * lam.cwiseInverse().asDiagonal() * p.y;
  const MatrixXd Ksq = Se(p.Xq, Z, p.l, p.sf2);
  const VectorXd mean = Ksq * w;
  const VectorXd var =
      VectorXd::Constant(7, p.sf2) - (Ksq * (Kmm_inv - Sig) * Ksq.transpose()).diagonal();
  // Through the block: block_values for the mean, se_moments at Sigma = 0 for the variance.
  const VectorXd m2 = drops::pilco::block_values(b, p.Xq);
  EXPECT_LT((m2 - mean).cwiseAbs().maxCoeff(), 1e-8);
  drops::pilco::SeModel model;
  model.input_dim = 2;
  model.outputs.push_back({{b}});
  for (int q = 0; q < 7; ++q) {
    const auto m = drops::pilco::se_moments(model, p.Xq.row(q).transpose(), MatrixXd::Zero(2, 2));
    EXPECT_NEAR(m.mean[0], mean[q], 1e-8);
    EXPECT_NEAR(m.cov(0, 0), var[q], 1e-8);
  }
}

TEST(PilcoFitc, RejectsBadInputWithAMessage) {
  const Problem p = MakeProblem(10, 2, 3);
  EXPECT_THROW(drops::pilco::fitc_block(p.X, p.y, MatrixXd(0, 2), p.l, 1, 0.01),
               drops::InvalidArgument);
  EXPECT_THROW(drops::pilco::fitc_block(p.X, p.y.head(5), p.X, p.l, 1, 0.01),
               drops::InvalidArgument);
  EXPECT_THROW(drops::pilco::fitc_block(p.X, p.y, p.X, -p.l, 1, 0.01), drops::InvalidArgument);
  EXPECT_THROW(drops::pilco::fitc_block(p.X, p.y, p.X, p.l, 1, 0.0), drops::InvalidArgument);
}

TEST(PilcoBlockValues, EqualTheGpPosteriorMean) {
  const Problem p = MakeProblem(30, 3, 4);
  drops::gp::Gp gp(3);
  VectorXd h(5);
  h << p.l.array().log().matrix(), 0.5 * std::log(p.sf2), 0.5 * std::log(p.sn2);
  gp.set_h_params(h);
  gp.compute(p.X, p.y);
  const VectorXd v = drops::pilco::block_values(drops::pilco::gp_mean_block(gp), p.Xq);
  for (int q = 0; q < p.Xq.rows(); ++q) {
    double m = 0, s2 = 0;
    gp.predict(p.Xq.row(q).transpose(), m, s2);
    EXPECT_NEAR(v[q], m, 1e-10);
  }
  EXPECT_THROW(drops::pilco::block_values(drops::pilco::gp_mean_block(gp), MatrixXd(2, 2)),
               drops::InvalidArgument);
}

TEST(PilcoTaskModel, ThePendubotsRewardIsOneMinusTheCostOfTheRewardWidth) {
  const drops::pendubot::TaskOptions to;
  const auto tm = drops::pendubot::pilco_task_model(to);
  std::string why;
  ASSERT_TRUE(tm.IsValid(&why)) << why;
  const drops::pendubot::SwingUpTask task(to);
  const auto cost = tm.cost(tm.reward_width);
  Rng rng(5);
  for (int k = 0; k < 100; ++k) {
    const VectorXd x = RandomVector(rng, 4, -7.0, 7.0);
    EXPECT_NEAR(1.0 - cost(tm.augment(x)), task.reward(x), 1e-12);
  }
  // x_aug's order: sin, cos per angle; the GP input adds u.
  VectorXd x(4);
  x << 1, 2, 0.3, -0.4;
  const VectorXd a = tm.augment(x);
  EXPECT_DOUBLE_EQ(a[4], std::sin(0.3));
  EXPECT_DOUBLE_EQ(a[5], std::cos(0.3));
  EXPECT_DOUBLE_EQ(a[7], std::cos(-0.4));
  const VectorXd in = tm.dynamics_input(x, VectorXd::Constant(1, 2.5));
  ASSERT_EQ(in.size(), 7);
  EXPECT_EQ(in[0], 1);
  EXPECT_EQ(in[2], a[4]);
  EXPECT_EQ(in[6], 2.5);
  EXPECT_EQ(tm.policy_input(x).size(), 6);
}

TEST(PilcoTaskModel, IsValidNamesWhatIsWrong) {
  auto tm = drops::pendubot::pilco_task_model({});
  std::string why;
  auto bad = tm;
  bad.cost_map = MatrixXd::Zero(2, 7);
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("cost_map"), std::string::npos) << why;
  bad = tm;
  bad.initial_cov = MatrixXd::Identity(3, 3);
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("initial_cov"), std::string::npos) << why;
  bad = tm;
  bad.policy_length_scales = VectorXd::Ones(2);
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("policy_length_scales"), std::string::npos) << why;
  bad = tm;
  bad.config.angles = {4};
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_THROW(tm.cost(0.0), drops::InvalidArgument);
  EXPECT_THROW(tm.augment(VectorXd::Zero(3)), drops::InvalidArgument);
}

TEST(PilcoExpectedCost, GradientMatchesFiniteDifferencesOnAPriorMeanPlusFitcModelOfThePendubot) {
  // The model PILCO with priors builds beyond max_points (src/algo/pilco.cpp): per output, the
  // simulator GP's posterior mean (an RBF block without variance) plus a FITC residual GP whose
  // "k_inverse" is Kmm^-1 - Sigma_m, not an inverse kernel matrix; on the pendubot's task model
  // (4 states, 2 angles, 6 policy inputs, 7 GP inputs). dJ/dtheta of the full objective against
  // fourth-order central differences (step 1e-4, as test_pilco_propagate), H = 5.
  const auto tm = drops::pendubot::pilco_task_model({});
  Rng rng(17);
  const int N = 40, M = 12, Din = 7;
  MatrixXd X(N, Din), Y(N, 4);
  for (int i = 0; i < N; ++i) {
    const VectorXd x = RandomVector(rng, 4, -1.0, 1.0) + Eigen::Vector4d(0, 0, 3.0, 3.0);
    const VectorXd u = RandomVector(rng, 1, -3.5, 3.5);
    X.row(i) = tm.dynamics_input(x, u).transpose();
    Y.row(i) << 0.3 * u[0] - 0.5 * std::sin(x[2]), 0.2 * std::sin(x[3] - x[2]) - 0.1 * u[0],
        0.05 * x[0], 0.05 * x[1];
    for (int a = 0; a < 4; ++a) Y(i, a) += 0.01 * rng.normal();
  }
  drops::pilco::SeModel model;
  model.input_dim = Din;
  for (int a = 0; a < 4; ++a) {
    drops::gp::Gp prior_gp(Din);
    VectorXd h(Din + 2);
    h.head(Din) = RandomVector(rng, Din, std::log(0.8), std::log(2.0));
    h[Din] = std::log(0.3);
    h[Din + 1] = std::log(0.02);
    prior_gp.set_h_params(h);
    prior_gp.compute(X.topRows(20), Y.col(a).head(20));
    const VectorXd residual =
        Y.col(a) - 0.8 * drops::pilco::block_values(drops::pilco::gp_mean_block(prior_gp), X);
    drops::pilco::SeOutput out;
    drops::pilco::SeBlock pm = drops::pilco::gp_mean_block(prior_gp);
    pm.weights *= 0.8;
    out.blocks.push_back(pm);
    out.blocks.push_back(drops::pilco::fitc_block(X, residual, X.bottomRows(M),
                                                  RandomVector(rng, Din, 0.8, 2.0), 0.05, 4e-4));
    model.outputs.push_back(std::move(out));
  }
  drops::pilco::RbfPolicy policy(6, 5, 1);
  MatrixXd centres(5, 6);
  for (int i = 0; i < 5; ++i) {
    const VectorXd x = RandomVector(rng, 4, -0.5, 0.5) + Eigen::Vector4d(0, 0, 3.1, 3.1);
    centres.row(i) = tm.policy_input(x).transpose();
  }
  policy.set(centres, 0.5 * RandomMatrix(rng, 5, 1, -1.0, 1.0),
             tm.policy_length_scales.array().log().matrix());
  const VectorXd x0 = Eigen::Vector4d(0, 0, 3.1, 3.0);
  const drops::pilco::ExpectedCost J(tm.config, model, policy, tm.cost(tm.reward_width), x0,
                                     tm.initial_cov, 5, 1.0);
  const VectorXd theta = policy.params();
  ASSERT_EQ(theta.size(), 5 * 6 + 5 + 6);
  VectorXd g;
  const double value = J(theta, &g);
  EXPECT_EQ(value, J(theta));
  const MatrixXd fd =
      FdJacobian([&](const VectorXd& t) { return VectorXd::Constant(1, J(t)); }, theta, 1e-4, 4);
  ExpectJacobian("dJ/dtheta, prior mean + FITC residual (pendubot, H = 5)", g.transpose(), fd,
                 1e-6);
}
