// Configuration: defaults, overrides, and actionable errors for bad input; the schema assembled
// from the tasks' sections (the registry); task-dependent defaults.
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "drops/experiment/campaign.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "drops/model/simulator_model.hpp"
#include "fixtures.hpp"
#include "schema_ranges.hpp"

using namespace drops;
using drops::fixtures::registry;
using drops::fixtures::settings;

namespace {
std::string error_of(const std::string& yaml, const std::vector<std::string>& ov = {}) {
  try {
    experiment::make_experiment(registry(), settings(yaml, ov));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

algo::BlackDropsOptions algo_of(const experiment::Settings& s) {
  return experiment::black_drops_options(registry(), s);
}

/// The built-in variant of the model that a's factory builds for experiment e ("?" for another
/// model).
std::string built_model(const algo::BlackDropsOptions& a, const experiment::Experiment& e) {
  const auto m = a.model_factory(a.model, e.setup.task, a.uses_prior() ? e.setup.prior : nullptr,
                                 e.setup.prior_parameters);
  if (const auto* g = dynamic_cast<const model::GpDynamicsModel*>(m.get()))
    return model::to_string(g->type());
  if (const auto* s = dynamic_cast<const model::SimulatorModel*>(m.get()))
    return model::to_string(s->type());
  return "?";
}

/// A task of the tests: its own key, and its own defaults of two shared keys.
class ToyTask : public experiment::TaskPlugin {
 public:
  std::string name() const override { return "toy"; }
  std::string description() const override { return "a task of the tests"; }
  std::vector<experiment::KeySpec> keys() const override {
    return {{"toy.length", "double", "1.5", 0.1, 10, {}, "m", "the toy's length"}};
  }
  std::map<std::string, std::string> shared_defaults() const override {
    return {{"policy.bound", "0.5"},
            {"optimizer.max_evaluations", "2000"},
            {"model.rprop.max_length_scale_ratio", "10"},
            {"model.rprop.penalty", "on"}};
  }
  experiment::TaskSetup make(const experiment::Settings&) const override {
    throw ConfigError("the toy task builds nothing");
  }
  std::string prior_label(const experiment::Settings&) const override { return "toy-prior"; }
  experiment::ReportInfo report_info(const experiment::Settings&) const override { return {}; }
};

const experiment::Registry& toy_registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    pendubot::register_task(*reg);
    reg->add_task(std::make_unique<ToyTask>());
    return reg;
  }();
  return *r;
}
}  // namespace

TEST(Config, DefaultsAreThePaperSettings) {
  const auto e = fixtures::experiment();
  const auto a = algo_of(e.settings);
  EXPECT_EQ(e.task, "pendubot");
  EXPECT_EQ(e.algorithm, "black_drops");
  EXPECT_EQ(e.variant, "gp_mi");
  EXPECT_TRUE(a.uses_prior());
  EXPECT_EQ(built_model(a, e), "gp_mi");
  EXPECT_EQ(e.setup.prior_label, "tunable-useful");
  EXPECT_EQ(a.episodes, 10);
  EXPECT_EQ(e.seed, 1u);
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[0], 0.65);  // Table I, prior A
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[3], 0.4);
  EXPECT_EQ(e.setup.prior_parameters.tunable, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_DOUBLE_EQ(e.setup.phi_actual[0], 0.5);
  EXPECT_EQ(a.model.rprop.max_iterations, 300);
  EXPECT_EQ(a.search.cmaes.max_evaluations, 10000);
  EXPECT_DOUBLE_EQ(a.search.theta_bound, 5.0);
}

