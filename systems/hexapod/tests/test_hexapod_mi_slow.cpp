// GP-MI (paper Algorithm 2) on the default "real" hexapod (servos, friction, 1 ms step, noise;
// real_robot.hpp) with a leg removed: the exhaustive search over the 7 removed-leg priors should
// pick the leg that is missing. About 25 s per case on 2 cores (label slow).

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "hexapod_mi_data.hpp"

namespace drops::hexapod {
namespace {

using testing::damaged;
using testing::hexapod_model;
using testing::real_data;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Per prior, fitted on its own: a gp_prior model at that removed_leg (the kernels of all 48
// outputs fitted with the full Rprop budget from the default start, no warm start from another
// prior). score is GP-MI's S(phi) = log sum_i exp(loglik_i); sum_loglik is sum_i loglik_i.
// Agreement between S(phi) from GP-MI's search and from the separate fits, nats (a 1% likelihood
// ratio).
constexpr double kScoreTolerance = 0.01;

struct PriorFit {
  double score = 0;
  double sum_loglik = 0;
};

std::vector<PriorFit> fit_each_prior(const std::vector<Transition>& data) {
  std::vector<PriorFit> fits;
  model::ModelOptions o;
  o.type = model::ModelType::kGpPrior;
  for (int leg = -1; leg < kNumLegs; ++leg) {
    const model::ModelSummary s = hexapod_model(o, leg)->learn(data);
    fits.push_back({s.score, s.log_likelihoods.sum()});
  }
  return fits;
}

std::string table(const std::vector<PriorFit>& fits) {
  std::string out;
  char buf[96];
  for (std::size_t i = 0; i < fits.size(); ++i) {
    std::snprintf(buf, sizeof buf, "\n  removed_leg %2d: S %.6f, sum loglik %.3f",
                  static_cast<int>(i) - 1, fits[i].score, fits[i].sum_loglik);
    out += buf;
  }
  return out;
}

class GpMiPicksTheRemovedLeg : public ::testing::TestWithParam<int> {};

// DISABLED: fails today, for two reasons found while writing it (closing note of the session,
// docs/hexapod.md "Status"): (1) the paper's score log sum_i exp(loglik_i) is decided by the one
// best-fitting of the 48 outputs (model.gp_mi.score=sum_log_likelihoods addresses this); (2) with
// the default servo stiffness (kp = 1.2 N m/rad) the "real" robot without leg 0 is best explained
// by the prior without leg 5 and vice versa, by every score and by MI (with kp = 10, MI picks
// right). Run it with --gtest_also_run_disabled_tests; enable it once the real robot's servo model
// is revised.
TEST_P(GpMiPicksTheRemovedLeg, DISABLED_FromTwoEpisodesOfTheServoRobot) {
  const int leg = GetParam();
  long nonfinite = 0;
  const auto data = real_data(damaged(leg), 2, &nonfinite);
  ASSERT_EQ(data.size(), 80u);
  EXPECT_EQ(nonfinite, 0);
  auto t0 = std::chrono::steady_clock::now();
  auto m = hexapod_model({});
  const model::ModelSummary s = m->learn(data);
  const double mi_seconds = seconds_since(t0);
  ASSERT_EQ(s.phi.size(), 1);

  // The oracle: S(phi) of each prior from its own fit. The API reports only the winner's score.
  t0 = std::chrono::steady_clock::now();
  const std::vector<PriorFit> fits = fit_each_prior(data);
  const double oracle_seconds = seconds_since(t0);
  int best = 0;  // first maximum, as GP-MI's search (a later prior must score strictly higher)
  for (int i = 1; i < 7; ++i)
    if (fits[static_cast<std::size_t>(i)].score > fits[static_cast<std::size_t>(best)].score)
      best = i;
  std::printf("[info] removed leg %d: gp_mi picked %g (%s; %.1f s); per prior (%.1f s):%s\n", leg,
              s.phi[0], s.BriefReport().c_str(), mi_seconds, oracle_seconds, table(fits).c_str());

  EXPECT_EQ(s.phi[0], leg) << "GP-MI picked the wrong prior (per-prior scores above)";
  EXPECT_EQ(best - 1, leg) << "the actual leg does not have the best S(phi)";
  // The search itself: the prior it picked has the best S(phi) up to the accuracy of the kernel
  // fits (GP-MI's alternating search scores phi with kernels fitted at another phi).
  const int chosen = static_cast<int>(s.phi[0]) + 1;
  ASSERT_GE(chosen, 0);
  ASSERT_LT(chosen, 7);
  EXPECT_GE(fits[static_cast<std::size_t>(chosen)].score,
            fits[static_cast<std::size_t>(best)].score - kScoreTolerance)
      << "GP-MI picked " << s.phi[0] << " but S is largest at " << best - 1;
  EXPECT_EQ(s.phi_evaluations, 7 * s.rounds) << "every prior is scored once per round";
  EXPECT_EQ(s.nonfinite_prior_outputs, 0);
}

INSTANTIATE_TEST_SUITE_P(Hexapod, GpMiPicksTheRemovedLeg, ::testing::Values(0, 5, -1),
                         [](const ::testing::TestParamInfo<int>& i) {
                           return i.param < 0 ? std::string("Intact")
                                              : "Leg" + std::to_string(i.param);
                         });

}  // namespace
}  // namespace drops::hexapod
