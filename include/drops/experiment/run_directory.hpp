#pragma once
/// \file The run directory: its one writer (RunDirectory, used by `drops run` for every
/// algorithm) and its one reader (read_run, read_checkpoint, read_trajectory_csv, used by
/// `drops report`, `drops plot`, the animations and, through the files `drops plot` writes, the
/// Python plotting). The library's core never writes files; this is where runs become files.
///
/// This is run-directory format version 1 (kRunDirectoryFormatVersion), the first released one;
/// summary.json and checkpoint.json carry it as "format_version". This drops reads version 1 only:
/// a run directory of another version, or without one (written before the format was versioned),
/// is refused by --resume and by campaigns, and is "unreadable" to drops report and drops plot.
///
///   <output>/<name>/
///     config.yaml                 resolved configuration (every key of the task's schema)
///     episodes.csv                one row per finished episode (appended and flushed at its end)
///     summary.json                format_version, status, what the run is (task, algorithm,
///                                 variant, panel), per-episode details (rewritten atomically
///                                 after each episode)
///     episodes/NNN/real.csv       real trajectory: t, states, actions, reward, the task's extras
///     episodes/NNN/predicted.csv  mean-propagated trajectory on the model that chose the policy
///     episodes/NNN/policy.csv     policy parameters theta (one per line)
///     checkpoint.json             format_version, the algorithm's state after the last finished
///                                 episode (--resume), with what it covers: the resolved
///                                 configuration and SHA-256 checksums of the recorded files and
///                                 of itself
///     archive.csv                 IT&E: the MAP-Elites archive (archive_file.hpp), saved with the
///                                 state that holds it, before checkpoint.json
///     archive_progress.csv        IT&E building its archive: coverage per MAP-Elites generation
///     .lock                       flock()ed by the process writing the directory

#include <chrono>
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

/// The run-directory format this drops writes and reads ("format_version" of summary.json and
/// checkpoint.json). Version 1 is the first released format.
inline constexpr int kRunDirectoryFormatVersion = 1;

/// Throws drops::Error when DIR/summary.json or DIR/checkpoint.json (each checked when present and
/// parseable) does not carry "format_version" kRunDirectoryFormatVersion. The message names the
/// file, the version found (or that there is none) and the version this drops reads, and says to
/// use the drops that wrote the run or to run it again. Thread-safe.
void check_run_directory_format(const std::filesystem::path& dir);

/// What summary.json of a run directory of `e` holds when the run starts (format version 1): the
/// task, algorithm, variant and its style, whether it uses a prior and a model, the prior's
/// label, the report block (ReportInfo), seed, planned episodes, phi's names and actual values,
/// the trajectory columns' names, the start time and no episode. read_run needs every member.
/// Thread-safe.
nlohmann::json summary_head(const Experiment& e);
/// What the run's robot declares, recorded in summary.json ("task_record") and checkpoint.json
/// (validation.task) and compared by RunDirectory::reopen, so that a run is never continued with
/// another robot: the trajectory columns (state, action and extra names), observation_dim,
/// horizon, dt (s), the initial state, the policy's parameter count, the prior's parameters
/// (names, starting values, bounds of the tunable ones, which are tunable) and
/// TaskSetup::declaration. Thread-safe.
nlohmann::json task_record(const Experiment& e);

/// The largest run file drops reads whole (episodes.csv, summary.json, checkpoint.json, a
/// trajectory or policy file): 256 MiB.
inline constexpr std::uintmax_t kMaxRunFileBytes = std::uintmax_t{256} << 20;
/// The largest configuration or campaign file drops reads: 16 MiB.
inline constexpr std::uintmax_t kMaxConfigFileBytes = std::uintmax_t{16} << 20;
/// The whole content of the regular file at path (binary), at most max_bytes. Throws
/// drops::Error naming the file before reading anything when it is not a regular file (a
/// directory, a device such as /dev/zero, a FIFO: "PATH is not a regular file (a directory)") or
/// larger than max_bytes, and "cannot read PATH: <the operating system's reason>" when it cannot
/// be opened or read (symbolic links are followed). Thread-safe.
std::string read_file_text(const std::filesystem::path& path,
                           std::uintmax_t max_bytes = kMaxRunFileBytes);
