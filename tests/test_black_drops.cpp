// Algorithm 1 as a library call: reproducibility across thread counts and episode bookkeeping.
#include <gtest/gtest.h>

#include "drops/algo/black_drops.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "fixtures.hpp"
#include "drops/core/rng.hpp"

using namespace drops;

namespace {
std::vector<algo::EpisodeRecord> run(int threads, const std::vector<std::string>& overrides) {
  ThreadLimit limit(threads);
  const auto e = fixtures::experiment(overrides);
  std::vector<algo::EpisodeRecord> records;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, experiment::black_drops_options(e.settings), cb);
  return records;
}
}  // namespace

TEST(BlackDrops, SameSeedGivesIdenticalEpisodesWithOneAndTwoThreads) {
  const std::vector<std::string> ov = {"episodes=3", "optimizer.max_evaluations=1500",
                                       "optimizer.prior_optimizations=1", "rollouts.count=2"};
  const auto a = run(1, ov), b = run(2, ov);
  ASSERT_EQ(a.size(), 3u);
  ASSERT_EQ(b.size(), 3u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].theta, b[k].theta) << "episode " << k + 1;
    EXPECT_EQ(a[k].real_return, b[k].real_return);
    EXPECT_EQ(a[k].phi, b[k].phi);
    EXPECT_EQ(a[k].predicted_return, b[k].predicted_return);
  }
}

TEST(BlackDrops, RecordsEveryEpisodeWithItsData) {
  const auto r = run(2, {"episodes=2", "model.type=gp", "optimizer.max_evaluations=500"});
  ASSERT_EQ(r.size(), 2u);
  EXPECT_TRUE(r[0].random_policy);  // no prior: episode 1 is random
  EXPECT_FALSE(r[1].random_policy);
  EXPECT_EQ(r[1].model.points, 50);
  EXPECT_EQ(r[0].real.states.rows(), 51);
  EXPECT_DOUBLE_EQ(r[1].interaction_time, 5.0);
  EXPECT_NEAR(r[1].real_return, r[1].real.rewards.sum(), 1e-12);
  EXPECT_LE(r[1].evaluations, 500);  // the budget (the start point is not evaluated by default)
  EXPECT_GT(r[1].evaluations, 400);
}

TEST(BlackDrops, DifferentSeedsGiveDifferentRuns) {
  const auto a = run(2, {"episodes=1", "optimizer.max_evaluations=300", "seed=1"});
  const auto b = run(2, {"episodes=1", "optimizer.max_evaluations=300", "seed=2"});
  EXPECT_NE(a[0].theta, b[0].theta);
}

// keep_start_point on a deterministic objective (the prior alone, mean propagation): the returned
// policy is never worse on the model than the start, whatever the selection; without it, a tiny
// budget from a good start often returns something worse (the situation the option is for).
TEST(BlackDrops, KeepStartNeverReturnsAPolicyWorseOnTheModelThanTheStart) {
  const auto e = fixtures::experiment({"optimizer.max_evaluations=200", "optimizer.restarts=0"});
  const auto& task = e.setup.task;
  const policy::Policy& pol = *e.setup.policy;
  const auto model = model::make_prior_only_model(e.setup.prior, e.setup.prior_parameters);
  auto o = experiment::black_drops_options(e.settings);
  o.rollouts.sample = false;  // deterministic: one rollout is the exact model return
  o.reevaluation_rollouts = 1;
  auto model_return = [&](const VectorXd& theta) {
    VectorXd r;
    rollout::evaluate_policies(*task, *model, pol, {theta}, {7}, o.rollouts, r);
    return r[0];
  };
  int worse_without = 0, start_kept = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    o.cmaes.max_evaluations = 200;
    const VectorXd zero = VectorXd::Zero(pol.param_dim());
    const VectorXd start = algo::optimize_policy(*task, *model, pol, zero, o, seed, nullptr,
                                                 nullptr).theta;
    const double start_return = model_return(start);
    o.cmaes.max_evaluations = 30;
    for (auto sel : {algo::PolicySelection::kBestSeen, algo::PolicySelection::kReevaluate}) {
      o.selection = sel;
      o.keep_start_point = true;
      const auto with = algo::optimize_policy(*task, *model, pol, start, o, seed + 100, nullptr,
                                              nullptr);
      EXPECT_GE(model_return(with.theta), start_return - 1e-9) << "seed " << seed;
      EXPECT_NEAR(with.value, model_return(with.theta), 1e-9);
      EXPECT_EQ(with.search.evaluations, 30);  // the start and 29 candidates (the budget is total)
      if (with.selected == "start") {
        ++start_kept;
        EXPECT_EQ(with.theta, start);
      }
    }
    o.selection = algo::PolicySelection::kBestSeen;
    o.keep_start_point = false;
    const auto without = algo::optimize_policy(*task, *model, pol, start, o, seed + 100, nullptr,
                                               nullptr);
    if (model_return(without.theta) < start_return - 1e-9) ++worse_without;
  }
  EXPECT_GT(worse_without, 0);  // without it a worse policy is returned
  EXPECT_GT(start_kept, 0);     // with it, the start itself is returned then
}

