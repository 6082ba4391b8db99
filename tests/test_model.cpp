// Dynamics-model variants: GP-MI and MI identify the pendubot's parameters (paper §IV-B).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <limits>

#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/model/dataset.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "drops/model/gp_mi.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "pendulum_task.hpp"

using namespace drops;

namespace {

/// Two episodes of the actual pendubot under random network policies (fixed seeds).
std::vector<Transition> actual_data(int episodes = 2) {
  pendubot::SwingUpTask task;
  pendubot::PendubotSystem real(pendubot::Params{});
  policy::NeuralNetPolicyOptions po;
  po.input_scale = VectorXd(6);
  po.input_scale << 10, 10, 1, 1, 1, 1;
  policy::NeuralNetPolicy pol(po);
  std::vector<Transition> data;
  for (int e = 0; e < episodes; ++e) {
    Rng rng(100 + e);
    VectorXd theta(pol.param_dim());
    for (int i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1, 1);
    pol.set_params(theta);
    const auto tr = rollout::run_episode(task, real, pol, rng);
    for (auto& t : tr.transitions()) data.push_back(t);
  }
  return data;
}

model::PriorParameters tunable_prior(const std::string& preset) {
  model::PriorParameters p;
  p.names = pendubot::parameter_names();
  p.values = pendubot::preset(preset).to_phi();
  p.tunable = {0, 1, 2, 3};
  p.lower = VectorXd::Constant(4, 0.05);
  p.upper = VectorXd::Constant(4, 1.0);
  p.choices.assign(4, {});
  return p;
}

/// gp_prior with a short final kernel fit and variances from `variance_points` transitions.
model::ModelOptions gp_prior_options(int variance_points) {
  model::ModelOptions o;
  o.type = model::ModelType::kGpPrior;
  o.rprop.max_iterations = 30;
  o.variance_points = variance_points;
  return o;
}

/// A model of `type` on the pendubot prior, starting from `params`.
std::unique_ptr<model::DynamicsModel> pendubot_model(model::ModelOptions o, model::ModelType type,
                                                     const model::PriorParameters& params) {
  o.type = type;
  return model::make_model(o, std::make_shared<pendubot::SwingUpTask>(),
                           std::make_shared<pendubot::PendubotPrior>(), params);
}

}  // namespace

TEST(LogSumExp, IsStableAndExact) {
  VectorXd v(3);
  v << -1000, -1001, -1002;
  EXPECT_NEAR(model::log_sum_exp(v), -1000 + std::log(1 + std::exp(-1.0) + std::exp(-2.0)), 1e-12);
  v << 1000, 0, -5;
  EXPECT_NEAR(model::log_sum_exp(v), 1000, 1e-12);
  EXPECT_TRUE(std::isinf(model::log_sum_exp(VectorXd())));
}

TEST(GpMi, SumOfLogLikelihoodsScoreAlsoIdentifiesM2AndReportsTheSum) {
  const auto data = actual_data(2);
  model::ModelOptions o;
  o.gp_mi.score = model::GpMiScore::kSumOfLogLikelihoods;
  auto m = pendubot_model(o, model::ModelType::kGpMi, tunable_prior("tunable"));
  const auto s = m->learn(data);
  EXPECT_NEAR(s.phi[1], 0.5, 0.025) << s.BriefReport();
  ASSERT_EQ(s.log_likelihoods.size(), 4);
  EXPECT_DOUBLE_EQ(s.score, s.log_likelihoods.sum());  // the joint log likelihood, not log-sum-exp
  VectorXd ll(3);
  ll << -1, -std::numeric_limits<double>::infinity(), 2;
  EXPECT_EQ(model::gp_mi_score(ll, model::GpMiScore::kSumOfLogLikelihoods),
            -std::numeric_limits<double>::infinity());
  EXPECT_NEAR(model::gp_mi_score(ll, model::GpMiScore::kSumOfLikelihoods),
              std::log(std::exp(-1.0) + std::exp(2.0)), 1e-12);
}

/// A pendulum simulator of the simplest kind: x = [omega, theta] (rad/s, rad; theta = pi hanging),
/// u = [torque] (N m), one explicit Euler step of 0.05 s per control period,
///   omega' = omega + dt (u - b omega + m g l sin theta) / (m l^2),  theta' = theta + dt omega,
/// so its angle output does not depend on phi = [m, l, b] (kg, m, N m s); those three trade off
/// in the velocity output (g / l, 1 / (m l^2) and b / (m l^2) are what the data show).
VectorXd euler_pendulum_step(const VectorXd& phi, const VectorXd& x, double u) {
  constexpr double kDt = 0.05, kG = 9.81;
  const double m = phi[0], l = phi[1], b = phi[2];
  VectorXd next(2);
  next << x[0] + kDt * (u - b * x[0] + m * kG * l * std::sin(x[1])) / (m * l * l),
      x[1] + kDt * x[0];
  return next;
}

class EulerPendulumPrior final : public model::MeanFunction {
 public:
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"m", "l", "b"}; }
  void check_phi(const VectorXd& phi) const override {
    if (phi.size() != 3 || !(phi[0] > 0.01 && phi[1] > 0.01 && phi[2] >= 0))
      throw InvalidArgument("EulerPendulumPrior: phi = [m > 0.01, l > 0.01, b >= 0]");
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    dx = euler_pendulum_step(phi, x, u[0]) - x;
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<EulerPendulumPrior>(*this);
  }
};

// EulerPendulumPrior with evaluate_batch overridden: counts the batched calls and their rows (the
// shape of a Python prior, which takes the interpreter lock once per call).
class CountingBatchPrior final : public model::MeanFunction {
 public:
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return inner_.parameter_names(); }
  void check_phi(const VectorXd& phi) const override { inner_.check_phi(phi); }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    ++single_calls;
    inner_.evaluate(x, u, phi, dx);
  }
  void evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                      MatrixXd& dX) const override {
    ++batch_calls;
    dX.resize(X.rows(), 2);
    for (Eigen::Index b = 0; b < X.rows(); ++b)
      dX.row(b) = (euler_pendulum_step(phi, X.row(b).transpose(), U(b, 0)) -
                   X.row(b).transpose()).transpose();
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<CountingBatchPrior>();
  }
  mutable std::atomic<int> batch_calls{0}, single_calls{0};

 private:
  EulerPendulumPrior inner_;
};

// The model's batched prediction and GP-MI's residuals (prior_outputs) go through the prior's
// evaluate_batch, one call per batch (per block of 64 recorded transitions), never through
// evaluate() row by row; the default evaluate_batch gives the same numbers as evaluate().
TEST(MeanFunction, PredictionsAndResidualsCallEvaluateBatchOncePerBatch) {
  const Eigen::Vector3d phi(1.0, 0.6, 0.05);
  std::vector<Transition> data;
  Rng rng(3);
  VectorXd x(2);
  x << 0.0, 3.0;
  for (int t = 0; t < 100; ++t) {
    const VectorXd u = VectorXd::Constant(1, rng.uniform(-1.0, 1.0));
    const VectorXd next = euler_pendulum_step(phi, x, u[0]);
    data.push_back({x, u, next - x});
    x = next;
  }
  const auto d = model::make_dataset(data, nullptr, 2, 1);
  auto counting = std::make_shared<CountingBatchPrior>();
  const EulerPendulumPrior plain;
  long bad = 0;
  const MatrixXd batched = model::prior_outputs(*counting, d.x, d.u, phi, &bad);
  EXPECT_EQ(counting->batch_calls.load(), 2);  // 100 rows: blocks of 64 and 36
  MatrixXd by_rows;
  plain.evaluate_batch(d.x, d.u, phi, by_rows);  // the default: evaluate() row by row
  EXPECT_EQ((batched - by_rows).cwiseAbs().maxCoeff(), 0.0);

  model::PriorParameters p;
  p.names = {"m", "l", "b"};
  p.values = phi;
  p.choices.assign(0, {});
  model::ModelOptions o;
  o.type = model::ModelType::kGpPrior;
  o.rprop.max_iterations = 20;
  auto m = model::make_model(o, std::make_shared<drops::testing::PendulumTask>(), counting, p);
  m->learn(data);
  const int before = counting->batch_calls.load();
  MatrixXd mean, var;
  m->predict_batch(d.x.topRows(8), d.u.topRows(8), mean, var);
  EXPECT_EQ(counting->batch_calls.load(), before + 1);
  EXPECT_EQ(counting->single_calls.load(), 0);
}