/// read_file_text's message about a file of the kind `what` (e.g. "config file"): "cannot read
/// config file PATH: <reason>", "config file PATH is not a regular file (...)". Thread-safe.
std::string file_error(const std::string& what, const std::string& message);
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

/// Thrown by RunDirectory::reopen when the run directory does not match its checkpoint (a file
/// missing, cut or edited since the checkpoint was written); the message names the file.
class RunDirectoryDamaged : public Error {
 public:
  using Error::Error;
};

/// The writer of a run directory, for one experiment (every algorithm writes the same format).
/// Not thread-safe: call from the thread that runs the algorithm (its callbacks).
class RunDirectory {
 public:
  /// Creates the directory `dir` (and its parents), takes the lock (RunDirectoryBusy if another
  /// process holds it), writes config.yaml (config_yaml: to_yaml of the experiment's settings) and
  /// the header of episodes.csv. Throws drops::Error naming the directory when it already holds a
  /// run (an episodes.csv) or cannot be created. experiment must outlive the RunDirectory.
  RunDirectory(const std::filesystem::path& dir, const std::string& config_yaml,
               const Experiment& experiment);
  ~RunDirectory();
  RunDirectory(const RunDirectory&) = delete;
  RunDirectory& operator=(const RunDirectory&) = delete;

  /// As the constructor, in a directory of its own under `parent` named `name` or, when that
  /// exists already, `name-2`, `name-3`, ... (claimed with mkdir(2), so two processes started in
  /// the same second get two directories). For default run names, which hold a timestamp.
  static std::unique_ptr<RunDirectory> create_unique(const std::filesystem::path& parent,
                                                     const std::string& name,
                                                     const std::string& config_yaml,
                                                     const Experiment& experiment);

  /// Reopens an existing run directory to continue it: takes the lock, reads checkpoint.json (and
  /// the algorithm's side state, StateFiles::load, into state->side_state) into *state and checks the directory
  /// against it, then removes what was recorded after it.
  /// experiment must be the one of DIR/config.yaml (with the episodes= and threads= of the resumed
  /// session); config_yaml is to_yaml of its settings, written to DIR/config.yaml when it differs
  /// (so that the file says the new episode count and `drops run DIR/config.yaml` repeats the run).
  ///
  /// Checks: summary.json and checkpoint.json are of run-directory format version 1
  /// (check_run_directory_format; drops::Error otherwise); checkpoint.json's own checksum; every
  /// key of the configuration the run was started with is in config.yaml with the same value
  /// (episodes and threads aside); the first episodes_done rows of episodes.csv,
  /// the first episodes_done entries of summary.json's "episodes" and every file of episodes/NNN
  /// up to episodes_done have the checksums recorded in the checkpoint; the files of the
  /// algorithm's side state (IT&E's archive.csv, which carries its own MAP-Elites cursor and may
  /// be newer than the checkpoint) are checked by their reader (RunDirectoryDamaged naming the
  /// file and line).
  ///
  /// Repairs (listed by repairs()): rows of episodes.csv after episodes_done (also a last row cut
  /// mid-line by a crash), summary entries of later episodes and episodes/NNN folders of later
  /// episodes are removed: the checkpoint does not cover them and the resumed run writes them
  /// again.
  ///
  /// Without checkpoint.json and without a finished episode (a run stopped or killed during its
  /// first one: nothing was recorded), the run starts from its beginning in DIR: what the session
  /// left (episodes.csv, summary.json, episodes/, the side state's files) is removed,
  /// *state is left untouched and has_checkpoint() is false (the caller runs the algorithm from
  /// the start); repairs() says so.
  ///
  /// Throws drops::Error when DIR is not a run directory or is of another format version;
  /// RunDirectoryBusy when another process
  /// holds the lock; RunDirectoryDamaged naming the file when a check fails, or when
  /// checkpoint.json is missing although episodes are recorded (they are kept, the directory is
  /// not changed); ConfigError when the configuration differs from the one the run was started
  /// with (naming the key) or plans fewer episodes than are done.
  static std::unique_ptr<RunDirectory> reopen(const std::filesystem::path& dir,
                                              const Experiment& experiment,
                                              const std::string& config_yaml,
                                              algo::RunState* state);

