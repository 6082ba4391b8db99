// Algorithm 1 as a library call: reproducibility across thread counts and episode bookkeeping.
#include <gtest/gtest.h>

#include <random>
#include <sstream>

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
                        e.setup.prior_parameters,
                        experiment::black_drops_options(fixtures::registry(), e.settings), cb);
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
                        e.setup.prior_parameters,
                        experiment::black_drops_options(fixtures::registry(), e.settings), cb);
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
  algo::run_black_drops(
      e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior, e.setup.prior_parameters,
      experiment::black_drops_options(fixtures::registry(), e.settings), cb, &saved);
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
  algo::PolicySearchOptions o = [this] {
    auto opts = experiment::black_drops_options(fixtures::registry(), e.settings).search;
    opts.rollouts.sample = false;
    opts.reevaluation.rollouts = 1;
    return opts;
  }();
  double model_return(const VectorXd& theta) const {
    VectorXd r;
    rollout::evaluate_policies(*task, *model, pol, {theta}, {7}, o.rollouts, r);
    return r[0];
  }
  /// A fixed start away from the model's optimum.
  const VectorXd start = VectorXd::Constant(pol.param_dim(), 0.3 * o.theta_bound);
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
    const VectorXd start = algo::optimize_policy(*task, *model, pol, o, {zero, seed}).theta;
    const double start_return = model_return(start);
    o.cmaes.max_evaluations = 30;
    for (auto sel : {algo::PolicySelection::kBestSeen, algo::PolicySelection::kReevaluate}) {
      o.selection = sel;
      o.keep_start_point = true;
      const auto with = algo::optimize_policy(*task, *model, pol, o, {start, seed + 100});
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
    const auto without = algo::optimize_policy(*task, *model, pol, o, {start, seed + 100});
    if (model_return(without.theta) < start_return - 1e-9) ++worse_without;
  }
  EXPECT_GT(worse_without, 0);  // without it a worse policy is returned
  EXPECT_GT(start_kept, 0);     // with it, the start itself is returned then
}

// A noisy model (sampled rollouts of a GP learned on 3 random episodes): by a 2,000-rollout oracle,
// the re-evaluated choice has a better mean than the luckiest single evaluation, and its reported
// value is close to its mean; the luckiest draw over-states its own.
TEST(BlackDrops, ReevaluatedSelectionPicksABetterMeanThanTheLuckiestDrawOnANoisyModel) {
  // Without the pendubot's reflected transitions, which would double what the model knows.
  const auto e = fixtures::experiment(
      {"optimizer.max_evaluations=300", "model.type=gp", "model.reflect_transitions=false"});
  const auto& task = e.setup.task;
  const rollout::System& real = *e.setup.real;
  const policy::Policy& pol = *e.setup.policy;
  const auto algo_options = experiment::black_drops_options(fixtures::registry(), e.settings);
  // A GP model learned on 3 random episodes: wide predictive variances, so rollouts are noisy.
  auto model = algo_options.model_factory(algo_options.model, task, nullptr,
                                          e.setup.prior_parameters);
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
    rollout::RolloutOptions ro = algo_options.search.rollouts;
    ro.rollouts = 2000;
    VectorXd r;
    rollout::evaluate_policies(*task, *model, pol, {theta}, {99}, ro, r);
    return r[0];
  };
  double margin_sum = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    auto o = algo_options.search;
    o.selection = algo::PolicySelection::kReevaluate;
    const auto s =
        algo::optimize_policy(*task, *model, pol, o, {VectorXd::Zero(pol.param_dim()), seed});
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

  auto o = experiment::black_drops_options(fixtures::registry(), e.settings);
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
    return std::make_unique<fixtures::CountingModel>(model::make_model(mo, t, p, pp), &learns);
  };
  cb.on_episode = [&](const algo::EpisodeRecord& r) { custom.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, o, cb);
  EXPECT_EQ(made, 1);
  EXPECT_EQ(learns, 2);  // before episodes 2 and 3
  ASSERT_EQ(custom.size(), plain.size());
  for (std::size_t k = 0; k < plain.size(); ++k) EXPECT_EQ(custom[k].real_return, plain[k].real_return);
}