/// The Euler pendulum's data: three 2 s episodes of random torques in [-1, 1] N m from rest,
/// hanging, with phi = truth.
std::vector<Transition> euler_pendulum_data(const VectorXd& truth) {
  std::vector<Transition> data;
  Rng rng(7);
  for (int e = 0; e < 3; ++e) {
    VectorXd x(2);
    x << 0.0, std::numbers::pi;
    for (int t = 0; t < 40; ++t) {
      const VectorXd u = VectorXd::Constant(1, rng.uniform(-1.0, 1.0));
      const VectorXd next = euler_pendulum_step(truth, x, u[0]);
      data.push_back({x, u, next - x});
      x = next;
    }
  }
  return data;
}

/// The pendulum prior's parameters m, l, b (kg, m, N m s), all tunable: start [0.5, 1, 0.02], 40-60 %
/// off the truth of the tests, within [0.1, 2] x [0.1, 2] x [0, 0.5].
model::PriorParameters euler_pendulum_parameters() {
  model::PriorParameters p;
  p.names = {"m", "l", "b"};
  p.values = Eigen::Vector3d(0.5, 1.0, 0.02);
  p.tunable = {0, 1, 2};
  p.lower = Eigen::Vector3d(0.1, 0.1, 0.0);
  p.upper = Eigen::Vector3d(2.0, 2.0, 0.5);
  p.choices.assign(3, {});
  return p;
}

// GP-MI's default score identifies every parameter of a prior whose parameters trade off and one
// of whose outputs every phi predicts alike (issue 43): the pendulum above with m = 1 kg,
// l = 0.6 m, b = 0.05 N m s, from three 2 s episodes of random torques in [-1, 1] N m, each of
// m, l, b within 10 % of the truth from a prior 40-60 % off. The paper's sum of the likelihoods is
// dominated by the angle's output, which phi does not change: docs/decisions/gp-mi-score.md.
TEST(GpMi, TheDefaultScoreIdentifiesEveryParameterOfAPendulum) {
  const Eigen::Vector3d truth(1.0, 0.6, 0.05);
  const auto data = euler_pendulum_data(truth);
  const model::PriorParameters p = euler_pendulum_parameters();
  auto learn = [&](const model::ModelOptions& o) {
    return model::make_model(o, std::make_shared<drops::testing::PendulumTask>(),
                             std::make_shared<EulerPendulumPrior>(), p)
        ->learn(data);
  };
  const auto s = learn({});
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(s.phi[i], truth[i], 0.1 * truth[i]) << p.names[i] << ": " << s.BriefReport();
  // The paper's score on the same data: phi stays where it started (the measurement of
  // docs/decisions/gp-mi-score.md; printed, not asserted).
  model::ModelOptions paper;
  paper.gp_mi.score = model::GpMiScore::kSumOfLikelihoods;
  const auto sp = learn(paper);
  std::printf("[info] sum of the likelihoods: phi = [%g, %g, %g]\n", sp.phi[0], sp.phi[1],
              sp.phi[2]);
}

/// The same pendulum whose inertia m l^2 is the product a c of two parameters (phi = [a, c],
/// kg m and m; b = 0.05 and l = 0.6 in the friction and gravity terms): only a c can be known.
class ProductPendulumPrior final : public model::MeanFunction {
 public:
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"a", "c"}; }
  void check_phi(const VectorXd& phi) const override {
    if (phi.size() != 2 || !(phi.array() > 0.01).all())
      throw InvalidArgument("ProductPendulumPrior: phi = [a, c] > 0.01");
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    const double inertia = phi[0] * phi[1], m = inertia / (0.6 * 0.6);
    dx = euler_pendulum_step(Eigen::Vector3d(m, 0.6, 0.05), x, u[0]) - x;
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<ProductPendulumPrior>(*this);
  }
};

// GP-MI's posterior over phi (issue 45): on the pendulum whose m, l, b the data pin down, each
// interval phi* +- 3 sd holds the truth and is narrow, the parameters are not perfectly correlated;
// where two parameters enter only through their product, both keep a standard deviation of the
// order of their search interval's and show a correlation of about -1 (the trade-off), though
// their product is right.
TEST(GpMi, ThePosteriorOverPhiIsNarrowWhereTheDataPinItAndShowsATradeOff) {
  const Eigen::Vector3d truth(1.0, 0.6, 0.05);
  const auto data = euler_pendulum_data(truth);
  const model::PriorParameters p = euler_pendulum_parameters();
  const auto task = std::make_shared<drops::testing::PendulumTask>();
  const auto s = model::make_model({}, task, std::make_shared<EulerPendulumPrior>(), p)->learn(data);
  const auto& post = s.phi_posterior;
  ASSERT_EQ(post.names, (std::vector<std::string>{"m", "l", "b"}));
  const VectorXd sd = post.stddev();
  std::printf("[info] pendulum: phi* %g %g %g, sd %g %g %g\n", post.mean[0], post.mean[1],
              post.mean[2], sd[0], sd[1], sd[2]);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(post.mean[i] - truth[i]), 3 * sd[i] + 1e-9) << p.names[i];
    EXPECT_LT(sd[i], 0.05 * truth[i]) << p.names[i];
  }
  EXPECT_LT(post.correlation().cwiseAbs().maxCoeff() - 1.0, 1e-12);
  EXPECT_LT((post.correlation() - MatrixXd::Identity(3, 3)).cwiseAbs().maxCoeff(), 0.99);

  model::PriorParameters q;
  q.names = {"a", "c"};
  q.values = Eigen::Vector2d(0.5, 0.5);
  q.tunable = {0, 1};
  q.lower = Eigen::Vector2d(0.1, 0.1);
  q.upper = Eigen::Vector2d(2.0, 2.0);
  q.choices.assign(2, {});
  const auto t = model::make_model({}, task, std::make_shared<ProductPendulumPrior>(), q)->learn(data);
  const VectorXd tsd = t.phi_posterior.stddev();
  std::printf("[info] product: phi* %g %g (product %g), sd %g %g, correlation %g\n",
              t.phi_posterior.mean[0], t.phi_posterior.mean[1],
              t.phi_posterior.mean[0] * t.phi_posterior.mean[1], tsd[0], tsd[1],
              t.phi_posterior.correlation()(0, 1));
  EXPECT_NEAR(t.phi[0] * t.phi[1], 0.36, 0.036);  // the product is identified
  EXPECT_LT(t.phi_posterior.correlation()(0, 1), -0.99);
  EXPECT_GT(tsd.minCoeff(), 0.25);  // of the order of the interval's sd, 1.9 / sqrt(12) = 0.55
}

/// dx = a sin(x) + b u on one state and one action (phi = [a, b]): the prior of the tests of
/// the joint Laplace approximation.
class SineGainPrior final : public model::MeanFunction {
 public:
  int state_dim() const override { return 1; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"a", "b"}; }
  void check_phi(const VectorXd& phi) const override {
    if (phi.size() != 2 || !phi.allFinite()) throw InvalidArgument("SineGainPrior: phi = [a, b]");
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    dx[0] = phi[0] * std::sin(x[0]) + phi[1] * u[0];
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<SineGainPrior>(*this);
  }
};

/// The sine-gain problem at a phi that a search left short of its maximum: n = 80 transitions of
/// dx = a sin(x) + b u + cosine cos(2 x) + noise N(0, noise^2), x in [-3, 3] and u in [-1, 1]
/// uniform (the cosine is what the prior lacks: a smooth function of x that the residual GP fits
/// and that overlaps with a sin(x)); phi = GP-MI's phi* with a moved by `offset`, and the output
/// GP's kernel fitted to the residuals there (as the alternating search leaves it when it stops).
struct SineGainFit {
  model::Dataset data;
  model::PriorParameters parameters;  ///< values: the phi of the fit
  std::vector<gp::Gp> gps;
};
SineGainFit sine_gain_fit(const Eigen::Vector2d& truth, double cosine, double noise, double offset) {
  SineGainFit f;
  const int n = 80;
  Rng rng(11);
  auto& d = f.data;
  d.x.resize(n, 1);
  d.u.resize(n, 1);
  d.dx.resize(n, 1);
  for (int k = 0; k < n; ++k) {
    d.x(k, 0) = rng.uniform(-3.0, 3.0);
    d.u(k, 0) = rng.uniform(-1.0, 1.0);
    d.dx(k, 0) = truth[0] * std::sin(d.x(k, 0)) + truth[1] * d.u(k, 0) +
                 cosine * std::cos(2 * d.x(k, 0)) + noise * rng.normal();
  }
  d.gp_in.resize(n, 2);
  d.gp_in << d.x, d.u;
  auto& p = f.parameters;
  p.names = {"a", "b"};
  p.values = Eigen::Vector2d(0.4, 1.0);
  p.tunable = {0, 1};
  p.lower = Eigen::Vector2d(0.0, 0.0);
  p.upper = Eigen::Vector2d(2.0, 2.0);
  p.choices.assign(2, {});
  const SineGainPrior prior;
  f.gps.assign(1, gp::Gp(2));
  p.values = model::identify_phi(prior, p, d, {}, {}, f.gps).phi;
  p.values[0] += offset;
  long its = 0;
  model::fit_output_gps(f.gps, d.gp_in, d.dx - model::prior_outputs(prior, d.x, d.u, p.values, nullptr),
                        {}, &its);
  return f;
}

