// Model rollouts: the batched evaluator equals the shared single-step path, and is independent of
// the thread count.
#include <gtest/gtest.h>

#include "drops/core/parallel.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/pendubot/pendubot.hpp"

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

TEST(Rollout, BatchedEvaluationEqualsRunEpisodeOnTheModelSystem) {
  Fixture f;
  rollout::RolloutOptions o;
  o.batch = 4;
  VectorXd returns;
  rollout::evaluate_policies(*f.task, *f.model, *f.pol, f.thetas, f.seeds, o, returns);
  rollout::ModelSystem system(*f.model, o);
  for (std::size_t k = 0; k < f.thetas.size(); ++k) {
    auto p = f.pol->clone();
    p->set_params(f.thetas[k]);
    Rng rng(derive_seed(f.seeds[k], {0}));
    const auto tr = rollout::run_episode(*f.task, system, *p, rng);
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