// A noisy model (sampled rollouts of a GP learned on 3 random episodes): by a 2,000-rollout oracle,
// the re-evaluated choice has a better mean than the luckiest single evaluation, and its reported
// value is close to its mean; the luckiest draw over-states its own.
TEST(BlackDrops, ReevaluatedSelectionPicksABetterMeanThanTheLuckiestDrawOnANoisyModel) {
  const auto e = fixtures::experiment({"optimizer.max_evaluations=300", "model.type=gp"});
  const auto& task = e.setup.task;
  const rollout::System& real = *e.setup.real;
  const policy::Policy& pol = *e.setup.policy;
  const auto algo_options = experiment::black_drops_options(e.settings);
  // A GP model learned on 3 random episodes: wide predictive variances, so rollouts are noisy.
  auto model = model::make_model(algo_options.model, task, nullptr, e.setup.prior_parameters);
  std::vector<Transition> data;
  for (std::uint64_t k = 0; k < 3; ++k) {
    Rng rng(derive_seed(11, {k}));
    VectorXd theta(pol.param_dim());
    for (Eigen::Index i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1, 1);
    auto p = pol.clone();
    p->set_params(theta);
    for (auto& t : rollout::run_episode(*task, real, *p, rng).transitions()) data.push_back(t);
  }
  model->learn(data);
  auto oracle = [&](const VectorXd& theta) {
    rollout::RolloutOptions ro = algo_options.rollouts;
    ro.rollouts = 2000;
    VectorXd r;
    rollout::evaluate_policies(*task, *model, pol, {theta}, {99}, ro, r);
    return r[0];
  };
  double margin_sum = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    auto o = algo_options;
    o.selection = algo::PolicySelection::kReevaluate;
    const auto s = algo::optimize_policy(*task, *model, pol, VectorXd::Zero(pol.param_dim()), o,
                                         seed, nullptr, nullptr);
    EXPECT_GE(s.candidates, 2);
    const double chosen = oracle(s.theta), luckiest = oracle(s.search.best_x);
    std::printf("[info] seed %d: chosen %.2f (re-evaluated %.2f, %s), luckiest %.2f (its draw "
                "%.2f)\n", static_cast<int>(seed), chosen, s.value, s.selected.c_str(), luckiest,
                -s.search.best_value);
    // The single best draw over-states its own mean by far (measured 6-14); the re-evaluated value
    // is close to the oracle (measured within 0.3). The luckiest draw is on the short list, so the
    // chosen policy is never clearly worse than it; it may be the same policy (seed 2 on an
    // AVX-512 machine: the luckiest draw was also the best mean).
    EXPECT_GT(-s.search.best_value - luckiest, 5.0) << "seed " << seed;
    EXPECT_NEAR(s.value, chosen, 1.0) << "seed " << seed;
    EXPECT_GE(chosen, luckiest - 0.5) << "seed " << seed;
    margin_sum += chosen - luckiest;
  }
  // On average the re-evaluated choice is better than the luckiest draw by a margin (measured: a
  // mean of 2.1 over the 3 seeds on AVX-512, 2.5-4 per seed on the previous machine).
  EXPECT_GT(margin_sum / 3, 1.0);
}

// A model of one's own plugs in through BlackDropsOptions::model_factory: here a wrapper that
// counts its calls and its learn()s around the default model, so the run must equal the default.
TEST(BlackDrops, ACustomModelFactoryIsUsedForEveryLearning) {
  const auto e = fixtures::experiment({"episodes=3", "optimizer.max_evaluations=300",
                                       "optimizer.prior_optimizations=1"});
  class Counting final : public model::DynamicsModel {
   public:
    Counting(std::unique_ptr<model::DynamicsModel> m, int* learns) : m_(std::move(m)), learns_(learns) {}
    model::ModelType type() const override { return m_->type(); }
    model::ModelSummary learn(const std::vector<Transition>& d,
                              const model::ModelProgress& p) override {
      ++*learns_;
      return m_->learn(d, p);
    }
    void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
      m_->predict(x, u, out);
    }
    void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                       MatrixXd& var) const override {
      m_->predict_batch(X, U, mean, var);
    }
    VectorXd phi() const override { return m_->phi(); }
    model::ModelState state() const override { return m_->state(); }
    void restore(const model::ModelState& s) override { m_->restore(s); }

   private:
    std::unique_ptr<model::DynamicsModel> m_;
    int* learns_;
  };
  auto o = experiment::black_drops_options(e.settings);
  std::vector<algo::EpisodeRecord> plain, custom;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { plain.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, o, cb);
  int made = 0, learns = 0;
  o.model_factory = [&](const model::ModelOptions& mo, std::shared_ptr<const rollout::Task> t,
                        std::shared_ptr<const model::MeanFunction> p,
                        const model::PriorParameters& pp) -> std::unique_ptr<model::DynamicsModel> {
    ++made;
    return std::make_unique<Counting>(model::make_model(mo, t, p, pp), &learns);
  };
  cb.on_episode = [&](const algo::EpisodeRecord& r) { custom.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, o, cb);
  EXPECT_EQ(made, 1);
  EXPECT_EQ(learns, 2);  // before episodes 2 and 3
  ASSERT_EQ(custom.size(), plain.size());
  for (std::size_t k = 0; k < plain.size(); ++k) EXPECT_EQ(custom[k].real_return, plain[k].real_return);
}

TEST(BlackDrops, InvalidOptionsAreRejected) {
  algo::BlackDropsOptions o;
  o.episodes = 0;
  auto task = std::make_shared<pendubot::SwingUpTask>();
  pendubot::PendubotSystem real(pendubot::Params{});
  policy::NeuralNetPolicy pol;
  EXPECT_THROW(algo::run_black_drops(task, real, pol, nullptr, {}, o), InvalidArgument);
}
