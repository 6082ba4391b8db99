// The hexapod task plugin: its keys, the prior family it builds, its defaults of shared keys, its
// damage and its report labels.
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <stdexcept>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"
#include "drops/hexapod/plugin.hpp"
#include "drops/hexapod/prior.hpp"
#include "schema_ranges.hpp"

using namespace drops;

namespace {
const experiment::Registry& registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    pendubot::register_task(*reg);
    hexapod::register_task(*reg);
    return reg;
  }();
  return *r;
}
experiment::Experiment make(const std::string& yaml, const std::vector<std::string>& ov = {}) {
  return experiment::make_experiment(registry(), experiment::load_settings(registry(), yaml, ov));
}
std::string error_of(const std::string& yaml, const std::vector<std::string>& ov = {}) {
  try {
    make(yaml, ov);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
// The HexapodPrior of a hexapod experiment; throws when the setup's prior is of another type.
std::shared_ptr<const hexapod::HexapodPrior> prior_of(const experiment::Experiment& e) {
  auto p = std::dynamic_pointer_cast<const hexapod::HexapodPrior>(e.setup.prior);
  if (p == nullptr) throw std::logic_error("the hexapod setup's prior is not a HexapodPrior");
  return p;
}
// The state after n control steps of the experiment's prior (intact, phi = -1) from the task's
// start state with the joint targets u(t), t = 0..n-1 (18-D).
Eigen::VectorXd prior_steps(const experiment::Experiment& e, int n,
                            const std::function<Eigen::VectorXd(int)>& u) {
  const auto prior = prior_of(e);
  Eigen::VectorXd x = e.setup.task->initial_state();
  Eigen::VectorXd dx(x.size());
  const Eigen::VectorXd phi = Eigen::VectorXd::Constant(1, -1.0);
  for (int t = 0; t < n; ++t) {
    prior->evaluate(x, u(t), phi, dx);
    x += dx;
  }
  return x;
}
}  // namespace

TEST(HexapodPlugin, BuildsTheSevenPriorFamilyAndTaskDefaults) {
  const auto e = make("task: hexapod\n");
  const auto a = experiment::black_drops_options(registry(), e.settings);
  const auto& p = e.setup.prior_parameters;
  EXPECT_EQ(e.task, "hexapod");
  EXPECT_EQ(p.names, (std::vector<std::string>{"removed_leg"}));
  ASSERT_EQ(p.values.size(), 1);
  EXPECT_EQ(p.values[0], -1.0);  // starts from the intact prior
  EXPECT_EQ(p.tunable, (std::vector<int>{0}));
  ASSERT_EQ(p.choices.size(), 1u);
  EXPECT_EQ(p.choices[0], (std::vector<double>{-1, 0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(p.lower[0], -1.0);
  EXPECT_EQ(p.upper[0], 5.0);
  EXPECT_EQ(e.setup.prior_label, "intact");
  EXPECT_EQ(e.setup.phi_actual, (std::vector<double>{-1}));
  EXPECT_DOUBLE_EQ(a.search.theta_bound, 0.5);  // gait parameters theta + 0.5 in [0, 1]
  EXPECT_EQ(a.search.cmaes.max_evaluations, 5000);
  EXPECT_EQ(a.search.reevaluation.rollouts, 20);
  // GP-MI: the joint likelihood, every candidate's kernels from a new GP's (measured choices).
  EXPECT_EQ(a.model.gp_mi.score, model::GpMiScore::kSumOfLogLikelihoods);
  EXPECT_EQ(a.model.gp_mi.candidate_start, model::GpMiCandidateStart::kInitial);
  EXPECT_TRUE(a.trust_region.enabled);  // around the best real gait (measured)
  EXPECT_EQ(e.setup.task->horizon(), 40);
  // PILCO's soft walls: on by default for the hexapod, with its own length-scale ratio.
  EXPECT_TRUE(a.model.rprop.penalty);
  EXPECT_DOUBLE_EQ(a.model.rprop.max_length_scale_ratio, 3.0);  // measured by the walls study
  // Explicit values win over the derived ones.
  const auto x = experiment::black_drops_options(
      registry(),
      make("task: hexapod\n", {"policy.bound=0.25", "optimizer.max_evaluations=300"}).settings);
  EXPECT_DOUBLE_EQ(x.search.theta_bound, 0.25);
  EXPECT_EQ(x.search.cmaes.max_evaluations, 300);
  // Report labels: the damage as panel, the walking speed as metric, no success criterion.
  EXPECT_EQ(e.report.panel.label, "intact");
  EXPECT_EQ(e.report.metric.name, "walking_speed_m_s");
  EXPECT_FALSE(e.report.success_criterion);
  EXPECT_EQ(e.report.phi_value_labels.at(5), "leg5");
  EXPECT_EQ(e.report.column_labels.at("vx").unit, "m/s");  // the trajectory figure's body columns
  // A direct search on the damaged robot stays in the damage's panel (its model-free reference).
  const auto direct =
      make("task: hexapod\n", {"algorithm=direct", "hexapod.damage.removed_leg=leg5"});
  EXPECT_EQ(direct.report.panel.label, "leg5 removed");
}

// hexapod.reward.tilt_penalty reaches the task's reward: a body on its back (roll = pi) at the
// start position costs the penalty per step, an upright one nothing; settings.md's 10 by default.
TEST(HexapodPlugin, TiltPenaltyKeySetsTheTippedReward) {
  Eigen::VectorXd upright = Eigen::VectorXd::Zero(48);
  upright[38] = 0.2;  // body z
  Eigen::VectorXd on_back = upright;
  on_back[39] = 3.0;  // roll, rad: tilt 172 degrees
  const auto d = make("task: hexapod\n");
  EXPECT_DOUBLE_EQ(d.setup.task->reward(upright), 0.0);
  EXPECT_DOUBLE_EQ(d.setup.task->reward(on_back), -10.0);
  const auto one = make("task: hexapod\n", {"hexapod.reward.tilt_penalty=1.5"});
  EXPECT_DOUBLE_EQ(one.setup.task->reward(on_back), -1.5);
  EXPECT_DOUBLE_EQ(one.setup.task->reward(upright), 0.0);
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.reward.tilt_penalty=-1"}).find(
                "hexapod.reward.tilt_penalty"),
            std::string::npos);
}

TEST(HexapodPlugin, PriorEngineKeyChoosesThePhysicsStep) {
  auto engine = [](const std::vector<std::string>& ov) {
    return prior_of(make("task: hexapod\n", ov))->options().simulator.engine;
  };
  EXPECT_EQ(engine({}), hexapod::PriorEngine::kRigid);  // default: the dedicated step
  EXPECT_EQ(engine({"hexapod.prior.engine=rigid"}), hexapod::PriorEngine::kRigid);
  EXPECT_EQ(engine({"hexapod.prior.engine=dart"}), hexapod::PriorEngine::kDart);
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.prior.engine=fast"}).find("hexapod.prior.engine"),
            std::string::npos);
}

// hexapod.prior.ground_friction reaches the prior's world: 1 (DART's default) unless set; the
// same steps from the start state, every hip swung forward 0.6 rad and back while the feet carry
// the body, end elsewhere on a floor of 0.4 than on one of 1 (the feet slip); out of range fails.
TEST(HexapodPlugin, PriorGroundFrictionKeySetsThePriorsFloor) {
  const auto swing = [](int t) {
    Eigen::VectorXd u = Eigen::VectorXd::Zero(hexapod::kNumJoints);
    for (int k = 0; k < hexapod::kNumLegs; ++k) u[3 * k] = (t % 2 == 0 ? 0.6 : -0.6);
    return u;
  };
  const auto one = make("task: hexapod\n");
  const auto slippery = make("task: hexapod\n", {"hexapod.prior.ground_friction=0.4"});
  EXPECT_DOUBLE_EQ(prior_of(one)->options().simulator.ground_friction, 1.0);
  EXPECT_DOUBLE_EQ(prior_of(slippery)->options().simulator.ground_friction, 0.4);
  const Eigen::VectorXd a = prior_steps(one, 10, swing);
  const Eigen::VectorXd b = prior_steps(slippery, 10, swing);
  ASSERT_EQ(a.size(), 48);
  ASSERT_EQ(b.size(), 48);
  ASSERT_TRUE(a.allFinite() && b.allFinite());
  // Body position and roll, pitch, yaw (x[36..41]) move differently.
  EXPECT_GT((a.segment<6>(36) - b.segment<6>(36)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.prior.ground_friction=0"})
                .find("hexapod.prior.ground_friction"),
            std::string::npos);
}

// hexapod.prior.velocity_gain_period reaches the prior's actuators: settings.md's pi to the bit by
// default (so the key changes no earlier result); with 2 pi a joint target step of 0.05 rad (the
// command stays below the 7 rad/s clip) is followed more slowly; out of range fails.
TEST(HexapodPlugin, PriorVelocityGainPeriodKeySetsThePriorsActuators) {
  const auto step = [](int) { return Eigen::VectorXd::Constant(hexapod::kNumJoints, 0.05); };
  const auto fast = make("task: hexapod\n");
  const auto slow =
      make("task: hexapod\n", {"hexapod.prior.velocity_gain_period=6.283185307179586"});
  EXPECT_EQ(prior_of(fast)->options().simulator.velocity_gain_period,
            3.14159265358979323846);  // bit-identical to settings.md's pi
  EXPECT_DOUBLE_EQ(prior_of(slow)->options().simulator.velocity_gain_period,
                   2 * 3.14159265358979323846);
  const Eigen::VectorXd a = prior_steps(fast, 1, step);
  const Eigen::VectorXd b = prior_steps(slow, 1, step);
  ASSERT_EQ(a.size(), 48);
  ASSERT_EQ(b.size(), 48);
  // Hip of leg 0 (x[0], 0 at the start): each 10 ms physics step closes 1/period of the gap to the
  // target, so over the 10 steps of a control step the joint reaches about 0.049 rad with pi and
  // 0.041 with 2 pi.
  EXPECT_GT(a[0], b[0] + 1e-3);
  EXPECT_GT(b[0], 0.0);
  EXPECT_LE(a[0], 0.05 + 1e-9);
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.prior.velocity_gain_period=0"})
                .find("hexapod.prior.velocity_gain_period"),
            std::string::npos);
}

TEST(HexapodPlugin, DamageAndPriorChoices) {
  const auto e = make(
      "task: hexapod\nhexapod:\n  damage: {removed_leg: leg5, blocked_leg: leg1, blocked_joint: 2}\n"
      "  prior: {start: leg0, choices: [leg5, intact, leg0]}\n");
  const auto spec = hexapod::real_robot_spec(e.settings);
  EXPECT_TRUE(spec.legs[5].removed);
  EXPECT_EQ(spec.legs[1].blocked_joint, 2);
  EXPECT_EQ(e.setup.phi_actual, (std::vector<double>{5}));
  EXPECT_EQ(e.setup.prior_parameters.choices[0], (std::vector<double>{-1, 0, 5}));  // sorted
  EXPECT_EQ(e.setup.prior_parameters.values[0], 0.0);
  EXPECT_EQ(e.setup.prior_label, "leg0");
  EXPECT_EQ(e.report.panel.label, "leg5 removed, leg1 blocked");
  // A start outside the family, an impossible damage and an unknown leg name are named.
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.prior.start=leg2", "hexapod.prior.choices=[intact]"})
                .find("hexapod.prior.start"),
            std::string::npos);
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.damage.removed_leg=leg3",
                                          "hexapod.damage.shortened_leg=leg3"})
                .find("leg3 is removed"),
            std::string::npos);
  const std::string bad = error_of("task: hexapod\n", {"hexapod.damage.removed_leg=leg7"});
  EXPECT_NE(bad.find("hexapod.damage.removed_leg"), std::string::npos) << bad;
  EXPECT_NE(bad.find("leg5"), std::string::npos) << bad;  // lists what is allowed
  EXPECT_NE(error_of("task: hexapod\n", {"hexapod.damge.removed_leg=leg0"}).find("did you mean"),
            std::string::npos);
  // A pendubot key in a hexapod experiment names the task it belongs to.
  EXPECT_NE(error_of("task: hexapod\n", {"prior.preset=tunable"}).find("belongs to task 'pendubot'"),
            std::string::npos);
}

