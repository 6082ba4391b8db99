// Model rollouts: the batched evaluator equals the shared single-step path, and is independent of
// the thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "drops/control/balance.hpp"
#include "drops/core/parallel.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "torque_cost_task.hpp"

using namespace drops;

namespace {
struct Fixture {
  std::shared_ptr<pendubot::SwingUpTask> task = std::make_shared<pendubot::SwingUpTask>();
  std::shared_ptr<pendubot::PendubotPrior> prior = std::make_shared<pendubot::PendubotPrior>();
  std::unique_ptr<policy::NeuralNetPolicy> pol;
  std::unique_ptr<model::DynamicsModel> model;
  std::vector<VectorXd> thetas;
  std::vector<std::uint64_t> seeds;
  Fixture() {
    policy::NeuralNetPolicyOptions po;
    po.input_scale = VectorXd(6);
    po.input_scale << 10, 10, 1, 1, 1, 1;
    pol = std::make_unique<policy::NeuralNetPolicy>(po);
    pendubot::PendubotSystem real(pendubot::Params{});
    std::vector<Transition> data;
    Rng rng(9);
    VectorXd theta(81);
    for (int i = 0; i < 81; ++i) theta[i] = rng.uniform(-1, 1);
    pol->set_params(theta);
    for (auto& t : rollout::run_episode(*task, real, *pol, rng).transitions()) data.push_back(t);
    model::PriorParameters p;
    p.names = pendubot::parameter_names();
    p.values = pendubot::preset("tunable").to_phi();
    model::ModelOptions o;
    o.type = model::ModelType::kGpPrior;
    o.rprop.max_iterations = 50;
    model = model::make_model(o, task, prior, p);
    model->learn(data);
    for (int k = 0; k < 13; ++k) {
      VectorXd th(81);
      for (int i = 0; i < 81; ++i) th[i] = rng.uniform(-2, 2);
      thetas.push_back(th);
      seeds.push_back(1000 + static_cast<std::uint64_t>(k));
    }
  }
};
}  // namespace

namespace {
/// run_episode of the fixture's policy k on the model system, with rollout 0's random stream:
/// what evaluate_policies computes for thetas[k] with one rollout.
rollout::Trajectory model_episode(const Fixture& f, const rollout::Task& task,
                                  const rollout::ModelSystem& system, std::size_t k) {
  auto p = f.pol->clone();
  p->set_params(f.thetas[k]);
  Rng rng(derive_seed(f.seeds[k], {0}));
  return rollout::run_episode(task, system, *p, rng);
}
}  // namespace

TEST(Rollout, BatchedEvaluationEqualsRunEpisodeOnTheModelSystem) {
  Fixture f;
  rollout::RolloutOptions o;
  o.batch = 4;
  VectorXd returns;
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, returns);
  rollout::ModelSystem system(*f.model, o);
  for (std::size_t k = 0; k < f.thetas.size(); ++k) {
    const auto tr = model_episode(f, *f.task, system, k);
    EXPECT_NEAR(tr.total_return(), returns[static_cast<Eigen::Index>(k)], 1e-6) << k;
  }
}

TEST(Rollout, SameSeedSameReturnsWithOneAndTwoThreads) {
  Fixture f;
  rollout::RolloutOptions o;
  o.rollouts = 3;
  VectorXd r1, r2;
  {
    ThreadLimit one(1);
    rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, r1);
  }
  {
    ThreadLimit two(2);
    rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, r2);
  }
  EXPECT_EQ((r1 - r2).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Rollout, SamplingChangesReturnsAndMeanPropagationIsDeterministic) {
  Fixture f;
  rollout::RolloutOptions o;
  VectorXd a, b;
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, a);
  std::vector<std::uint64_t> other(f.seeds.size(), 77);
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, other, o, b);
  EXPECT_GT((a - b).cwiseAbs().maxCoeff(), 0.0);
  o.sample = false;
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, a);
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, other, o, b);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
}

// The oracle of the statistics' tests: the returns of policy k's o.rollouts rollouts, each run
// alone through run_episode on the model with its own stream, sorted.
namespace {
std::vector<double> sorted_rollout_returns(const Fixture& f, const rollout::RolloutOptions& o,
                                           std::size_t k) {
  const rollout::ModelSystem system(*f.model, o);
  auto p = f.pol->clone();
  p->set_params(f.thetas[k]);
  std::vector<double> r;
  for (int i = 0; i < o.rollouts; ++i) {
    Rng rng(derive_seed(f.seeds[k], {static_cast<std::uint64_t>(i)}));
    r.push_back(rollout::run_episode(*f.task, system, *p, rng).total_return());
  }
  std::sort(r.begin(), r.end());
  return r;
}
}  // namespace