// One source of each default: the configuration's defaults are the Options structs' own.
TEST(Config, DefaultsAreTheOptionsStructsDefaults) {
  const algo::BlackDropsOptions d;
  const auto a = algo_of(settings(""));
  EXPECT_EQ(a.episodes, d.episodes);
  EXPECT_EQ(a.search.theta_bound, d.search.theta_bound);
  EXPECT_EQ(a.model.rprop.tolerance, d.model.rprop.tolerance);
  EXPECT_EQ(a.model.rprop.max_length_scale_ratio, d.model.rprop.max_length_scale_ratio);
  EXPECT_EQ(a.model.rprop.penalty, d.model.rprop.penalty);
  EXPECT_EQ(a.model.gp_mi.max_evaluations, d.model.gp_mi.max_evaluations);
  // The pendubot sets its own tolerance (its shared_defaults); a task that sets none gets the
  // struct's.
  EXPECT_EQ(a.model.gp_mi.xtol_rel, 1e-9);
  EXPECT_EQ(a.model.gp_mi.ftol_rel, 1e-9);
  EXPECT_NE(d.model.gp_mi.xtol_rel, 1e-9);
  const auto toy = algo_of(experiment::load_settings(toy_registry(), "task: toy\n", {}));
  EXPECT_EQ(toy.model.gp_mi.xtol_rel, d.model.gp_mi.xtol_rel);
  EXPECT_EQ(a.model.mi.max_evaluations, d.model.mi.max_evaluations);
  EXPECT_EQ(a.search.cmaes.max_evaluations, d.search.cmaes.max_evaluations);
  EXPECT_EQ(a.search.cmaes.max_run_evaluations, d.search.cmaes.max_run_evaluations);
  EXPECT_EQ(a.search.cmaes.tol_fun, d.search.cmaes.tol_fun);
  EXPECT_EQ(a.search.cmaes.restart_start, d.search.cmaes.restart_start);
  EXPECT_EQ(a.search.cmaes.stagnation, d.search.cmaes.stagnation);
  EXPECT_EQ(a.search.cmaes.max_restarts, d.search.cmaes.max_restarts);
  EXPECT_EQ(a.search.keep_start_point, d.search.keep_start_point);
  EXPECT_EQ(a.search.selection, d.search.selection);
  EXPECT_EQ(a.search.reevaluation.rollouts, d.search.reevaluation.rollouts);
  EXPECT_EQ(a.search.reevaluation.candidates, d.search.reevaluation.candidates);
  EXPECT_EQ(a.search.rollouts.batch, d.search.rollouts.batch);
  EXPECT_EQ(a.search.rollouts.statistic, d.search.rollouts.statistic);
  EXPECT_EQ(a.predicted_rollouts, d.predicted_rollouts);
  EXPECT_EQ(algo_of(settings("", {"rollouts.statistic=median"})).search.rollouts.statistic,
            rollout::ReturnStatistic::kMedian);
  const std::string m = error_of("", {"rollouts.statistic=mode"});
  EXPECT_NE(m.find("mean, median"), std::string::npos) << m;
  EXPECT_EQ(a.model.gp_mi.candidate_start, d.model.gp_mi.candidate_start);
  EXPECT_EQ(algo_of(settings("", {"model.gp_mi.candidate_start=initial"}))
                .model.gp_mi.candidate_start,
            model::GpMiCandidateStart::kInitial);
  const std::string c = error_of("", {"model.gp_mi.candidate_start=fresh"});
  EXPECT_NE(c.find("best_so_far, initial"), std::string::npos) << c;
  // The trust region: off for the pendubot, on when asked, a clear error for a wrong value.
  EXPECT_EQ(a.trust_region.enabled, d.trust_region.enabled);
  EXPECT_FALSE(a.trust_region.enabled);
  const auto tr = algo_of(settings("", {"optimizer.trust_region=true",
                                        "optimizer.trust_region_min=0.25"}));
  EXPECT_TRUE(tr.trust_region.enabled);
  EXPECT_DOUBLE_EQ(tr.trust_region.min_radius, 0.25);
  const std::string t = error_of("", {"optimizer.trust_region_min=0"});
  EXPECT_NE(t.find("optimizer.trust_region_min"), std::string::npos) << t;
}

