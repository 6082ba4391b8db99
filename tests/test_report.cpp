// drops report / drops plot: quantiles, aggregation of fake run directories against statistics
// worked out by hand below, and the CSV files written from them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/report.hpp"
#include "drops/experiment/run_directory.hpp"
#include "figures.hpp"
#include "fixtures.hpp"

using namespace drops;
using namespace drops::experiment;
using drops::app::plot_run;
using drops::app::write_report;
namespace fs = std::filesystem;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A fresh directory under the system temp dir, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("drops-test-report-") + info->name() + "-" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The report block of summary.json of a task that declares no label, no metric and no tunable
// phi, in a panel called `panel` (what a robot of one's own that the registry does not know
// writes).
nlohmann::json unlabelled_report(const std::string& panel) {
  return {{"phi_tunable", nlohmann::json::array()},
          {"phi_labels", nlohmann::json::object()},
          {"column_labels", nlohmann::json::object()},
          {"panel", {{"label", panel}, {"rank", 0}, {"title", panel}, {"chosen_by_prior", true}}},
          {"metric",
           {{"name", ""},
            {"label", ""},
            {"unit", ""},
            {"file", ""},
            {"predicted", ""},
            {"reference", nullptr},
            {"reference_label", ""}}},
          {"success_criterion", true},
          {"phi_value_labels", nlohmann::json::array()}};
}

// A run directory with only what the report reads: config.yaml and summary.json, whose head is
// the one a run of that config.yaml starts with (summary_head). Episode k has interaction time
// 2.5 k s, returns[k-1] and solved[k-1]; φ = (k, 10) for every run.
void fake_run(const fs::path& runs, const std::string& name, const std::string& model,
              const std::string& prior, int seed, const std::string& status,
              const std::vector<double>& returns, const std::vector<bool>& solved,
              const std::string& extra_config = "") {
  const fs::path dir = runs / name;
  write(dir / "config.yaml", "task: pendubot\nseed: " + std::to_string(seed) +
                                 "\nmodel:\n  type: " + model + "\nprior:\n  preset: " + prior +
                                 "\n  tunable: [m1]\n" + extra_config);
  const Registry& registry = fixtures::registry();
  nlohmann::json s = summary_head(
      make_experiment(registry, load_settings_file(registry, (dir / "config.yaml").string(), {})));
  s.update({{"prior", prior},
            {"episodes_planned", 3},
            {"phi_names", {"m1", "b1"}},
            {"phi_actual", {0.5, 0.1}},
            {"status", status}});
  bool any = false;
  for (std::size_t i = 0; i < returns.size(); ++i) {
    const int k = static_cast<int>(i) + 1;
    s["episodes"].push_back(
        {{"episode", k},
         {"interaction_time_s", 2.5 * k},
         {"real_return", returns[i]},
         {"predicted_return", i == 0 ? nlohmann::json(nullptr) : nlohmann::json(returns[i] + 1.0)},
         {"solved", static_cast<bool>(solved[i])},
         {"random_policy", i == 0},
         {"phi", {static_cast<double>(k), 10.0}}});
    any = any || solved[i];
  }
  s["solved"] = any;
  s["episodes_done"] = returns.size();
  write(dir / "summary.json", s.dump(2));
}

// The campaign of the aggregation tests (first solved episodes in brackets):
//   gp_mi / tunable-useful: returns {1,10,20} [2], {2,12,18} [3], {3,14} interrupted [never],
//                           {4} failed [never]; plus one directory without summary.json
//   gp / tunable-useful:    {0,5,8} [2, not at last], {1,2,9} [3], {0.5,1.5,2.5} [never]
//   gp_mi / tunable:        {1,2,3} [2], {0,0,0} [never], {0,0,0} [never]
void fake_campaign(const fs::path& dir) {
  const fs::path runs = dir / "runs";
  fake_run(runs, "gp_mi-tunable-useful-seed1", "gp_mi", "tunable-useful", 1, "complete",
           {1, 10, 20}, {false, true, true});
  fake_run(runs, "gp_mi-tunable-useful-seed2", "gp_mi", "tunable-useful", 2, "complete",
           {2, 12, 18}, {false, false, true});
  fake_run(runs, "gp_mi-tunable-useful-seed3", "gp_mi", "tunable-useful", 3, "interrupted", {3, 14},
           {false, false});
  fake_run(runs, "gp_mi-tunable-useful-seed4", "gp_mi", "tunable-useful", 4, "failed", {4},
           {false});
  write(runs / "gp_mi-tunable-useful-seed5" / "config.yaml",
        "seed: 5\nmodel:\n  type: gp_mi\nprior:\n  preset: tunable-useful\n  tunable: [m1]\n");
  fake_run(runs, "gp-tunable-useful-seed1", "gp", "tunable-useful", 1, "complete", {0, 5, 8},
           {false, true, false});
  fake_run(runs, "gp-tunable-useful-seed2", "gp", "tunable-useful", 2, "complete", {1, 2, 9},
           {false, false, true});
  fake_run(runs, "gp-tunable-useful-seed3", "gp", "tunable-useful", 3, "running", {0.5, 1.5, 2.5},
           {false, false, false});
  fake_run(runs, "gp_mi-tunable-seed1", "gp_mi", "tunable", 1, "complete", {1, 2, 3},
           {false, true, true});
  fake_run(runs, "gp_mi-tunable-seed2", "gp_mi", "tunable", 2, "complete", {0, 0, 0},
           {false, false, false});
  fake_run(runs, "gp_mi-tunable-seed3", "gp_mi", "tunable", 3, "complete", {0, 0, 0},
           {false, false, false});
}

const GroupReport& group(const CampaignReport& r, const std::string& variant,
                         const std::string& prior) {
  for (const auto& g : r.groups)
    if (g.variant == variant && g.prior == prior) return g;
  throw std::runtime_error("no group " + variant + "/" + prior);
}

// CSV rows keyed by their first `key_columns` fields joined with ','; naive split (the fixtures
// hold no quoted fields).
std::map<std::string, std::map<std::string, std::string>> read_csv(const fs::path& p,
                                                                   int key_columns) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::istringstream in(read(p));
  std::string line;
  std::vector<std::string> header;
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::stringstream ss(l);
    std::string x;
    while (std::getline(ss, x, ',')) f.push_back(x);
    if (!l.empty() && l.back() == ',') f.emplace_back();
    return f;
  };
  std::getline(in, line);
  header = split(line);
  while (std::getline(in, line)) {
    const auto f = split(line);
    EXPECT_EQ(f.size(), header.size()) << line;
    std::string key;
    for (int i = 0; i < key_columns; ++i) key += (i ? "," : "") + f[i];
    for (std::size_t i = 0; i < f.size() && i < header.size(); ++i) rows[key][header[i]] = f[i];
  }
  return rows;
}

}  // namespace

// ---------------------------------------------------------------- quantile