  /// Writes every file of one finished episode (trajectories and policy only when
  /// rec.keep_trajectories), then appends its row and rewrites summary.json.
  void record(const algo::EpisodeRecord& rec);
  /// Records a phase that is not a real episode (e.g. PILCO with priors' simulation phase) in
  /// summary.json under "phases".<name> (its summary's numbers and texts, and "episodes": one
  /// object per episode of the phase), replacing an earlier record of the same name.
  void record_phase(const algo::PhaseRecord& phase);
  /// Hands a status of the running algorithm to the files of its side state
  /// (StateFiles::on_status; IT&E: a row of archive_progress.csv per MAP-Elites generation) with
  /// the run's wall-clock seconds, earlier sessions included as summary.json counted them.
  /// Throws drops::Error when a file cannot be written. Not thread-safe (caller's thread).
  void record_status(const algo::Status& status);
  /// Writes checkpoint.json (atomically): doubles in the shortest form that reads back exactly,
  /// so a resumed run is bit-identical to an uninterrupted one. Before it, the algorithm's side
  /// state goes to its own files when it changed (StateFiles::save; IT&E: archive.csv with its
  /// MAP-Elites cursor, recorded in summary.json "archive").
  void save_state(const algo::RunState& state);
  /// Rewrites summary.json with the final status ("complete", "interrupted" or "failed").
  void finish(const algo::RunSummary& summary, const std::string& status,
              const std::string& error = "");
  const std::filesystem::path& path() const { return dir_; }
  /// True when checkpoint.json exists: the run can be continued with `drops run --resume` (false
  /// until the first save_state() of a new run, which comes after the first finished episode or,
  /// for IT&E, while its archive is being built, for PILCO with priors after its simulation phase).
  bool has_checkpoint() const { return has_checkpoint_; }
  /// What reopen() removed or rewrote, one sentence each (empty for a new run).
  const std::vector<std::string>& repairs() const { return repairs_; }

