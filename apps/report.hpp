#pragma once
// Reading run directories back and aggregating a campaign: the numbers behind `drops report`
// (tables and the paper's Fig. 3 form) and `drops plot` (figures of one run). Every statistic is
// computed here; python/drops_plot.py only draws what these functions wrote.
//
// Statistics (docs/reports.md states them for users):
//   quantiles         linear interpolation between order statistics (Hyndman & Fan type 7, the
//                     numpy/R default): q(p) = x[⌊h⌋] + (h − ⌊h⌋)(x[⌊h⌋+1] − x[⌊h⌋]), h = (n − 1)p
//   success rate      fraction of a group's started runs solved at least once
//   first solve       median over all started runs, never-solved runs counted as +∞, so the
//                     median is +∞ ("not solved") once at least half the runs never solved

#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace drops::app {

/// The q-quantile (p in [0, 1]) of `values` by linear interpolation between order statistics
/// (Hyndman & Fan 1996, definition 7; numpy.quantile's default). `values` need not be sorted and
/// may hold +∞ (an interpolation towards +∞ gives +∞). Throws drops::InvalidArgument when values
/// is empty or holds a NaN, or when p is NaN or outside [0, 1]. Thread-safe.
double quantile(std::vector<double> values, double p);

/// One finished episode of a run, as recorded in summary.json.
struct EpisodeResult {
  int episode = 0;                  ///< 1-based episode number
  double interaction_time_s = 0.0;  ///< real-system time used so far, this episode included (s)
  /// Return of the episode on the real system; NaN when summary.json holds null.
  double real_return = std::numeric_limits<double>::quiet_NaN();
  /// Return the model predicted for the chosen policy; NaN for a random first episode.
  double predicted_return = std::numeric_limits<double>::quiet_NaN();
  bool solved = false;         ///< the task's success criterion held on the real system
  bool random_policy = false;  ///< θ was drawn at random (episode 1 of the gp variant)
  std::vector<double> phi;     ///< prior parameters φ used by the model (dim = phi_names)
  /// Hexapod: forward distance / episode duration on the real robot (m/s); NaN when absent.
  double walking_speed_m_s = std::numeric_limits<double>::quiet_NaN();
};

/// One run directory read back (config.yaml and summary.json).
struct RunResult {
  std::string name;           ///< directory name
  std::filesystem::path dir;  ///< the run directory
  /// "running", "complete", "interrupted" or "failed" (summary.json), "not started" (no
  /// summary.json) or "unreadable" (summary.json or config.yaml could not be parsed; see error).
  std::string status;
  std::string error;       ///< why a run is unreadable, or the error a failed run recorded
  std::string model_type;  ///< model.type (gp_mi, gp_prior, mi, gp); empty when unknown
  std::string task;        ///< task (pendubot, hexapod); empty when unknown
  /// The panel the run belongs to: prior.preset for the pendubot; for the hexapod the "real"
  /// robot's damage ("intact", "leg5 removed", "leg2 shortened", "leg1 blocked", joined by ", ").
  /// Empty when unknown.
  std::string prior;
  /// Group label: model_type, then " key=value" per extra campaign grid axis.
  std::string variant;
  std::int64_t seed = -1;                   ///< the run's seed; -1 when unknown
  int episodes_planned = 0;                 ///< episodes the run was configured for
  std::vector<std::string> phi_names;       ///< names of φ's components
  std::vector<double> phi_actual;           ///< φ of the real system (dim = phi_names)
  std::vector<EpisodeResult> episodes;      ///< finished episodes in order
  std::vector<std::string> phi_tunable;     ///< prior.tunable from config.yaml (may be empty)
  bool solved = false;                      ///< solved at least once
  std::optional<int> first_solved_episode;  ///< first solved episode, if any
  /// Interaction time at the first solved episode (s); +∞ when never solved.
  double first_solved_time_s = std::numeric_limits<double>::infinity();

  /// True when summary.json was read (the run counts in the statistics).
  bool started() const { return status != "not started" && status != "unreadable"; }
};