// The median statistic is the median of the rollouts' own returns (oracle: each rollout run alone
// through run_episode on the model with its stream), for an odd and an even count, and it is not
// the mean.
TEST(Rollout, MedianStatisticIsTheMedianOfTheRolloutsReturns) {
  Fixture f;
  for (const int R : {5, 4}) {
    rollout::RolloutOptions o;
    o.rollouts = R;
    o.batch = 3;
    VectorXd mean, median;
    rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, mean);
    o.statistic = rollout::ReturnStatistic::kMedian;
    rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, median);
    double largest_gap = 0;
    for (std::size_t k = 0; k < f.thetas.size(); ++k) {
      const std::vector<double> r = sorted_rollout_returns(f, o, k);
      const double expected = R % 2 ? r[R / 2] : 0.5 * (r[R / 2 - 1] + r[R / 2]);
      const auto i = static_cast<Eigen::Index>(k);
      EXPECT_NEAR(median[i], expected, 1e-6) << "R " << R << " policy " << k;
      largest_gap = std::max(largest_gap, std::abs(median[i] - mean[i]));
    }
    EXPECT_GT(largest_gap, 1e-3) << "R " << R;
  }
}

// Each rollout's return, as evaluate_policies reports it for calibration: rollout r of policy k is
// the oracle's run_episode with stream derive_seed(seeds[k], {r}), in rollout order, and their
// mean is the mean statistic.
TEST(Rollout, EachRolloutsReturnIsReportedInRolloutOrder) {
  Fixture f;
  rollout::RolloutOptions o;
  o.rollouts = 5;
  o.batch = 3;
  VectorXd mean;
  MatrixXd each;
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, mean, nullptr,
                             &each);
  ASSERT_EQ(each.rows(), static_cast<Eigen::Index>(f.thetas.size()));
  ASSERT_EQ(each.cols(), 5);
  const rollout::ModelSystem system(*f.model, o);
  for (std::size_t k = 0; k < f.thetas.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    auto p = f.pol->clone();
    p->set_params(f.thetas[k]);
    for (int r = 0; r < 5; ++r) {
      Rng rng(derive_seed(f.seeds[k], {static_cast<std::uint64_t>(r)}));
      EXPECT_NEAR(each(i, r), rollout::run_episode(*f.task, system, *p, rng).total_return(), 1e-6)
          << "policy " << k << " rollout " << r;
    }
    EXPECT_NEAR(each.row(i).mean(), mean[i], 1e-12 * std::max(1.0, std::abs(mean[i])));
  }
}

namespace {
/// A 1-D toy: x climbs by 1 per step (whatever the action) until it reaches `top`, where it
/// stays; reward x per step. With `absorbing`, x >= top is declared absorbing.
class Climb final : public rollout::Task {
 public:
  Climb(double top, bool absorbing) : top_(top), absorbing_(absorbing) {}
  std::string name() const override { return "climb"; }
  int state_dim() const override { return 1; }
  int action_dim() const override { return 1; }
  int observation_dim() const override { return 1; }
  int horizon() const override { return 10; }
  double dt() const override { return 1; }
  VectorXd initial_state() const override { return VectorXd::Zero(1); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override { obs = x; }
  double reward(const VectorXd& x) const override { return x[0]; }
  bool solved(const rollout::Trajectory&) const override { return false; }
  bool absorbing(const VectorXd& x) const override { return absorbing_ && x[0] >= top_; }

 private:
  double top_;
  bool absorbing_;
};

/// dx = 1 below the top, 0 at it; counts the rows it is asked to predict.
class ClimbModel final : public model::DynamicsModel {
 public:
  explicit ClimbModel(double top) : top_(top) {}
  model::ModelSummary learn(const std::vector<Transition>&, const model::ModelProgress&) override {
    return {};
  }
  void predict(const VectorXd& x, const VectorXd&, Prediction& out) const override {
    out.mean = VectorXd::Constant(1, x[0] >= top_ ? 0.0 : 1.0);
    out.var = VectorXd::Zero(1);
  }
  void predict_batch(const MatrixXd& X, const MatrixXd&, MatrixXd& mean,
                     MatrixXd& var) const override {
    rows += X.rows();
    mean.resize(X.rows(), 1);
    var = MatrixXd::Zero(X.rows(), 1);
    for (Eigen::Index b = 0; b < X.rows(); ++b) mean(b, 0) = X(b, 0) >= top_ ? 0.0 : 1.0;
  }
  VectorXd phi() const override { return {}; }
  model::ModelState state() const override { return {}; }
  void restore(const model::ModelState&) override {}
  mutable std::atomic<long> rows{0};