// A real system that breaks down (fault injection): at step 20 of episode 2 it returns NaN. That
// episode ends there (reward 0 afterwards), is never solved (its frozen last rows could look like
// success), records the step, and only its 20 finite transitions join the data; the run goes on.
TEST(BlackDrops, ARealEpisodeThatGoesNonFiniteEndsThereIsNotSolvedAndAddsOnlyItsFiniteSteps) {
  class Breaking final : public rollout::System {
   public:
    explicit Breaking(const rollout::System& inner) : inner_(inner) {}
    VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override {
      return inner_.step(x, u, rng);
    }
    std::unique_ptr<rollout::EpisodeSession> begin_episode(const VectorXd& x0) const override {
      class Session final : public rollout::EpisodeSession {
       public:
        Session(std::unique_ptr<rollout::EpisodeSession> s, bool breaks)
            : s_(std::move(s)), breaks_(breaks) {}
        VectorXd step(const VectorXd& u, Rng& rng) override {
          VectorXd x = s_->step(u, rng);
          if (breaks_ && ++t_ > 20) x.setConstant(std::numeric_limits<double>::quiet_NaN());
          return x;
        }

       private:
        std::unique_ptr<rollout::EpisodeSession> s_;
        bool breaks_;
        int t_ = 0;
      };
      return std::make_unique<Session>(inner_.begin_episode(x0), ++episodes_ == 2);
    }

   private:
    const rollout::System& inner_;
    mutable int episodes_ = 0;
  };
  ThreadLimit limit(1);
  const auto e = fixtures::experiment({"episodes=3", "optimizer.max_evaluations=300",
                                       "optimizer.prior_optimizations=1"});
  const Breaking real(*e.setup.real);
  std::vector<algo::EpisodeRecord> records;
  std::vector<std::size_t> data_sizes;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  cb.on_state = [&](const algo::BlackDropsState& st) { data_sizes.push_back(st.data.size()); };
  algo::run_black_drops(e.setup.task, real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters,
                        experiment::black_drops_options(fixtures::registry(), e.settings), cb);
  ASSERT_EQ(records.size(), 3u);
  const int H = e.setup.task->horizon();
  EXPECT_EQ(records[0].real.nonfinite_step, -1);
  EXPECT_EQ(records[1].real.nonfinite_step, 20);
  EXPECT_FALSE(records[1].solved);
  EXPECT_TRUE(records[1].real.rewards.tail(H - 20).isZero());
  EXPECT_DOUBLE_EQ(records[1].real_return, records[1].real.rewards.head(20).sum());
  EXPECT_TRUE(records[1].real.states.allFinite());  // frozen, never NaN in the record
  EXPECT_EQ(data_sizes, (std::vector<std::size_t>{std::size_t(H), std::size_t(H + 20),
                                                  std::size_t(2 * H + 20)}));
  EXPECT_EQ(records[2].model.points, H + 20);
  // The task's own criterion on the frozen trajectory is not consulted.
  rollout::Trajectory frozen = records[1].real;
  EXPECT_FALSE(rollout::episode_solved(*e.setup.task, frozen));
  frozen.nonfinite_step = -1;
  EXPECT_EQ(rollout::episode_solved(*e.setup.task, frozen), e.setup.task->solved(frozen));
}

