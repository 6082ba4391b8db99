// The hexapod's IT&E descriptor (duty factor, turned-over robots) on known gaits of the prior, and
// a tiny IT&E run of the plugin's experiment (MAP-Elites on the prior, then one real trial).
#include <gtest/gtest.h>

#include <numbers>

#include "drops/algo/ite.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/ite_descriptor.hpp"
#include "drops/hexapod/plugin.hpp"
#include "drops/hexapod/simulator.hpp"

using namespace drops;

namespace {
const experiment::Registry& registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    hexapod::register_task(*reg);
    return reg;
  }();
  return *r;
}
experiment::Experiment make(const std::vector<std::string>& ov = {}) {
  std::vector<std::string> all = {"task=hexapod", "algorithm=ite", "threads=2"};
  all.insert(all.end(), ov.begin(), ov.end());
  return experiment::make_experiment(registry(), experiment::load_settings(registry(), "", all));
}
// The gait's parameters in [0, 1] as the policy's theta (theta + 0.5).
VectorXd theta_of(const VectorXd& gait) { return gait.array() - 0.5; }

// The duty factor of `gait` in a prior episode of the experiment, and the episode.
VectorXd duty(const experiment::Experiment& e, const VectorXd& gait, rollout::Trajectory* out = nullptr) {
  const rollout::Trajectory tr = algo::prior_episode(e.setup.problem(), theta_of(gait));
  if (out) *out = tr;
  return experiment::task_behaviour(e.setup)->describe(tr);
}
}  // namespace

TEST(HexapodIte, ThePluginGivesTheSixDimensionalDutyFactorOnAFiveBinGrid) {
  const auto e = make();
  ASSERT_NE(experiment::task_behaviour(e.setup), nullptr);
  const auto& b = *experiment::task_behaviour(e.setup);
  ASSERT_TRUE(b.available());
  EXPECT_EQ(b.bins, std::vector<int>(6, 5));
  EXPECT_EQ(b.names.front(), "duty_leg0");
  EXPECT_EQ(b.names.back(), "duty_leg5");
  EXPECT_TRUE(static_cast<bool>(b.alive));
  const auto o = experiment::ite_options(e.settings, e.setup);
  EXPECT_EQ(o.map_elites.mutation, ite::Mutation::kResample);  // the reference genotype
  EXPECT_DOUBLE_EQ(o.map_elites.mutation_rate, 0.05);
  EXPECT_EQ(o.map_elites.grid_levels, 21);
  EXPECT_DOUBLE_EQ(o.theta_bound, 0.5);
  EXPECT_DOUBLE_EQ(o.performance_scale, 1.0);
}

// The tripod gait commands each foot down for half of its period. In the prior the robot pitches
// onto its front legs: measured at 5 mm, 0.225 0.400 0.625 0.525 0.400 0.225 (legs 0-5), mean
// 0.40 (at 0 mm: 0.15 ... 0.525; docs/ite.md). So: every leg in (0, 1), the mean near the
// commanded half, mirror legs of the two tripods (0-5, 1-4, 2-3) equal within one sample per
// period (0.1 = 4 of the 40 samples), front legs more on the ground than rear legs.
TEST(HexapodIte, ATripodGaitGivesAboutHalfOnAverageWithSymmetricMirrorLegs) {
  const auto e = make();
  rollout::Trajectory tr;
  const VectorXd b = duty(e, hexapod::tripod_gait(), &tr);
  ASSERT_EQ(b.size(), 6);
  for (int k = 0; k < 6; ++k) {
    EXPECT_GE(b[k], 0.15) << "leg " << k;
    EXPECT_LE(b[k], 0.7) << "leg " << k;
  }
  EXPECT_NEAR(b.mean(), 0.5, 0.15);
  EXPECT_NEAR(b[0], b[5], 0.1);
  EXPECT_NEAR(b[1], b[4], 0.1);
  EXPECT_NEAR(b[2], b[3], 0.1 + 1e-12);
  EXPECT_GT(b[2] + b[3], b[0] + b[5]);
  EXPECT_TRUE(experiment::task_behaviour(e.setup)->alive(tr));
  // A multiple of 1/40: 40 sampled states.
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(b[k] * 40, std::round(b[k] * 40), 1e-9);
}

TEST(HexapodIte, StandingStillEveryFootTouchesTheGroundAllTheTime) {
  const auto e = make();
  // Every amplitude 0: all joints stay at 0 and the robot stands (its feet within 3.5 mm of the
  // ground once it has dropped from its start height).
  const VectorXd b = duty(e, VectorXd::Zero(36));
  EXPECT_EQ(b, VectorXd::Ones(6));
  // The gait of 0.5 everywhere shuffles with every foot on the ground (within 3.3 mm) too.
  EXPECT_EQ(duty(e, VectorXd::Constant(36, 0.5)), VectorXd::Ones(6));
}

