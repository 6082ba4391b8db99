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

// The checkpoint state after episode `done` of a one-thread run with these overrides (its
// episodes_done is 0 if the run never got there).
algo::BlackDropsState state_after(const std::vector<std::string>& overrides, int done) {
  ThreadLimit limit(1);
  const auto e = fixtures::experiment(overrides);
  algo::BlackDropsState saved;
  algo::BlackDropsCallbacks cb;
  cb.on_state = [&](const algo::BlackDropsState& st) {
    if (st.episodes_done == done) saved = st;
  };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, experiment::black_drops_options(e.settings), cb);
  return saved;
}

// The episodes of a one-thread run with these overrides resumed from `saved`.
std::vector<algo::EpisodeRecord> resumed_from(const std::vector<std::string>& overrides,
                                              const algo::BlackDropsState& saved) {
  ThreadLimit limit(1);
  const auto e = fixtures::experiment(overrides);
  std::vector<algo::EpisodeRecord> records;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, experiment::black_drops_options(e.settings), cb,
                        &saved);
  return records;
}

// A deterministic objective for optimize_policy: the pendubot's prior alone with mean propagation
// (one rollout is the exact model return), a 200-evaluation budget and no restarts.
class DeterministicPriorSearch : public ::testing::Test {
 protected:
  experiment::Experiment e =
      fixtures::experiment({"optimizer.max_evaluations=200", "optimizer.restarts=0"});
  const std::shared_ptr<const rollout::Task>& task = e.setup.task;
  const policy::Policy& pol = *e.setup.policy;
  std::unique_ptr<model::DynamicsModel> model =
      model::make_prior_only_model(e.setup.prior, e.setup.prior_parameters);
  algo::BlackDropsOptions o = [this] {
    auto opts = experiment::black_drops_options(e.settings);
    opts.rollouts.sample = false;
    opts.reevaluation_rollouts = 1;
    return opts;
  }();
  double model_return(const VectorXd& theta) const {
    VectorXd r;
    rollout::evaluate_policies(*task, *model, pol, {theta}, {7}, o.rollouts, r);
    return r[0];
  }
  /// The search from a fixed start with the start kept and re-evaluated, before any check.
  const VectorXd start = VectorXd::Constant(pol.param_dim(), 0.3 * o.theta_bound);
  algo::PolicySearchResult plain_search() {
    o.selection = algo::PolicySelection::kReevaluate;
    o.keep_start_point = true;
    return algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  }
};
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
TEST_F(DeterministicPriorSearch, KeepStartNeverReturnsAPolicyWorseOnTheModelThanTheStart) {
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

// start_may_be_chosen = false (what skip_known_replays asks for) on a deterministic objective:
// the start still centres the search and is evaluated, but the returned policy is another one,
// and the best of the others: by the exact model return, no other evaluated candidate on the
// short list (the best single evaluations and the runs' final means) beats it. The same searches
// with the start allowed return the start in some seeds (so the exclusion is what changed them).
TEST_F(DeterministicPriorSearch, WithoutTheStartTheBestOtherEvaluatedPolicyIsReturned) {
  int start_chosen_when_allowed = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    o.cmaes.max_evaluations = 200;
    o.selection = algo::PolicySelection::kReevaluate;
    const VectorXd start = algo::optimize_policy(*task, *model, pol,
                                                 VectorXd::Zero(pol.param_dim()), o, seed,
                                                 nullptr, nullptr).theta;
    o.cmaes.max_evaluations = 30;
    for (auto sel : {algo::PolicySelection::kBestSeen, algo::PolicySelection::kReevaluate}) {
      o.selection = sel;
      const auto allowed = algo::optimize_policy(*task, *model, pol, start, o, seed + 100,
                                                 nullptr, nullptr, true);
      if (allowed.selected == "start") ++start_chosen_when_allowed;
      const auto other = algo::optimize_policy(*task, *model, pol, start, o, seed + 100, nullptr,
                                               nullptr, false);
      // The same search (the choice comes after it): the start was evaluated first.
      EXPECT_EQ(other.search.evaluations, allowed.search.evaluations);
      EXPECT_EQ(other.search.start_value, allowed.search.start_value);
      EXPECT_NE(other.selected, "start") << "seed " << seed;
      EXPECT_FALSE((other.theta.array() == start.array()).all()) << "seed " << seed;
      const double chosen = model_return(other.theta);
      EXPECT_NEAR(other.value, chosen, 1e-9);
      for (const auto& c : other.search.best_candidates)
        if (!(c.x.array() == start.array()).all())
          EXPECT_GE(chosen, model_return(c.x) - 1e-9) << "seed " << seed;
      if (sel == algo::PolicySelection::kReevaluate)
        for (const auto& r : other.search.runs)
          if (!(r.final_mean.array() == start.array()).all())
            EXPECT_GE(chosen, model_return(r.final_mean) - 1e-9);
    }
  }
  EXPECT_GT(start_chosen_when_allowed, 0);
}