// Issue 43: a prior that cannot simulate the policy chosen on it (the pendubot's prior with a
// damping of 100, or with one integration step of 0.5 s, both beyond what its explicit integrator
// can follow) stops the run before the first real episode, with the step and phi in the message;
// the real system is never started and nothing is recorded.
TEST(BlackDrops, APriorThatCannotSimulateStopsTheRunBeforeTheFirstRealEpisode) {
  class Counting final : public rollout::System {
   public:
    explicit Counting(const rollout::System& inner) : inner_(inner) {}
    VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override {
      ++steps;
      return inner_.step(x, u, rng);
    }
    std::unique_ptr<rollout::EpisodeSession> begin_episode(const VectorXd& x0) const override {
      ++episodes;
      return inner_.begin_episode(x0);
    }
    mutable int steps = 0, episodes = 0;

   private:
    const rollout::System& inner_;
  };
  ThreadLimit limit(1);
  for (const std::string bad : {"prior.b2=100", "pendubot.dt=0.5 pendubot.substeps=1"}) {
    std::vector<std::string> ov{"episodes=2", "optimizer.max_evaluations=300",
                                "optimizer.prior_optimizations=1"};
    std::istringstream words(bad);
    for (std::string w; words >> w;) ov.push_back(w);
    const auto e = fixtures::experiment(ov);
    const Counting real(*e.setup.real);
    int recorded = 0;
    algo::BlackDropsCallbacks cb;
    cb.on_episode = [&](const algo::EpisodeRecord&) { ++recorded; };
    cb.on_state = [&](const algo::BlackDropsState&) { ++recorded; };
    std::string what;
    try {
      algo::run_black_drops(e.setup.task, real, *e.setup.policy, e.setup.prior,
                            e.setup.prior_parameters,
                            experiment::black_drops_options(fixtures::registry(), e.settings), cb);
    } catch (const Error& err) {
      what = err.what();
    }
    EXPECT_NE(what.find("the simulator prior cannot simulate the policy chosen on it"),
              std::string::npos) << bad << ": " << what;
    EXPECT_NE(what.find("nothing was run on the real system"), std::string::npos) << what;
    EXPECT_EQ(real.episodes + real.steps, 0) << bad;
    EXPECT_EQ(recorded, 0) << bad;
  }
  // The default prior simulates its policy: the real system runs.
  const auto ok = fixtures::experiment({"episodes=1", "optimizer.max_evaluations=300",
                                        "optimizer.prior_optimizations=1"});
  const Counting real(*ok.setup.real);
  algo::run_black_drops(ok.setup.task, real, *ok.setup.policy, ok.setup.prior,
                        ok.setup.prior_parameters,
                        experiment::black_drops_options(fixtures::registry(), ok.settings));
  EXPECT_EQ(real.episodes, 1);
}

// Calibration (issue 45): where the real return falls among the predicted rollouts' returns. The
// oracle is a count over the 20 returns 1..20 and the definition-6 quantiles by hand.
TEST(BlackDrops, CalibrationIsTheRealReturnsRankAmongThePredictedReturns) {
  algo::EpisodeRecord rec;
  EXPECT_FALSE(algo::calibration(rec).has_value());  // no model predicted it
  rec.predicted_returns = VectorXd::LinSpaced(20, 1.0, 20.0).reverse();  // order does not matter
  rec.predicted_return = 10.5;
  rec.real_return = 5.5;
  auto c = algo::calibration(rec);
  ASSERT_TRUE(c.has_value());
  EXPECT_DOUBLE_EQ(c->quantile, 5.0 / 20);
  EXPECT_NEAR(c->band_low, 1.05, 1e-12);    // position 0.05 * 21 = 1.05: between 1 and 2
  EXPECT_NEAR(c->band_high, 19.95, 1e-12);  // position 19.95: between 19 and 20
  EXPECT_TRUE(c->inside_band);
  EXPECT_DOUBLE_EQ(c->gap, 5.0);
  rec.real_return = 7.0;  // equal to one return: counts half
  EXPECT_DOUBLE_EQ(algo::calibration(rec)->quantile, 6.5 / 20);
  rec.real_return = 19.97;  // above the 95 % quantile
  c = algo::calibration(rec);
  EXPECT_FALSE(c->inside_band);
  EXPECT_DOUBLE_EQ(c->quantile, 19.0 / 20);
  rec.predicted_returns = VectorXd::LinSpaced(5, 1.0, 5.0);  // positions below 1: the extremes
  rec.real_return = 1.0;
  c = algo::calibration(rec);
  EXPECT_DOUBLE_EQ(c->band_low, 1.0);
  EXPECT_DOUBLE_EQ(c->band_high, 5.0);
  EXPECT_TRUE(c->inside_band);
}

