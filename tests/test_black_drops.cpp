// Algorithm 1 as a library call: reproducibility across thread counts and episode bookkeeping.
#include <gtest/gtest.h>

#include "drops/algo/black_drops.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/io/config.hpp"

using namespace drops;

namespace {
std::vector<algo::EpisodeRecord> run(int threads, const std::vector<std::string>& overrides) {
  ThreadLimit limit(threads);
  const auto e = io::make_experiment(io::load_settings("", overrides));
  auto task = std::make_shared<pendubot::SwingUpTask>(e.task_options);
  pendubot::PendubotSystem real(e.actual, e.task_options);
  auto prior = std::make_shared<pendubot::PendubotPrior>(e.task_options);
  policy::NeuralNetPolicy pol(e.policy);
  std::vector<algo::EpisodeRecord> records;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  algo::run_black_drops(task, real, pol, prior, e.prior, e.algo, cb);
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
  EXPECT_LE(r[1].evaluations, 501);  // the budget, plus the evaluation of the start point
  EXPECT_GT(r[1].evaluations, 400);
}

TEST(BlackDrops, DifferentSeedsGiveDifferentRuns) {
  const auto a = run(2, {"episodes=1", "optimizer.max_evaluations=300", "seed=1"});
  const auto b = run(2, {"episodes=1", "optimizer.max_evaluations=300", "seed=2"});
  EXPECT_NE(a[0].theta, b[0].theta);
}

TEST(BlackDrops, InvalidOptionsAreRejected) {
  algo::BlackDropsOptions o;
  o.episodes = 0;
  auto task = std::make_shared<pendubot::SwingUpTask>();
  pendubot::PendubotSystem real(pendubot::Params{});
  policy::NeuralNetPolicy pol;
  EXPECT_THROW(algo::run_black_drops(task, real, pol, nullptr, {}, o), InvalidArgument);
}