TEST(Config, YamlAndOverridesApplyInOrder) {
  const auto s = settings("model: {type: mi}\nprior:\n  preset: tunable\n  m1: 0.6\n",
                          {"episodes=3", "prior.bounds.m2=[0.1, 0.9]", "model.type=gp"});
  const auto e = experiment::make_experiment(registry(), s);
  const auto a = algo_of(s);
  EXPECT_EQ(built_model(a, e), "gp");
  EXPECT_FALSE(a.uses_prior());
  EXPECT_EQ(e.variant, "gp");
  EXPECT_EQ(a.episodes, 3);
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[0], 0.6);
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[1], 0.75);
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.lower[1], 0.1);
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
  m = error_of("task: cartpole\n");
  EXPECT_NE(m.find("unknown task (available: pendubot)"), std::string::npos) << m;
  EXPECT_NE(m.find("drops.run(config, task="), std::string::npos) << m;  // a Python task's run
  m = error_of("", {"algorithm=ppo"});
  EXPECT_NE(m.find("black_drops, direct"), std::string::npos) << m;
}

// What std::stod reads but YAML does not (a hexadecimal number) is refused where it is read, with
// the key; before, an interval of one passed the check and failed later in yaml-cpp with a bare
// "bad conversion" (issue 18). Conversions of settings that did not come from load_settings name
// the key too.
TEST(Config, NumbersYamlCannotReadAreRefusedWithTheKey) {
  std::string m = error_of("", {"prior.bounds.m2=[0x1, 2]"});
  EXPECT_NE(m.find("config key 'prior.bounds.m2' = '0x1': expected a finite decimal number"),
            std::string::npos)
      << m;
  m = error_of("policy:\n  bound: 0x10\n");
  EXPECT_NE(m.find("config key 'policy.bound' = '0x10'"), std::string::npos) << m;
  m = error_of("episodes: ' 3'\n");
  EXPECT_NE(m.find("config key 'episodes'"), std::string::npos) << m;
  // What load_settings accepts, every reader reads.
  EXPECT_EQ(experiment::get_interval(settings("", {"prior.bounds.m2=[1e-1, .2e1]"}),
                                     "prior.bounds.m2"),
            (std::vector<double>{0.1, 2.0}));
  experiment::Settings bad = settings("", {});
  bad["prior.bounds.m2"] = "[a, b]";
  bad["episodes"] = "ten";
  try {
    experiment::get_interval(bad, "prior.bounds.m2");
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'prior.bounds.m2' = '[a, b]'"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(experiment::get_int(bad, "episodes"), ConfigError);
}

TEST(Config, ResolvedYamlRoundTrips) {
  const auto s = settings("", {"prior.preset=tunable", "episodes=4"});
  const auto again = settings(experiment::to_yaml(registry(), s));
  EXPECT_EQ(s, again);
}

TEST(Config, MarkdownListsEveryKeyOfEveryTask) {
  const std::string md = experiment::schema_markdown(toy_registry());
  for (const auto& k : experiment::schema(toy_registry(), "pendubot"))
    EXPECT_NE(md.find("`" + k.key + "`"), std::string::npos) << k.key;
  EXPECT_NE(md.find("`toy.length`"), std::string::npos);
  EXPECT_NE(md.find("## Task `toy`"), std::string::npos);
}

// The documented ranges are what validation accepts (issue 43): every numeric key of the
// pendubot's schema at either end of its range builds an experiment, and just outside it is
// refused naming the key (tests/schema_ranges.hpp). Where two keys constrain each other (a prior's
// value lies in its search interval, an episode lasts at least three control periods, the balance
// hands back no sooner than it takes over; documented
// and named by their messages), the other key makes room.
TEST(Config, EveryNumericKeyAcceptsBothEndsOfItsDocumentedRangeAndNothingBeyond) {
  const auto all = experiment::schema(registry(), "pendubot");
  const int checked = fixtures::check_documented_ranges(
      registry(), "pendubot", [&](const std::string& key) {
        std::vector<std::string> context;
        if (key == "pendubot.duration") context.push_back("pendubot.dt=0.001");
        if (key == "pendubot.dt") context.push_back("pendubot.duration=100");
        if (key == "policy.balance.exit") context.push_back("policy.balance.enter=1e-9");
        if (key == "policy.balance.enter") context.push_back("policy.balance.exit=1e12");
        const std::string prefix = "prior.";
        if (key.rfind(prefix, 0) == 0)
          for (const auto& k : all)
            if (k.key == "prior.bounds." + key.substr(prefix.size()))
              context.push_back(k.key + "=[" + fixtures::exact_text(k.min) + ", " +
                                fixtures::exact_text(k.max) + "]");
        return context;
      });
  EXPECT_GT(checked, 100);
}

// The schema is the base keys plus the experiment's task's own: another task's key is refused
// with the task it belongs to.
TEST(Config, TaskKeysBelongToTheirTask) {
  const auto& r = toy_registry();
  const auto toy = experiment::load_settings(r, "task: toy\n", {"toy.length=2"});
  EXPECT_EQ(toy.at("toy.length"), "2");
  EXPECT_EQ(toy.count("prior.preset"), 0u);
  EXPECT_EQ(experiment::load_settings(r, "", {}).count("toy.length"), 0u);
  try {
    experiment::load_settings(r, "", {"toy.length=2"});
    FAIL() << "a toy key was accepted for the pendubot";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("belongs to task 'toy'"), std::string::npos) << e.what();
  }
  // A task whose keys collide with the base keys is refused.
  class Bad : public ToyTask {
    std::string name() const override { return "bad"; }
    std::vector<experiment::KeySpec> keys() const override {
      return {{"episodes", "int", "3", 1, 9, {}, "-", "a base key"}};
    }
  };
  experiment::Registry reg;
  experiment::register_builtin_algorithms(reg);
  EXPECT_THROW(reg.add_task(std::make_unique<Bad>()), InvalidArgument);
}