// GP-MI's posterior over phi marginalises the kernels: its covariance is the phi block
// of the inverse of the joint negative Hessian over (phi, h) plus the documented prior precisions
// (12 / width^2 of each phi's interval and of Rprop's box for each log hyper-parameter; those the
// box holds stay fixed), here by brute force: second differences of the log likelihood itself,
// with other steps than phi_posterior's. At a phi the search left short of its maximum the
// kernel's fit depends on phi and takes part of a's effect: a's interval is then much wider than
// with the kernel fixed.
TEST(GpMi, ThePosteriorOverPhiIsTheJointLaplaceApproximationOverPhiAndTheKernels) {
  const SineGainFit f = sine_gain_fit(Eigen::Vector2d(0.8, 0.5), 0.3, 0.05, 0.5);
  const SineGainPrior prior;
  const auto& d = f.data;
  const auto& p = f.parameters;
  const VectorXd h = f.gps[0].h_params();
  const Eigen::Index H = h.size();
  std::vector<Eigen::Index> free;  // the hyper-parameters that Rprop's box does not hold
  for (Eigen::Index j = 0; j < H; ++j)
    if (h[j] > (j == H - 1 ? std::log(1e-5) : -10.0) + 1e-6 && h[j] < 10.0 - 1e-6) free.push_back(j);
  ASSERT_GE(free.size(), 2u) << h.transpose();

  // -Hessian of L(phi, h) = log p(dx - M(phi) | X, h) over theta = [phi, free h], plus the priors.
  const auto P = static_cast<Eigen::Index>(2 + free.size());
  auto L = [&](const VectorXd& theta) {
    gp::Gp g = f.gps[0];
    VectorXd ht = h;
    for (std::size_t k = 0; k < free.size(); ++k) ht[free[k]] = theta[2 + static_cast<Eigen::Index>(k)];
    g.set_h_params(ht);
    g.set_targets(d.dx.col(0) - model::prior_outputs(prior, d.x, d.u, theta.head(2), nullptr).col(0));
    return g.log_marginal_likelihood();
  };
  VectorXd theta0(P);
  theta0.head(2) = p.values;
  for (std::size_t k = 0; k < free.size(); ++k) theta0[2 + static_cast<Eigen::Index>(k)] = h[free[k]];
  VectorXd step = VectorXd::Constant(P, 1e-2);
  step.head(2).setConstant(1e-3);
  MatrixXd J(P, P);
  for (Eigen::Index i = 0; i < P; ++i)
    for (Eigen::Index j = 0; j <= i; ++j) {
      auto at = [&](double di, double dj) {
        VectorXd t = theta0;
        t[i] += di * step[i];
        t[j] += dj * step[j];
        return L(t);
      };
      J(i, j) = J(j, i) = -(at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / (4 * step[i] * step[j]);
    }
  for (Eigen::Index i = 0; i < P; ++i) {
    const Eigen::Index j = i < 2 ? -1 : free[static_cast<std::size_t>(i - 2)];
    const double width = i < 2 ? 2.0 : 10.0 - (j == H - 1 ? std::log(1e-5) : -10.0);
    J(i, i) += 12.0 / (width * width);
  }
  const Eigen::LLT<MatrixXd> llt(J);
  ASSERT_EQ(llt.info(), Eigen::Success) << "the joint likelihood is concave there";
  const MatrixXd joint = llt.solve(MatrixXd::Identity(P, P)).topLeftCorner(2, 2);
  const MatrixXd fixed = MatrixXd(J.topLeftCorner(2, 2)).llt().solve(MatrixXd::Identity(2, 2));

  const auto post = model::phi_posterior(prior, p, d, f.gps);
  const auto post_fixed =
      model::phi_posterior(prior, p, d, f.gps, model::PhiPosteriorKernels::kFixed);
  ASSERT_EQ(post.names, (std::vector<std::string>{"a", "b"}));
  const VectorXd sd = post.stddev(), sd_fixed = post_fixed.stddev();
  std::printf("[info] phi %g %g, sd %g %g (kernels fixed: %g %g)\n", post.mean[0], post.mean[1],
              sd[0], sd[1], sd_fixed[0], sd_fixed[1]);
  for (Eigen::Index a = 0; a < 2; ++a)
    for (Eigen::Index b = 0; b < 2; ++b) {
      EXPECT_NEAR(post.covariance(a, b), joint(a, b), 1e-3 * std::sqrt(joint(a, a) * joint(b, b)))
          << a << ", " << b;
      EXPECT_NEAR(post_fixed.covariance(a, b), fixed(a, b),
                  1e-3 * std::sqrt(fixed(a, a) * fixed(b, b)))
          << a << ", " << b;
    }
  EXPECT_GT(sd[0], 1.5 * sd_fixed[0]);
}

// Where the kernel's refit could take more of a's effect than the data pin down (low noise, the
// search stopped short of the maximum: the joint likelihood still rises along a with the kernel
// following), a keeps about its prior's spread: its interval holds the truth, where the one with
// the kernel fixed is narrow around the wrong value.
TEST(GpMi, AParameterTheKernelsCanTakeOverShowsItsPriorsSpread) {
  const Eigen::Vector2d truth(0.8, 0.5);
  const SineGainFit f = sine_gain_fit(truth, 0.0, 0.01, 0.1);
  const SineGainPrior prior;
  const auto post = model::phi_posterior(prior, f.parameters, f.data, f.gps);
  const auto post_fixed = model::phi_posterior(prior, f.parameters, f.data, f.gps,
                                               model::PhiPosteriorKernels::kFixed);
  const VectorXd sd = post.stddev(), sd_fixed = post_fixed.stddev();
  std::printf("[info] phi %g %g, sd %g %g (kernels fixed: %g %g)\n", post.mean[0], post.mean[1],
              sd[0], sd[1], sd_fixed[0], sd_fixed[1]);
  EXPECT_GT(std::abs(post.mean[0] - truth[0]), 2 * sd_fixed[0]);  // the kernel fixed: overconfident
  EXPECT_LE(std::abs(post.mean[0] - truth[0]), 2 * sd[0]);
  EXPECT_GT(sd[0], 0.25);  // of the order of the interval's sd, 2 / sqrt(12) = 0.58
  EXPECT_LE(std::abs(post.mean[1] - truth[1]), 2 * sd[1]);
}

// The pendubot from prior A (m1 and l2 off; m1, m2, l1, l2 tunable) on two episodes of the
// actual system: GP-MI's phi* lies on the ridge of masses against lengths that the kernels'
// refit follows, and each interval phi* +- 2 sd holds the actual value, 0.5.
TEST(GpMi, ThePendubotsIntervalsFromPriorAHoldTheActualValues) {
  auto m = pendubot_model({}, model::ModelType::kGpMi, tunable_prior("tunable-useful"));
  const auto s = m->learn(actual_data(2));
  const auto& post = s.phi_posterior;
  ASSERT_EQ(post.names, (std::vector<std::string>{"m1", "m2", "l1", "l2"}));
  const VectorXd sd = post.stddev();
  std::printf("[info] phi* %g %g %g %g, sd %g %g %g %g\n", post.mean[0], post.mean[1],
              post.mean[2], post.mean[3], sd[0], sd[1], sd[2], sd[3]);
  for (int i = 0; i < 4; ++i) EXPECT_LE(std::abs(post.mean[i] - 0.5), 2 * sd[i]) << post.names[i];
}

TEST(GpMi, IdentifiesM2FromTwoEpisodesStartingFromTheTunablePrior) {
  const auto data = actual_data(2);
  ASSERT_EQ(data.size(), 100u);
  auto m = pendubot_model({}, model::ModelType::kGpMi, tunable_prior("tunable"));
  const auto s = m->learn(data);
  EXPECT_NEAR(s.phi[1], 0.5, 0.025) << s.BriefReport();
  EXPECT_GT(s.phi_evaluations, 10);
  // the learned model predicts held-out actual transitions well
  const auto test = actual_data(3);
  double err = 0;
  Prediction p;
  for (std::size_t n = 100; n < test.size(); ++n) {
    m->predict(test[n].x, test[n].u, p);
    err = std::max(err, (p.mean - test[n].dx).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(err, 0.05);
}

TEST(GpMi, NestedSearchAlsoIdentifiesM2) {
  const auto data = actual_data(2);
  model::ModelOptions o;
  o.gp_mi.search = model::GpMiSearch::kNested;
  o.gp_mi.max_evaluations = 300;
  o.gp_mi.inner_rprop_iterations = 20;
  auto m = pendubot_model(o, model::ModelType::kGpMi, tunable_prior("tunable"));
  const auto s = m->learn(data);
  EXPECT_NEAR(s.phi[1], 0.5, 0.025) << s.BriefReport();
}

TEST(Mi, IdentifiesM2FromTwoEpisodes) {
  const auto data = actual_data(2);
  auto m = pendubot_model({}, model::ModelType::kMi, tunable_prior("tunable"));
  const auto s = m->learn(data);
  EXPECT_NEAR(s.phi[1], 0.5, 0.025) << s.BriefReport();
  Prediction p;
  m->predict(data[7].x, data[7].u, p);
  EXPECT_EQ(p.var.norm(), 0.0);  // MI is deterministic
}

TEST(GpPrior, KeepsPhiFixedAndCorrectsTheResidual) {
  const auto data = actual_data(2);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  model::ModelOptions o;
  o.type = model::ModelType::kGpPrior;
  const auto params = tunable_prior("tunable");
  auto m = model::make_model(o, task, prior, params);
  const auto s = m->learn(data);
  EXPECT_EQ((s.phi - params.values).norm(), 0.0);
  // On training inputs the GP residual corrects the wrong prior.
  Prediction p;
  VectorXd prior_dx(4);
  double gp_err = 0, prior_err = 0;
  for (std::size_t n = 0; n < data.size(); n += 5) {
    m->predict(data[n].x, data[n].u, p);
    prior->evaluate(data[n].x, data[n].u, params.values, prior_dx);
    gp_err += (p.mean - data[n].dx).norm();
    prior_err += (prior_dx - data[n].dx).norm();
  }
  EXPECT_LT(gp_err, 0.2 * prior_err);
}

TEST(Models, BatchPredictionEqualsSinglePrediction) {
  const auto data = actual_data(1);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  for (auto type : {model::ModelType::kGp, model::ModelType::kGpPrior, model::ModelType::kMi}) {
    model::ModelOptions o;
    o.type = type;
    o.rprop.max_iterations = 30;
    auto m = model::make_model(o, task, prior, tunable_prior("tunable-useful"));
    m->learn(data);
    MatrixXd X(5, 4), U(5, 1), mean, var;
    for (int b = 0; b < 5; ++b) {
      X.row(b) = data[static_cast<std::size_t>(b * 7)].x.transpose();
      U.row(b) = data[static_cast<std::size_t>(b * 7)].u.transpose();
    }
    m->predict_batch(X, U, mean, var);
    Prediction p;
    for (int b = 0; b < 5; ++b) {
      m->predict(X.row(b).transpose(), U.row(b).transpose(), p);
      EXPECT_LT((p.mean - mean.row(b).transpose()).norm(), 1e-9);
      EXPECT_LT((p.var - var.row(b).transpose()).norm(), 1e-9);
    }
  }
}

// A policy replayed on a deterministic robot records the same transitions again. With fewer
// distinct transitions than variance_points, the variances are the exact ones (the GP on every
// transition, the oracle): the subset leaves out copies, not transitions seen once. An evenly
// spaced subset of all the rows would keep copies and leave out distinct transitions, where
// the variance then grows (checked on that subset too).
TEST(Models, VariancePointsKeepEveryDistinctTransitionOfAReplayedEpisode) {
  auto data = actual_data(2);
  const int distinct = static_cast<int>(data.size());
  const auto replay = actual_data(1);  // episode 1's policy again: the same transitions
  data.insert(data.end(), replay.begin(), replay.end());
  const int N = static_cast<int>(data.size()), m = distinct + 10;
  ASSERT_LT(m, N);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  const auto params = tunable_prior("tunable");
  model::GpDynamicsModel exact(gp_prior_options(0), task, prior, params);
  model::GpDynamicsModel sub(gp_prior_options(m), task, prior, params);
  exact.learn(data);
  sub.learn(data);
  const model::Dataset d = model::make_dataset(data, task.get(), 4, 1);
  ASSERT_TRUE(d.gp_in.bottomRows(N - distinct) == d.gp_in.topRows(N - distinct));  // copies
  MatrixXd X = d.x.topRows(distinct), U = d.u.topRows(distinct), me, ve, ms, vs;
  exact.predict_batch(X, U, me, ve);
  sub.predict_batch(X, U, ms, vs);
  EXPECT_LT((ms - me).cwiseAbs().maxCoeff(), 1e-8);
  double worst = 0.0, naive_growth = 0.0;
  for (int i = 0; i < 4; ++i) {
    const gp::Gp& g = sub.output_gps()[static_cast<std::size_t>(i)];
    EXPECT_LE(g.variance_points(), m);
    // A copy only halves sigma_n^2 at its input, and the greedy subset stops once every row's
    // variance is below 1e-9 sigma_f^2 per output: the difference is of that order.
    const double sn2 = g.noise_variance() + 4e-9 * g.kernel().variance();
    worst = std::max(worst, ((vs.col(i) - ve.col(i)).array().abs() / sn2).maxCoeff());
    EXPECT_GE((vs.col(i) - ve.col(i)).minCoeff(), -1e-10) << "output " << i;
    // The evenly spaced subset of all N rows, on the model's kernel.
    gp::Gp naive = g;
    naive.set_variance_points(0);
    naive.compute(d.rows(model::subsample(N, m)).gp_in, VectorXd::Zero(m));
    VectorXd mn, vn;
    naive.predict_batch(d.gp_in.topRows(distinct), mn, vn);
    naive_growth = std::max(naive_growth, ((vn - ve.col(i)).array() / sn2).maxCoeff());
  }
  EXPECT_LE(worst, 1.0);
  EXPECT_GT(naive_growth, 10.0);
}

// model.variance_points: each output GP's variances are those of a GP with the same kernel on
// the greedy subset of m transitions (gp::greedy_variance_subset on the fitted kernels) alone,
// never below those of the GP on every transition, whose means the model keeps (the oracles
// use the model's own kernels). At the recorded transitions the greedy subset's largest
// variance is below an evenly spaced subset's.
TEST(Models, VariancePointsConditionTheVariancesOnAGreedySubset) {
  const auto data = actual_data(2);
  const int N = static_cast<int>(data.size()), m = 40;
  ASSERT_GT(N, 2 * m);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  const auto params = tunable_prior("tunable");
  model::ModelOptions o = gp_prior_options(m);
  model::GpDynamicsModel sub(o, task, prior, params);
  sub.learn(data);
  const model::Dataset d = model::make_dataset(data, task.get(), 4, 1);
  const std::vector<int> chosen = gp::greedy_variance_subset(d.gp_in, sub.output_gps(), m);
  ASSERT_EQ(static_cast<int>(chosen.size()), m);
  const model::Dataset greedy = d.rows(chosen), evenly = d.rows(model::subsample(N, m));
  MatrixXd targets = d.dx;  // gp_prior: the residuals at the fixed phi
  targets -= model::prior_outputs(*prior, d.x, d.u, params.values, nullptr);
  // Queries: transitions in the subset and between its rows, and states between transitions.
  const std::vector<int> rows{0, 1, 7, 21, 36, N - 30, N - 12, N - 1};
  const int B = static_cast<int>(rows.size());
  MatrixXd X(B, 4), U(B, 1), in(B, d.gp_in.cols()), mean, var;
  for (int b = 0; b < B; ++b) {
    const int r = rows[static_cast<std::size_t>(b)];
    const int r2 = std::min(r + 1, N - 1);
    X.row(b) = 0.5 * (d.x.row(r) + d.x.row(r2));
    U.row(b) = d.u.row(r);
  }
  {
    MatrixXd obs;
    task->observe_batch(X, obs);
    in.leftCols(obs.cols()) = obs;
    in.rightCols(1) = U;
  }
  sub.predict_batch(X, U, mean, var);
  MatrixXd prior_mean;
  prior->evaluate_batch(X, U, params.values, prior_mean);
  double growth = 0.0;
  for (int i = 0; i < 4; ++i) {
    const gp::Gp& g = sub.output_gps()[static_cast<std::size_t>(i)];
    EXPECT_EQ(g.variance_points(), m);
    gp::Gp all = g;  // the model's kernel on every transition, in the order recorded
    all.set_variance_points(0);
    all.compute(d.gp_in, targets.col(i));
    gp::Gp subset = all;  // ... and on the greedy subset alone
    subset.compute(greedy.gp_in, VectorXd::Zero(m));
    Eigen::VectorXd ma, va, ms, vs;
    all.predict_batch(in, ma, va);
    subset.predict_batch(in, ms, vs);
    gp::Gp spaced = all;  // ... and on the evenly spaced subset, at every recorded transition
    spaced.compute(evenly.gp_in, VectorXd::Zero(m));
    Eigen::VectorXd mg, vg, me, ve;
    subset.predict_batch(d.gp_in, mg, vg);
    spaced.predict_batch(d.gp_in, me, ve);
    EXPECT_LT(vg.maxCoeff(), ve.maxCoeff()) << "output " << i;
    for (int b = 0; b < B; ++b) {
      const std::string at = "output " + std::to_string(i) + " row " +
                             std::to_string(rows[static_cast<std::size_t>(b)]);
      EXPECT_NEAR(mean(b, i), prior_mean(b, i) + ma[b], 1e-8) << at;
      // (round-off: the oracles order and centre their inputs differently)
      EXPECT_NEAR(var(b, i), vs[b], 1e-8) << at;
      EXPECT_GE(var(b, i), va[b] - 1e-10) << at;
      growth = std::max(growth, var(b, i) - va[b]);
    }
  }
  EXPECT_GT(growth, 1e-6);  // a subset is not the whole
  o.variance_points = -1;
  EXPECT_THROW(model::GpDynamicsModel(o, task, prior, params), drops::InvalidArgument);
}

TEST(Models, RejectMissingPriorAndBadData) {
  auto task = std::make_shared<pendubot::SwingUpTask>();
  model::ModelOptions o;
  o.type = model::ModelType::kGpMi;
  EXPECT_THROW(model::make_model(o, task, nullptr, {}), InvalidArgument);
  o.type = model::ModelType::kGp;
  auto m = model::make_model(o, task, nullptr, {});
  Transition t{VectorXd::Zero(3), VectorXd::Zero(1), VectorXd::Zero(4)};
  EXPECT_THROW(m->learn({t}), InvalidArgument);
}

TEST(GpMi, ExhaustiveSearchOverADiscreteParameterPicksTheActualValue) {
  const auto data = actual_data(2);
  model::PriorParameters p;
  p.names = pendubot::parameter_names();
  p.values = pendubot::preset("tunable").to_phi();  // m2 = 0.75
  p.tunable = {1};
  p.lower = VectorXd::Constant(1, 0.3);
  p.upper = VectorXd::Constant(1, 0.8);
  p.choices = {{0.35, 0.5, 0.65, 0.75}};
  for (auto type : {model::ModelType::kGpMi, model::ModelType::kMi}) {
    auto m = pendubot_model({}, type, p);
    const auto s = m->learn(data);
    EXPECT_EQ(s.phi[1], 0.5) << model::to_string(type) << ": " << s.BriefReport();
    EXPECT_EQ(s.phi_evaluations, 4);  // every choice scored once (GP-MI: nested for a discrete phi)
  }
}

namespace {

// The pendubot's m2 as a discrete phi of four choices (the others at the "tunable" preset).
model::PriorParameters discrete_m2_parameters() {
  model::PriorParameters p;
  p.names = pendubot::parameter_names();
  p.values = pendubot::preset("tunable").to_phi();
  p.tunable = {1};
  p.lower = VectorXd::Constant(1, 0.3);
  p.upper = VectorXd::Constant(1, 0.8);
  p.choices = {{0.35, 0.5, 0.65, 0.75}};
  return p;
}

// A naive loop (the oracle of the tests below): for each choice of p's discrete parameter, the
// sum of the log likelihoods of fresh GPs, one per output, fitted by rprop on the residuals.
std::vector<double> fresh_fit_scores(const model::MeanFunction& prior,
                                     const model::PriorParameters& p, const model::Dataset& d,
                                     const gp::RpropOptions& rprop) {
  std::vector<double> scores;
  for (double v : p.choices[0]) {
    VectorXd phi = p.values;
    phi[p.tunable[0]] = v;
    long bad = 0;
    const MatrixXd t = d.dx - model::prior_outputs(prior, d.x, d.u, phi, &bad);
    EXPECT_EQ(bad, 0);
    double sum = 0;
    for (Eigen::Index i = 0; i < t.cols(); ++i) {
      gp::Gp g(static_cast<int>(d.gp_in.cols()));
      g.compute(d.gp_in, t.col(i));
      g.optimize_h_params(rprop);
      sum += g.log_marginal_likelihood();
    }
    scores.push_back(sum);
  }
  return scores;
}

}  // namespace

// candidate_start = initial: every candidate of a discrete phi is fitted from a new GP's kernels,
// so GP-MI's choice, its score and each candidate's score are those of a naive loop of fresh fits
// (the oracle), whatever kernels the GPs held on entry; best_so_far starts from those kernels and
// scores the candidates differently.
TEST(GpMi, InitialCandidateStartScoresEveryCandidateAsAFreshFit) {
  const auto data = actual_data(2);
  pendubot::SwingUpTask task;
  const int E = task.state_dim();
  const model::Dataset d = model::make_dataset(data, &task, E, task.action_dim());
  const model::PriorParameters p = discrete_m2_parameters();
  pendubot::PendubotPrior prior;
  model::GpMiOptions o;
  o.score = model::GpMiScore::kSumOfLogLikelihoods;
  o.inner_rprop_iterations = 20;
  gp::RpropOptions rprop;
  rprop.max_iterations = 20;

  // The oracle: for each choice, E fresh GPs fitted with 20 Rprop iterations.
  const std::vector<double> oracle = fresh_fit_scores(prior, p, d, rprop);
  const auto best = std::max_element(oracle.begin(), oracle.end());
  const double best_m2 = p.choices[0][static_cast<std::size_t>(best - oracle.begin())];
  auto is_an_oracle_score = [&](double s) {
    return std::any_of(oracle.begin(), oracle.end(),
                       [&](double v) { return std::abs(s - v) <= 1e-9 * std::abs(v); });
  };

  // Kernels on entry far from a new GP's: every log length scale 2, as after an earlier fit.
  auto entry_gps = [&] {
    std::vector<gp::Gp> gps(static_cast<std::size_t>(E), gp::Gp(static_cast<int>(d.gp_in.cols())));
    for (auto& g : gps) {
      VectorXd h = g.h_params();
      h.head(d.gp_in.cols()).setConstant(2.0);
      g.set_h_params(h);
    }
    return gps;
  };
  // The first candidate's score, as the progress callback reports it after evaluation 0.
  double first = std::numeric_limits<double>::quiet_NaN();
  auto progress = [&](const std::string&, int k, double s) {
    if (k == 0) first = s;
  };

  o.candidate_start = model::GpMiCandidateStart::kInitial;
  auto gps = entry_gps();
  const auto initial = model::identify_phi(prior, p, d, o, rprop, gps, progress);
  EXPECT_EQ(initial.phi[1], best_m2);
  EXPECT_NEAR(initial.score, *best, 1e-9 * std::abs(*best));
  EXPECT_EQ(initial.evaluations, 4);
  EXPECT_TRUE(is_an_oracle_score(first)) << first;

  o.candidate_start = model::GpMiCandidateStart::kBestSoFar;
  gps = entry_gps();
  model::identify_phi(prior, p, d, o, rprop, gps, progress);
  EXPECT_FALSE(is_an_oracle_score(first))
      << first << ": best_so_far starts the first candidate from the entry kernels";
}

// The candidate screen (GpMiOptions::screen_iterations): with candidate_start = initial, the
// candidates whose short fit scores more than the margin below the best short fit are left out,
// exactly those a naive loop of short fresh fits (the oracle) puts below it, and the search's
// choice, score and kernels are those of the unscreened search, bit for bit, with fewer Rprop
// iterations.
TEST(GpMi, TheCandidateScreenLeavesOutTheCandidatesBelowItsMarginAndKeepsTheChoice) {
  const auto data = actual_data(2);
  pendubot::SwingUpTask task;
  const int E = task.state_dim();
  const model::Dataset d = model::make_dataset(data, &task, E, task.action_dim());
  const model::PriorParameters p = discrete_m2_parameters();
  pendubot::PendubotPrior prior;
  model::GpMiOptions o;
  o.score = model::GpMiScore::kSumOfLogLikelihoods;
  o.candidate_start = model::GpMiCandidateStart::kInitial;
  o.inner_rprop_iterations = 20;
  gp::RpropOptions rprop;
  rprop.max_iterations = 20;
  constexpr int kScreen = 4;

  // The oracle: each choice's score after kScreen Rprop iterations of E fresh GPs.
  gp::RpropOptions short_fit = rprop;
  short_fit.max_iterations = kScreen;
  const std::vector<double> short_scores = fresh_fit_scores(prior, p, d, short_fit);
  std::vector<double> sorted = short_scores;
  std::sort(sorted.rbegin(), sorted.rend());
  ASSERT_GT(sorted[0] - sorted[1], 1e-6) << "the test needs a single best short fit";

  auto fresh = [&] {
    return std::vector<gp::Gp>(static_cast<std::size_t>(E), gp::Gp(static_cast<int>(d.gp_in.cols())));
  };
  auto gps_full = fresh();
  const auto full = model::identify_phi(prior, p, d, o, rprop, gps_full, {});
  EXPECT_EQ(full.screened_out, 0);

  for (double margin : {0.5 * (sorted[0] - sorted[1]), 0.5 * (sorted[1] - sorted[2]) + sorted[0] - sorted[1]}) {
    model::GpMiOptions so = o;
    so.screen_iterations = kScreen;
    so.screen_margin = margin;
    const long below = std::count_if(short_scores.begin(), short_scores.end(),
                                     [&](double v) { return v < sorted[0] - margin; });
    auto gps = fresh();
    const auto screened = model::identify_phi(prior, p, d, so, rprop, gps, {});
    EXPECT_EQ(screened.screened_out, below) << "margin " << margin;
    EXPECT_EQ(screened.evaluations, 4);
    // The winner of the full fits passed this screen in this data (checked below), so the result
    // is the unscreened one.
    const auto winner = std::find(p.choices[0].begin(), p.choices[0].end(), full.phi[1]) -
                        p.choices[0].begin();
    ASSERT_GE(short_scores[static_cast<std::size_t>(winner)], sorted[0] - margin);
    EXPECT_EQ(screened.phi[1], full.phi[1]);
    EXPECT_EQ(screened.score, full.score);
    for (int i = 0; i < E; ++i)
      EXPECT_EQ(gps[static_cast<std::size_t>(i)].h_params(), gps_full[static_cast<std::size_t>(i)].h_params());
    EXPECT_LT(screened.rprop_iterations, full.rprop_iterations);
  }

  // A screen as long as the full fit is no screen.
  model::GpMiOptions as_long = o;
  as_long.screen_iterations = o.inner_rprop_iterations;
  as_long.screen_margin = 0.0;
  auto gps = fresh();
  const auto unscreened = model::identify_phi(prior, p, d, as_long, rprop, gps, {});
  EXPECT_EQ(unscreened.screened_out, 0);
  EXPECT_EQ(unscreened.rprop_iterations, full.rprop_iterations);

  model::GpMiOptions bad = o;
  bad.screen_iterations = -1;
  EXPECT_THROW(model::identify_phi(prior, p, d, bad, rprop, gps, {}), InvalidArgument);
}

namespace {

// The GP-MI model on the pendubot from prior A with rollouts over phi's posterior, learnt on two
// episodes of the actual system.
struct PosteriorRolloutModel {
  std::vector<Transition> data = actual_data(2);
  std::shared_ptr<pendubot::SwingUpTask> task = std::make_shared<pendubot::SwingUpTask>();
  std::shared_ptr<pendubot::PendubotPrior> prior = std::make_shared<pendubot::PendubotPrior>();
  model::GpDynamicsModel model;
  model::ModelSummary summary;
  explicit PosteriorRolloutModel(model::RolloutPhi rollout_phi)
      : model(options(rollout_phi), task, prior, tunable_prior("tunable-useful")) {
    summary = model.learn(data);
  }
  static model::ModelOptions options(model::RolloutPhi rollout_phi) {
    model::ModelOptions o;
    o.type = model::ModelType::kGpMi;
    o.gp_mi.rollout_phi = rollout_phi;
    return o;
  }
};

// One of a model's phi samples as a model of its own (every row under that sample).
class OneSample final : public model::DynamicsModel {
 public:
  OneSample(const model::DynamicsModel& m, int sample) : m_(m), sample_(sample) {}
  model::ModelSummary learn(const std::vector<Transition>&, const model::ModelProgress&) override {
    throw Error("OneSample::learn: not used");
  }
  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
    MatrixXd X = x.transpose(), U = u.transpose(), mean, var;
    predict_batch(X, U, mean, var);
    out.mean = mean.row(0).transpose();
    out.var = var.row(0).transpose();
  }
  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override {
    m_.predict_batch_sampled(X, U, std::vector<int>(static_cast<std::size_t>(X.rows()), sample_),
                             mean, var);
  }
  VectorXd phi() const override { return m_.phi(); }
  model::ModelState state() const override { return {}; }
  void restore(const model::ModelState&) override {}

 private:
  const model::DynamicsModel& m_;
  int sample_;
};

}  // namespace

// model.gp_mi.rollout_phi: posterior. The draws follow the Laplace posterior (moments within
// sampling error; the parameters outside it stay at phi*), one seed gives the same draws, and
// under sample s the model is the simulator at phi_s plus the output GPs conditioned on the
// residuals at phi_s (oracle: copies of the output GPs given those targets).
TEST(GpMi, PosteriorSamplesFollowThePosteriorAndPredictAsTheGpsOfTheirResiduals) {
  PosteriorRolloutModel f(model::RolloutPhi::kPosterior);
  auto& m = f.model;
  const auto& post = f.summary.phi_posterior;
  ASSERT_EQ(post.names.size(), 4u);
  ASSERT_TRUE(post.covariance.allFinite());
  EXPECT_EQ(m.phi_samples(), 0);
  EXPECT_THROW(m.draw_phi_samples(0, 7), InvalidArgument);

  const int S = 4000;
  const auto ps = m.draw_phi_samples(S, 7);
  EXPECT_EQ(ps.samples, S);
  EXPECT_EQ(ps.rejected, 0);
  EXPECT_LT(ps.clamped, S / 50);  // the interval [0.05, 1] is > 2 sd away from phi*
  ASSERT_EQ(m.phi_samples(), S);
  MatrixXd P(S, 4);
  for (int s = 0; s < S; ++s) {
    const VectorXd& phi = m.sample_phis()[static_cast<std::size_t>(s)];
    P.row(s) = phi.head(4).transpose();
    EXPECT_EQ(phi.tail(2), m.phi().tail(2));  // b1, b2: not tunable
  }
  const VectorXd mean = P.colwise().mean().transpose();
  const MatrixXd centred = P.rowwise() - mean.transpose();
  const MatrixXd cov = centred.transpose() * centred / (S - 1);
  const VectorXd sd = post.stddev();
  const MatrixXd corr = post.correlation();
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR(mean[k], post.mean[k], 5 * sd[k] / std::sqrt(double(S))) << post.names[k];
    EXPECT_NEAR(std::sqrt(cov(k, k)), sd[k], 0.05 * sd[k]) << post.names[k];
    for (int j = 0; j < 4; ++j)
      EXPECT_NEAR(cov(k, j) / std::sqrt(cov(k, k) * cov(j, j)), corr(k, j), 0.05);
  }
  EXPECT_GT(sd.maxCoeff(), 0.05);  // a posterior wide enough for the test to mean something

  // One seed, one set of draws.
  const std::vector<VectorXd> first = m.sample_phis();
  m.draw_phi_samples(S, 7);
  EXPECT_EQ(m.sample_phis(), first);
  m.draw_phi_samples(3, 8);
  ASSERT_EQ(m.phi_samples(), 3);
  EXPECT_NE(m.sample_phis()[0], first[0]);

  // Predictions under samples 2, 0, 1, 2, 0 of rows near the data.
  const model::Dataset d = model::make_dataset(f.data, f.task.get(), 4, 1);
  const std::vector<int> sample = {2, 0, 1, 2, 0};
  MatrixXd X(5, 4), U(5, 1);
  for (int b = 0; b < 5; ++b) {
    X.row(b) = d.x.row(7 + 19 * b) + Eigen::RowVectorXd::Constant(4, 0.05);
    U.row(b) = d.u.row(7 + 19 * b);
  }
  MatrixXd mean_s, var_s, mean_p, var_p, obs;
  m.predict_batch_sampled(X, U, sample, mean_s, var_s);
  m.predict_batch(X, U, mean_p, var_p);
  f.task->observe_batch(X, obs);
  MatrixXd in(5, obs.cols() + 1);
  in << obs, U;
  for (int b = 0; b < 5; ++b) {
    const VectorXd& phi = m.sample_phis()[static_cast<std::size_t>(sample[static_cast<std::size_t>(b)])];
    MatrixXd residual_means, Mrow;
    f.prior->evaluate_batch(d.x, d.u, phi, residual_means);
    f.prior->evaluate_batch(X.row(b), U.row(b), phi, Mrow);
    for (int i = 0; i < 4; ++i) {
      gp::Gp g = m.output_gps()[static_cast<std::size_t>(i)];
      g.set_targets(d.dx.col(i) - residual_means.col(i));
      double gm, gv;
      g.predict(in.row(b).transpose(), gm, gv);
      EXPECT_NEAR(mean_s(b, i), Mrow(0, i) + gm, 1e-9) << "row " << b << " output " << i;
      EXPECT_NEAR(var_s(b, i), gv, 1e-12);
      EXPECT_EQ(var_s(b, i), var_p(b, i));
    }
  }
  EXPECT_GT((mean_s - mean_p).cwiseAbs().maxCoeff(), 1e-6);  // the samples differ from phi*
  EXPECT_THROW(m.predict_batch_sampled(X, U, {0, 1, 2, 3, 0}, mean_s, var_s), InvalidArgument);
  EXPECT_THROW(m.predict_batch_sampled(X, U, {0, 1}, mean_s, var_s), InvalidArgument);

  // A new learn() discards the draws.
  m.learn(f.data);
  EXPECT_EQ(m.phi_samples(), 0);
}

// rollout_phi: point (the default): no draws, and predict_batch_sampled is predict_batch.
TEST(GpMi, ThePointEstimateDrawsNoSamples) {
  PosteriorRolloutModel f(model::RolloutPhi::kPoint);
  EXPECT_EQ(f.model.draw_phi_samples(20, 7).samples, 0);
  EXPECT_EQ(f.model.phi_samples(), 0);
  const model::Dataset d = model::make_dataset(f.data, f.task.get(), 4, 1);
  MatrixXd mean_s, var_s, mean_p, var_p;
  f.model.predict_batch_sampled(d.x.topRows(3), d.u.topRows(3), {0, 0, 0}, mean_s, var_s);
  f.model.predict_batch(d.x.topRows(3), d.u.topRows(3), mean_p, var_p);
  EXPECT_EQ(mean_s, mean_p);
  EXPECT_EQ(var_s, var_p);
  EXPECT_THROW(f.model.predict_batch_sampled(d.x.topRows(1), d.u.topRows(1), {1}, mean_s, var_s),
               InvalidArgument);
}

// rollout_phi: posterior needs a continuous tunable phi: a prior that tunes only discrete entries
// (or nothing) is refused when the model is made, with the key's name; gp_prior ignores the key.
TEST(GpMi, PosteriorRolloutsWithoutAContinuousPhiAreRefused) {
  model::ModelOptions o = PosteriorRolloutModel::options(model::RolloutPhi::kPosterior);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  try {
    model::GpDynamicsModel m(o, task, prior, discrete_m2_parameters());
    FAIL() << "a discrete phi was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("model.gp_mi.rollout_phi"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("discrete"), std::string::npos) << e.what();
  }
  model::PriorParameters none = tunable_prior("tunable");
  none.tunable.clear();
  none.lower.resize(0);
  none.upper.resize(0);
  none.choices.clear();
  EXPECT_THROW(model::GpDynamicsModel(o, task, prior, none), InvalidArgument);
  o.type = model::ModelType::kGpPrior;
  EXPECT_NO_THROW(model::GpDynamicsModel(o, task, prior, discrete_m2_parameters()));
}

// Rollout r of a policy runs under sample r mod S: with sampling of the predictive noise off, each
// rollout's return is that of the policy on the model of its sample alone (oracle: OneSample).
TEST(GpMi, RolloutRRunsUnderPhiSampleRModS) {
  PosteriorRolloutModel f(model::RolloutPhi::kPosterior);
  f.model.draw_phi_samples(3, 5);
  policy::NeuralNetPolicyOptions po;
  po.input_scale = VectorXd(6);
  po.input_scale << 10, 10, 1, 1, 1, 1;
  policy::NeuralNetPolicy pol(po);
  Rng rng(3);
  VectorXd theta(pol.param_dim());
  for (int i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1, 1);
  rollout::RolloutOptions ro;
  ro.sample = false;
  ro.batch = 1;  // a query's round-off does not depend on its batch then
  ro.rollouts = 6;
  VectorXd returns;
  MatrixXd per_rollout;
  rollout::evaluate_policies(*f.task, f.model, pol, {theta}, {42}, ro, returns, nullptr,
                             &per_rollout);
  ro.rollouts = 1;
  for (int r = 0; r < 6; ++r) {
    const OneSample alone(f.model, r % 3);
    VectorXd one;
    rollout::evaluate_policies(*f.task, alone, pol, {theta}, {42}, ro, one);
    EXPECT_EQ(per_rollout(0, r), one[0]) << "rollout " << r;
  }
  EXPECT_GT(std::abs(per_rollout(0, 0) - per_rollout(0, 1)) +
                std::abs(per_rollout(0, 1) - per_rollout(0, 2)),
            1e-6);  // the samples lead to other returns
}

// ModelOptions::reflect_transitions: the model learns each transition and its mirror image, so
// its predictions are equivariant under the task's reflection (the oracle: the model itself at
// the mirrored input) on and off the data; without it they are not, which the test also checks
// so that it can fail. Every GP variant; gp_prior's prior is itself symmetric.
TEST(Models, ReflectedTransitionsMakeThePredictionsEquivariant) {
  const auto data = actual_data(1);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  const auto r = task->reflection();
  ASSERT_TRUE(r.has_value());
  Rng rng(5);
  std::vector<Transition> probes(data.begin(), data.begin() + 10);  // on the data
  for (int k = 0; k < 10; ++k) {                                    // and away from it
    Transition t;
    t.x = VectorXd(4);
    t.x << rng.uniform(-6, 6), rng.uniform(-6, 6), rng.uniform(0, 6.3), rng.uniform(0, 6.3);
    t.u = VectorXd::Constant(1, rng.uniform(-3.5, 3.5));
    t.dx = VectorXd::Zero(4);
    probes.push_back(t);
  }
  for (auto type : {model::ModelType::kGp, model::ModelType::kGpPrior, model::ModelType::kGpMi}) {
    double worst[2] = {0, 0};
    for (bool reflect : {false, true}) {
      model::ModelOptions o = gp_prior_options(0);
      o.reflect_transitions = reflect;
      o.gp_mi.max_evaluations = 20;
      auto m = pendubot_model(o, type, tunable_prior("tunable"));
      const auto s = m->learn(data);
      EXPECT_EQ(s.points, static_cast<int>(data.size()));
      EXPECT_EQ(static_cast<model::GpDynamicsModel&>(*m).output_gps()[0].size(),
                static_cast<Eigen::Index>(data.size()) * (reflect ? 2 : 1));
      Prediction p, q;
      for (const auto& t : probes) {
        const Transition mt = r->apply(t);
        m->predict(t.x, t.u, p);
        m->predict(mt.x, mt.u, q);
        const double scale = 1 + p.mean.cwiseAbs().maxCoeff();
        const VectorXd mirrored = r->state_sign.cwiseProduct(p.mean);
        worst[reflect] = std::max({worst[reflect],
                                   (q.mean - mirrored).cwiseAbs().maxCoeff() / scale,
                                   (q.var - p.var).cwiseAbs().maxCoeff() / scale});
      }
    }
    // Round-off only (2e-6 for gp, whose GPs sit near their noise floor, so K is ill-conditioned;
    // 3e-8 and 3e-14 for gp_prior and gp_mi). Without: 1.5, 0.48 and 0.0032 (gp_mi's identified
    // phi leaves a small residual).
    EXPECT_LT(worst[1], 1e-5) << to_string(type);
    EXPECT_GT(worst[0], 1e-3) << to_string(type);
  }
}

// GP-MI's phi step on reflected pairs scores by blocks (the prior on the recorded rows, one
// solve of N per output). The oracle: the same search on the same 2N rows without the pairs
// declared (every score on all 2N rows, the kernels fitted on 2N). The kernel fits agree to
// ~1e-4 (test_reflected_pairs), so phi and the score need not agree to round-off.
TEST(Models, GpMiScoresAndPosteriorByBlocksAreThoseOnAllRows) {
  const auto data = actual_data(2);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  pendubot::PendubotPrior prior;
  const auto r = task->reflection();
  ASSERT_TRUE(r.has_value());
  std::vector<Transition> both = data;
  for (const auto& t : data) both.push_back(r->apply(t));
  model::Dataset d = model::make_dataset(both, task.get(), 4, 1);
  const Eigen::Index n = static_cast<Eigen::Index>(data.size());
  model::Dataset paired = d;
  paired.pairs.n = static_cast<int>(n);
  paired.pairs.sign = r->state_sign;
  paired.pairs.flip.resize(d.gp_in.cols());
  for (Eigen::Index c = 0; c < d.gp_in.cols(); ++c) {
    const auto a = d.gp_in.col(c).head(n), b = d.gp_in.col(c).tail(n);
    const double tol = 1e-12 * (1.0 + a.cwiseAbs().maxCoeff());
    const bool even = (b - a).cwiseAbs().maxCoeff() <= tol;
    paired.pairs.flip[c] = even ? 1.0 : -1.0;
    ASSERT_TRUE(even || (b + a).cwiseAbs().maxCoeff() <= tol) << "column " << c;
  }
  auto p = tunable_prior("partially-tunable");  // (no phi fits exactly: residuals stay)
  model::GpMiOptions o;
  o.max_evaluations = 300;
  o.rounds = 1;
  o.inner_rprop_iterations = 40;
  gp::RpropOptions rprop;
  rprop.max_iterations = 40;
  const int D = static_cast<int>(d.gp_in.cols());
  std::vector<gp::Gp> g_blocks(4, gp::Gp(D)), g_all(4, gp::Gp(D));
  const auto blocks = model::identify_phi(prior, p, paired, o, rprop, g_blocks, {});
  const auto all = model::identify_phi(prior, p, d, o, rprop, g_all, {});
  const VectorXd width = p.upper - p.lower;
  double moved = 0.0, apart = 0.0;
  for (std::size_t k = 0; k < p.tunable.size(); ++k) {
    const int i = p.tunable[k];
    const auto kk = static_cast<Eigen::Index>(k);
    moved = std::max(moved, std::abs(all.phi[i] - p.values[i]) / width[kk]);
    apart = std::max(apart, std::abs(blocks.phi[i] - all.phi[i]) / width[kk]);
  }
  EXPECT_GT(moved, 1e-2);  // the search does move phi
  EXPECT_LT(apart, 1e-3) << "blocks " << blocks.phi.transpose() << ", all " << all.phi.transpose();
  // (measured: the same phi, the scores 1e-9 apart; with residuals left at every phi, a wrong
  // factor on the quadratic term moves the score by ~2%)
  EXPECT_NEAR(blocks.score, all.score, 1e-6 * std::abs(all.score));
  // phi's posterior at the phi found, with the kernels marginalised: its gradients by blocks on
  // the pairs, against the same GPs on all 2N rows. The finite differences of gradients amplify
  // round-off (K is ill-conditioned near the noise floor): measured 2e-4 of the largest entry.
  auto at = p;
  at.values = blocks.phi;
  const auto post_blocks = model::phi_posterior(prior, at, paired, g_blocks);
  const auto post_all = model::phi_posterior(prior, at, d, g_blocks);
  ASSERT_GT(post_all.covariance.rows(), 0);
  ASSERT_TRUE(post_all.covariance.allFinite());
  const double cov_scale = post_all.covariance.cwiseAbs().maxCoeff();
  EXPECT_LT((post_blocks.covariance - post_all.covariance).cwiseAbs().maxCoeff(), 1e-3 * cov_scale)
      << post_blocks.covariance << "\n" << post_all.covariance;
}

TEST(Models, ReflectedTransitionsNeedATaskThatDeclaresAReflection) {
  model::ModelOptions o;
  o.type = model::ModelType::kGp;
  o.reflect_transitions = true;
  try {
    model::GpDynamicsModel m(o, std::make_shared<drops::testing::PendulumTask>(), nullptr, {});
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("declares no reflection"), std::string::npos) << e.what();
  }
}