 private:
  double top_;
};
}  // namespace

// An absorbing state ends a rollout early with the return it would have had: the climb reaches
// the top (3) at step 3 and stays; declared absorbing, the rollout stops there, adds 3 for each of
// the 7 remaining steps, and the model predicts 3 steps of it instead of 10.
TEST(Rollout, AnAbsorbingStateEndsTheRolloutWithTheSameReturnAndFewerPredictions) {
  policy::NeuralNetPolicyOptions po;
  po.observation_dim = 1;
  po.hidden_units = 2;
  policy::NeuralNetPolicy pol(po);
  const std::vector<VectorXd> thetas(3, VectorXd::Zero(pol.param_dim()));
  const std::vector<std::uint64_t> seeds = {1, 2, 3};
  rollout::RolloutOptions ro;
  ro.sample = false;
  ro.batch = 2;  // a batch of 2 lanes and one of 1
  VectorXd plain, absorbed;
  ClimbModel m1(3), m2(3);
  rollout::RolloutStats s1, s2;
  rollout::evaluate_policies(Climb(3, false), m1, pol, thetas, seeds, ro, plain, &s1);
  rollout::evaluate_policies(Climb(3, true), m2, pol, thetas, seeds, ro, absorbed, &s2);
  const double expected = 1 + 2 + 3 * 8;  // x = 1, 2, then 3 for the remaining 8 steps
  for (int k = 0; k < 3; ++k) {
    EXPECT_DOUBLE_EQ(plain[k], expected);
    EXPECT_DOUBLE_EQ(absorbed[k], expected);
  }
  EXPECT_EQ(m1.rows.load(), 3 * 10);
  EXPECT_EQ(m2.rows.load(), 3 * 3);
  EXPECT_EQ(s1.absorbed, 0);
  EXPECT_EQ(s2.absorbed, 3);
}

using drops::testing::TorqueCostTask;

TEST(Rollout, AnActionRewardIsAddedToEachStepOfEpisodesAndOfTheModelsRollouts) {
  Fixture f;
  const double w = 0.01;
  const TorqueCostTask costly(f.task, w);
  // On the real system: the same states and actions, each step's reward lowered by w u_t^2.
  pendubot::PendubotSystem real(pendubot::Params{});
  Rng r1(5), r2(5);
  f.pol->set_params(f.thetas[0]);
  const auto plain = rollout::run_episode(*f.task, real, *f.pol, r1);
  const auto with_cost = rollout::run_episode(costly, real, *f.pol, r2);
  ASSERT_EQ(plain.states, with_cost.states);
  double cost = 0;
  for (int t = 0; t < f.task->horizon(); ++t) {
    const double u2 = plain.actions.row(t).squaredNorm();
    EXPECT_NEAR(with_cost.rewards[t], plain.rewards[t] - w * u2, 1e-12) << t;
    cost += w * u2;
  }
  ASSERT_GT(cost, 1e-3);  // the policy does act
  // The catch-and-balance wrapper keeps it.
  const control::BalanceTask balanced(std::make_shared<TorqueCostTask>(f.task, w));
  EXPECT_TRUE(balanced.has_action_reward());
  EXPECT_DOUBLE_EQ(balanced.action_reward(VectorXd::Constant(1, 3.0)), -9 * w);
  // On the model: the batched evaluator (lanes leaving the batch included) equals run_episode on
  // the model system, and differs from the plain task's returns by the rollouts' action costs.
  rollout::RolloutOptions o;
  o.batch = 4;
  VectorXd returns, plain_returns;
  rollout::evaluate_policies(costly, *f.model, *f.pol, f.thetas, f.seeds, o, returns);
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, plain_returns);
  rollout::ModelSystem system(*f.model, o);
  for (std::size_t k = 0; k < f.thetas.size(); ++k) {
    const auto tr = model_episode(f, costly, system, k);
    const auto i = static_cast<Eigen::Index>(k);
    EXPECT_NEAR(tr.total_return(), returns[i], 1e-6) << k;
    const Eigen::Index steps = tr.nonfinite_step >= 0 ? tr.nonfinite_step : tr.actions.rows();
    const double rollout_cost = w * tr.actions.topRows(steps).squaredNorm();
    EXPECT_GT(rollout_cost, 0) << k;
    EXPECT_NEAR(plain_returns[i] - returns[i], rollout_cost, 1e-6) << k;
  }
}