/// Reads one run directory. A directory without summary.json gives status "not started" (its
/// config.yaml is still read for the group, when present); a file that cannot be parsed gives
/// status "unreadable" with the reason in `error`. `extra_axes` are dotted config keys whose
/// values are appended to the variant label. Never throws for bad run files; throws
/// drops::Error only when `dir` is not a directory. Thread-safe.
RunResult read_run(const std::filesystem::path& dir,
                   const std::vector<std::string>& extra_axes = {});

/// Statistics of one group at one episode number k over the runs that have episode k.
struct EpisodeStats {
  int episode = 0;                  ///< k (1-based)
  double interaction_time_s = 0.0;  ///< median over the runs of their interaction time at k (s)
  int runs = 0;                     ///< runs with a finite real return at episode k
  double median = 0.0;              ///< median real return at k
  double q25 = 0.0;                 ///< 25th percentile of the real return at k
  double q75 = 0.0;                 ///< 75th percentile of the real return at k
  /// Median φ at k per component (dim = GroupReport::phi_names; runs whose φ has another size
  /// are left out).
  std::vector<double> phi_median;
  /// Runs at k per value of φ's first component, in increasing value order (for a discrete φ
  /// such as the hexapod's removed leg: how many runs used each prior).
  std::vector<std::pair<double, int>> phi_counts;
  int speed_runs = 0;  ///< runs with a finite walking speed at k (hexapod)
  /// Median and quartiles of the walking speed at k (m/s); NaN when speed_runs = 0.
  double speed_median = std::numeric_limits<double>::quiet_NaN();
  double speed_q25 = std::numeric_limits<double>::quiet_NaN();
  double speed_q75 = std::numeric_limits<double>::quiet_NaN();
};

/// Aggregate of one group (variant, prior) of a campaign.
struct GroupReport {
  std::string variant;                 ///< see RunResult::variant
  std::string model_type;              ///< model.type of the group's runs
  std::string task;                    ///< task of the group's first run
  std::string prior;                   ///< the panel: see RunResult::prior
  std::vector<std::string> run_names;  ///< started runs of the group
  int runs = 0;              ///< started runs (complete + running + interrupted + failed + other)
  int complete = 0;          ///< status "complete"
  int running = 0;           ///< status "running" (in progress, or stopped without a final status)
  int interrupted = 0;       ///< status "interrupted"
  int failed = 0;            ///< status "failed" (its episodes still count)
  int not_started = 0;       ///< run directories without summary.json (not in `runs`)
  int solved_runs = 0;       ///< runs solved at least once
  int solved_last_runs = 0;  ///< runs solved at their last finished episode
  /// solved_runs / runs; NaN when runs = 0.
  double success_rate = std::numeric_limits<double>::quiet_NaN();
  /// solved_last_runs / runs; NaN when runs = 0.
  double solved_last_rate = std::numeric_limits<double>::quiet_NaN();
  /// Median first solved episode over all started runs, never solved = +∞; NaN when runs = 0.
  double median_first_solve_episode = std::numeric_limits<double>::quiet_NaN();
  /// The same in interaction time (s).
  double median_first_solve_time_s = std::numeric_limits<double>::quiet_NaN();
  /// Median of each run's real return at its last finished episode; NaN when none.
  double median_final_return = std::numeric_limits<double>::quiet_NaN();
  /// Median of each run's walking speed at its last finished episode (m/s, the hexapod); NaN
  /// when none.
  double median_final_speed_m_s = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> phi_names;  ///< φ names (from the group's first run)
  std::vector<double> phi_actual;      ///< φ of the real system (from the group's first run)
  std::vector<EpisodeStats> episodes;  ///< k = 1, 2, ... up to the longest run
  /// True when some run reported a walking speed (the hexapod).
  bool has_speed() const {
    for (const auto& e : episodes)
      if (e.speed_runs > 0) return true;
    return false;
  }
};

/// A campaign directory read back and aggregated.
struct CampaignReport {
  std::filesystem::path dir;       ///< the campaign directory
  std::filesystem::path runs_dir;  ///< where the run directories were found
  /// Grid axes of campaign.yaml (other than seed, model.type, prior.preset and the hexapod's
  /// hexapod.damage.*, which make the panels) with more than one value; they extend the variant
  /// labels.
  std::vector<std::string> extra_axes;
  std::vector<RunResult> runs;      ///< every run directory, sorted by name
  std::vector<GroupReport> groups;  ///< by prior (Table I order A–D first), then variant
};

