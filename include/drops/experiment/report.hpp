#pragma once
/// \file Result statistics: a campaign's runs (read_run) grouped by variant and panel and
/// aggregated per episode, the tables `drops report` writes (Markdown, CSV) and the data files
/// from which python/drops_plot.py draws the figures of `drops report` and `drops plot`. Every
/// statistic is computed here; the plotting script only draws.
///
/// Statistics (docs/reports.md states them for users):
///   quantiles         linear interpolation between order statistics (Hyndman & Fan type 7, the
///                     numpy/R default): q(p) = x[floor(h)] + (h - floor(h))(x[floor(h)+1] -
///                     x[floor(h)]), h = (n - 1)p
///   success rate      fraction of a group's started runs solved at least once
///   first solve       median over all started runs, never-solved runs counted as +inf, so the
///                     median is +inf ("not solved") once at least half the runs never solved

#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "drops/experiment/run_directory.hpp"

namespace drops::experiment {

class Registry;

/// The p-quantile (p in [0, 1]) of `values` by linear interpolation between order statistics
/// (Hyndman & Fan 1996, definition 7; numpy.quantile's default). `values` need not be sorted and
/// may hold +inf. Throws InvalidArgument when values is empty or holds a NaN, or when p is NaN or
/// outside [0, 1]. Thread-safe.
double quantile(std::vector<double> values, double p);

/// Median and quartiles of a quantity over the runs that have it at one episode.
struct Quartiles {
  int runs = 0;  ///< runs with a finite value
  double median = std::numeric_limits<double>::quiet_NaN();
  double q25 = std::numeric_limits<double>::quiet_NaN();
  double q75 = std::numeric_limits<double>::quiet_NaN();
};

/// Statistics of one group at one episode number k over the runs that have episode k.
struct EpisodeStats {
  int episode = 0;                  ///< k (1-based)
  double interaction_time_s = 0.0;  ///< median over the runs of their interaction time at k (s)
  int runs = 0;                     ///< runs with a finite real return at episode k
  double median = 0.0;              ///< median real return at k
  double q25 = 0.0;                 ///< 25th percentile of the real return at k
  double q75 = 0.0;                 ///< 75th percentile of the real return at k
  /// Median phi at k per component (dim = GroupReport::phi_names; runs whose phi has another size
  /// are left out).
  std::vector<double> phi_median;
  /// Runs at k per value of phi's first component, in increasing value order (for a discrete phi
  /// such as a removed leg's index: how many runs used each prior).
  std::vector<std::pair<double, int>> phi_counts;
  /// The task's report metric (ReportInfo::metric) at k; runs = 0 when none.
  Quartiles metric;
};

/// Aggregate of one group (variant, panel) of a campaign.
struct GroupReport {
  std::string variant;                 ///< see RunResult::variant
  std::string model_type;              ///< the runs' RunResult::model_type
  VariantStyle variant_style;          ///< of the group's first run (legend, order, colour)
  std::string task;                    ///< task of the group's first run
  std::string prior;                   ///< the panel label (ReportInfo::panel.label)
  ReportInfo report;                   ///< of the group's first run
  bool uses_prior = true;              ///< of the group's first run
  std::vector<std::string> run_names;  ///< started runs of the group
  int runs = 0;              ///< started runs (complete + running + interrupted + failed + other)
  int complete = 0;          ///< status "complete"
  int running = 0;           ///< status "running" (in progress, or stopped without a final status)
  int interrupted = 0;       ///< status "interrupted"
  int failed = 0;            ///< status "failed" (its episodes still count)
  int not_started = 0;       ///< run directories without summary.json (not in `runs`)
  int solved_runs = 0;       ///< runs solved at least once
  int solved_last_runs = 0;  ///< runs solved at their last finished episode
  double success_rate = std::numeric_limits<double>::quiet_NaN();      ///< solved_runs / runs
  double solved_last_rate = std::numeric_limits<double>::quiet_NaN();  ///< solved_last_runs / runs
  /// Median first solved episode over all started runs, never solved = +inf; NaN when runs = 0.
  double median_first_solve_episode = std::numeric_limits<double>::quiet_NaN();
  /// The same in interaction time (s).
  double median_first_solve_time_s = std::numeric_limits<double>::quiet_NaN();
  /// Median of each run's real return at its last finished episode; NaN when none.
  double median_final_return = std::numeric_limits<double>::quiet_NaN();
  /// Median of each run's report metric at its last finished episode; NaN when none.
  double median_final_metric = std::numeric_limits<double>::quiet_NaN();
  /// Calibration of the model's predictions (algo::Calibration) over the group's episodes that a
  /// model predicted, in three sets: from episode 2 on, those whose policy was new
  /// (calibrated_episodes) and those that replayed the best policy already run
  /// (replayed_episodes); and episode 1 (prior_only_episodes), predicted before any real data by
  /// the prior simulator alone, whose rollouts agree (a band of zero width) wherever the
  /// simulator is deterministic. Per set: the fraction whose real return fell inside the
  /// predicted rollouts' 5-95 % band and the median gap predicted - real (> 0: optimistic); NaN
  /// when the set is empty.
  int calibrated_episodes = 0;
  double inside_band_rate = std::numeric_limits<double>::quiet_NaN();
  double median_gap = std::numeric_limits<double>::quiet_NaN();
  int replayed_episodes = 0;
  double replay_inside_band_rate = std::numeric_limits<double>::quiet_NaN();
  double replay_median_gap = std::numeric_limits<double>::quiet_NaN();
  int prior_only_episodes = 0;
  double prior_only_inside_band_rate = std::numeric_limits<double>::quiet_NaN();
  double prior_only_median_gap = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> phi_names;  ///< phi names (from the group's first run)
  std::vector<double> phi_actual;      ///< phi of the real system (from the group's first run)
  std::vector<EpisodeStats> episodes;  ///< k = 1, 2, ... up to the longest run
  /// True when some run reported the task's metric.
  bool has_metric() const;
};

/// A campaign directory read back and aggregated.
struct CampaignReport {
  std::filesystem::path dir;       ///< the campaign directory
  std::filesystem::path runs_dir;  ///< where the run directories were found
  /// Grid axes of campaign.yaml that name variants, extending the variant labels: the axes with
  /// more than one value (other than seed, algorithm, model.type and task) in which runs of the
  /// same panel and model differ.
  std::vector<std::string> extra_axes;
  /// Settings outside extra_axes that split the variants the same way: "task" and the task's
  /// own keys (RunResult::task_settings) in which runs of the same task, panel and model differ,
  /// e.g. a torque limit. Runs are never merged across them.
  std::vector<std::string> split_settings;
  std::vector<RunResult> runs;      ///< every run directory, sorted by name
  std::vector<GroupReport> groups;  ///< by panel (rank, label), then variant
};

/// The legend name of a variant: style.label, or the variant's name (model_type) when the style
/// has none. Thread-safe.
std::string variant_long_name(const VariantStyle& style, const std::string& model_type);

/// Groups runs by (variant, panel) and computes every statistic of GroupReport. Runs that are not
/// started count as `not_started` in their group when their config.yaml names one; unreadable
/// runs are in no group. Pure function; thread-safe.
std::vector<GroupReport> aggregate_runs(const std::vector<RunResult>& runs);

/// Reads every run directory of a campaign (CAMPAIGN_DIR/runs/*, or CAMPAIGN_DIR/* when there is
/// no runs/ folder but its subdirectories are run directories) and aggregates them, the variants
/// split by extra_axes and split_settings. Only reads.
/// Throws ConfigError when the directory does not exist or holds no run directory, and when
/// campaign.yaml exists but cannot be parsed. Thread-safe.
CampaignReport aggregate_campaign(const Registry& registry,
                                  const std::filesystem::path& campaign_dir);

/// Writes summary.csv: one row per group (columns in docs/reports.md). +inf is written "inf" and
/// an undefined value "nan". Throws drops::Error when the file cannot be written.
void write_summary_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes returns.csv, long format: variant,prior,episode,interaction_time_s,runs,median,q25,q75,
/// variant_label,panel_title,variant_colour, rows in report order (panels, then variants by
/// their VariantStyle::rank, then name).
void write_returns_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes the task's report metric (e.g. speed.csv) in the format of returns.csv, for the groups
/// with has_metric(). Returns false (and writes nothing) when no group has it.
bool write_metric_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes calibration.csv, long format, one row per episode a model predicted:
/// variant,prior,run,episode,quantile,inside_band,gap,replay,variant_label,panel_title,
/// variant_colour (the
/// columns of algo::Calibration; inside_band and replay 0 or 1). Returns false (and writes
/// nothing) when no episode has a calibration. Throws drops::Error on write failure.
bool write_calibration_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes phi.csv, long format: variant,prior,episode,parameter,median,actual.
void write_phi_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes report.md: run counts, the summary table, median [q25, q75] return per episode (one
/// table per panel), the task's metric and the prior identified per episode when they apply, the
/// final median phi, and the list of runs. Throws drops::Error on write failure.
void write_report_markdown(const CampaignReport& report, const std::filesystem::path& path);

/// Episodes `drops plot` draws by default: the first solved episode and the last finished one
/// with trajectories (one of them when they coincide or the run never solved).
std::vector<int> default_plot_episodes(const RunResult& run);
/// Parses an episode list "1,5,10" (1-based, each in [1, last]) in the given order without
/// duplicates. Throws ConfigError naming the bad entry and the allowed range.
std::vector<int> parse_episode_list(const std::string& text, int last);
/// phi components `drops plot` draws: those that change across the run's episodes plus the
/// tunable ones; empty when the run uses no prior.
std::vector<std::string> plotted_phi_names(const RunResult& run);
/// Writes the JSON file from which python/drops_plot.py draws one run (`drops plot`): per
/// episode the returns, phi and metrics, and the real and predicted trajectories of `episodes`
/// (read with read_trajectory_csv); the label and unit of each phi component ("phi_labels") and
/// trajectory column ("columns", with its kind: time, state, action, reward or extra) as the
/// task declared them (ReportInfo), else its name without a unit; the variant's legend name and
/// colour ("variant_label", "variant_colour": RunResult::variant_style). Throws drops::Error
/// naming a missing trajectory file.
void write_plot_data(const RunResult& run, const std::vector<int>& episodes,
                     const std::filesystem::path& path);

}  // namespace drops::experiment