TEST(Quantile, FourValuesInterpolateBetweenOrderStatistics) {
  // h = 3p: p=0.25 -> 1 + 0.75*(2-1); p=0.5 -> 2 + 0.5*(3-2); p=0.75 -> 3 + 0.25*(4-3).
  EXPECT_DOUBLE_EQ(quantile({1, 2, 3, 4}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(quantile({1, 2, 3, 4}, 0.25), 1.75);
  EXPECT_DOUBLE_EQ(quantile({1, 2, 3, 4}, 0.75), 3.25);
}

TEST(Quantile, UnsortedInputGivesTheSameAsSorted) {
  EXPECT_DOUBLE_EQ(quantile({4, 1, 3, 2}, 0.25), 1.75);
  EXPECT_DOUBLE_EQ(quantile({10, -5, 0}, 0.5), 0.0);
}

TEST(Quantile, OneValueIsEveryQuantile) {
  for (double p : {0.0, 0.25, 0.5, 1.0}) EXPECT_DOUBLE_EQ(quantile({7.5}, p), 7.5);
}

TEST(Quantile, TwoValuesInterpolateLinearly) {
  EXPECT_DOUBLE_EQ(quantile({20, 10}, 0.25), 12.5);
  EXPECT_DOUBLE_EQ(quantile({20, 10}, 0.5), 15.0);
  EXPECT_DOUBLE_EQ(quantile({20, 10}, 0.75), 17.5);
}

TEST(Quantile, ZeroAndOneAreMinimumAndMaximum) {
  EXPECT_DOUBLE_EQ(quantile({3, -1, 8, 2}, 0.0), -1.0);
  EXPECT_DOUBLE_EQ(quantile({3, -1, 8, 2}, 1.0), 8.0);
}

TEST(Quantile, InfinityCountsAsLargerThanEveryValue) {
  EXPECT_DOUBLE_EQ(quantile({2, 3, kInf}, 0.5), 3.0);
  EXPECT_EQ(quantile({2, kInf, kInf}, 0.5), kInf);
  EXPECT_EQ(quantile({2, 3, kInf, kInf}, 0.5), kInf);  // halfway to +inf
  EXPECT_DOUBLE_EQ(quantile({2, kInf, kInf}, 0.0), 2.0);
}

TEST(Quantile, RejectsEmptyInputNanAndPOutsideZeroOne) {
  EXPECT_THROW(quantile({}, 0.5), InvalidArgument);
  EXPECT_THROW(quantile({1, 2}, -0.1), InvalidArgument);
  EXPECT_THROW(quantile({1, 2}, 1.5), InvalidArgument);
  EXPECT_THROW(quantile({1, 2}, std::nan("")), InvalidArgument);
  EXPECT_THROW(quantile({1, std::nan("")}, 0.5), InvalidArgument);
}

// ---------------------------------------------------------------- aggregation

TEST(Report, ReadsRunStatusEpisodesAndFirstSolve) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const RunResult r = read_run(tmp.path() / "runs" / "gp-tunable-useful-seed2", &fixtures::registry());
  EXPECT_EQ(r.status, "complete");
  EXPECT_EQ(r.model_type, "gp");
  EXPECT_EQ(r.prior, "tunable-useful");
  EXPECT_EQ(r.variant, "gp");
  EXPECT_EQ(r.seed, 2);
  ASSERT_EQ(r.episodes.size(), 3u);
  EXPECT_TRUE(std::isnan(r.episodes[0].predicted_return));  // null in summary.json
  EXPECT_DOUBLE_EQ(r.episodes[1].predicted_return, 3.0);
  ASSERT_TRUE(r.first_solved_episode.has_value());
  EXPECT_EQ(*r.first_solved_episode, 3);
  EXPECT_DOUBLE_EQ(r.first_solved_time_s, 7.5);
  EXPECT_EQ(r.phi_tunable, (std::vector<std::string>{"m1"}));

  const RunResult ns = read_run(tmp.path() / "runs" / "gp_mi-tunable-useful-seed5", &fixtures::registry());
  EXPECT_EQ(ns.status, "not started");
  EXPECT_FALSE(ns.started());
  EXPECT_EQ(ns.model_type, "gp_mi");
}

TEST(Report, CountsRunsByStatusAndSuccessRates) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_EQ(rep.runs.size(), 11u);
  ASSERT_EQ(rep.groups.size(), 3u);

  const GroupReport& a = group(rep, "gp_mi", "tunable-useful");
  EXPECT_EQ(a.runs, 4);  // the directory without summary.json is not a started run
  EXPECT_EQ(a.not_started, 1);
  EXPECT_EQ(a.complete, 2);
  EXPECT_EQ(a.interrupted, 1);
  EXPECT_EQ(a.failed, 1);
  EXPECT_EQ(a.solved_runs, 2);
  EXPECT_DOUBLE_EQ(a.success_rate, 0.5);      // 2 of 4 solved at least once
  EXPECT_DOUBLE_EQ(a.solved_last_rate, 0.5);  // seeds 1 and 2 solved at episode 3

  const GroupReport& b = group(rep, "gp", "tunable-useful");
  EXPECT_EQ(b.runs, 3);
  EXPECT_EQ(b.running, 1);
  EXPECT_DOUBLE_EQ(b.success_rate, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(b.solved_last_rate, 1.0 / 3.0);  // seed 1 solved at 2 but not at 3
}

TEST(Report, MedianFirstSolveCountsNeverSolvedAsInfinity) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  // {2, 3, never} -> median 3 (episode), 3 * 2.5 s.
  const GroupReport& b = group(rep, "gp", "tunable-useful");
  EXPECT_DOUBLE_EQ(b.median_first_solve_episode, 3.0);
  EXPECT_DOUBLE_EQ(b.median_first_solve_time_s, 7.5);
  // {2, never, never} -> not solved.
  const GroupReport& c = group(rep, "gp_mi", "tunable");
  EXPECT_EQ(c.median_first_solve_episode, kInf);
  EXPECT_EQ(c.median_first_solve_time_s, kInf);
  // {2, 3, never, never}: the median lies halfway between 3 and +inf -> not solved.
  EXPECT_EQ(group(rep, "gp_mi", "tunable-useful").median_first_solve_episode, kInf);
}

TEST(Report, PerEpisodeQuartilesUseTheRunsThatReachedTheEpisode) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  const GroupReport& a = group(rep, "gp_mi", "tunable-useful");
  ASSERT_EQ(a.episodes.size(), 3u);
  // Episode 1: {1, 2, 3, 4} (the failed run counts).
  EXPECT_EQ(a.episodes[0].runs, 4);
  EXPECT_DOUBLE_EQ(a.episodes[0].interaction_time_s, 2.5);
  EXPECT_DOUBLE_EQ(a.episodes[0].median, 2.5);
  EXPECT_DOUBLE_EQ(a.episodes[0].q25, 1.75);
  EXPECT_DOUBLE_EQ(a.episodes[0].q75, 3.25);
  // Episode 2: {10, 12, 14}: h = 0.5 -> 11, h = 1 -> 12, h = 1.5 -> 13.
  EXPECT_EQ(a.episodes[1].runs, 3);
  EXPECT_DOUBLE_EQ(a.episodes[1].median, 12.0);
  EXPECT_DOUBLE_EQ(a.episodes[1].q25, 11.0);
  EXPECT_DOUBLE_EQ(a.episodes[1].q75, 13.0);
  // Episode 3: {18, 20}.
  EXPECT_EQ(a.episodes[2].runs, 2);
  EXPECT_DOUBLE_EQ(a.episodes[2].interaction_time_s, 7.5);
  EXPECT_DOUBLE_EQ(a.episodes[2].median, 19.0);
  EXPECT_DOUBLE_EQ(a.episodes[2].q25, 18.5);
  EXPECT_DOUBLE_EQ(a.episodes[2].q75, 19.5);
  // Final returns {20, 18, 14, 4} -> median 16.
  EXPECT_DOUBLE_EQ(a.median_final_return, 16.0);
  // φ = (k, 10) in every run.
  ASSERT_EQ(a.episodes[1].phi_median.size(), 2u);
  EXPECT_DOUBLE_EQ(a.episodes[1].phi_median[0], 2.0);
  EXPECT_DOUBLE_EQ(a.episodes[1].phi_median[1], 10.0);

  const GroupReport& b = group(rep, "gp", "tunable-useful");
  // Episode 1: {0, 1, 0.5} -> sorted {0, 0.5, 1}.
  EXPECT_DOUBLE_EQ(b.episodes[0].median, 0.5);
  EXPECT_DOUBLE_EQ(b.episodes[0].q25, 0.25);
  EXPECT_DOUBLE_EQ(b.episodes[0].q75, 0.75);
}