// skip_known_replays in a run: the "real" pendubot is deterministic, and with the actual system as
// the prior (gp_prior) and a 20-evaluation search the best policy soon cannot be beaten on the
// model and is run again with the same return; the episode after that runs another policy and
// records replay_skipped. Without the option, the same run is identical up to there and then
// replays the same policy a third time.
TEST(BlackDrops, AnUnsolvedPolicyReplayedWithTheSameReturnIsNotRunAThirdTime) {
  // 6 episodes: here the first replay is at episode 4; the spare episode leaves room for a
  // machine whose round-off puts it one later.
  const std::vector<std::string> base = {"prior.preset=actual", "model.type=gp_prior",
                                         "episodes=6", "optimizer.max_evaluations=20",
                                         "optimizer.prior_optimizations=1"};
  auto with = [&](const char* skip) {
    auto ov = base;
    ov.push_back(std::string("optimizer.skip_known_replays=") + skip);
    return run(1, ov);
  };
  const auto on = with("true"), off = with("false");
  ASSERT_EQ(on.size(), 6u);
  ASSERT_EQ(off.size(), 6u);
  auto same = [](const VectorXd& a, const VectorXd& b) {
    return a.size() == b.size() && (a.array() == b.array()).all();
  };
  // The first identical replay of the best policy so far, and the episode after it.
  std::size_t replay = 0;
  for (std::size_t k = 1; k + 1 < on.size() && !replay; ++k) {
    std::size_t best = 0;
    for (std::size_t j = 1; j < k; ++j)
      if (on[j].real_return > on[best].real_return) best = j;
    if (same(on[k].theta, on[best].theta) && on[k].real_return == on[best].real_return &&
        !on[best].solved)
      replay = k;
  }
  ASSERT_GT(replay, 0u) << "no identical replay happened: the setting no longer exercises the rule";
  const std::size_t next = replay + 1;
  for (std::size_t k = 0; k <= replay; ++k) {
    EXPECT_EQ(on[k].theta, off[k].theta) << "episode " << k + 1;
    EXPECT_EQ(on[k].real_return, off[k].real_return);
    EXPECT_EQ(on[k].details.numbers.count("replay_skipped"), 0u);
  }
  EXPECT_FALSE(same(on[next].theta, on[replay].theta));
  EXPECT_EQ(on[next].details.numbers.count("replay_skipped"), 1u);
  EXPECT_TRUE(same(off[next].theta, off[replay].theta));  // without it: a third identical run
  EXPECT_EQ(off[next].real_return, off[replay].real_return);
  EXPECT_EQ(off[next].details.numbers.count("replay_skipped"), 0u);

  // A run resumed right after the replay knows it (the checkpoint's record) and does the same.
  auto ov = base;
  ov.push_back("optimizer.skip_known_replays=true");
  const auto saved = state_after(ov, static_cast<int>(replay) + 1);
  ASSERT_EQ(saved.episodes_done, static_cast<int>(replay) + 1);
  const auto resumed = resumed_from(ov, saved);
  ASSERT_FALSE(resumed.empty());
  EXPECT_EQ(resumed[0].episode, static_cast<int>(next) + 1);
  EXPECT_EQ(resumed[0].theta, on[next].theta);
  EXPECT_EQ(resumed[0].details.numbers.count("replay_skipped"), 1u);
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

// The trust region's box, against a per-coordinate oracle: centre +- region b, clipped to [-b, b].
TEST(BlackDropsTrustRegion, BoxIsTheCentrePlusMinusTheRadiusInsideTheBounds) {
  VectorXd centre(4);
  centre << 0.0, 0.45, -0.5, -0.2;
  VectorXd lower, upper;
  algo::trust_region_box(centre, 0.5, 0.25, lower, upper);
  for (Eigen::Index i = 0; i < centre.size(); ++i) {
    EXPECT_DOUBLE_EQ(lower[i], std::max(-0.5, centre[i] - 0.125)) << i;
    EXPECT_DOUBLE_EQ(upper[i], std::min(0.5, centre[i] + 0.125)) << i;
  }
  algo::trust_region_box(VectorXd::Zero(4), 0.5, 1.0, lower, upper);
  EXPECT_TRUE((lower.array() == -0.5).all() && (upper.array() == 0.5).all());
  EXPECT_THROW(algo::trust_region_box(centre, 0.5, 0.0, lower, upper), InvalidArgument);
  EXPECT_THROW(algo::trust_region_box(centre, 0.5, 1.5, lower, upper), InvalidArgument);
  EXPECT_THROW(algo::trust_region_box(centre, 0.0, 0.5, lower, upper), InvalidArgument);
}

// A search in a trust region stays in it: every candidate CMA-ES kept and the returned policy lie
// within region b of the start; region 1 is the search without a region, to the bit.
TEST_F(DeterministicPriorSearch, ASearchInATrustRegionStaysInItAndRegionOneChangesNothing) {
  const double region = 0.1, half = region * o.theta_bound;
  const auto s = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr, true,
                                       region);
  auto inside = [&](const VectorXd& x) {
    return ((x - start).cwiseAbs().array() <= half * (1 + 1e-12)).all() &&
           (x.cwiseAbs().array() <= o.theta_bound).all();
  };
  EXPECT_TRUE(inside(s.theta));
  ASSERT_FALSE(s.search.best_candidates.empty());
  for (const auto& c : s.search.best_candidates) EXPECT_TRUE(inside(c.x));
  // Without the region the same search leaves that box (the optimum is not next to the start).
  const auto whole = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  EXPECT_FALSE(inside(whole.theta));
  const auto one = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr, true,
                                         1.0);
  EXPECT_EQ(one.theta, whole.theta);
  EXPECT_EQ(one.value, whole.value);
  for (double bad : {0.0, 1.5, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW(
        algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr, true, bad),
        InvalidArgument)
        << bad;
}