// The band is what it claims to be: when the real return is one more draw from the distribution
// of the predicted returns (a calibrated model), it falls inside in about 90 % of the episodes,
// whatever that distribution and for 20 (the default) or 50 rollouts. The oracle is the nominal
// 0.90; 20,000 episodes put the estimate's standard error at 0.002, and definition 7's quantiles
// would cover 0.81 with 20 rollouts.
TEST(BlackDrops, CalibrationBandHoldsADrawFromTheSameDistributionNinetyPercentOfTheTime) {
  std::mt19937_64 gen(45);
  std::normal_distribution<double> normal(3.0, 2.0);
  std::exponential_distribution<double> exponential(0.5);
  for (const int n : {20, 50}) {
    for (const bool skewed : {false, true}) {
      auto draw = [&] { return skewed ? exponential(gen) : normal(gen); };
      const int trials = 20000;
      int inside = 0;
      algo::EpisodeRecord rec;
      rec.predicted_returns.resize(n);
      for (int t = 0; t < trials; ++t) {
        for (int i = 0; i < n; ++i) rec.predicted_returns[i] = draw();
        rec.real_return = draw();
        inside += algo::calibration(rec)->inside_band ? 1 : 0;
      }
      EXPECT_NEAR(static_cast<double>(inside) / trials, 0.90, 0.008)
          << n << " rollouts, " << (skewed ? "exponential" : "normal");
    }
  }
}