TEST(Report, GroupsFollowTableIOrderThenVariantOrder) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_TRUE(rep.split_settings.empty());
  ASSERT_EQ(rep.groups.size(), 3u);
  EXPECT_EQ(rep.groups[0].variant + "/" + rep.groups[0].prior, "gp_mi/tunable-useful");
  EXPECT_EQ(rep.groups[1].variant + "/" + rep.groups[1].prior, "gp/tunable-useful");
  EXPECT_EQ(rep.groups[2].variant + "/" + rep.groups[2].prior, "gp_mi/tunable");
}

TEST(Report, ExtraGridAxesSplitTheVariant) {
  TempDir tmp;
  write(tmp.path() / "campaign.yaml",
        "grid:\n  model: {type: [gp_mi]}\n  prior.preset: [tunable]\n  seed: {first: 1, count: 2}\n"
        "  rollouts:\n    count: [1, 3]\n  pendubot.dt: [0.05]\n  episodes: {first: 2, count: 1}\n"
        "settings:\n  task: pendubot\n");
  const fs::path runs = tmp.path() / "runs";
  fake_run(runs, "a1", "gp_mi", "tunable", 1, "complete", {1, 2}, {false, true},
           "rollouts:\n  count: 1\n");
  fake_run(runs, "a2", "gp_mi", "tunable", 2, "complete", {3, 4}, {false, false},
           "rollouts:\n  count: 1\n");
  fake_run(runs, "b1", "gp_mi", "tunable", 1, "complete", {5, 6}, {true, true},
           "rollouts:\n  count: 3\n");
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  // dt and episodes have one value each; seed, model.type and prior.preset are the usual axes.
  EXPECT_EQ(rep.extra_axes, (std::vector<std::string>{"rollouts.count"}));
  ASSERT_EQ(rep.groups.size(), 2u);
  const GroupReport& one = group(rep, "gp_mi rollouts.count=1", "tunable");
  EXPECT_EQ(one.runs, 2);
  EXPECT_DOUBLE_EQ(one.success_rate, 0.5);
  EXPECT_DOUBLE_EQ(one.episodes[1].median, 3.0);  // {2, 4}
  const GroupReport& three = group(rep, "gp_mi rollouts.count=3", "tunable");
  EXPECT_DOUBLE_EQ(three.median_first_solve_episode, 1.0);
}

// Runs of one panel and variant whose task settings differ (a torque limit of 0.5 and 3 N m, in
// a folder of plain `drops run` outputs, no campaign.yaml) are split into groups labelled by the
// setting; 3 and 3.0 are one setting.
TEST(Report, RunsWhoseTaskSettingsDifferAreSplitByTheSettingNotMerged) {
  TempDir tmp;
  const fs::path runs = tmp.path() / "runs";
  fake_run(runs, "a", "gp_mi", "tunable", 1, "complete", {1, 2}, {false, true},
           "pendubot:\n  max_torque: 0.5\n");
  fake_run(runs, "b", "gp_mi", "tunable", 2, "complete", {3, 4}, {false, false},
           "pendubot:\n  max_torque: 3.0\n");
  fake_run(runs, "c", "gp_mi", "tunable", 3, "complete", {5, 6}, {true, true},
           "pendubot:\n  max_torque: 3\n");
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_TRUE(rep.extra_axes.empty());
  EXPECT_EQ(rep.split_settings, (std::vector<std::string>{"pendubot.max_torque"}));
  ASSERT_EQ(rep.groups.size(), 2u);
  const GroupReport& low = group(rep, "gp_mi pendubot.max_torque=0.5", "tunable");
  EXPECT_EQ(low.runs, 1);
  EXPECT_DOUBLE_EQ(low.median_final_return, 2.0);
  const GroupReport& high = group(rep, "gp_mi pendubot.max_torque=3", "tunable");
  EXPECT_EQ(high.runs, 2);
  EXPECT_DOUBLE_EQ(high.median_final_return, 5.0);  // {4, 6}
  write_report_markdown(rep, tmp.path() / "report.md");
  const std::string md = read(tmp.path() / "report.md");
  EXPECT_NE(md.find("differ in the task settings pendubot.max_torque"), std::string::npos) << md;
  write_returns_csv(rep, tmp.path() / "returns.csv");
  EXPECT_NE(
      read(tmp.path() / "returns.csv").find("Black-DROPS with GP-MI, pendubot.max_torque=0.5"),
      std::string::npos);

  // Runs of another task in the same panel and variant are split by the task, not by the
  // pendubot's settings they do not have.
  write(runs / "z" / "summary.json",
        nlohmann::json({{"format_version", kRunDirectoryFormatVersion},
                        {"task", "myrobot"},
                        {"algorithm", "black_drops"},
                        {"model", "gp_mi"},
                        {"uses_prior", true},
                        {"uses_model", true},
                        {"prior", "tunable"},
                        {"report", unlabelled_report("tunable")},
                        {"state_names", {"x"}},
                        {"action_names", {"u"}},
                        {"status", "complete"},
                        {"episodes", {{{"episode", 1}, {"real_return", 7.0}}}}})
            .dump());
  const CampaignReport two = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_EQ(two.split_settings, (std::vector<std::string>{"pendubot.max_torque", "task"}));
  EXPECT_EQ(group(two, "gp_mi task=myrobot", "tunable").runs, 1);
  EXPECT_EQ(group(two, "gp_mi pendubot.max_torque=3 task=pendubot", "tunable").runs, 2);
}

// A direct search of the pendubot (config.yaml with algorithm: direct).
void fake_direct_run(const fs::path& runs, const std::string& name, const std::string& preset,
                     int seed, const std::vector<double>& returns) {
  fake_run(runs, name, "gp", preset, seed, "complete", returns,
           std::vector<bool>(returns.size(), false),
           "algorithm: direct\n");
}

