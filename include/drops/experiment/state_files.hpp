#pragma once
/// \file The files in which a run directory keeps an algorithm's side state
/// (algo::RunState::side_state): what only that algorithm's plugin knows how to write and read.

#include <any>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "drops/algo/algorithm.hpp"

namespace drops::experiment {

/// An algorithm's side state as files of the run directory, beside checkpoint.json (IT&E: its
/// archive, archive.csv, and the archive's progress, archive_progress.csv). The algorithm's plugin
/// makes one per run directory (AlgorithmPlugin::state_files); RunDirectory calls it and no other
/// code knows these files. Not thread-safe: called from the thread that owns the run directory.
class StateFiles {
 public:
  virtual ~StateFiles() = default;
  /// The files it may write, relative to the run directory, the one that holds the side state
  /// first (a checkpoint of no episode without it is refused as damaged): a run that restarts
  /// from its beginning removes them.
  virtual std::vector<std::string> file_names() const = 0;
  /// Writes `side` (a RunState's side_state, possibly empty) into `dir` when it differs from what
  /// this object last wrote or read, before the checkpoint is written; then sets its entry of
  /// summary.json in *summary and returns true. Returns false when nothing was written. Throws
  /// drops::Error when a file cannot be written.
  virtual bool save(const std::any& side, const std::filesystem::path& dir,
                    nlohmann::json* summary) = 0;
  /// Reads the side state back from `dir` into *side when a run is resumed; false when `dir`
  /// holds none. Appends a sentence to *repairs for each file it repaired. Throws
  /// RunDirectoryDamaged naming the file when one is unreadable.
  virtual bool load(const std::filesystem::path& dir, std::any* side,
                    std::vector<std::string>* repairs) = 0;
  /// Each status of the running algorithm (algo::Callbacks::on_status), with the run's wall-clock
  /// seconds over all its sessions, e.g. for a progress file. Default: nothing. Throws
  /// drops::Error when a file cannot be written.
  virtual void on_status(const algo::Status& status, double seconds,
                         const std::filesystem::path& dir) {
    (void)status, (void)seconds, (void)dir;
  }
};

/// Makes one StateFiles for a run directory.
using StateFilesFactory = std::function<std::unique_ptr<StateFiles>()>;

}  // namespace drops::experiment
