// Catch and balance (control/lqr.hpp, control/balance.hpp): the DARE solver against a closed form
// and the plain Riccati iteration, the linearisation against a known linear model, the LQR on the
// pendubot's true dynamics at the top, the hybrid policy's switching rule, and Black-DROPS with
// policy.balance.mode lqr.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <numbers>

#include "drops/control/balance.hpp"
#include "drops/core/errors.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "fixtures.hpp"

using namespace drops;

namespace {

// The plain Riccati iteration P <- Q + A'PA - A'PB (R + B'PB)^-1 B'PA from P = Q, to convergence
// (P = Q >= 0 converges to the stabilising solution for a stabilisable, detectable pair).
MatrixXd riccati_iteration(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q,
                           const MatrixXd& R) {
  MatrixXd P = Q;
  for (int k = 0; k < 100000; ++k) {
    const MatrixXd S = R + B.transpose() * P * B;
    MatrixXd next =
        Q + A.transpose() * P * A - A.transpose() * P * B * S.ldlt().solve(B.transpose() * P * A);
    next = 0.5 * (next + next.transpose());  // else round-off grows along the unstable modes
    const double change = (next - P).norm();
    P = next;
    if (change < 1e-14 * std::max(1.0, P.norm())) break;
  }
  return P;
}

// x_{t+1} = A x_t + B u_t as a learned model (mean dx = (A - I) x + B u, variance 0).
class LinearModel final : public model::DynamicsModel {
 public:
  LinearModel(MatrixXd A, MatrixXd B) : A_(std::move(A)), B_(std::move(B)) {}
  model::ModelSummary learn(const std::vector<Transition>&, const model::ModelProgress&) override {
    return {};
  }
  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
    out.mean = (A_ - MatrixXd::Identity(A_.rows(), A_.cols())) * x + B_ * u;
    out.var = VectorXd::Zero(x.size());
  }
  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override {
    mean = X * (A_ - MatrixXd::Identity(A_.rows(), A_.cols())).transpose() + U * B_.transpose();
    var = MatrixXd::Zero(X.rows(), X.cols());
  }
  VectorXd phi() const override { return {}; }
  model::ModelState state() const override { return {}; }
  void restore(const model::ModelState&) override {}

 private:
  MatrixXd A_, B_;
};

// The pendubot's true dynamics as a model: the prior at the actual parameters.
std::unique_ptr<model::DynamicsModel> true_pendubot_model(const pendubot::TaskOptions& o) {
  model::PriorParameters p;
  p.names = {"m1", "m2", "l1", "l2", "b1", "b2"};
  p.values = pendubot::Params{}.to_phi();
  return model::make_prior_only_model(std::make_shared<pendubot::PendubotPrior>(o), p);
}

}  // namespace

TEST(Dare, ScalarSolutionIsTheClosedForm) {
  // b^2 P^2 + (r - a^2 r - q b^2) P - q r = 0, positive root.
  const double a = 1.3, b = 0.4, q = 2.0, r = 0.5;
  const double c1 = r - a * a * r - q * b * b;
  const double P = (-c1 + std::sqrt(c1 * c1 + 4 * b * b * q * r)) / (2 * b * b);
  const auto res = control::solve_dare(MatrixXd::Constant(1, 1, a), MatrixXd::Constant(1, 1, b),
                                       MatrixXd::Constant(1, 1, q), MatrixXd::Constant(1, 1, r));
  ASSERT_TRUE(res.converged);
  EXPECT_NEAR(res.P(0, 0), P, 1e-10 * P);
  EXPECT_NEAR(res.K(0, 0), b * P * a / (r + b * b * P), 1e-10);
  EXPECT_LT(res.closed_loop_radius, 1.0);
  EXPECT_LT(res.residual, 1e-10);
}

TEST(Dare, MatrixSolutionEqualsThePlainRiccatiIteration) {
  Rng rng(5);
  const int n = 4, m = 2;
  MatrixXd A(n, n), B(n, m), L(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = rng.uniform(-1, 1), L(i, j) = rng.uniform(-1, 1);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) B(i, j) = rng.uniform(-1, 1);
  A += 0.8 * MatrixXd::Identity(n, n);  // some eigenvalues outside the unit circle
  const MatrixXd Q = L * L.transpose() + 0.1 * MatrixXd::Identity(n, n);
  const MatrixXd R = MatrixXd::Identity(m, m) * 0.7;
  const double open_radius =
      Eigen::EigenSolver<MatrixXd>(A, false).eigenvalues().cwiseAbs().maxCoeff();
  ASSERT_GT(open_radius, 1.0);
  const auto res = control::solve_dare(A, B, Q, R);
  ASSERT_TRUE(res.converged);
  EXPECT_LT(res.iterations, 20);
  const MatrixXd P = riccati_iteration(A, B, Q, R);
  EXPECT_LT((res.P - P).norm(), 1e-9 * P.norm());
  const MatrixXd K = (R + B.transpose() * P * B).ldlt().solve(B.transpose() * P * A);
  EXPECT_LT((res.K - K).norm(), 1e-9 * K.norm());
  EXPECT_LT(res.closed_loop_radius, 1.0);
}