// Direct runs use neither a model nor a prior: they get a panel of their own after the priors',
// whatever the prior.preset of their configuration, which does not split them; Black-DROPS
// without a prior (gp) stays in the prior's panel.
TEST(Report, DirectRunsGetAPanelOfTheirOwnNotAPriorsPanel) {
  TempDir tmp;
  const fs::path runs = tmp.path() / "runs";
  fake_run(runs, "gp_mi-1", "gp_mi", "tunable-useful", 1, "complete", {1, 2}, {false, true});
  fake_run(runs, "gp-1", "gp", "tunable-useful", 1, "complete", {1, 3}, {false, true});
  fake_direct_run(runs, "direct-1", "tunable-useful", 1, {0, 1});
  fake_direct_run(runs, "direct-2", "tunable", 2, {0, 3});
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_TRUE(rep.split_settings.empty());
  ASSERT_EQ(rep.groups.size(), 3u);
  EXPECT_EQ(rep.groups[0].variant + "/" + rep.groups[0].prior, "gp_mi/tunable-useful");
  EXPECT_EQ(rep.groups[1].variant + "/" + rep.groups[1].prior, "gp/tunable-useful");
  const GroupReport& d = rep.groups[2];
  EXPECT_EQ(d.variant + "/" + d.prior, "direct/" + model_free_panel().label);
  EXPECT_EQ(d.runs, 2);
  write_returns_csv(rep, tmp.path() / "returns.csv");
  auto ret = read_csv(tmp.path() / "returns.csv", 3);
  EXPECT_EQ(ret.at("direct,no model,2").at("panel_title"), model_free_panel().title);
  EXPECT_EQ(ret.at("direct,no model,2").at("median"), "2");
  EXPECT_EQ(ret.count("direct,tunable-useful,2"), 0u);
}

// A task whose panel is what every run shares (the hexapod's damage) keeps its direct runs in it.
TEST(Report, ModelFreeRunsKeepAPanelNotChosenByThePrior) {
  ReportInfo damage;
  damage.panel = {"leg5 removed", 1, "real robot: leg5 removed", false};
  EXPECT_EQ(run_report_info(damage, false, false).panel.label, "leg5 removed");
  ReportInfo prior;
  prior.panel = {"tunable", 1, "B tunable", true};
  EXPECT_EQ(run_report_info(prior, false, false).panel.label, "no model");
  EXPECT_EQ(run_report_info(prior, false, true).panel.label, "tunable");  // gp: a model
  EXPECT_EQ(run_report_info(prior, true, true).panel.label, "tunable");
}

// What a new run directory records for reports: the panel (its own for a direct search), the
// task's labels and units, the state and action column names.
TEST(Report, RunDirectoryRecordsLabelsUnitsColumnsAndTheModelFreePanel) {
  TempDir tmp;
  for (const std::string algorithm : {"black_drops", "direct"}) {
    const Experiment e = fixtures::experiment(
        {"algorithm=" + algorithm,
         algorithm == "direct" ? "optimizer.max_evaluations=10" : "episodes=1"});
    const fs::path dir = tmp.path() / algorithm;
    { RunDirectory rd(dir, to_yaml(fixtures::registry(), e.settings), e); }
    const auto s = nlohmann::json::parse(read(dir / "summary.json"));
    EXPECT_EQ(s.at("uses_model").get<bool>(), algorithm != "direct");
    EXPECT_EQ(s.at("action_names"), nlohmann::json::array({"u"}));
    EXPECT_EQ(s.at("state_names").size(), 4u);
    EXPECT_EQ(s.at("report").at("phi_labels").at("m1").at("unit"), "kg");
    EXPECT_EQ(s.at("report").at("column_labels").at("u").at("unit"), "N·m");
    const RunResult r = read_run(dir, &fixtures::registry());
    EXPECT_EQ(r.report.panel.label, algorithm == "direct" ? "no model" : "tunable-useful");
    EXPECT_EQ(r.report.column_labels.at("theta1").unit, "rad");
    EXPECT_EQ(r.action_names, (std::vector<std::string>{"u"}));
  }
}

// A hexapod run directory: config.yaml with the damage, summary.json with the walking speed and
// the prior (φ = removed leg, -1 = intact) of each episode; interaction time 4 k s.
void fake_hexapod_run(const fs::path& runs, const std::string& name, const std::string& model,
                      const std::string& removed_leg, int seed, const std::vector<double>& speeds,
                      const std::vector<double>& legs) {
  const fs::path dir = runs / name;
  write(dir / "config.yaml", "task: hexapod\nseed: " + std::to_string(seed) +
                                 "\nmodel:\n  type: " + model +
                                 "\nprior:\n  preset: tunable-useful\nhexapod:\n  damage:\n"
                                 "    removed_leg: " + removed_leg + "\n");
  // The summary as the hexapod plugin's run directories write it (the core tests have no DART):
  // the panel is the damage, the metric the walking speed, phi a leg index.
  const std::string panel = removed_leg == "none" ? "intact" : removed_leg + " removed";
  nlohmann::json labels = nlohmann::json::array();
  for (int leg = -1; leg < 6; ++leg)
    labels.push_back({leg, leg < 0 ? std::string("intact") : "leg" + std::to_string(leg)});
  nlohmann::json s = {
      {"format_version", kRunDirectoryFormatVersion},
      {"task", "hexapod"},        {"algorithm", "black_drops"},
      {"model", model},           {"uses_prior", true},
      {"uses_model", true},       {"phi_actual", {removed_leg == "none" ? -1 : 5}},
      {"state_names", {"x"}},     {"action_names", {"u"}},
      {"prior", "intact"},        {"seed", seed},
      {"episodes_planned", 2},    {"phi_names", {"removed_leg"}},
      {"status", "complete"},     {"episodes", nlohmann::json::array()},
      {"report", unlabelled_report(panel)}};
  s["report"].merge_patch(
      {{"panel", {{"rank", removed_leg == "none" ? 0 : 1},
                  {"title", "real robot: " + panel},
                  {"chosen_by_prior", false}}},
       {"metric", {{"name", "walking_speed_m_s"}, {"label", "walking speed"}, {"unit", "m/s"},
                   {"file", "speed"}}},
       {"success_criterion", false},
       {"phi_value_labels", labels}});
  for (std::size_t i = 0; i < speeds.size(); ++i)
    s["episodes"].push_back({{"episode", static_cast<int>(i) + 1},
                             {"interaction_time_s", 4.0 * static_cast<double>(i + 1)},
                             {"real_return", 10 * speeds[i]},
                             {"solved", false},
                             {"walking_speed_m_s", speeds[i]},
                             {"phi", {legs[i]}}});
  write(dir / "summary.json", s.dump(2));
}