// Each Black-DROPS episode records its predicted rollouts' returns, whose mean is the predicted
// return, and whether its policy replays the best one so far.
TEST(BlackDrops, EpisodesRecordThePredictedReturnsAndWhetherTheyReplayTheBestPolicy) {
  ThreadLimit limit(1);
  const auto e = fixtures::experiment({"episodes=4", "optimizer.max_evaluations=300",
                                       "optimizer.prior_optimizations=1", "rollouts.predicted=7"});
  std::vector<algo::EpisodeRecord> records;
  algo::BlackDropsCallbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  algo::run_black_drops(e.setup.task, *e.setup.real, *e.setup.policy, e.setup.prior,
                        e.setup.prior_parameters, experiment::black_drops_options(fixtures::registry(), e.settings), cb);
  ASSERT_EQ(records.size(), 4u);
  VectorXd best;
  double best_return = -1e300;
  for (const auto& r : records) {
    ASSERT_EQ(r.predicted_returns.size(), 7) << r.episode;
    EXPECT_NEAR(r.predicted_returns.mean(), r.predicted_return,
                1e-12 * std::max(1.0, std::abs(r.predicted_return)));
    EXPECT_EQ(r.replay, best.size() > 0 && (best.array() == r.theta.array()).all()) << r.episode;
    if (r.real_return > best_return) {
      best_return = r.real_return;
      best = r.theta;
    }
  }
  EXPECT_GT(records[1].predicted_returns.maxCoeff() - records[1].predicted_returns.minCoeff(),
            0.0);  // sampled rollouts on a GP model spread
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

// TuRBO's rule on the radius: doubling up to 1 after a success, halving down to the minimum after
// a failure; off, it neither moves nor bounds the search; a radius outside (0, 1] is refused.
TEST(BlackDropsTrustRegion, TheRadiusDoublesOnSuccessAndHalvesOnFailureWithinItsBounds) {
  algo::TrustRegion tr({true, 0.2});
  EXPECT_EQ(tr.search_radius(false), 1.0);  // no real policy yet: the whole box
  const bool steps[] = {false, false, false, false, true, true, true};
  const double expected[] = {0.5, 0.25, 0.2, 0.2, 0.4, 0.8, 1.0};
  for (int k = 0; k < 7; ++k) {
    tr.update(steps[k]);
    EXPECT_DOUBLE_EQ(tr.radius(), expected[k]) << "step " << k;
    EXPECT_DOUBLE_EQ(tr.search_radius(true), expected[k]) << "step " << k;
  }
  algo::TrustRegion off({false, 0.2});
  off.update(false);
  EXPECT_EQ(off.search_radius(true), 1.0);
  EXPECT_THROW(algo::TrustRegion({true, 0.2}, 1.5), InvalidArgument);
  EXPECT_THROW(algo::TrustRegion({true, 0.0}), InvalidArgument);
}

// A search in a trust region stays in it: every candidate CMA-ES kept and the returned policy lie
// within region b of the start; region 1 is the search without a region, to the bit.
TEST_F(DeterministicPriorSearch, ASearchInATrustRegionStaysInItAndRegionOneChangesNothing) {
  const double region = 0.1, half = region * o.theta_bound;
  const auto s = algo::optimize_policy(*task, *model, pol, o, {start, 5, region});
  auto inside = [&](const VectorXd& x) {
    return ((x - start).cwiseAbs().array() <= half * (1 + 1e-12)).all() &&
           (x.cwiseAbs().array() <= o.theta_bound).all();
  };
  EXPECT_TRUE(inside(s.theta));
  ASSERT_FALSE(s.search.best_candidates.empty());
  for (const auto& c : s.search.best_candidates) EXPECT_TRUE(inside(c.x));
  // Without the region the same search leaves that box (the optimum is not next to the start).
  const auto whole = algo::optimize_policy(*task, *model, pol, o, {start, 5});
  EXPECT_FALSE(inside(whole.theta));
  const auto one = algo::optimize_policy(*task, *model, pol, o, {start, 5, 1.0});
  EXPECT_EQ(one.theta, whole.theta);
  EXPECT_EQ(one.value, whole.value);
  for (double bad : {0.0, 1.5, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW(
        algo::optimize_policy(*task, *model, pol, o, {start, 5, bad}),
        InvalidArgument)
        << bad;
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
  const auto o =
      experiment::black_drops_options(fixtures::registry(), fixtures::experiment(ov).settings);
  double region = 1.0, best_return = r[0].real_return;
  VectorXd best = r[0].theta;
  int shrinks = 0;
  for (std::size_t k = 1; k < r.size(); ++k) {
    ASSERT_EQ(r[k].details.numbers.count("trust_region_radius"), 1u) << "episode " << k + 1;
    EXPECT_EQ(r[k].details.numbers.at("trust_region_radius"), region) << "episode " << k + 1;
    std::printf("[info] episode %d: radius %.3f, return %.3f\n", static_cast<int>(k + 1), region,
                r[k].real_return);
    if (region < 1)
      EXPECT_LE((r[k].theta - best).cwiseAbs().maxCoeff(), region * o.search.theta_bound * (1 + 1e-12))
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
  ASSERT_TRUE(algo::BlackDropsOwnState::load(saved.extra).trust_region_radius.has_value());
  const auto resumed = resumed_from(ov, saved);
  ASSERT_EQ(resumed.size(), 3u);
  for (std::size_t k = 0; k < resumed.size(); ++k) {
    EXPECT_EQ(resumed[k].theta, r[k + 4].theta) << "episode " << k + 5;
    EXPECT_EQ(resumed[k].details.numbers.at("trust_region_radius"),
              r[k + 4].details.numbers.at("trust_region_radius"));
  }
  // A radius outside (0, 1] in a checkpoint is an error, not a silent reset.
  saved.extra = algo::BlackDropsOwnState{2.0}.save();
  EXPECT_THROW(resumed_from(ov, saved), InvalidArgument);
  saved.extra.clear();  // the trust region is on: its radius must be there
  EXPECT_THROW(resumed_from(ov, saved), InvalidArgument);
}

// Catch and balance (policy.balance.mode lqr): the gain is a function of the learned model, so a
// resumed run recomputes the gains and runs the policies of an uninterrupted one; 1 or 2 threads
// give the same episodes.
TEST(BlackDropsBalance, AResumedRunRecomputesTheGainsOfAnUninterruptedOne) {
  const std::vector<std::string> ov = {"episodes=3", "model.type=gp_prior",
                                       "optimizer.max_evaluations=40",
                                       "optimizer.prior_optimizations=1",
                                       "optimizer.reevaluation_rollouts=5",
                                       "rollouts.predicted=3", "policy.balance.mode=lqr"};
  const auto r = run(1, ov);
  ASSERT_EQ(r.size(), 3u);
  const auto r2 = run(2, ov);
  ASSERT_EQ(r2.size(), 3u);
  const auto resumed = resumed_from(ov, state_after(ov, 1));
  ASSERT_EQ(resumed.size(), 2u);
  for (std::size_t k = 0; k < r.size(); ++k) {
    EXPECT_EQ(r2[k].theta, r[k].theta) << "episode " << k + 1;
    EXPECT_EQ(r2[k].details.numbers, r[k].details.numbers) << "episode " << k + 1;
  }
  for (std::size_t k = 0; k < resumed.size(); ++k) {
    EXPECT_EQ(resumed[k].theta, r[k + 1].theta) << "episode " << k + 2;
    EXPECT_EQ(resumed[k].details.numbers, r[k + 1].details.numbers) << "episode " << k + 2;
    EXPECT_EQ(resumed[k].details.numbers.count("balance_k_0_0"), 1u);
  }
}