// Each base key is declared once with the field it sets (base_key_table): a value other than the
// default, applied through the declarations, changes that key's field and no other key's (read
// back through the same declarations), so no two keys share a field and none sets nothing.
TEST(Config, EveryBaseKeySetsAFieldOfItsOwn) {
  const auto& table = experiment::base_key_table();
  const auto registered = experiment::schema(registry(), "pendubot");
  const experiment::Settings start = settings("");
  // The base keys with the values of `start` as their defaults (an optional key's: "").
  const std::vector<experiment::KeySpec> defaults = table.specs(experiment::base_options(start));
  int changed = 0;
  for (std::size_t i = 0; i < defaults.size(); ++i) {
    const experiment::KeySpec& k = defaults[i];
    std::string v;
    if (k.type == "bool") {
      v = k.default_value == "true" ? "false" : "true";
    } else if (k.type == "enum") {
      const auto it = std::find_if(registered.begin(), registered.end(),
                                   [&](const experiment::KeySpec& r) { return r.key == k.key; });
      ASSERT_NE(it, registered.end()) << k.key;
      for (const auto& a : it->allowed)
        if (a != k.default_value) v = a;
    } else if (k.type == "string") {
      v = k.default_value + "x";
    } else if (!k.default_value.empty()) {  // int or double (an optional key reads back as "")
      ASSERT_LT(k.min, k.max) << k.key;
      const double d = std::stod(k.default_value);
      const double x = d != k.max ? k.max : k.min;
      v = k.type == "int" ? std::to_string(static_cast<long long>(x)) : fixtures::exact_text(x);
    }
    if (v.empty()) continue;
    experiment::Settings s = start;
    s[k.key] = v;
    const auto back = table.specs(experiment::base_options(s));
    ASSERT_EQ(back.size(), defaults.size());
    for (std::size_t j = 0; j < back.size(); ++j) {
      const std::string want = j == i ? v : defaults[j].default_value;
      if (defaults[j].type == "int" || defaults[j].type == "double")
        if (!want.empty() && !back[j].default_value.empty()) {
          EXPECT_DOUBLE_EQ(std::stod(back[j].default_value), std::stod(want))
              << "setting " << k.key << " = " << v << " changed " << back[j].key;
          continue;
        }
      EXPECT_EQ(back[j].default_value, want)
          << "setting " << k.key << " = " << v << " changed " << back[j].key;
    }
    ++changed;
  }
  EXPECT_GE(changed, static_cast<int>(defaults.size()) - 1);  // all but the optional one
}

