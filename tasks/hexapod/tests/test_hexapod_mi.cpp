// The hexapod's removed-leg priors in the model variants (paper §V-B): the data of a real robot
// with the prior's physics identify the removed leg (MI), and GP-MI learning plus a short policy
// search give bit-identical results with 1 and 2 threads. GP-MI on the default (servo) real robot
// is in test_hexapod_mi_slow.cpp.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "drops/core/parallel.hpp"
#include "hexapod_mi_data.hpp"

namespace drops::hexapod {
namespace {

using testing::damaged;
using testing::hexapod_model;
using testing::real_data;
using testing::seconds_since;

// ---------------- identification without a reality gap ----------------

// A "real" robot with the prior's physics (velocity actuators, 10 ms step, ground friction 1) and
// the default measurement noise: the only differences from prior k are the damage and the noise,
// so the one-step error sum_n ||M(x_n, u_n; phi) - dx_n||^2 (MI) is smallest at the removed leg.
// Guards the leg numbering shared by HexapodRealSystem, HexapodPrior and the model code.
class MiPicksTheRemovedLeg : public ::testing::TestWithParam<int> {};

TEST_P(MiPicksTheRemovedLeg, WhenTheRealRobotHasThePriorsPhysics) {
  const int leg = GetParam();
  RealRobotOptions o;
  o.simulator = PriorOptions{};
  long nonfinite = 0;
  const auto data = real_data(damaged(leg, o), 2, &nonfinite);
  ASSERT_EQ(data.size(), 80u);
  EXPECT_EQ(nonfinite, 0);
  model::ModelOptions mo;
  mo.type = model::ModelType::kMi;
  auto m = hexapod_model(mo);
  const model::ModelSummary s = m->learn(data);
  EXPECT_EQ(s.phi[0], leg) << s.BriefReport();
  EXPECT_EQ(s.phi_evaluations, 7);
  EXPECT_EQ(s.nonfinite_prior_outputs, 0);
}

INSTANTIATE_TEST_SUITE_P(Hexapod, MiPicksTheRemovedLeg, ::testing::Values(0, 5, -1),
                         [](const ::testing::TestParamInfo<int>& i) {
                           return i.param < 0 ? std::string("Intact")
                                              : "Leg" + std::to_string(i.param);
                         });

// ---------------- reproducibility across thread counts ----------------

// One GP-MI model learning and a short policy search (200 CMA-ES evaluations, 1 model rollout
// each, batched 8 per prediction), with `threads` worker threads.
struct LearnAndSearch {
  model::ModelSummary learned;
  model::ModelState state;
  algo::PolicySearchResult search;
  long nonfinite_steps = 0;
};

LearnAndSearch learn_and_search(int threads, const std::vector<Transition>& data) {
  ThreadLimit limit(threads);
  LearnAndSearch r;
  auto m = hexapod_model({});
  r.learned = m->learn(data);
  r.state = m->state();
  const auto t0 = std::chrono::steady_clock::now();
  const HexapodTask task;
  HexapodGaitPolicy policy;
  algo::PolicySearchOptions o;
  o.theta_bound = HexapodGaitPolicyOptions{}.theta_bound;
  o.cmaes.max_evaluations = 200;
  o.rollouts.rollouts = 1;
  Rng rng(5);
  r.search = algo::optimize_policy(task, *m, policy, o,
                                   {policy.theta_of(testing::gentle_gait(rng)), 77});
  r.nonfinite_steps = r.search.nonfinite_model_steps;
  std::printf("[info] %d thread(s): learning %.1f s (%d rounds), policy search %.1f s\n", threads,
              r.learned.seconds, r.learned.rounds, seconds_since(t0));
  return r;
}

TEST(HexapodGpMi, SameSeedGivesBitIdenticalModelAndPolicySearchWithOneAndTwoThreads) {
  const auto data = real_data(damaged(0), 1);
  ASSERT_EQ(data.size(), 40u);
  const auto t0 = std::chrono::steady_clock::now();
  const LearnAndSearch a = learn_and_search(1, data);
  const double one = seconds_since(t0);
  const LearnAndSearch b = learn_and_search(2, data);
  std::printf(
      "[info] learn (40 transitions) + 200-evaluation search: 1 thread %.1f s, "
      "2 threads %.1f s\n",
      one, seconds_since(t0) - one);
  EXPECT_EQ(a.learned.phi, b.learned.phi);
  EXPECT_EQ(a.learned.log_likelihoods, b.learned.log_likelihoods);
  EXPECT_EQ(a.learned.score, b.learned.score);
  EXPECT_EQ(a.learned.rounds, b.learned.rounds);
  EXPECT_EQ(a.learned.phi_evaluations, b.learned.phi_evaluations);
  EXPECT_EQ(a.learned.rprop_iterations, b.learned.rprop_iterations);
  EXPECT_EQ(a.state.phi, b.state.phi);
  ASSERT_EQ(a.state.h_params.size(), 48u);
  ASSERT_EQ(b.state.h_params.size(), 48u);
  for (std::size_t i = 0; i < a.state.h_params.size(); ++i)
    EXPECT_EQ(a.state.h_params[i], b.state.h_params[i]) << "output " << i;
  EXPECT_EQ(a.search.theta, b.search.theta);
  EXPECT_EQ(a.search.value, b.search.value);
  EXPECT_EQ(a.search.search.best_value, b.search.search.best_value);
  EXPECT_EQ(a.search.search.evaluations, b.search.search.evaluations);
  EXPECT_EQ(a.search.search.generations, b.search.search.generations);
  EXPECT_EQ(a.nonfinite_steps, b.nonfinite_steps);
  // Both runs did the work being compared: kernels were fitted and the budget was used.
  EXPECT_GT(a.learned.rprop_iterations, 0);
  EXPECT_GT(a.search.search.evaluations, 150);
  EXPECT_LE(a.search.search.evaluations, 200);
  EXPECT_TRUE(std::isfinite(a.search.value));
}

}  // namespace
}  // namespace drops::hexapod