// optimizer.improvement_margin in one search (a deterministic model, so the paired check's
// per-stream differences all equal the chosen policy's gain over the start): the start's
// re-evaluated value is its model return; a margin below the gain changes nothing, one above it
// returns the start (recorded as kept by the margin).
TEST_F(DeterministicPriorSearch, TheStartIsReturnedUnlessACandidateBeatsItByTheMargin) {
  const auto plain = plain_search();
  ASSERT_NE(plain.selected, "start");
  EXPECT_FALSE(plain.kept_by_margin);
  EXPECT_NEAR(plain.start_value, model_return(start), 1e-9 * std::max(1.0, plain.value));
  const double gain = plain.value - plain.start_value;
  ASSERT_GT(gain, 0);
  o.improvement_margin = 0.5 * gain;
  const auto below = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  EXPECT_EQ(below.theta, plain.theta);
  EXPECT_FALSE(below.kept_by_margin);
  // Without sampling every stream's difference is the gain itself, and so is their median.
  EXPECT_NEAR(below.paired_improvement, gain, 1e-9 * std::max(1.0, plain.value));
  EXPECT_TRUE(std::isnan(plain.paired_improvement));  // no check without a margin
  o.improvement_margin = 1.5 * gain;
  const auto above = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  EXPECT_EQ(above.theta, start);
  EXPECT_EQ(above.selected, "start");
  EXPECT_TRUE(above.kept_by_margin);
  EXPECT_EQ(above.value, above.start_value);
  o.improvement_margin = -1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("improvement_margin"), std::string::npos) << why;
}

// optimizer.improvement_cap in one search (the deterministic model again: the paired improvement
// is the chosen policy's gain): a cap above the gain changes nothing, one below it returns the
// start (recorded as kept by the cap, not by the margin); the cap alone turns the check on.
TEST_F(DeterministicPriorSearch, TheStartIsReturnedWhenACandidateBeatsItByMoreThanTheCap) {
  const auto plain = plain_search();
  ASSERT_NE(plain.selected, "start");
  const double gain = plain.value - plain.start_value;
  ASSERT_GT(gain, 0);
  o.improvement_cap = 1.5 * gain;
  const auto above = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  EXPECT_EQ(above.theta, plain.theta);
  EXPECT_FALSE(above.kept_by_cap);
  EXPECT_NEAR(above.paired_improvement, gain, 1e-9 * std::max(1.0, plain.value));
  o.improvement_cap = 0.5 * gain;
  const auto below = algo::optimize_policy(*task, *model, pol, start, o, 5, nullptr, nullptr);
  EXPECT_EQ(below.theta, start);
  EXPECT_EQ(below.selected, "start");
  EXPECT_TRUE(below.kept_by_cap);
  EXPECT_FALSE(below.kept_by_margin);
  std::string why;
  o.improvement_margin = 0.5 * gain;  // a cap must lie above the margin
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("improvement_cap"), std::string::npos) << why;
  o.improvement_margin = 0;
  o.improvement_cap = -1;
  EXPECT_FALSE(o.IsValid(&why));
}