// A task's default of a shared key goes through that key's declaration: it is the default of the
// task's schema (and its section of the Markdown), and a value the declaration refuses, or a key
// that does not exist, is refused naming the task and the key.
TEST(Config, ATasksDefaultIsValidatedByTheKeysDeclarationAndIsItsSchemasDefault) {
  const auto default_of = [](const std::vector<experiment::KeySpec>& keys, const std::string& k) {
    for (const auto& s : keys)
      if (s.key == k) return s.default_value;
    return std::string("(absent)");
  };
  const auto toy = experiment::schema(toy_registry(), "toy");
  EXPECT_EQ(default_of(toy, "policy.bound"), "0.5");
  EXPECT_EQ(default_of(toy, "model.rprop.penalty"), "on");
  const auto pendubot = experiment::schema(toy_registry(), "pendubot");
  EXPECT_EQ(default_of(pendubot, "model.rprop.penalty"), "off");  // the Options struct's
  EXPECT_EQ(default_of(experiment::base_keys(), "policy.bound"), "5");
  EXPECT_NE(experiment::schema_markdown(toy_registry()).find("`policy.bound` = `0.5`"),
            std::string::npos);
  class Far : public ToyTask {
    std::string name() const override { return "far"; }
    std::vector<experiment::KeySpec> keys() const override { return {}; }
    std::map<std::string, std::string> shared_defaults() const override {
      return {{"policy.bound", "5000"}};
    }
  };
  class Misspelt : public Far {
    std::string name() const override { return "misspelt"; }
    std::map<std::string, std::string> shared_defaults() const override {
      return {{"policy.bund", "1"}};
    }
  };
  experiment::Registry reg;
  experiment::register_builtin_algorithms(reg);
  reg.add_task(std::make_unique<Far>());
  reg.add_task(std::make_unique<Misspelt>());
  for (const auto& [task, words] :
       std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"far", {"task 'far'", "'policy.bound' = '5000'", "out of range"}},
           {"misspelt", {"task 'misspelt'", "'policy.bund'"}}}) {
    try {
      experiment::schema(reg, task);
      ADD_FAILURE() << task << "'s default was accepted";
    } catch (const ConfigError& e) {
      for (const auto& w : words)
        EXPECT_NE(std::string(e.what()).find(w), std::string::npos) << e.what();
    }
  }
}

TEST(Config, TaskDependentDefaultsComeFromTheTaskAndExplicitValuesWin) {
  const auto& r = toy_registry();
  const auto toy = experiment::load_settings(r, "task: toy\n", {});
  const auto a = algo_of(toy);
  EXPECT_DOUBLE_EQ(a.search.theta_bound, 0.5);
  EXPECT_EQ(a.search.cmaes.max_evaluations, 2000);
  EXPECT_EQ(a.search.cmaes.max_run_evaluations, 500);  // a quarter of the task's total
  EXPECT_TRUE(a.model.rprop.penalty);
  EXPECT_DOUBLE_EQ(a.model.rprop.max_length_scale_ratio, 10.0);
  // The pendubot keeps the Options structs' defaults.
  const auto p = algo_of(experiment::load_settings(r, "", {}));
  EXPECT_DOUBLE_EQ(p.search.theta_bound, 5.0);
  EXPECT_EQ(p.search.cmaes.max_evaluations, 10000);
  EXPECT_FALSE(p.model.rprop.penalty);
  // Explicit values win over the derived ones.
  const auto x = algo_of(experiment::load_settings(
      r, "task: toy\n", {"policy.bound=0.25", "optimizer.max_evaluations=300",
                         "model.rprop.penalty=off"}));
  EXPECT_DOUBLE_EQ(x.search.theta_bound, 0.25);
  EXPECT_EQ(x.search.cmaes.max_evaluations, 300);
  EXPECT_FALSE(x.model.rprop.penalty);
  const auto on = algo_of(settings("", {"model.type=gp", "model.rprop.penalty=on"}));
  EXPECT_TRUE(on.model.rprop.penalty);
  EXPECT_DOUBLE_EQ(on.model.rprop.max_length_scale_ratio, 100.0);
}