TEST(HexapodIte, ARemovedLegOfThePriorHasDutyFactorZero) {
  const auto e = make({"hexapod.prior.start=leg5"});
  EXPECT_EQ(duty(e, hexapod::tripod_gait())[5], 0.0);
  // Standing, the other five feet stay on the ground.
  const VectorXd b = duty(e, VectorXd::Zero(36));
  EXPECT_EQ(b[5], 0.0);
  for (int k = 0; k < 5; ++k) EXPECT_GT(b[k], 0.9) << "leg " << k;
}

TEST(HexapodIte, ARobotOnItsBackIsNotAliveAndANonFiniteStateGivesNaN) {
  const auto e = make();
  rollout::Trajectory tr;
  duty(e, hexapod::tripod_gait(), &tr);
  EXPECT_TRUE(hexapod::stayed_upright(tr, std::numbers::pi / 2));
  rollout::Trajectory flipped = tr;
  flipped.states(20, hexapod::kBodyRpy) = 3.0;  // roll: on its back
  EXPECT_FALSE(hexapod::stayed_upright(flipped, std::numbers::pi / 2));
  EXPECT_FALSE(experiment::task_behaviour(e.setup)->alive(flipped));
  rollout::Trajectory broken = tr;
  broken.states(7, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(experiment::task_behaviour(e.setup)->describe(broken).array().isNaN().all());
  rollout::Trajectory wrong;
  wrong.states = MatrixXd::Zero(5, 4);
  EXPECT_THROW(experiment::task_behaviour(e.setup)->describe(wrong), InvalidArgument);
}

TEST(HexapodIte, ATinyRunBuildsAnArchiveOnThePriorAndRunsOneRealTrial) {
  const auto e = make({"episodes=1", "ite.evaluations=60", "ite.batch=20",
                       "ite.initial_population=20"});
  std::vector<algo::EpisodeRecord> records;
  algo::ArchiveState archive;
  algo::Callbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { records.push_back(r); };
  cb.on_state = [&](const algo::RunState& s) {
    if (const auto* a = algo::archive_state(s)) archive = *a;
  };
  const auto summary = e.runner->run(e.setup.problem(), cb);
  ASSERT_EQ(records.size(), 1u);
  ASSERT_TRUE(archive.archive);
  EXPECT_TRUE(archive.complete);
  EXPECT_EQ(archive.cursor.evaluations, 60);
  EXPECT_GT(archive.archive->size(), 5u);
  EXPECT_EQ(records[0].theta, archive.archive->best().theta);  // first trial: the best cell
  EXPECT_EQ(records[0].selected, "trial");
  EXPECT_EQ(summary.details.numbers.at("trials"), 1.0);
}

// The descriptor samples the 40 states of an episode (0.1 s apart); the reference sampled every
// 2 physics steps. Here the same episodes are simulated in physics steps of 10 ms with the foot
// heights after each (400 samples): the 0.1 s sampling must agree within one 0.2-wide bin's
// fraction, and on average closely (measured: mean 0.033, max 0.152 over these 36 leg values).
TEST(HexapodIte, TheDutyFactorOfTheControlStepsAgreesWithOneOfThePhysicsSteps) {
  const auto e = make();
  Rng rng(3);
  double sum = 0, worst = 0;
  for (int g = 0; g < 6; ++g) {
    VectorXd gait(36);
    if (g == 0) gait = hexapod::tripod_gait();
    else if (g == 1) gait = VectorXd::Zero(36);
    else for (int i = 0; i < 36; ++i) gait[i] = rng.uniform();
    const VectorXd coarse = duty(e, gait);
    hexapod::PriorOptions po;
    po.control_dt = 0.01;  // one physics step per step(): a sample every 10 ms
    hexapod::PriorSimulator fine(hexapod::HexapodSpec{}, po);
    hexapod::GaitController ctrl;
    ctrl.set_params(gait);
    VectorXd contacts = VectorXd::Zero(6);
    for (int t = 0; t < 40; ++t) {
      const VectorXd u = ctrl.targets(t * 0.1);  // held over the control step, as in an episode
      for (int j = 0; j < 10; ++j) {
        fine.step(u);
        const auto h = fine.foot_heights();
        for (int k = 0; k < 6; ++k) contacts[k] += h[static_cast<std::size_t>(k)] <= 0.005;
      }
    }
    const VectorXd diff = (coarse - contacts / 400.0).cwiseAbs();
    sum += diff.sum();
    worst = std::max(worst, diff.maxCoeff());
  }
  EXPECT_LT(worst, 0.2);
  EXPECT_LT(sum / 36, 0.06);
}