// optimizer.improvement_margin in a run: with a margin no model gain can reach, every episode
// after the first runs the first episode's policy again; the first (planned on the prior, from a
// guess) is unaffected, so it equals the run without the margin.
TEST(BlackDrops, AnUnreachableImprovementMarginRunsTheBestRealPolicyAgain) {
  const std::vector<std::string> ov = {"episodes=3", "model.type=gp_prior",
                                       "optimizer.max_evaluations=100",
                                       "optimizer.prior_optimizations=1"};
  auto with = ov;
  with.push_back("optimizer.improvement_margin=1e6");
  const auto plain = run(1, ov), kept = run(1, with);
  ASSERT_EQ(kept.size(), 3u);
  ASSERT_EQ(plain.size(), 3u);
  EXPECT_EQ(kept[0].theta, plain[0].theta);
  EXPECT_EQ(kept[0].details.numbers.count("kept_by_margin"), 0u);
  int moved_without = 0;
  for (std::size_t k = 1; k < kept.size(); ++k) {
    EXPECT_EQ(kept[k].theta, kept[0].theta) << "episode " << k + 1;
    EXPECT_EQ(kept[k].selected, "start") << "episode " << k + 1;
    ASSERT_EQ(kept[k].details.numbers.count("start_reevaluated_return"), 1u);
    EXPECT_EQ(kept[k].details.numbers.at("start_reevaluated_return"), kept[k].reevaluated_return);
    if (!(plain[k].theta.array() == plain[0].theta.array()).all()) ++moved_without;
  }
  EXPECT_GT(moved_without, 0);  // without the margin the run does move: the test can fail
}

// optimizer.improvement_cap in a run: with a cap every positive gain exceeds and no margin, every
// episode after the first runs the first episode's policy again (kept by the cap, by a gain that
// is not positive, or chosen by the re-evaluation itself), and records why.
TEST(BlackDrops, ATinyImprovementCapRunsTheBestRealPolicyAgain) {
  const std::vector<std::string> ov = {"episodes=3", "model.type=gp_prior",
                                       "optimizer.max_evaluations=100",
                                       "optimizer.prior_optimizations=1",
                                       "optimizer.improvement_cap=1e-9"};
  const auto kept = run(1, ov);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0].details.numbers.count("kept_by_cap"), 0u);
  int by_cap = 0;
  for (std::size_t k = 1; k < kept.size(); ++k) {
    EXPECT_EQ(kept[k].theta, kept[0].theta) << "episode " << k + 1;
    const auto& n = kept[k].details.numbers;
    ASSERT_EQ(n.count("kept_by_cap"), 1u) << "episode " << k + 1;
    ASSERT_EQ(n.count("kept_by_margin"), 1u) << "episode " << k + 1;
    EXPECT_LE(n.at("kept_by_cap") + n.at("kept_by_margin"), 1.0) << "episode " << k + 1;
    by_cap += static_cast<int>(n.at("kept_by_cap"));
  }
  EXPECT_GT(by_cap, 0);  // the cap acted: without it the run moves (the margin test above)
}