// The hexapod's campaign: panels are the real robot's damage (not prior.preset, which the
// hexapod ignores), the damage axis does not split the variants, and the walking speed and the
// prior identified are aggregated per episode. By hand (quantiles of type 7):
//   gp_mi / leg5 removed, speeds {-0.1, 0.1} {0.0, 0.3} {0.2}, legs {-1, 5} {-1, 0} {-1}:
//     episode 1: median 0.0, q25 -0.05, q75 0.1, intact x3; episode 2 (2 runs): median 0.2,
//     q25 0.15, q75 0.25, leg0 x1 and leg5 x1; final speeds {0.1, 0.3, 0.2}: median 0.2.
TEST(Report, HexapodCampaignAggregatesWalkingSpeedAndThePriorIdentifiedPerDamage) {
  TempDir tmp;
  write(tmp.path() / "campaign.yaml",
        "grid:\n  model.type: [gp_mi, gp_prior]\n  hexapod.damage.removed_leg: [none, leg5]\n"
        "  seed: {first: 1, count: 3}\nsettings:\n  task: hexapod\n");
  const fs::path runs = tmp.path() / "runs";
  fake_hexapod_run(runs, "gp_mi-leg5-seed1", "gp_mi", "leg5", 1, {-0.1, 0.1}, {-1, 5});
  fake_hexapod_run(runs, "gp_mi-leg5-seed2", "gp_mi", "leg5", 2, {0.0, 0.3}, {-1, 0});
  fake_hexapod_run(runs, "gp_mi-leg5-seed3", "gp_mi", "leg5", 3, {0.2}, {-1});
  fake_hexapod_run(runs, "gp_prior-none-seed1", "gp_prior", "none", 1, {0.05, 0.07}, {-1, -1});
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_TRUE(rep.extra_axes.empty());
  ASSERT_EQ(rep.groups.size(), 2u);
  const GroupReport& g = group(rep, "gp_mi", "leg5 removed");
  EXPECT_EQ(g.task, "hexapod");
  EXPECT_EQ(g.runs, 3);
  ASSERT_EQ(g.episodes.size(), 2u);
  const EpisodeStats& e1 = g.episodes[0];
  EXPECT_EQ(e1.metric.runs, 3);
  EXPECT_NEAR(e1.metric.median, 0.0, 1e-12);
  EXPECT_NEAR(e1.metric.q25, -0.05, 1e-12);
  EXPECT_NEAR(e1.metric.q75, 0.1, 1e-12);
  EXPECT_EQ(e1.phi_counts, (std::vector<std::pair<double, int>>{{-1.0, 3}}));
  const EpisodeStats& e2 = g.episodes[1];
  EXPECT_EQ(e2.metric.runs, 2);
  EXPECT_NEAR(e2.metric.median, 0.2, 1e-12);
  EXPECT_NEAR(e2.metric.q25, 0.15, 1e-12);
  EXPECT_NEAR(e2.metric.q75, 0.25, 1e-12);
  EXPECT_EQ(e2.phi_counts, (std::vector<std::pair<double, int>>{{0.0, 1}, {5.0, 1}}));
  EXPECT_NEAR(g.median_final_metric, 0.2, 1e-12);
  EXPECT_NEAR(group(rep, "gp_prior", "intact").median_final_return, 0.7, 1e-12);

  EXPECT_TRUE(write_metric_csv(rep, tmp.path() / "speed.csv"));
  auto speed = read_csv(tmp.path() / "speed.csv", 3);
  EXPECT_EQ(speed.size(), 4u);  // 2 groups x 2 episodes
  EXPECT_NEAR(std::stod(speed.at("gp_mi,leg5 removed,2").at("q75")), 0.25, 1e-9);
  EXPECT_EQ(speed.at("gp_mi,leg5 removed,2").at("runs"), "2");
  write_report_markdown(rep, tmp.path() / "report.md");
  const std::string md = read(tmp.path() / "report.md");
  EXPECT_NE(md.find("| 2 | leg0 ×1, leg5 ×1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 2 | 8.00 | 0.200 [0.150, 0.250] (2 runs) |"), std::string::npos) << md;
  EXPECT_NE(md.find("### real robot: leg5 removed"), std::string::npos) << md;
  EXPECT_EQ(md.find("solved at least once"), std::string::npos) << "the hexapod has no success";
  // φ is a leg index: no median-φ table (and no single "actual" row, which differs per damage)
  EXPECT_EQ(md.find("actual (real system)"), std::string::npos) << md;
}

TEST(Report, MissingOrEmptyCampaignIsAConfigError) {
  TempDir tmp;
  EXPECT_THROW(aggregate_campaign(fixtures::registry(), tmp.path() / "nope"), ConfigError);
  fs::create_directories(tmp.path() / "runs");
  EXPECT_THROW(aggregate_campaign(fixtures::registry(), tmp.path()), ConfigError);
}

TEST(Report, UnreadableSummaryIsListedButNotCounted) {
  TempDir tmp;
  fake_campaign(tmp.path());
  write(tmp.path() / "runs" / "gp-tunable-useful-seed9" / "summary.json", "{\"status\": ");
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  EXPECT_EQ(rep.runs.size(), 12u);
  const auto it = std::find_if(rep.runs.begin(), rep.runs.end(), [](const RunResult& r) {
    return r.name == "gp-tunable-useful-seed9";
  });
  ASSERT_NE(it, rep.runs.end());
  EXPECT_EQ(it->status, "unreadable");
  EXPECT_FALSE(it->error.empty());
  EXPECT_EQ(group(rep, "gp", "tunable-useful").runs, 3);
}

// Run-directory format version 1 is the one this drops reads: a summary.json of another version,
// or without one (written before the format was versioned), makes its run unreadable with the
// file, the version found and the version read named; the run is left out of the statistics.
TEST(Report, ARunOfAnotherFormatVersionIsUnreadableAndSaysWhichVersions) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const fs::path newer = tmp.path() / "runs" / "gp-tunable-useful-seed1" / "summary.json";
  const fs::path unversioned = tmp.path() / "runs" / "gp-tunable-useful-seed2" / "summary.json";
  auto s = nlohmann::json::parse(read(newer));
  ASSERT_EQ(s["format_version"], 1);
  s["format_version"] = 2;
  write(newer, s.dump());
  s = nlohmann::json::parse(read(unversioned));
  s.erase("format_version");
  write(unversioned, s.dump());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  const auto run = [&](const std::string& name) {
    const auto it = std::find_if(rep.runs.begin(), rep.runs.end(),
                                 [&](const RunResult& r) { return r.name == name; });
    EXPECT_NE(it, rep.runs.end()) << name;
    return it == rep.runs.end() ? RunResult{} : *it;
  };
  const RunResult a = run("gp-tunable-useful-seed1"), b = run("gp-tunable-useful-seed2");
  EXPECT_EQ(a.status, "unreadable");
  const std::string versions = ": run-directory format version 2, but this drops reads version 1";
  EXPECT_NE(a.error.find(newer.string() + versions + " only"), std::string::npos) << a.error;
  EXPECT_NE(a.error.find("run it again with this one"), std::string::npos) << a.error;
  EXPECT_EQ(b.status, "unreadable");
  EXPECT_NE(b.error.find(unversioned.string() + " has no format_version"), std::string::npos)
      << b.error;
  EXPECT_NE(b.error.find("reads run-directory format version 1 only"), std::string::npos)
      << b.error;
  EXPECT_EQ(group(rep, "gp", "tunable-useful").runs, 1);  // 3 runs, 2 of other versions
}

// ---------------------------------------------------------------- files