/// Groups runs by (variant, prior) and computes every statistic of GroupReport. Runs that are not
/// started count as `not_started` in their group when their config.yaml names one; unreadable
/// runs are in no group. Pure function; thread-safe.
std::vector<GroupReport> aggregate_runs(const std::vector<RunResult>& runs);

/// Reads every run directory of a campaign (CAMPAIGN_DIR/runs/*, or CAMPAIGN_DIR/* when there is
/// no runs/ folder but its subdirectories are run directories) and aggregates them. Only reads.
/// Throws drops::ConfigError when the directory does not exist or holds no run directory, and
/// when campaign.yaml exists but cannot be parsed. Thread-safe.
CampaignReport aggregate_campaign(const std::filesystem::path& campaign_dir);

/// Writes summary.csv: one row per group (columns in docs/reports.md). +∞ is written "inf" and
/// an undefined value "nan". Throws drops::Error when the file cannot be written.
void write_summary_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes returns.csv, long format: variant,prior,episode,interaction_time_s,runs,median,q25,q75.
/// Throws drops::Error when the file cannot be written.
void write_returns_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes speed.csv (the hexapod's walking speed), long format:
/// variant,prior,episode,interaction_time_s,runs,median,q25,q75 (m/s), for the groups with
/// has_speed(). Throws drops::Error when the file cannot be written.
void write_speed_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes phi.csv, long format: variant,prior,episode,parameter,median,actual (median φ over the
/// runs that finished the episode; actual = the real system's value).
/// Throws drops::Error when the file cannot be written.
void write_phi_csv(const CampaignReport& report, const std::filesystem::path& path);
/// Writes report.md: run counts, the summary table, median [q25, q75] return per episode (one
/// table per prior), for the hexapod the walking speed and the prior identified per episode, the
/// final median φ, and the list of runs. Throws drops::Error on write
/// failure.
void write_report_markdown(const CampaignReport& report, const std::filesystem::path& path);

/// Episodes `drops plot` draws by default: the first solved episode and the last finished one
/// (one of them when they coincide or the run never solved); empty when the run has no episode.
std::vector<int> default_plot_episodes(const RunResult& run);

/// Parses an episode list "1,5,10" (1-based, each in [1, last]) in the given order without
/// duplicates. Throws drops::ConfigError naming the bad entry and the allowed range.
std::vector<int> parse_episode_list(const std::string& text, int last);

/// φ components `drops plot` draws: those that change across the run's episodes plus those listed
/// as tunable in its config.yaml, in φ order; empty for the gp variant (it uses no prior).
std::vector<std::string> plotted_phi_names(const RunResult& run);

/// `drops report`: writes report.md, summary.csv, returns.csv and phi.csv into `out_dir`
/// (created if needed), plus speed.csv when a group has walking speeds (the hexapod), and, when
/// `figures`, returns.png (and speed.png) through python/drops_plot.py. Returns the
/// files written. Throws drops::Error when a file cannot be written or the figure cannot be drawn
/// (Debian's /usr/bin/python3 with matplotlib and numpy is needed; the tables are kept).
/// Not thread-safe with another call writing the same `out_dir`.
std::vector<std::filesystem::path> write_report(const CampaignReport& report,
                                                const std::filesystem::path& out_dir, bool figures);

/// `drops plot`: draws returns.png, phi.png (when plotted_phi_names() is not empty) and
/// trajectories-NNN.png for each episode of `episodes` ("1,5,10"; empty = default_plot_episodes())
/// into `out_dir` (created if needed). Returns the files written. Throws drops::ConfigError when
/// `run_dir` is not a started run directory or the episode list is invalid, drops::Error when the
/// run has no episode, a trajectory file is missing or python/matplotlib fails.
std::vector<std::filesystem::path> plot_run(const std::filesystem::path& run_dir,
                                            const std::string& episodes,
                                            const std::filesystem::path& out_dir);

}  // namespace drops::app