TEST(Dare, UnstabilisableSystemIsReportedNotConverged) {
  MatrixXd A(2, 2), B(2, 1);
  A << 1.5, 0, 0, 0.5;
  B << 0, 1;  // the unstable mode cannot be reached
  const auto res = control::solve_dare(A, B, MatrixXd::Identity(2, 2), MatrixXd::Identity(1, 1));
  EXPECT_FALSE(res.converged);
  EXPECT_THROW(control::solve_dare(A, B, MatrixXd::Identity(2, 2), -MatrixXd::Identity(1, 1)),
               InvalidArgument);
  EXPECT_THROW(control::solve_dare(A, B, MatrixXd::Identity(3, 3), MatrixXd::Identity(1, 1)),
               InvalidArgument);
}

TEST(Linearize, RecoversTheMatricesOfALinearModel) {
  MatrixXd A(3, 3), B(3, 2);
  A << 1.1, 0.2, 0, -0.3, 0.9, 0.1, 0, 0.05, 1.02;
  B << 0.1, 0, 0, 0.2, 0.3, -0.1;
  const LinearModel m(A, B);
  VectorXd x(3), u(2);
  x << 0.3, -1, 2;
  u << 0.5, -0.2;
  const auto lin = control::linearize(m, x, u, 1e-3);
  EXPECT_LT((lin.A - A).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((lin.B - B).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((lin.drift - (A * x + B * u - x)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(control::linearize(m, x, u, 0), InvalidArgument);
}

TEST(Goal, ErrorWrapsTheAngles) {
  Goal g;
  g.state = VectorXd::Zero(2);
  g.action = VectorXd::Zero(1);
  g.action_limit = VectorXd::Ones(1);
  g.angles = {1};
  VectorXd x(2);
  x << 7.0, 2 * std::numbers::pi - 0.1;
  const VectorXd e = g.error(x);
  EXPECT_DOUBLE_EQ(e[0], 7.0);  // not an angle
  EXPECT_NEAR(e[1], -0.1, 1e-12);
  x[1] = -4 * std::numbers::pi + 0.2;
  EXPECT_NEAR(g.error(x)[1], 0.2, 1e-12);
  EXPECT_NO_THROW(g.check(2, 1));
  g.angles = {2};
  EXPECT_THROW(g.check(2, 1), InvalidArgument);
}

TEST(Balance, LqrOnThePendubotsTrueDynamicsCatchesASmallOffset) {
  const pendubot::TaskOptions o;
  const pendubot::SwingUpTask task(o);
  const auto model = true_pendubot_model(o);
  const auto c = control::make_balance_controller(task, *model, {});
  ASSERT_TRUE(c.usable());
  EXPECT_LT(c.linearization.drift.norm(), 1e-12);  // upright at rest is an equilibrium
  const pendubot::PendubotSystem real(pendubot::Params{}, o);
  Rng rng(1);
  VectorXd x(4), u(1);
  x << 0.2, -0.2, 0.1, 2 * std::numbers::pi - 0.08;  // theta2 wrapped
  const double v0 = c.cost_to_go(x);
  for (int t = 0; t < 200; ++t) {  // 10 s
    c.act(x, u);
    EXPECT_LE(std::abs(u[0]), o.max_torque);
    x = real.step(x, u, rng);
  }
  EXPECT_LT(c.goal.error(x).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT(c.cost_to_go(x), 1e-6 * v0);
}

TEST(Balance, HybridPolicySwitchesWithHysteresisAndResetsAtTheStart) {
  const pendubot::TaskOptions o;
  auto task = std::make_shared<pendubot::SwingUpTask>(o);
  const auto model = true_pendubot_model(o);
  control::BalanceOptions bo;
  bo.mode = control::BalanceMode::kLqr;
  bo.enter = 1.0;
  bo.exit = 4.0;
  auto c = std::make_shared<const control::BalanceController>(
      control::make_balance_controller(*task, *model, bo));
  policy::NeuralNetPolicyOptions po;
  po.max_action = o.max_torque;
  auto inner = std::make_unique<policy::NeuralNetPolicy>(po);
  VectorXd theta = VectorXd::Constant(inner->param_dim(), 0.3);
  control::BalancePolicy hybrid(inner->clone(), 4, c, bo);
  hybrid.set_params(theta);
  inner->set_params(theta);
  const control::BalanceTask btask(task);
  ASSERT_EQ(hybrid.observation_dim(), btask.observation_dim());
  // Three states along a ray from the goal: inside enter, between enter and exit, beyond exit.
  VectorXd dir(4);
  dir << 0.1, -0.1, 0.05, 0.03;
  const double v1 = c->cost_to_go(dir);
  auto at = [&](double v) { return VectorXd(dir * std::sqrt(v / v1)); };
  const VectorXd inside = at(0.5), between = at(2.0), outside = at(8.0);
  auto act = [&](const control::BalancePolicy& p, const VectorXd& x, double t) {
    VectorXd obs(btask.observation_dim()), u(1);
    btask.observe(x, obs);
    p.act(obs, t, u);
    return u[0];
  };
  auto learned = [&](const VectorXd& x) {
    VectorXd obs(6), u(1);
    task->observe(x, obs);
    inner->act(obs, 0, u);
    return u[0];
  };
  auto lqr = [&](const VectorXd& x) {
    VectorXd u(1);
    c->act(x, u);
    return u[0];
  };
  ASSERT_NE(learned(between), lqr(between));
  EXPECT_EQ(act(hybrid, between, 0.0), learned(between));   // not engaged yet
  EXPECT_EQ(act(hybrid, inside, 0.05), lqr(inside));        // enters
  EXPECT_EQ(act(hybrid, between, 0.10), lqr(between));      // stays (hysteresis)
  EXPECT_EQ(act(hybrid, outside, 0.15), learned(outside));  // leaves beyond exit
  EXPECT_EQ(act(hybrid, between, 0.20), learned(between));  // and needs enter again
  EXPECT_EQ(hybrid.balance_steps(), 2);
  EXPECT_EQ(hybrid.first_balance_step(), 1);
  EXPECT_EQ(act(hybrid, inside, 0.25), lqr(inside));
  EXPECT_EQ(act(hybrid, between, 0.0), learned(between));  // a new episode starts released
  EXPECT_EQ(hybrid.balance_steps(), 0);
}

TEST(Balance, BlackDropsRecordsTheGainAndRunsTheHybrid) {
  // Prior "actual" (the true dynamics): episode 1 plans on it with the LQR of its linearisation.
  auto exp = fixtures::experiment({"episodes=2", "optimizer.max_evaluations=200",
                                   "optimizer.reevaluation_rollouts=5", "rollouts.predicted=3",
                                   "prior.preset=actual", "policy.balance.mode=lqr", "seed=3"});
  std::vector<algo::EpisodeRecord> recs;
  algo::Callbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { recs.push_back(r); };
  exp.runner->run(exp.setup.problem(), cb);
  ASSERT_EQ(recs.size(), 2u);
  for (const auto& r : recs) {
    const auto& n = r.details.numbers;
    ASSERT_EQ(n.count("balance_k_0_3"), 1u);
    EXPECT_EQ(n.at("balance_usable"), 1.0);
    EXPECT_LT(n.at("balance_closed_loop_radius"), 1.0);
    ASSERT_EQ(n.count("balance_steps"), 1u);
  }
  // Episode 1's gain is the LQR of the prior at the actual parameters.
  const pendubot::SwingUpTask task;
  control::BalanceOptions bo;
  const auto c = control::make_balance_controller(task, *true_pendubot_model({}), bo);
  EXPECT_NEAR(recs[0].details.numbers.at("balance_k_0_2"), c.dare.K(0, 2), 1e-9);
  // exit below enter is refused.
  EXPECT_THROW(fixtures::experiment(
                   {"policy.balance.mode=lqr", "policy.balance.enter=2", "policy.balance.exit=1"}),
               ConfigError);
  // Only Black-DROPS catches and balances: the other algorithms refuse lqr instead of ignoring it.
  for (const char* a : {"algorithm=direct", "algorithm=ite", "algorithm=pilco"}) {
    try {
      fixtures::experiment({a, "policy.balance.mode=lqr"});
      ADD_FAILURE() << a << " accepted policy.balance.mode=lqr";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("does not catch and balance"), std::string::npos)
          << a << ": " << e.what();
    }
  }
  EXPECT_NO_THROW(fixtures::experiment({"algorithm=pilco", "policy.balance.mode=off"}));
}