TEST(Report, CsvFilesHoldTheAggregatedNumbers) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  write_summary_csv(rep, tmp.path() / "summary.csv");
  write_returns_csv(rep, tmp.path() / "returns.csv");
  write_phi_csv(rep, tmp.path() / "phi.csv");

  const std::string returns = read(tmp.path() / "returns.csv");
  EXPECT_EQ(returns.substr(0, returns.find('\n')),
            "variant,prior,episode,interaction_time_s,runs,median,q25,q75,variant_label,"
            "panel_title,variant_colour");
  auto ret = read_csv(tmp.path() / "returns.csv", 3);
  ASSERT_EQ(ret.size(), 9u);  // 3 groups x 3 episodes
  const auto& r1 = ret.at("gp_mi,tunable-useful,1");
  EXPECT_DOUBLE_EQ(std::stod(r1.at("interaction_time_s")), 2.5);
  EXPECT_EQ(r1.at("runs"), "4");
  EXPECT_DOUBLE_EQ(std::stod(r1.at("median")), 2.5);
  EXPECT_DOUBLE_EQ(std::stod(r1.at("q25")), 1.75);
  EXPECT_DOUBLE_EQ(std::stod(r1.at("q75")), 3.25);
  EXPECT_EQ(ret.at("gp_mi,tunable-useful,3").at("runs"), "2");
  EXPECT_DOUBLE_EQ(std::stod(ret.at("gp_mi,tunable-useful,3").at("q25")), 18.5);

  auto sum = read_csv(tmp.path() / "summary.csv", 2);
  ASSERT_EQ(sum.size(), 3u);
  const auto& b = sum.at("gp,tunable-useful");
  EXPECT_EQ(b.at("runs"), "3");
  EXPECT_EQ(b.at("running"), "1");
  EXPECT_EQ(b.at("solved_runs"), "2");
  EXPECT_NEAR(std::stod(b.at("success_rate")), 2.0 / 3.0, 1e-9);
  EXPECT_NEAR(std::stod(b.at("solved_last_rate")), 1.0 / 3.0, 1e-9);
  EXPECT_DOUBLE_EQ(std::stod(b.at("median_first_solve_episode")), 3.0);
  EXPECT_DOUBLE_EQ(std::stod(b.at("median_first_solve_time_s")), 7.5);
  const auto& a = sum.at("gp_mi,tunable-useful");
  EXPECT_EQ(a.at("not_started"), "1");
  EXPECT_EQ(a.at("failed"), "1");
  EXPECT_EQ(a.at("median_first_solve_episode"), "inf");
  EXPECT_DOUBLE_EQ(std::stod(a.at("median_final_return")), 16.0);

  auto phi = read_csv(tmp.path() / "phi.csv", 4);
  EXPECT_DOUBLE_EQ(std::stod(phi.at("gp_mi,tunable,3,m1").at("median")), 3.0);
  EXPECT_DOUBLE_EQ(std::stod(phi.at("gp_mi,tunable,3,m1").at("actual")), 0.5);
}

TEST(Report, MarkdownShowsTwoDecimalsAndNotSolved) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  write_report_markdown(rep, tmp.path() / "report.md");
  const std::string md = read(tmp.path() / "report.md");
  EXPECT_NE(md.find("| gp | A tunable & useful | 3 | 2 | 0.67 (2/3) | 0.33 (1/3) | 3.00 | 7.50 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| gp_mi | B tunable | 3 | 3 | 0.33 (1/3) | 0.33 (1/3) | not solved | not "
                    "solved |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 1 | 2.50 | 2.50 [1.75, 3.25] |"), std::string::npos) << md;
  EXPECT_NE(md.find("19.00 [18.50, 19.50] (2 runs)"), std::string::npos) << md;
  EXPECT_NE(md.find("| gp_mi-tunable-useful-seed5 | gp_mi | tunable-useful | 5 | not started |"),
            std::string::npos)
      << md;
}

// ---------------------------------------------------------------- drops plot helpers

TEST(Plot, DefaultEpisodesAreFirstSolvedAndLast) {
  RunResult r;
  for (int k = 1; k <= 5; ++k) r.episodes.push_back({.episode = k});
  EXPECT_EQ(default_plot_episodes(r), (std::vector<int>{5}));  // never solved
  r.first_solved_episode = 2;
  EXPECT_EQ(default_plot_episodes(r), (std::vector<int>{2, 5}));
  r.first_solved_episode = 5;
  EXPECT_EQ(default_plot_episodes(r), (std::vector<int>{5}));
  EXPECT_TRUE(default_plot_episodes(RunResult{}).empty());
}

TEST(Plot, EpisodeListIsParsedAndChecked) {
  EXPECT_EQ(parse_episode_list("1,5, 10", 10), (std::vector<int>{1, 5, 10}));
  EXPECT_EQ(parse_episode_list("3,3,1", 10), (std::vector<int>{3, 1}));
  EXPECT_THROW(parse_episode_list("0", 10), ConfigError);
  EXPECT_THROW(parse_episode_list("11", 10), ConfigError);
  EXPECT_THROW(parse_episode_list("1,x", 10), ConfigError);
  EXPECT_THROW(parse_episode_list("2.5", 10), ConfigError);
  EXPECT_THROW(parse_episode_list("", 10), ConfigError);
  try {
    parse_episode_list("12", 8);
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("allowed 1 to 8"), std::string::npos) << e.what();
  }
}

TEST(Plot, PhiPanelsAreChangingOrTunableComponents) {
  TempDir tmp;
  fake_campaign(tmp.path());
  // φ = (k, 10): m1 changes (and is tunable), b1 is constant and not tunable.
  const RunResult r = read_run(tmp.path() / "runs" / "gp_mi-tunable-seed1", &fixtures::registry());
  EXPECT_EQ(plotted_phi_names(r), (std::vector<std::string>{"m1"}));
  RunResult constant = r;
  for (auto& e : constant.episodes) e.phi = {0.65, 0.1};
  EXPECT_EQ(plotted_phi_names(constant), (std::vector<std::string>{"m1"}));  // tunable
  constant.phi_tunable.clear();
  EXPECT_TRUE(plotted_phi_names(constant).empty());
  const RunResult gp = read_run(tmp.path() / "runs" / "gp-tunable-useful-seed1", &fixtures::registry());
  EXPECT_TRUE(plotted_phi_names(gp).empty());  // the gp variant uses no prior
}

// ---------------------------------------------------------------- figures (need matplotlib)

namespace {

bool matplotlib_available() {
  return std::system("/usr/bin/python3 -c 'import matplotlib, numpy' >/dev/null 2>&1") == 0;
}

bool is_png(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  return in && std::string(sig + 1, 3) == "PNG" && fs::file_size(p) > 1000;
}

void fake_trajectory(const fs::path& file) {
  std::string t = "t,dtheta1,dtheta2,theta1,theta2,u,reward\n";
  for (int i = 0; i <= 10; ++i)
    t += std::to_string(0.05 * i) + "," + std::to_string(0.1 * i) + ",0," +
         std::to_string(3.14 - 0.1 * i) + ",3.14," + (i < 10 ? "1.5" : "") + "," +
         (i > 0 ? "0.5" : "") + "\n";
  write(file, t);
}

}  // namespace

