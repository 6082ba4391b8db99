// The RealAIGym leaderboards' criteria and scores on small trajectories whose values are worked
// out by hand in the comments (the definitions: drops/realaigym/score.hpp). The check against the
// lab's published scores is docs/decisions/realaigym-scorer.md (their data stays out of the tree).

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "drops/core/errors.hpp"
#include "drops/realaigym/score.hpp"

namespace rg = drops::realaigym;
using drops::MatrixXd;
using drops::VectorXd;

namespace {

// Four samples at t = 0, 1, 3, 4 (steps 1, 2, 1 s).
struct Small {
  VectorXd t{{0.0, 1.0, 3.0, 4.0}};
  MatrixXd x{{0.0, 0.0, 1.0, 0.0},  // q1, q2, qd1, qd2
             {0.5, 0.0, 2.0, 1.0},
             {0.0, 1.0, 0.0, 3.0},
             {1.0, 1.0, 0.0, 0.0}};
  MatrixXd tau{{1.0, 0.0}, {-2.0, 2.0}, {3.0, 1.0}, {5.0, -7.0}};
};

constexpr double kPi = 3.14159265358979323846;

// A trajectory of n samples 1 s apart (t = 0..n-1), every sample hanging down at rest.
rg::SwingupTrajectory hanging(int n) {
  rg::SwingupTrajectory tr{VectorXd::LinSpaced(n, 0.0, n - 1), MatrixXd::Zero(n, 4),
                           MatrixXd::Zero(n, 2)};
  return tr;
}

}  // namespace

TEST(RealAIGymScore, EnergyIsTheSumOfAbsoluteAngleStepsTimesTheTorqueAtTheirStart) {
  const Small s;
  // joint 1: |0.5 * 1| + |-0.5 * -2| + |1 * 3| = 4.5; joint 2: |0 * 0| + |1 * 2| + |0 * 1| = 2.
  EXPECT_NEAR(rg::energy(s.x, s.tau), 6.5, 1e-14);
}

TEST(RealAIGymScore, MaxTorqueIsTheLargestMagnitudeOverEverySampleAndJointIncludingTheLast) {
  const Small s;
  EXPECT_EQ(rg::max_torque(s.tau), 7.0);  // |-7| at the last sample
}

TEST(RealAIGymScore, IntegratedTorqueWeighsEachSampleButTheLastByTheStepAfterIt) {
  const Small s;
  // (|1| + |0|) 1 + (|-2| + |2|) 2 + (|3| + |1|) 1 = 1 + 8 + 4
  EXPECT_NEAR(rg::integrated_torque(s.t, s.tau), 13.0, 1e-14);
}

TEST(RealAIGymScore, TorqueCostIsTheSquaredTorqueIntegratedTheSameWay) {
  const Small s;
  // (1 + 0) 1 + (4 + 4) 2 + (9 + 1) 1 = 27
  EXPECT_NEAR(rg::torque_cost(s.t, s.tau), 27.0, 1e-14);
}

TEST(RealAIGymScore, SmoothnessIsTheSumOverJointsOfThePopulationStdOfTheTorqueSteps) {
  const Small s;
  // steps of joint 1: -3, 5, 2 (mean 4/3, variance 98/9); joint 2: 2, -1, -8 (mean -7/3,
  // variance 158/9): (sqrt(98) + sqrt(158)) / 3 = 7.4897666755294.
  EXPECT_NEAR(rg::torque_smoothness(s.tau), 7.4897666755294, 1e-12);
}

TEST(RealAIGymScore, VelocityCostIsTheSquaredVelocityIntegratedWithoutTheLastSample) {
  const Small s;
  // (1 + 0) 1 + (4 + 1) 2 + (0 + 9) 1 = 20
  EXPECT_NEAR(rg::velocity_cost(s.t, s.x), 20.0, 1e-14);
}

TEST(RealAIGymScore, SwingupTimeIsTheStartOfTheLastUpRunEndingAtTheSampleBeforeTheLast) {
  // v1's lengths l1 = 0.3, l2 = 0.2: up when 0.3 + 0.2 cos q2 > 0.45 at q1 = pi (cos q2 > 0.75).
  rg::SwingupTrajectory tr = hanging(11);  // t = 0..10
  for (int i = 2; i <= 9; ++i) tr.x(i, 0) = kPi;
  tr.x(5, 1) = 0.8;  // 0.3 + 0.2 cos 0.8 = 0.439: down, so the last run starts at sample 6
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.0), 6.0);
  tr.x(5, 1) = 0.6;  // 0.3 + 0.2 cos 0.6 = 0.465: up, the run starts at sample 2
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.0), 2.0);
  // With v2's lengths l1 = 0.2, l2 = 0.3 the same q2 = 0.6 is down (0.2 + 0.3 cos 0.6 = 0.448).
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.2, 0.3, 0.9, 10.0), 6.0);
}

TEST(RealAIGymScore, SwingupTimeIgnoresTheFirstAndLastSamplesAndNeedsTheFullEpisode) {
  rg::SwingupTrajectory tr = hanging(11);
  for (int i = 0; i <= 10; ++i) tr.x(i, 0) = kPi;
  // Up everywhere: sample 0 is not examined, so the time is t_1.
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.0), 1.0);
  // Down at the last sample only: not examined, still t_1.
  tr.x(10, 0) = 0.0;
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.0), 1.0);
  // Down at the sample before the last: no swing-up, the time is the last sample's.
  tr.x(10, 0) = kPi;
  tr.x(9, 0) = 0.0;
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.0), 10.0);
  // A trajectory that ends before 0.99 t_final: +inf.
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 0.9, 10.2),
            std::numeric_limits<double>::infinity());
  // Exactly at the goal height is not up (strict >): upright, the tip is at l1 + l2, never above.
  tr.x(9, 0) = kPi;
  EXPECT_EQ(rg::swingup_time(tr.t, tr.x, 0.3, 0.2, 1.0, 10.0), 10.0);
}