// The hexapod's task-dependent defaults, and explicit values win over them.
TEST(HexapodPlugin, ResolvedDerivedDefaultsEqualExplicitOnes) {
  auto hex = experiment::load_settings(registry(), "task: hexapod\n", {"policy.bound=0.25"});
  EXPECT_EQ(hex.at("policy.bound"), "0.25");  // explicit values stay
  EXPECT_EQ(hex.at("optimizer.max_evaluations"), "5000");
  EXPECT_EQ(hex.at("model.gp_mi.score"), "sum_log_likelihoods");
  EXPECT_EQ(hex.at("model.gp_mi.candidate_start"), "initial");
  // Explicit values win over the task's; a key left out takes the task's.
  const auto paper = experiment::load_settings(registry(), "task: hexapod\n",
                                               {"model.gp_mi.score=sum_likelihoods"});
  EXPECT_EQ(paper.at("model.gp_mi.score"), "sum_likelihoods");
  EXPECT_EQ(paper.at("model.gp_mi.candidate_start"), "initial");
  EXPECT_EQ(hex.at("optimizer.trust_region"), "true");
  EXPECT_EQ(hex.at("model.rprop.max_length_scale_ratio"), "3");
  EXPECT_EQ(hex.at("model.rprop.penalty"), "on");
}

// The documented ranges are what validation accepts (issue 43), on the hexapod's schema: every
// numeric key at either end of its range builds an experiment, and just outside it is refused
// naming the key (tests/schema_ranges.hpp). The balance hands back no sooner than it takes over
// (policy.balance.exit >= enter), so for each of the two the other key makes room.
TEST(HexapodPlugin, EveryNumericKeyAcceptsBothEndsOfItsDocumentedRangeAndNothingBeyond) {
  const int checked = fixtures::check_documented_ranges(
      registry(), "hexapod", [](const std::string& key) {
        std::vector<std::string> context;
        if (key == "policy.balance.exit") context.push_back("policy.balance.enter=1e-9");
        if (key == "policy.balance.enter") context.push_back("policy.balance.exit=1e12");
        return context;
      });
  EXPECT_GT(checked, 100);
}