// Two runs for the labels of `drops plot`, their plot-data.json written into `dir`:
//   pendubot.json: a pendubot run (its labels and column names from summary.json, as the
//                  registered task declared them);
//   own.json:      a robot of one's own whose task declares no labels (not registered here):
//                  summary.json names its columns q, dq (states) and u_1 (action), phi m1 and k.
fs::path label_fixtures(const fs::path& dir) {
  fake_campaign(dir);
  const fs::path run = dir / "runs" / "gp_mi-tunable-seed1";
  fake_trajectory(run / "episodes" / "002" / "real.csv");
  write_plot_data(read_run(run, &fixtures::registry()), {2}, dir / "pendubot.json");
  const fs::path own = dir / "own";
  nlohmann::json eps = nlohmann::json::array();
  for (int k = 1; k <= 2; ++k)
    eps.push_back({{"episode", k},
                   {"interaction_time_s", 3.0 * k},
                   {"real_return", 1.5 * k},
                   {"solved", false},
                   {"phi", {0.5 * k, 2.0}}});
  write(own / "summary.json", nlohmann::json({{"format_version", kRunDirectoryFormatVersion},
                                              {"task", "myrobot"},
                                              {"algorithm", "black_drops"},
                                              {"model", "gp_mi"},
                                              {"uses_prior", true},
                                              {"uses_model", true},
                                              {"prior", "p0"},
                                              {"report", unlabelled_report("p0")},
                                              {"status", "complete"},
                                              {"phi_names", {"m1", "k"}},
                                              {"phi_actual", {1.0, 2.0}},
                                              {"state_names", {"q", "dq"}},
                                              {"action_names", {"u_1"}},
                                              {"episodes", eps}})
                                  .dump());
  std::ostringstream csv;
  csv << "t,q,dq,u_1,reward\n";
  for (int i = 0; i <= 20; ++i) {
    csv << 0.1 * i << ',' << std::sin(0.3 * i) << ',' << 0.3 * std::cos(0.3 * i) << ',';
    if (i < 20) csv << (i % 7 < 3 ? 0.8 : -0.4);
    csv << ',';
    if (i > 0) csv << 0.05 * i;
    csv << '\n';
  }
  for (const char* k : {"001", "002"}) write(own / "episodes" / k / "real.csv", csv.str());
  write_plot_data(read_run(own, &fixtures::registry()), {2}, dir / "own.json");
  return own;
}

nlohmann::json plot_column(const nlohmann::json& data, const std::string& name) {
  for (const auto& c : data.at("columns"))
    if (c.at("name") == name) return c;
  return nullptr;
}

// GP-MI's posterior over phi (issue 45) goes from summary.json to plot-data.json: each
// episode's standard deviation per entry of phi (null where the posterior has none), the last
// posterior's correlation matrix, and the figure phi-correlation.png.
TEST(Plot, PlotDataCarriesPhisPosteriorAndItsCorrelationFigure) {
  TempDir tmp;
  fake_campaign(tmp.path());
  const fs::path run = tmp.path() / "runs" / "gp_mi-tunable-seed1";
  auto j = nlohmann::json::parse(read(run / "summary.json"));
  j["episodes"][1]["phi_posterior"] = {{"names", {"b1", "m1"}},
                                       {"mean", {10.0, 2.0}},
                                       {"sd", {0.5, 0.25}},
                                       {"correlation", {{1.0, -0.9}, {-0.9, 1.0}}}};
  write(run / "summary.json", j.dump());
  fake_trajectory(run / "episodes" / "002" / "real.csv");
  const RunResult r = read_run(run, &fixtures::registry());
  ASSERT_EQ(r.episodes[1].posterior_names, (std::vector<std::string>{"b1", "m1"}));
  write_plot_data(r, {2}, tmp.path() / "plot.json");
  const auto d = nlohmann::json::parse(read(tmp.path() / "plot.json"));
  // phi_names are m1, b1: the sd follows them, not the posterior's order.
  EXPECT_EQ(d["episodes"][1]["phi_sd"], nlohmann::json({0.25, 0.5}));
  EXPECT_EQ(d["episodes"][0]["phi_sd"], nlohmann::json({nullptr, nullptr}));
  EXPECT_EQ(d["phi_correlation"]["episode"], 2);
  EXPECT_EQ(d["phi_correlation"]["matrix"][0][1], -0.9);
  if (!matplotlib_available()) GTEST_SKIP() << "Debian's python3-matplotlib is not installed";
  plot_run(fixtures::registry(), run, "2", tmp.path() / "plots");
  EXPECT_TRUE(is_png(tmp.path() / "plots" / "phi-correlation.png"));
  EXPECT_TRUE(is_png(tmp.path() / "plots" / "phi.png"));
}

TEST(Plot, PlotDataCarriesTheTasksLabelsAndUnitsAndOnlyNamesForATaskThatDeclaresNone) {
  TempDir tmp;
  label_fixtures(tmp.path());
  const auto p = nlohmann::json::parse(read(tmp.path() / "pendubot.json"));
  EXPECT_EQ(plot_column(p, "u").at("kind"), "action");
  EXPECT_EQ(plot_column(p, "u").at("unit"), "N·m");
  EXPECT_EQ(plot_column(p, "theta1").at("kind"), "state");
  EXPECT_EQ(plot_column(p, "theta1").at("text"), "θ₁");
  EXPECT_EQ(plot_column(p, "reward").at("kind"), "reward");
  EXPECT_EQ(plot_column(p, "t").at("kind"), "time");
  EXPECT_EQ(p.at("phi_labels").at(0).at("unit"), "kg");  // m1

  const auto o = nlohmann::json::parse(read(tmp.path() / "own.json"));
  EXPECT_EQ(plot_column(o, "u_1").at("kind"), "action");
  EXPECT_EQ(plot_column(o, "u_1").at("text"), "u_1");
  EXPECT_EQ(plot_column(o, "u_1").at("unit"), "");
  EXPECT_EQ(plot_column(o, "dq").at("kind"), "state");
  // m1 is one of the pendubot's names, not a mass of this task: no unit.
  EXPECT_EQ(o.at("phi_labels").at(0),
            nlohmann::json({{"name", "m1"}, {"text", "m1"}, {"unit", ""}, {"labelled", false}}));
}

TEST(Figures, ReportAndRunFiguresAreWrittenAsPng) {
  if (!matplotlib_available()) GTEST_SKIP() << "Debian's python3-matplotlib is not installed";
  TempDir tmp;
  fake_campaign(tmp.path());
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  const auto files = write_report(rep, tmp.path() / "report", true);
  ASSERT_EQ(files.size(), 5u);
  EXPECT_TRUE(is_png(tmp.path() / "report" / "returns.png"));

  const fs::path run = tmp.path() / "runs" / "gp_mi-tunable-seed1";  // solved first at 2
  fake_trajectory(run / "episodes" / "001" / "real.csv");  // no predicted.csv: random episode
  for (const char* k : {"002", "003"}) {
    fake_trajectory(run / "episodes" / k / "real.csv");
    fake_trajectory(run / "episodes" / k / "predicted.csv");
  }
  const auto plots = plot_run(fixtures::registry(), run, "", tmp.path() / "plots");
  EXPECT_EQ(plots.size(), 5u);  // plot-data.json; returns, phi, trajectories of episodes 2 and 3
  for (const char* f : {"returns.png", "phi.png", "trajectories-002.png", "trajectories-003.png"})
    EXPECT_TRUE(is_png(tmp.path() / "plots" / f)) << f;
  plot_run(fixtures::registry(), run, "1", tmp.path() / "plots");
  EXPECT_TRUE(is_png(tmp.path() / "plots" / "trajectories-001.png"));
  EXPECT_THROW(plot_run(fixtures::registry(), run, "4", tmp.path() / "plots"), ConfigError);
}