// optimizer.improvement_cap_max_runs in a run: the tiny cap above again, but once the real system
// has run the best policy twice the cap is off, so the run cannot stay locked on the first
// policy. The recorded run count follows the real episodes (recomputed here).
TEST(BlackDrops, TheCapStopsRunningAPolicyAgainAfterItsMaxRuns) {
  const std::vector<std::string> ov = {"episodes=4", "model.type=gp_prior",
                                       "optimizer.max_evaluations=100",
                                       "optimizer.prior_optimizations=1",
                                       "optimizer.improvement_cap=1e-9",
                                       "optimizer.improvement_cap_max_runs=2"};
  const auto r = run(1, ov);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r[0].details.numbers.count("best_policy_runs"), 0u);  // no real policy yet
  VectorXd best = r[0].theta;
  double best_return = r[0].real_return;
  int runs = 1, capped = 0, moved_after = 0;
  for (std::size_t k = 1; k < r.size(); ++k) {
    const auto& n = r[k].details.numbers;
    ASSERT_EQ(n.count("best_policy_runs"), 1u) << "episode " << k + 1;
    EXPECT_EQ(n.at("best_policy_runs"), runs) << "episode " << k + 1;
    const bool replay = (r[k].theta.array() == best.array()).all();
    if (runs >= 2) {
      EXPECT_EQ(n.count("kept_by_cap"), 0u) << "episode " << k + 1;  // the cap is off
      if (!replay) ++moved_after;
    } else if (n.count("kept_by_cap")) {
      capped += static_cast<int>(n.at("kept_by_cap"));
    }
    if (replay) ++runs;
    if (r[k].real_return > best_return) {
      if (!replay) runs = 1;
      best_return = r[k].real_return;
      best = r[k].theta;
    }
  }
  EXPECT_GT(capped, 0);       // the cap acted while it could
  EXPECT_GT(moved_after, 0);  // and the run moved on once it could not

  // A run resumed after episode 2 continues with the same count (the checkpoint keeps it).
  auto saved = state_after(ov, 2);
  ASSERT_EQ(saved.episodes_done, 2);
  ASSERT_EQ(saved.extra.count("best_policy_runs"), 1u);
  const auto resumed = resumed_from(ov, saved);
  ASSERT_EQ(resumed.size(), 2u);
  for (std::size_t k = 0; k < resumed.size(); ++k) {
    EXPECT_EQ(resumed[k].theta, r[k + 2].theta) << "episode " << k + 3;
    EXPECT_EQ(resumed[k].details.numbers.at("best_policy_runs"),
              r[k + 2].details.numbers.at("best_policy_runs"));
  }
  // A count below 1 in a checkpoint is an error, not a silent reset.
  saved.extra["best_policy_runs"] = VectorXd::Constant(1, 0.0);
  EXPECT_THROW(resumed_from(ov, saved), InvalidArgument);
}

// optimizer.trust_region in a run: the recorded radius of every episode follows TuRBO's rule from
// the episodes before it (recomputed here from their real returns), every policy run lies within
// its radius of the best real policy before it, and a run resumed from a checkpoint continues
// with the same radius and the same policies.
TEST(BlackDropsTrustRegion, TheRadiusFollowsTheRealEpisodesAndSurvivesAResume) {
  // Without the start kept as a candidate, a 30-evaluation search often runs a worse policy.
  const std::vector<std::string> ov = {"episodes=7", "model.type=gp_prior",
                                       "optimizer.max_evaluations=30", "optimizer.keep_start=false",
                                       "optimizer.prior_optimizations=1",
                                       "optimizer.trust_region=true",
                                       "optimizer.trust_region_min=0.25"};
  const auto r = run(1, ov);
  ASSERT_EQ(r.size(), 7u);
  const auto o = experiment::black_drops_options(fixtures::experiment(ov).settings);
  double region = 1.0, best_return = r[0].real_return;
  VectorXd best = r[0].theta;
  int shrinks = 0;
  for (std::size_t k = 1; k < r.size(); ++k) {
    ASSERT_EQ(r[k].details.numbers.count("trust_region_radius"), 1u) << "episode " << k + 1;
    EXPECT_EQ(r[k].details.numbers.at("trust_region_radius"), region) << "episode " << k + 1;
    std::printf("[info] episode %d: radius %.3f, return %.3f\n", static_cast<int>(k + 1), region,
                r[k].real_return);
    if (region < 1)
      EXPECT_LE((r[k].theta - best).cwiseAbs().maxCoeff(), region * o.theta_bound * (1 + 1e-12))
          << "episode " << k + 1;
    const bool replay = (r[k].theta.array() == best.array()).all();
    if (!replay) {
      const double before = region;
      region = r[k].real_return > best_return ? std::min(1.0, 2 * region)
                                              : std::max(0.25, region / 2);
      if (region < before) ++shrinks;
    }
    if (r[k].real_return > best_return) {
      best_return = r[k].real_return;
      best = r[k].theta;
    }
  }
  EXPECT_GT(shrinks, 0) << "no episode failed: the setting no longer exercises the rule";

  auto saved = state_after(ov, 4);
  ASSERT_EQ(saved.episodes_done, 4);
  ASSERT_EQ(saved.extra.count("trust_region_radius"), 1u);
  const auto resumed = resumed_from(ov, saved);
  ASSERT_EQ(resumed.size(), 3u);
  for (std::size_t k = 0; k < resumed.size(); ++k) {
    EXPECT_EQ(resumed[k].theta, r[k + 4].theta) << "episode " << k + 5;
    EXPECT_EQ(resumed[k].details.numbers.at("trust_region_radius"),
              r[k + 4].details.numbers.at("trust_region_radius"));
  }
  // A radius outside (0, 1] in a checkpoint is an error, not a silent reset.
  saved.extra["trust_region_radius"] = VectorXd::Constant(1, 2.0);
  EXPECT_THROW(resumed_from(ov, saved), InvalidArgument);
}
