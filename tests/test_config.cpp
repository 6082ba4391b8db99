// Configuration: defaults, overrides, and actionable errors for bad input.
#include <gtest/gtest.h>

#include "drops/core/errors.hpp"
#include "drops/io/config.hpp"

using namespace drops;

namespace {
std::string error_of(const std::string& yaml, const std::vector<std::string>& ov = {}) {
  try {
    io::make_experiment(io::load_settings(yaml, ov));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Config, DefaultsAreThePaperSettings) {
  const auto e = io::make_experiment(io::load_settings("", {}));
  EXPECT_EQ(e.algo.model.type, model::ModelType::kGpMi);
  EXPECT_EQ(e.prior_preset, "tunable-useful");
  EXPECT_EQ(e.algo.episodes, 10);
  EXPECT_EQ(e.seed, 1u);
  EXPECT_DOUBLE_EQ(e.prior.values[0], 0.65);  // Table I, prior A
  EXPECT_DOUBLE_EQ(e.prior.values[3], 0.4);
  EXPECT_EQ(e.prior.tunable, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_DOUBLE_EQ(e.actual.m1, 0.5);
  EXPECT_EQ(e.algo.model.rprop.max_iterations, 300);
  EXPECT_EQ(e.algo.cmaes.max_evaluations, 10000);
  EXPECT_DOUBLE_EQ(e.algo.theta_bound, 5.0);
}

TEST(Config, YamlAndOverridesApplyInOrder) {
  const auto s = io::load_settings("model: {type: mi}\nprior:\n  preset: tunable\n  m1: 0.6\n",
                                   {"episodes=3", "prior.bounds.m2=[0.1, 0.9]", "model.type=gp"});
  const auto e = io::make_experiment(s);
  EXPECT_EQ(e.algo.model.type, model::ModelType::kGp);
  EXPECT_EQ(e.algo.episodes, 3);
  EXPECT_DOUBLE_EQ(e.prior.values[0], 0.6);
  EXPECT_DOUBLE_EQ(e.prior.values[1], 0.75);
  EXPECT_DOUBLE_EQ(e.prior.lower[1], 0.1);
}

TEST(Config, UnknownKeyIsNamedWithASuggestion) {
  const std::string m = error_of("model:\n  tpye: gp\n");
  EXPECT_NE(m.find("model.tpye"), std::string::npos) << m;
  EXPECT_NE(m.find("did you mean 'model.type'"), std::string::npos) << m;
  EXPECT_NE(error_of("", {"episode=3"}).find("did you mean 'episodes'"), std::string::npos);
}

TEST(Config, WrongTypesAndRangesNameKeyValueAndAllowed) {
  std::string m = error_of("episodes: ten\n");
  EXPECT_NE(m.find("'episodes' = 'ten'"), std::string::npos) << m;
  m = error_of("episodes: 0\n");
  EXPECT_NE(m.find("allowed [1, 1000]"), std::string::npos) << m;
  m = error_of("model: {type: pilco}\n");
  EXPECT_NE(m.find("gp, gp_prior, gp_mi, mi"), std::string::npos) << m;
  m = error_of("", {"prior.bounds.m1=[0.0, 1.0]"});
  EXPECT_NE(m.find("prior.bounds.m1"), std::string::npos) << m;
  m = error_of("", {"prior.tunable=[m1, mass]"});
  EXPECT_NE(m.find("allowed names"), std::string::npos) << m;
  m = error_of("optimizer: {elitism: maybe}\n");
  EXPECT_NE(m.find("true or false"), std::string::npos) << m;
  m = error_of("", {"prior.bounds.l2=[0.5, 1.0]"});  // prior A has l2 = 0.4
  EXPECT_NE(m.find("outside"), std::string::npos) << m;
  m = error_of("", {"seed"});
  EXPECT_NE(m.find("key=value"), std::string::npos) << m;
  m = error_of("[1, 2]\n");
  EXPECT_NE(m.find("mapping"), std::string::npos) << m;
  m = error_of("model: {type: [gp}\n");
  EXPECT_NE(m.find("invalid YAML"), std::string::npos) << m;
}

TEST(Config, ResolvedYamlRoundTrips) {
  const auto s = io::load_settings("", {"prior.preset=tunable", "episodes=4"});
  const auto again = io::load_settings(io::to_yaml(s), {});
  EXPECT_EQ(s, again);
}

TEST(Config, MarkdownListsEveryKey) {
  const std::string md = io::schema_markdown();
  for (const auto& k : io::schema()) EXPECT_NE(md.find("`" + k.key + "`"), std::string::npos);
}

TEST(Config, HexapodBuildsTheSevenPriorFamilyAndTaskDefaults) {
  const auto e = io::make_experiment(io::load_settings("task: hexapod\n", {}));
  EXPECT_EQ(e.task, "hexapod");
  EXPECT_EQ(e.prior.names, (std::vector<std::string>{"removed_leg"}));
  ASSERT_EQ(e.prior.values.size(), 1);
  EXPECT_EQ(e.prior.values[0], -1.0);  // starts from the intact prior
  EXPECT_EQ(e.prior.tunable, (std::vector<int>{0}));
  ASSERT_EQ(e.prior.choices.size(), 1u);
  EXPECT_EQ(e.prior.choices[0], (std::vector<double>{-1, 0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(e.prior.lower[0], -1.0);
  EXPECT_EQ(e.prior.upper[0], 5.0);
  EXPECT_EQ(e.prior_preset, "intact");
  EXPECT_EQ(e.phi_actual, (std::vector<double>{-1}));
  EXPECT_DOUBLE_EQ(e.algo.theta_bound, 0.5);  // gait parameters theta + 0.5 in [0, 1]
  EXPECT_EQ(e.algo.cmaes.max_evaluations, 2000);
  EXPECT_EQ(e.hexapod.horizon, 40);
  // The pendubot keeps its own derived defaults.
  const auto p = io::make_experiment(io::load_settings("", {}));
  EXPECT_DOUBLE_EQ(p.algo.theta_bound, 5.0);
  EXPECT_EQ(p.algo.cmaes.max_evaluations, 10000);
  // Explicit values win over the derived ones.
  const auto x = io::make_experiment(
      io::load_settings("task: hexapod\n", {"policy.bound=0.25", "optimizer.max_evaluations=300"}));
  EXPECT_DOUBLE_EQ(x.algo.theta_bound, 0.25);
  EXPECT_EQ(x.algo.cmaes.max_evaluations, 300);
  // PILCO's soft walls: on by default for the hexapod only, with its own length-scale ratio.
  EXPECT_TRUE(e.algo.model.rprop.penalty);
  EXPECT_DOUBLE_EQ(e.algo.model.rprop.max_length_scale_ratio, 10.0);
  EXPECT_FALSE(p.algo.model.rprop.penalty);
  const auto on = io::make_experiment(io::load_settings("", {"model.type=gp", "model.rprop.penalty=on"}));
  EXPECT_TRUE(on.algo.model.rprop.penalty);
  EXPECT_DOUBLE_EQ(on.algo.model.rprop.max_length_scale_ratio, 100.0);
}

// A run directory's config.yaml written before the policy-search keys of 2026-11-22 resumes with
// the search it began with; a config that names the keys (or a user's file) keeps today's.
TEST(Config, RunSettingsWithoutTheNewSearchKeysKeepTheOldSearch) {
  const std::string old_run = "task: pendubot\noptimizer:\n  max_evaluations: 10000\n  keep_start: false\n";
  const auto legacy = io::make_experiment(io::load_run_settings(old_run, {"episodes=20"}));
  EXPECT_EQ(legacy.algo.selection, algo::PolicySelection::kBestSeen);
  EXPECT_EQ(legacy.algo.cmaes.max_run_evaluations, 0);
  EXPECT_FALSE(legacy.algo.cmaes.stagnation);
  EXPECT_EQ(legacy.algo.cmaes.tol_fun, 1e-12);
  EXPECT_EQ(legacy.algo.cmaes.restart_start, opt::CmaesRestartStart::kRandom);
  EXPECT_FALSE(legacy.algo.keep_start_point);
  EXPECT_EQ(legacy.algo.episodes, 20);  // the caller's overrides still apply
  const auto user = io::make_experiment(io::load_settings(old_run, {}));
  EXPECT_EQ(user.algo.selection, algo::PolicySelection::kReevaluate);
  EXPECT_EQ(user.algo.cmaes.max_run_evaluations, 2500);  // a quarter of the total
  EXPECT_TRUE(user.algo.cmaes.stagnation);
  EXPECT_EQ(user.algo.cmaes.restart_start, opt::CmaesRestartStart::kMixed);
  // A run written today names every key: nothing is replaced.
  const auto now = io::load_settings("", {});
  EXPECT_EQ(io::load_run_settings(io::to_yaml(now), {}), now);
  const auto big = io::make_experiment(io::load_settings("", {"optimizer.max_evaluations=40000"}));
  EXPECT_EQ(big.algo.cmaes.max_run_evaluations, 10000);
  const auto set = io::make_experiment(
      io::load_settings("", {"optimizer.max_evaluations=40000", "optimizer.run_evaluations=0"}));
  EXPECT_EQ(set.algo.cmaes.max_run_evaluations, 0);
}

// Settings written before a default became task-dependent hold the old value explicitly; once
// resolved, both compare equal (the campaign relies on this to continue old campaigns).
TEST(Config, ResolvedDerivedDefaultsEqualTheValuesOlderRunsWrote) {
  io::Settings now = io::load_settings("", {});
  io::Settings old = io::load_settings("", {"optimizer.max_evaluations=10000", "policy.bound=5"});
  EXPECT_NE(now, old);
  io::resolve_derived_defaults(now);
  io::resolve_derived_defaults(old);
  EXPECT_EQ(now.at("optimizer.max_evaluations"), "10000");
  EXPECT_EQ(now.at("policy.bound"), "5");
  EXPECT_EQ(now.at("model.rprop.max_length_scale_ratio"), "100");
  EXPECT_EQ(now, old);
  io::Settings hex = io::load_settings("task: hexapod\n", {"policy.bound=0.25"});
  io::resolve_derived_defaults(hex);
  EXPECT_EQ(hex.at("policy.bound"), "0.25");  // explicit values stay
  EXPECT_EQ(hex.at("optimizer.max_evaluations"), "2000");
  EXPECT_EQ(hex.at("model.rprop.max_length_scale_ratio"), "10");
}

TEST(Config, HexapodDamageAndPriorChoices) {
  const auto e = io::make_experiment(io::load_settings(
      "task: hexapod\nhexapod:\n  damage: {removed_leg: leg5, blocked_leg: leg1, blocked_joint: 2}\n"
      "  prior: {start: leg0, choices: [leg5, intact, leg0]}\n",
      {}));
  EXPECT_EQ(e.hexapod.removed_leg, 5);
  EXPECT_EQ(e.hexapod.blocked_leg, 1);
  EXPECT_EQ(e.hexapod.blocked_joint, 2);
  EXPECT_EQ(e.phi_actual, (std::vector<double>{5}));
  EXPECT_EQ(e.prior.choices[0], (std::vector<double>{-1, 0, 5}));  // sorted
  EXPECT_EQ(e.prior.values[0], 0.0);
  EXPECT_EQ(e.prior_preset, "leg0");
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
}