// Calibration (issue 45): per group, the episodes whose policy was new and the replays apart, the
// fraction inside the predicted band and the median gap (oracle: the counts of the entries
// written below), calibration.csv with a row per calibrated episode and its figure.
TEST(Figures, ReportSummarisesTheCalibrationOfTheModelsPredictions) {
  TempDir tmp;
  const fs::path runs = tmp.path() / "runs";
  fake_run(runs, "a", "gp_mi", "tunable", 1, "complete", {1, 2, 3, 4}, {false, false, false, true});
  fake_run(runs, "b", "gp_mi", "tunable", 2, "complete", {1, 2, 3}, {false, false, false});
  // (episode, gap, inside_band, replay) per run: run a's episode 1 has none (a random policy),
  // run b's was predicted by the prior alone and is counted apart.
  const std::map<std::string, std::vector<std::tuple<int, double, bool, bool>>> cal = {
      {"a", {{2, 0.5, true, false}, {3, 2.0, false, false}, {4, 0.1, true, true}}},
      {"b", {{1, 25.0, false, false}, {2, -0.3, true, false}, {3, 1.0, false, false}}}};
  for (const auto& [name, entries] : cal) {
    auto j = nlohmann::json::parse(read(runs / name / "summary.json"));
    for (const auto& [episode, gap, inside, replay] : entries) {
      j["episodes"][episode - 1]["calibration"] = {{"quantile", inside ? 0.5 : 0.0},
                                             {"band", {0.0, 1.0}},
                                             {"inside_band", inside},
                                             {"gap", gap},
                                             {"replay", replay}};
    }
    write(runs / name / "summary.json", j.dump());
  }
  const CampaignReport rep = aggregate_campaign(fixtures::registry(), tmp.path());
  ASSERT_EQ(rep.groups.size(), 1u);
  const GroupReport& g = rep.groups[0];
  EXPECT_EQ(g.calibrated_episodes, 4);
  EXPECT_DOUBLE_EQ(g.inside_band_rate, 0.5);
  EXPECT_DOUBLE_EQ(g.median_gap, 0.75);  // of -0.3, 0.5, 1.0, 2.0
  EXPECT_EQ(g.replayed_episodes, 1);
  EXPECT_DOUBLE_EQ(g.replay_inside_band_rate, 1.0);
  EXPECT_DOUBLE_EQ(g.replay_median_gap, 0.1);
  EXPECT_EQ(g.prior_only_episodes, 1);
  EXPECT_DOUBLE_EQ(g.prior_only_inside_band_rate, 0.0);
  EXPECT_DOUBLE_EQ(g.prior_only_median_gap, 25.0);
  ASSERT_TRUE(write_calibration_csv(rep, tmp.path() / "calibration.csv"));
  const std::string csv = read(tmp.path() / "calibration.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 6);  // header, 6 calibrated episodes
  write_report_markdown(rep, tmp.path() / "report.md");
  EXPECT_NE(read(tmp.path() / "report.md")
                .find("| gp_mi | B tunable | 4 | 50 % | 0.75 | 1 | 100 % | 0.1 | 1 | 0 % | 25 |"),
            std::string::npos)
      << read(tmp.path() / "report.md");
  if (!matplotlib_available()) GTEST_SKIP() << "Debian's python3-matplotlib is not installed";
  write_report(rep, tmp.path() / "out", true);
  EXPECT_TRUE(is_png(tmp.path() / "out" / "calibration.png"));
}

TEST(Figures, HexapodReportAddsTheWalkingSpeedFigure) {
  if (!matplotlib_available()) GTEST_SKIP() << "Debian's python3-matplotlib is not installed";
  TempDir tmp;
  const fs::path runs = tmp.path() / "runs";
  fake_hexapod_run(runs, "gp_mi-leg5-seed1", "gp_mi", "leg5", 1, {-0.1, 0.1}, {-1, 5});
  fake_hexapod_run(runs, "gp_mi-none-seed1", "gp_mi", "none", 1, {0.05, 0.2}, {-1, -1});
  const auto files = write_report(aggregate_campaign(fixtures::registry(), tmp.path()), tmp.path() / "out", true);
  EXPECT_TRUE(is_png(tmp.path() / "out" / "speed.png"));
  EXPECT_TRUE(is_png(tmp.path() / "out" / "returns.png"));
  EXPECT_TRUE(fs::exists(tmp.path() / "out" / "speed.csv"));
  EXPECT_EQ(files.size(), 7u);  // report.md, 4 CSV files, 2 figures
}

// drops_plot.py labels axes with what plot-data.json says, nothing of its own: the pendubot's
// units where the pendubot declares them, names without units for a task that declares none.
TEST(Figures, ThePlotScriptLabelsWhatTheTaskDeclaredAndNothingElse) {
  if (!matplotlib_available()) GTEST_SKIP() << "Debian's python3-matplotlib is not installed";
  TempDir tmp;
  const fs::path own = label_fixtures(tmp.path());
  const fs::path check = tmp.path() / "check.py";
  write(check, "import json, sys\nsys.path.insert(0, \"" + std::string(DROPS_TEST_PYTHON_DIR) +
                   "\")\np = json.load(open(\"" + (tmp.path() / "pendubot.json").string() +
                   "\"))\no = json.load(open(\"" + (tmp.path() / "own.json").string() + "\"))\n" +
                   R"py(import drops_plot as d
def same(a, b):
    if a != b:
        sys.exit(f"{a!r} != {b!r}")
same(d.column_info(p, "u"), ("action", "torque u (N·m)", True))
same(d.column_info(p, "dtheta1")[1], "dθ₁/dt (rad/s)")
same(d.phi_label(p, "m1"), "m1 (kg)")
same(d.column_info(o, "u_1"), ("action", "u_1", False))
same(d.phi_label(o, "m1"), "m1")
same(d.trajectory_columns(o, ["t", "q", "dq", "u_1", "reward"]), ["q", "dq", "u_1", "reward"])
)py");
  EXPECT_EQ(std::system(("/usr/bin/python3 " + check.string()).c_str()), 0);
  const auto files = plot_run(fixtures::registry(), own, "2", tmp.path() / "own-plots");
  for (const char* f : {"returns.png", "phi.png", "trajectories-002.png"})
    EXPECT_TRUE(is_png(tmp.path() / "own-plots" / f)) << f;
}

// The policy file's reader returns what RunDirectory::record writes (17 significant digits, one
// value per line) and names the file and line of a value that is not a number.
TEST(RunDirectoryReader, PolicyFileReadsBackItsValuesAndNamesABadLine) {
  TempDir tmp;
  const fs::path dir = episode_dir(tmp.path(), 7);
  EXPECT_EQ(dir, tmp.path() / "episodes" / "007");
  EXPECT_EQ(episode_dir(tmp.path(), 1234), tmp.path() / "episodes" / "1234");
  write(dir / "policy.csv", "0.021712759007204575\n-1.5870370591271457\n3\n");
  const std::vector<double> theta = read_policy_csv(dir / "policy.csv");
  ASSERT_EQ(theta.size(), 3u);
  EXPECT_EQ(theta[0], 0.021712759007204575);
  EXPECT_EQ(theta[1], -1.5870370591271457);
  EXPECT_EQ(theta[2], 3.0);
  write(dir / "bad.csv", "1\n2x\n");
  try {
    read_policy_csv(dir / "bad.csv");
    FAIL() << "a line that is not a number was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv line 2: '2x' is not a number"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(read_policy_csv(dir / "missing.csv"), Error);
}