TEST(RealAIGymScore, TheLinearV1ScoreSubtractsTheWeightedNormalisedCriteria) {
  rg::CriterionValues c{.swingup_time = 2.0,
                        .energy = 10.0,
                        .max_tau = 3.0,
                        .integrated_tau = 6.0,
                        .tau_cost = 36.0,
                        .tau_smoothness = 1.2,
                        .velocity_cost = 100.0};
  // 0.2 * 2/10 + 0.1 * 10/100 + 0.1 * 3/6 + 0.1 * 6/60 + 0.1 * 36/360 + 0.2 * 1.2/12
  // + 0.2 * 100/1000 = 0.04 + 0.01 + 0.05 + 0.01 + 0.01 + 0.02 + 0.02 = 0.16
  EXPECT_NEAR(rg::realai_score(true, c, rg::simulation_v1()), 0.84, 1e-14);
  EXPECT_EQ(rg::realai_score(false, c, rg::simulation_v1()), 0.0);
}

TEST(RealAIGymScore, TheTanhV2ScoreAveragesOverItsFiveWeightedCriteriaAndIgnoresTheOthers) {
  // Each of the five at a quarter of its normalisation: 1 - tanh(pi / 4) = 0.3442057973673276;
  // max_tau and integrated_tau have weight 0 in v2 and do not count, however large.
  rg::CriterionValues c{.swingup_time = 5.0,
                        .energy = 15.0,
                        .max_tau = 1e6,
                        .integrated_tau = 1e6,
                        .tau_cost = 5.0,
                        .tau_smoothness = 0.025,
                        .velocity_cost = 100.0};
  EXPECT_NEAR(rg::realai_score(true, c, rg::simulation_v2()), 0.3442057973673276, 1e-14);
  EXPECT_EQ(rg::realai_score(false, c, rg::simulation_v2()), 0.0);
}

TEST(RealAIGymScore, ScoreCombinesTheCriteriaOfATrajectory) {
  // Up from sample 3 to the end, 11 samples; a torque of 1 N m on joint 1 and a velocity of
  // 1 rad/s on joint 1 throughout, no angle change (so no energy).
  rg::SwingupTrajectory tr = hanging(11);
  for (int i = 3; i <= 10; ++i) tr.x(i, 0) = kPi;
  tr.x.col(2).setOnes();
  tr.tau.col(0).setOnes();
  const rg::Score s = rg::score(tr, rg::simulation_v1());
  EXPECT_TRUE(s.success);
  EXPECT_EQ(s.criteria.swingup_time, 3.0);
  // The angle steps of joint 1: +pi at sample 2 -> 3, times the torque 1 at sample 2.
  EXPECT_NEAR(s.criteria.energy, kPi, 1e-14);
  EXPECT_EQ(s.criteria.max_tau, 1.0);
  EXPECT_NEAR(s.criteria.integrated_tau, 10.0, 1e-14);
  EXPECT_NEAR(s.criteria.tau_cost, 10.0, 1e-14);
  EXPECT_EQ(s.criteria.tau_smoothness, 0.0);
  EXPECT_NEAR(s.criteria.velocity_cost, 10.0, 1e-14);
  // 1 - (0.2 * 0.3 + 0.1 * pi / 100 + 0.1 / 6 + 0.1 * 10 / 60 + 0.1 * 10 / 360 + 0 + 0.2 * 0.01)
  const double expected =
      1 - (0.06 + 0.001 * kPi + 0.1 / 6 + 0.1 * 10 / 60 + 0.1 * 10 / 360 + 0.002);
  EXPECT_NEAR(s.realai_score, expected, 1e-14);
  // Down again at the sample before the last: no success, score 0.
  tr.x(9, 0) = 0.0;
  const rg::Score f = rg::score(tr, rg::simulation_v1());
  EXPECT_FALSE(f.success);
  EXPECT_EQ(f.criteria.swingup_time, 10.0);
  EXPECT_EQ(f.realai_score, 0.0);
}

TEST(RealAIGymScore, WrongSizesAndInvalidDefinitionsThrow) {
  const Small s;
  EXPECT_THROW(rg::energy(s.x.leftCols(3), s.tau), drops::InvalidArgument);
  EXPECT_THROW(rg::velocity_cost(s.t.head(3), s.x), drops::InvalidArgument);
  EXPECT_THROW(rg::max_torque(s.tau.topRows(1)), drops::InvalidArgument);
  rg::ScoreDefinition d = rg::simulation_v1();
  std::string why;
  EXPECT_TRUE(d.IsValid(&why)) << why;
  EXPECT_TRUE(rg::simulation_v2().IsValid(&why)) << why;
  d.normalization.energy = 0.0;
  EXPECT_FALSE(d.IsValid(&why));
  EXPECT_NE(why.find("energy"), std::string::npos);
  EXPECT_THROW(rg::score({s.t, s.x, s.tau}, d), drops::InvalidArgument);
}
