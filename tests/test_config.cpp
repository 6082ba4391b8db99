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
