#pragma once
/// \file The run directory: its one writer (RunDirectory, used by `drops run` for every
/// algorithm) and its one reader (read_run, read_checkpoint, read_trajectory_csv, used by
/// `drops report`, `drops plot`, the animations and, through the files `drops plot` writes, the
/// Python plotting). The library's core never writes files; this is where runs become files.
///
///   <output>/<name>/
///     config.yaml                 resolved configuration (every key of the task's schema)
///     episodes.csv                one row per finished episode (appended and flushed at its end)
///     summary.json                status, what the run is (task, algorithm, variant, panel),
///                                 per-episode details (rewritten atomically after each episode)
///     episodes/NNN/real.csv       real trajectory: t, states, actions, reward, the task's extras
///     episodes/NNN/predicted.csv  mean-propagated trajectory on the model that chose the policy
///     episodes/NNN/policy.csv     policy parameters theta (one per line)
///     checkpoint.json             the algorithm's state after the last finished episode (--resume)
///     .lock                       flock()ed by the process writing the directory

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drops/algo/algorithm.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"

namespace drops::experiment {

class Registry;

/// Writes text to path through path.tmp and a rename, so a reader or a crash never sees a partial
/// file. Throws drops::Error naming the file when it cannot be written or renamed.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);
/// The current UTC time as ISO 8601 ("2026-11-21T17:05:27Z"), for logs and summaries.
std::string now_iso();
/// The local time as "YYYYMMDD-HHMMSS", for default run-directory names.
std::string local_timestamp();

/// A trajectory as CSV text, the format of episodes/NNN/real.csv: a header, then per step t (s),
/// the state (named by setup.state_names), the action that followed it (empty on the last row),
/// the reward that led to it (empty on the first row) and the task's per-state extras.
std::string trajectory_csv(const rollout::Trajectory& tr, const TaskSetup& setup);

/// Thrown when another process holds the run directory's lock (drops run exits with code 3).
class RunDirectoryBusy : public Error {
 public:
  using Error::Error;
};

/// The writer of a run directory, for one experiment (every algorithm writes the same format).
/// Not thread-safe: call from the thread that runs the algorithm (its callbacks).
class RunDirectory {
 public:
  /// Creates the directory (throws drops::Error if it exists and holds an episodes.csv, or cannot
  /// be created), writes config.yaml (config_yaml: to_yaml of the experiment's settings) and the
  /// header of episodes.csv, takes the lock (RunDirectoryBusy if another process holds it).
  /// experiment must outlive the RunDirectory.
  RunDirectory(const std::filesystem::path& dir, const std::string& config_yaml,
               const Experiment& experiment);
  ~RunDirectory();
  RunDirectory(const RunDirectory&) = delete;
  RunDirectory& operator=(const RunDirectory&) = delete;

  /// Reopens an existing run directory to continue it: takes the lock, reads checkpoint.json into
  /// *state, and removes what was recorded after it (rows of episodes.csv, episodes/NNN folders
  /// and summary entries of later episodes, e.g. an episode written just before a crash).
  /// experiment must be the one of DIR/config.yaml. Throws drops::Error when there is no
  /// checkpoint.json (no episode finished: start the run again) or it does not fit the experiment.
  static std::unique_ptr<RunDirectory> reopen(const std::filesystem::path& dir,
                                              const Experiment& experiment,
                                              algo::RunState* state);

  /// Writes every file of one finished episode (trajectories and policy only when
  /// rec.keep_trajectories), then appends its row and rewrites summary.json.
  void record(const algo::EpisodeRecord& rec);
  /// Records a phase that is not a real episode (e.g. PILCO with priors' simulation phase) in
  /// summary.json under "phases".<name> (its summary's numbers and texts, and "episodes": one
  /// object per episode of the phase), replacing an earlier record of the same name.
  void record_phase(const algo::PhaseRecord& phase);
  /// Writes checkpoint.json (atomically): doubles in the shortest form that reads back exactly,
  /// so a resumed run is bit-identical to an uninterrupted one.
  void save_state(const algo::RunState& state);
  /// Rewrites summary.json with the final status ("complete", "interrupted" or "failed").
  void finish(const algo::RunSummary& summary, const std::string& status,
              const std::string& error = "");
  const std::filesystem::path& path() const { return dir_; }