// A config that leaves the policy search's keys out gets today's defaults; a run directory's
// config.yaml (to_yaml of the settings) names every key and loads back to the same settings, so
// `drops run RUN_DIR/config.yaml` repeats the run.
TEST(Config, OmittedSearchKeysTakeTodaysDefaultsAndARunConfigLoadsBackUnchanged) {
  const std::string partial =
      "task: pendubot\noptimizer:\n  max_evaluations: 10000\n  keep_start: false\n";
  const auto user = algo_of(settings(partial, {"episodes=20"}));
  EXPECT_EQ(user.search.selection, algo::PolicySelection::kReevaluate);
  EXPECT_EQ(user.search.cmaes.max_run_evaluations, 2500);  // a quarter of the total
  EXPECT_TRUE(user.search.cmaes.stagnation);
  EXPECT_EQ(user.search.cmaes.restart_start, opt::CmaesRestartStart::kMixed);
  EXPECT_FALSE(user.search.keep_start_point);
  EXPECT_EQ(user.episodes, 20);
  for (const auto& now : {settings(""), settings(partial, {"model.type=gp_prior", "seed=7"})})
    EXPECT_EQ(experiment::load_settings(registry(), experiment::to_yaml(registry(), now), {}),
              now);
  const auto big = algo_of(settings("", {"optimizer.max_evaluations=40000"}));
  EXPECT_EQ(big.search.cmaes.max_run_evaluations, 10000);
  const auto set =
      algo_of(settings("", {"optimizer.max_evaluations=40000", "optimizer.run_evaluations=0"}));
  EXPECT_EQ(set.search.cmaes.max_run_evaluations, 0);
}

// Settings that hold the defaults explicitly (as a run directory's config.yaml does), or leave a
// derived one empty, compare equal to the defaults once resolved (the campaign compares a kept
// run's config.yaml with the campaign's settings this way).
TEST(Config, ResolvedDerivedDefaultsEqualTheSameValuesWrittenExplicitly) {
  const auto now = settings("");
  const auto written = experiment::load_settings(
      registry(),
      "task: pendubot\noptimizer: {max_evaluations: 10000, selection: reevaluate, "
      "run_evaluations: ~, stagnation: true, tol_fun: 0.01, restart_from: mixed}\n"
      "policy: {bound: 5, hidden_units: 10}\nmodel: {variance_points: 400, rprop: {penalty: "
      "off, max_length_scale_ratio: 100}, gp_mi: {score: sum_likelihoods, candidate_start: "
      "best_so_far}}\n",
      {});
  EXPECT_EQ(now.at("optimizer.max_evaluations"), "10000");
  EXPECT_EQ(now.at("policy.bound"), "5");
  EXPECT_EQ(now.at("model.rprop.max_length_scale_ratio"), "100");
  EXPECT_EQ(now.at("model.rprop.penalty"), "off");
  EXPECT_EQ(now.at("model.gp_mi.score"), "sum_likelihoods");  // the paper's, for the pendubot
  EXPECT_EQ(now.at("model.gp_mi.candidate_start"), "best_so_far");
  EXPECT_EQ(now.at("model.variance_points"), "400");  // the pendubot's
  std::string key;
  EXPECT_TRUE(experiment::same_settings(now, written, {}, &key)) << key;
}

