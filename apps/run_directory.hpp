#pragma once
// The run directory written by `drops run` (the library itself never writes files).
//
// <output>/<name>/
//   config.yaml            resolved configuration (every key)
//   episodes.csv           one row per finished episode (appended and flushed at episode end)
//   summary.json           status, progress and results (rewritten atomically after each episode)
//   episodes/NNN/real.csv       real trajectory: t, states, actions, reward, then the task's
//                               per-state extras (hexapod: foot heights)
//   episodes/NNN/predicted.csv  mean-propagated trajectory on the model that chose the policy
//   episodes/NNN/policy.csv     policy parameters theta (one per line)
//   checkpoint.json        state of Algorithm 1 after the last finished episode (drops run --resume)
//   .lock                  flock()ed by the process writing the directory

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "drops/algo/black_drops.hpp"
#include "drops/core/errors.hpp"
#include "drops/io/config.hpp"
#include "task_setup.hpp"

namespace drops::app {

/// Writes text to path through path.tmp and a rename, so a reader or a crash never sees a partial
/// file. Throws drops::Error naming the file when it cannot be written or renamed.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);
/// The current UTC time as ISO 8601 ("2026-11-21T17:05:27Z"), for logs and summaries.
std::string now_iso();

/// A trajectory as CSV text, the format of episodes/NNN/real.csv: a header, then per step t (s),
/// the state (named by setup.state_names), the action that followed it (empty on the last row),
/// the reward that led to it (empty on the first row) and the task's per-state extras.
std::string trajectory_csv(const rollout::Trajectory& tr, const TaskSetup& setup);

/// Thrown when another process holds the run directory's lock (drops run exits with code 3).
class RunDirectoryBusy : public Error {
 public:
  using Error::Error;
};

class RunDirectory {
 public:
  /// Creates the directory (throws drops::Error if it exists and holds an episodes.csv, or cannot
  /// be created) and writes config.yaml and the header of episodes.csv. Takes the lock
  /// (RunDirectoryBusy if another process holds it). setup names the trajectory columns and the
  /// task's per-episode metrics; it must outlive the RunDirectory.
  RunDirectory(const std::filesystem::path& dir, const io::Settings& settings,
               const io::Experiment& experiment, const TaskSetup& setup);
  ~RunDirectory();
  RunDirectory(const RunDirectory&) = delete;
  RunDirectory& operator=(const RunDirectory&) = delete;

  /// Reopens an existing run directory to continue it: takes the lock, reads checkpoint.json into
  /// *state, and removes what was recorded after it (rows of episodes.csv, episodes/NNN folders
  /// and summary entries of later episodes, e.g. an episode written just before a crash).
  /// experiment must be the one of DIR/config.yaml. Throws drops::Error when there is no
  /// checkpoint.json (no episode finished: start the run again) or it does not fit the experiment.
  static std::unique_ptr<RunDirectory> reopen(const std::filesystem::path& dir,
                                              const io::Experiment& experiment,
                                              const TaskSetup& setup,
                                              algo::BlackDropsState* state);

  /// Writes every file of one finished episode, then appends its row and rewrites summary.json.
  void record(const algo::EpisodeRecord& rec);
  /// Writes checkpoint.json (atomically): doubles with 17 significant digits, so a resumed run is
  /// bit-identical to an uninterrupted one.
  void save_state(const algo::BlackDropsState& state);
  /// Rewrites summary.json with the final status ("complete", "interrupted" or "failed").
  void finish(const algo::BlackDropsSummary& summary, const std::string& status,
              const std::string& error = "");
  const std::filesystem::path& path() const { return dir_; }

 private:
  RunDirectory(const std::filesystem::path& dir, const io::Experiment& experiment,
               const TaskSetup& setup);
  void lock();
  void write_trajectory(const std::filesystem::path& path, const rollout::Trajectory& tr) const;
  void write_summary(const std::string& status);
  int lock_fd_ = -1;
  double previous_seconds_ = 0;  ///< wall-clock time of earlier sessions of a resumed run
  std::filesystem::path dir_;
  io::Experiment experiment_;
  const TaskSetup& setup_;
  std::ofstream episodes_csv_;
  nlohmann::json summary_;
};

}  // namespace drops::app
