// The run loop's cost hint (src/experiment/run_hints.hpp): said when a policy search is long and
// grew, with the numbers that explain it; silent otherwise.
#include <gtest/gtest.h>

#include "run_hints.hpp"

namespace drops::experiment {
namespace {

TEST(PolicyCostHint, SaysTheTimeTheDataAndTheKeysWhenASearchIsLongAndGrew) {
  // A new user's rotary pendulum: 46 s, then 112 s at N = 360 with exact variances.
  const std::string h = policy_cost_hint(4, 112, 46, 360, 0, 10000);
  EXPECT_NE(h.find("episode 4's policy search took 112 s (46 s the episode before)"),
            std::string::npos) << h;
  EXPECT_NE(h.find("N = 360"), std::string::npos) << h;
  EXPECT_NE(h.find("O(N^2) (model.variance_points = 0: every transition)"), std::string::npos)
      << h;
  EXPECT_NE(h.find("optimizer.max_evaluations = 10000"), std::string::npos) << h;
  EXPECT_NE(h.find("What a run costs"), std::string::npos) << h;
  // With a cap below N the variance costs O(m^2).
  const std::string capped = policy_cost_hint(9, 90, 40, 800, 400, 10000);
  EXPECT_NE(capped.find("O(m^2) (model.variance_points = 400)"), std::string::npos) << capped;
  // With sparse GPs (model.inducing_points below N) the cost does not grow with N: the hint
  // says so and names the sparse key, not the variance cap.
  const std::string sparse = policy_cost_hint(6, 45, 25, 2500, 0, 10000, 200);
  EXPECT_NE(sparse.find("at most m = 200 inducing inputs"), std::string::npos) << sparse;
  EXPECT_NE(sparse.find("whatever N"), std::string::npos) << sparse;
  EXPECT_EQ(sparse.find("grows with N"), std::string::npos) << sparse;
  EXPECT_EQ(sparse.find("variance_points"), std::string::npos) << sparse;
  // Below the cap the GPs are exact: the exact hint.
  EXPECT_NE(policy_cost_hint(4, 112, 46, 150, 0, 10000, 200).find("O(N^2)"), std::string::npos);
}

TEST(PolicyCostHint, IsSilentForShortSearchesSteadyOnesAndTheFirst) {
  EXPECT_EQ(policy_cost_hint(3, 29.9, 10, 80, 0, 10000), "");   // short
  EXPECT_EQ(policy_cost_hint(3, 60, 41, 80, 0, 10000), "");     // grew less than 1.5 times
  EXPECT_EQ(policy_cost_hint(2, 100, 0, 40, 0, 10000), "");     // no search before it
  EXPECT_NE(policy_cost_hint(3, 61.5, 41, 80, 0, 10000), "");   // 1.5 times, 30 s or more
}

}  // namespace
}  // namespace drops::experiment