 private:
  RunDirectory(const std::filesystem::path& dir, const Experiment& experiment);
  void lock();
  void write_summary(const std::string& status);
  int lock_fd_ = -1;
  double previous_seconds_ = 0;  ///< wall-clock time of earlier sessions of a resumed run
  std::filesystem::path dir_;
  const Experiment& experiment_;
  std::ofstream episodes_csv_;
  nlohmann::json summary_;
};

// ---------------------------------------------------------------------------------------------
// Reading run directories back.

/// One finished episode of a run, as recorded in summary.json.
struct EpisodeResult {
  int episode = 0;                  ///< 1-based episode number
  double interaction_time_s = 0.0;  ///< real-system time used so far, this episode included (s)
  /// Return of the episode on the real system; NaN when summary.json holds null.
  double real_return = std::numeric_limits<double>::quiet_NaN();
  /// Return the model predicted for the chosen policy; NaN without a model.
  double predicted_return = std::numeric_limits<double>::quiet_NaN();
  bool solved = false;         ///< the task's success criterion held on the real system
  bool random_policy = false;  ///< theta was drawn at random (episode 1 of the gp variant)
  std::vector<double> phi;     ///< prior parameters phi used by the model (dim = phi_names)
  std::map<std::string, double> metrics;  ///< the task's per-episode metrics (NaN when null)
  /// The value of metric `name`, NaN when absent.
  double metric(const std::string& name) const;
};

/// One run directory read back (config.yaml and summary.json).
struct RunResult {
  std::string name;           ///< directory name
  std::filesystem::path dir;  ///< the run directory
  /// "running", "complete", "interrupted" or "failed" (summary.json), "not started" (no
  /// summary.json) or "unreadable" (summary.json or config.yaml could not be parsed; see error).
  std::string status;
  std::string error;       ///< why a run is unreadable, or the error a failed run recorded
  std::string task;        ///< task name; empty when unknown
  std::string algorithm;   ///< algorithm name ("black_drops" for runs written before it was recorded)
  /// The algorithm's variant (model.type for Black-DROPS, the algorithm's name otherwise); empty
  /// when unknown.
  std::string model_type;
  bool uses_prior = true;  ///< whether the variant uses the task's simulator prior
  std::string prior;       ///< the starting prior's label (summary.json "prior")
  ReportInfo report;       ///< panel, metric, success criterion, phi labels
  /// Group label: model_type (aggregate_campaign appends " key=value" per variant axis).
  std::string variant;
  std::int64_t seed = -1;                   ///< the run's seed; -1 when unknown
  int episodes_planned = 0;                 ///< episodes the run was configured for
  std::vector<std::string> phi_names;       ///< names of phi's components
  std::vector<double> phi_actual;           ///< phi of the real system (dim = phi_names)
  std::vector<std::string> phi_tunable;     ///< the tunable names (ReportInfo::phi_tunable)
  std::vector<EpisodeResult> episodes;      ///< finished episodes in order
  bool solved = false;                      ///< solved at least once
  std::optional<int> first_solved_episode;  ///< first solved episode, if any
  /// Interaction time at the first solved episode (s); +inf when never solved.
  double first_solved_time_s = std::numeric_limits<double>::infinity();

  /// True when summary.json was read (the run counts in the statistics).
  bool started() const { return status != "not started" && status != "unreadable"; }
};

/// Reads one run directory. A directory without summary.json gives status "not started" (its
/// config.yaml is still read for the group, when present); a file that cannot be parsed gives
/// status "unreadable" with the reason in `error`. What summary.json does not say (run
/// directories written before it recorded the panel, variant and report information) comes from
/// the task's plugin in `registry` applied to config.yaml, when the task is registered.
/// Never throws for bad run files; throws drops::Error only when `dir` is not a directory.
/// Thread-safe.
RunResult read_run(const std::filesystem::path& dir, const Registry* registry);

/// The state saved in DIR/checkpoint.json. Throws drops::Error naming the file when it is missing,
/// malformed or of another format.
algo::RunState read_checkpoint(const std::filesystem::path& dir);

/// A trajectory file (episodes/NNN/real.csv or predicted.csv) read back: its column names and a
/// row per line (empty cells are NaN).
struct TrajectoryTable {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  /// Index of a column, -1 when absent.
  int column(const std::string& name) const;
};
/// Reads a trajectory file. Throws drops::Error naming the file when it cannot be read or a row
/// has another number of cells than the header.
TrajectoryTable read_trajectory_csv(const std::filesystem::path& path);

}  // namespace drops::experiment