// A key given no value (~ or empty) takes its default, the task's where the task sets one: a
// config.yaml written when such keys were left empty (the task's choice) loads to the same values.
TEST(Config, AKeyGivenNoValueTakesItsDefault) {
  const auto& r = toy_registry();
  const auto toy = experiment::load_settings(
      r, "task: toy\npolicy: {bound: ~}\nmodel: {rprop: {penalty: ''}}\n",
      {"optimizer.trust_region=", "optimizer.max_evaluations="});
  EXPECT_EQ(toy.at("policy.bound"), "0.5");
  EXPECT_EQ(toy.at("model.rprop.penalty"), "on");
  EXPECT_EQ(toy.at("optimizer.trust_region"), "false");
  EXPECT_EQ(toy.at("optimizer.max_evaluations"), "2000");
  const auto old = settings("ite: {evaluations: ~, mutation: \"\", mutation_rate: ~}\n");
  EXPECT_EQ(old, settings(""));
  EXPECT_EQ(old.at("ite.evaluations"), "100000");
  EXPECT_EQ(old.at("ite.mutation"), "polynomial");
  EXPECT_EQ(settings("", {"ite.observation_floor="}).at("ite.observation_floor"), "");  // optional
}

TEST(Config, TheAlgorithmChoosesTheVariantAndItsKeys) {
  const auto direct = experiment::make_experiment(
      registry(), settings("", {"algorithm=direct", "optimizer.max_evaluations=40"}));
  EXPECT_EQ(direct.variant, "direct");
  EXPECT_FALSE(direct.uses_prior);
  EXPECT_EQ(direct.runner->name(), "direct");
  EXPECT_EQ(direct.runner->episodes(), 40);
  EXPECT_FALSE(direct.runner->resumable());
  EXPECT_EQ(direct.default_run_name(""), "pendubot-direct-seed1");
  const auto gp = fixtures::experiment({"model.type=gp", "seed=3"});
  EXPECT_EQ(gp.default_run_name("x"), "pendubot-gp-seed3-x");
  EXPECT_EQ(fixtures::experiment().default_run_name(""), "pendubot-gp_mi-tunable-useful-seed1");
  const std::string m = error_of("", {"algorithm=direct", "direct.start=/nonexistent/policy.csv"});
  EXPECT_NE(m.find("direct.start"), std::string::npos) << m;
  // Its budget is optimizer.max_evaluations: an `episodes` it would ignore (a few episodes asked
  // for, thousands run) is refused with the key to use; the default is not.
  const std::string e = error_of("", {"algorithm=direct", "episodes=5"});
  EXPECT_NE(e.find("config key 'episodes' = '5'"), std::string::npos) << e;
  EXPECT_NE(e.find("set optimizer.max_evaluations=5 instead"), std::string::npos) << e;
  EXPECT_EQ(error_of("", {"algorithm=direct", "episodes=10"}), "");
}

// The algorithm key offers the registered algorithms, and each one is described in the schema's
// Markdown (the same list as the registry; none is written out in the key's help).
TEST(Config, TheAlgorithmKeyListsTheRegisteredAlgorithmsEachWithItsSection) {
  const auto keys = experiment::schema(registry(), "pendubot");
  const auto it = std::find_if(keys.begin(), keys.end(),
                               [](const experiment::KeySpec& k) { return k.key == "algorithm"; });
  ASSERT_NE(it, keys.end());
  EXPECT_EQ(it->allowed, registry().algorithm_names());
  EXPECT_EQ(it->allowed.front(), "black_drops");
  const std::string md = experiment::schema_markdown(registry());
  for (const auto& a : registry().algorithm_names()) {
    const auto at = md.find("## Algorithm `" + a + "`\n\n" + registry().algorithm(a).description());
    EXPECT_NE(at, std::string::npos) << a;
  }
}