 private:
  RunDirectory(const std::filesystem::path& dir, const Experiment& experiment);
  void lock();
  void start(const std::string& config_yaml);
  /// reopen() of a directory where no episode finished: what a session left goes, then start().
  void restart(const std::string& config_yaml);
  void append_row(const std::string& row);
  void write_summary(const std::string& status);
  int lock_fd_ = -1;
  double previous_seconds_ = 0;  ///< wall-clock time of earlier sessions of a resumed run
  /// When this session opened the directory (archive_progress.csv's seconds).
  std::chrono::steady_clock::time_point opened_ = std::chrono::steady_clock::now();
  bool has_checkpoint_ = false;
  std::filesystem::path dir_;
  const Experiment& experiment_;
  std::unique_ptr<StateFiles> state_files_;  ///< the algorithm's side state's files (may be null)
  std::ofstream episodes_csv_;
  std::string episodes_csv_text_;  ///< every byte written to episodes.csv (for its checksum)
  /// SHA-256 of each file of episodes/NNN, by path relative to the run directory.
  std::map<std::string, std::string> file_sha256_;
  std::vector<std::string> repairs_;
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
  /// GP-MI's posterior over the continuous tunable phi (summary.json "phi_posterior",
  /// model::PhiPosterior): their names, standard deviations (units of phi) and correlation
  /// matrix (names x names); empty when the episode's model had none.
  std::vector<std::string> posterior_names;
  std::vector<double> posterior_sd;
  std::vector<std::vector<double>> posterior_correlation;
  /// Where the real return fell among the model's predicted rollouts' returns (summary.json
  /// "calibration", algo::Calibration): has_calibration is false when no model predicted it.
  bool has_calibration = false;
  double calibration_quantile = std::numeric_limits<double>::quiet_NaN();  ///< in [0, 1]
  bool inside_band = false;  ///< inside the rollouts' 5-95 % band
  double gap = std::numeric_limits<double>::quiet_NaN();  ///< predicted - real return
  bool replay = false;       ///< the policy is the best one already run, kept
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
  std::string algorithm;   ///< algorithm name; empty when unknown
  /// The algorithm's variant (model.type for Black-DROPS, the algorithm's name otherwise); empty
  /// when unknown.
  std::string model_type;
  /// How reports show model_type (summary.json "variant_style", recorded when the run started;
  /// for a run that recorded none, the registry's AlgorithmPlugin::variant_style of config.yaml,
  /// else the name alone, unranked).
  VariantStyle variant_style;
  bool uses_prior = true;  ///< whether the variant uses the task's simulator prior
  bool uses_model = true;  ///< whether it uses a model (AlgorithmPlugin::uses_model)
  std::string prior;       ///< the starting prior's label (summary.json "prior")
  /// Panel (run_report_info), metric, success criterion, labels and units.
  ReportInfo report;
  /// Group label: model_type, with " + recorded data" for a run that started from data.logs
  /// (aggregate_campaign appends " key=value" per variant axis).
  std::string variant;
  /// Transitions of data.logs the run started from (summary.json's task_record declaration
  /// "data.transitions"); 0: none.
  int recorded_transitions = 0;
  /// Whether episode 1 planned on a model learned from them (data.keep_first_episode false).
  bool first_episode_on_recorded_data = false;
  std::int64_t seed = -1;                   ///< the run's seed; -1 when unknown
  int episodes_planned = 0;                 ///< episodes the run was configured for
  std::vector<std::string> phi_names;       ///< names of phi's components
  std::vector<double> phi_actual;           ///< phi of the real system (dim = phi_names)
  std::vector<std::string> phi_tunable;     ///< the tunable names (ReportInfo::phi_tunable)
  /// Names of the trajectory files' state (dim E) and action (dim U) columns (summary.json).
  std::vector<std::string> state_names, action_names;
  /// The resolved values of the task's own keys (TaskPlugin::keys) in config.yaml, numbers in
  /// their shortest form, without the prior's keys (TaskPlugin::is_prior_key) when the run uses
  /// no prior; empty when this drops does not know the task or cannot read config.yaml.
  std::map<std::string, std::string> task_settings;
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
/// status "unreadable" with the reason in `error`, and so does one of another run-directory
/// format version (check_run_directory_format's message). The task, algorithm, variant, prior and
/// report information come from the task's plugin in `registry` applied to config.yaml when the
/// task is registered, from summary.json otherwise.
/// Never throws for bad run files; throws drops::Error only when `dir` is not a directory.
/// Thread-safe.
RunResult read_run(const std::filesystem::path& dir, const Registry* registry);

/// The state saved in DIR/checkpoint.json. Throws drops::Error naming the file when it is missing,
/// malformed, of another format version or fails its own checksum (edited by hand).
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
/// The folder of one episode's files in a run directory: run_dir/episodes/NNN (episode 1-based,
/// three digits at least). Whether it exists depends on the run (a direct search keeps the files
/// of the episodes that improved on the best). Thread-safe.
std::filesystem::path episode_dir(const std::filesystem::path& run_dir, int episode);
/// Reads a policy file (episodes/NNN/policy.csv): the policy parameters theta, one per line
/// (dim = the policy's parameter count). Throws drops::Error naming the file, and the line when
/// one is not a number. Thread-safe.
std::vector<double> read_policy_csv(const std::filesystem::path& path);

}  // namespace drops::experiment