namespace {

/// gp_mi on the pendubot prior with sparse output GPs of at most m inducing inputs.
model::ModelOptions sparse_gp_mi_options(int m) {
  model::ModelOptions o;
  o.type = model::ModelType::kGpMi;
  o.inducing_points = m;
  return o;
}

}  // namespace

TEST(GpMi, SparseOutputGpsIdentifyM2AndPredictHeldOutTransitions) {
  const auto data = actual_data(4);
  ASSERT_EQ(data.size(), 200u);
  auto m = model::make_model(sparse_gp_mi_options(60), std::make_shared<pendubot::SwingUpTask>(),
                             std::make_shared<pendubot::PendubotPrior>(),
                             tunable_prior("tunable"));
  const auto s = m->learn(data);
  const auto& gm = static_cast<const model::GpDynamicsModel&>(*m);
  ASSERT_TRUE(gm.sparse());
  for (const auto& g : gm.sparse_output_gps()) {
    EXPECT_EQ(g.size(), 200);
    EXPECT_LE(g.inducing_size(), 60);
  }
  EXPECT_NEAR(s.phi[1], 0.5, 0.025) << s.BriefReport();
  EXPECT_TRUE(s.phi_posterior.covariance.allFinite());
  const auto test = actual_data(5);
  double err = 0;
  Prediction p;
  for (std::size_t n = 200; n < test.size(); ++n) {
    m->predict(test[n].x, test[n].u, p);
    err = std::max(err, (p.mean - test[n].dx).cwiseAbs().maxCoeff());
    EXPECT_TRUE((p.var.array() >= 0).all());
  }
  EXPECT_LT(err, 0.05);
}

TEST(Models, InducingPointsAtLeastTheDataLeaveTheModelExact) {
  const auto data = actual_data(1);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  model::ModelOptions o = gp_prior_options(0);
  auto exact = model::make_model(o, task, prior, tunable_prior("tunable"));
  o.inducing_points = static_cast<int>(data.size());
  auto same = model::make_model(o, task, prior, tunable_prior("tunable"));
  exact->learn(data);
  same->learn(data);
  EXPECT_FALSE(static_cast<const model::GpDynamicsModel&>(*same).sparse());
  Prediction a, b;
  for (std::size_t n = 0; n < data.size(); n += 7) {
    exact->predict(data[n].x, data[n].u, a);
    same->predict(data[n].x, data[n].u, b);
    EXPECT_EQ(a.mean, b.mean);
    EXPECT_EQ(a.var, b.var);
  }
}

TEST(Models, ASparseModelRestoredFromItsStateLearnsExactlyAsTheOriginal) {
  const auto data = actual_data(3);
  const std::vector<Transition> first(data.begin(), data.begin() + 100);
  auto task = std::make_shared<pendubot::SwingUpTask>();
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  model::ModelOptions o = sparse_gp_mi_options(40);
  o.gp_mi.max_evaluations = 60;
  o.gp_mi.rounds = 2;
  o.rprop.max_iterations = 40;
  auto original = model::make_model(o, task, prior, tunable_prior("tunable"));
  original->learn(first);
  ASSERT_TRUE(static_cast<const model::GpDynamicsModel&>(*original).sparse());
  auto resumed = model::make_model(o, task, prior, tunable_prior("tunable"));
  resumed->restore(original->state());
  const auto s1 = original->learn(data);
  const auto s2 = resumed->learn(data);
  EXPECT_EQ(s1.phi, s2.phi);
  EXPECT_EQ(s1.log_likelihoods, s2.log_likelihoods);
  Prediction a, b;
  for (std::size_t n = 0; n < data.size(); n += 11) {
    original->predict(data[n].x, data[n].u, a);
    resumed->predict(data[n].x, data[n].u, b);
    EXPECT_EQ(a.mean, b.mean);
    EXPECT_EQ(a.var, b.var);
  }
}

TEST(Models, InducingPointsRefusePosteriorRollouts) {
  model::ModelOptions o = sparse_gp_mi_options(100);
  o.gp_mi.rollout_phi = model::RolloutPhi::kPosterior;
  EXPECT_THROW(model::make_model(o, std::make_shared<pendubot::SwingUpTask>(),
                                 std::make_shared<pendubot::PendubotPrior>(),
                                 tunable_prior("tunable")),
               InvalidArgument);
  o.gp_mi.rollout_phi = model::RolloutPhi::kPoint;
  o.inducing_points = -1;
  EXPECT_THROW(model::make_model(o, std::make_shared<pendubot::SwingUpTask>(),
                                 std::make_shared<pendubot::PendubotPrior>(),
                                 tunable_prior("tunable")),
               InvalidArgument);
}
