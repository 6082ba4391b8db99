#pragma once
/// \file The MAP-Elites archive as a file (IT&E): the one writer and reader of archive.csv, used by
/// the run directory (each IT&E run saves its archive there), by `ite.archive` (a run started from a
/// saved archive), by the archive cache (`ite.archive_cache`) and, through the file,
/// python/drops_plot.py (`drops plot` draws the archive). The rows are drops::ite's archive format
/// (drops/ite/archive_io.hpp, docs/ite.md); the experiment layer adds comment lines saying what
/// the archive is:
///
///   # drops-map-elites-archive 1
///   # bins 5 5 5 5 5 5
///   # param_dim 36
///   # binning floor: cell_d = min(floor(descriptor_d * bins_d), bins_d - 1)
///   # task <task>
///   # prior <prior label>
///   # descriptor <name_0> <name_1> ...
///   # descriptor_doc <one line>
///   # fitness <one line>
///   # map_elites complete 1 evaluations 100000 batches 250 generations 249 initial_drawn 200 initial_left 0
///   cell_0,...

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/ite/archive.hpp"
#include "drops/ite/map_elites.hpp"

namespace drops::experiment {

struct TaskSetup;

/// What the comments of an archive file say about it.
struct ArchiveFileInfo {
  std::string task;                           ///< the task's name (empty: not said)
  std::string prior;                          ///< the prior's label the archive was built on
  std::vector<std::string> descriptor_names;  ///< one per dimension (empty: not said)
  std::string descriptor_doc;                 ///< how the descriptor is computed
  std::string fitness_doc;                    ///< what the fitness is
  /// Whether the MAP-Elites run that built it finished (false: a snapshot of a generation in
  /// progress, continued from `cursor`). Files without the map_elites line are complete.
  bool complete = true;
  ite::MapElitesCursor cursor;  ///< where that run stood
};

/// The information an IT&E run of `setup` writes with its archive: task, the prior's label,
/// the behaviour descriptor's names and doc, and the fitness (the return of an episode on the
/// prior). complete and cursor are left at their defaults. Thread-safe.
ArchiveFileInfo archive_file_info(const std::string& task, const TaskSetup& setup);

/// Writes the archive file atomically (through path.tmp and a rename). Throws drops::Error naming
/// the file when it cannot be written.
void write_archive_file(const std::filesystem::path& path, const ite::Archive& archive,
                        const ArchiveFileInfo& info);

/// An archive file read back.
struct ArchiveFile {
  std::shared_ptr<const ite::Archive> archive;
  ArchiveFileInfo info;
};

/// Reads an archive file (rows checked by ite::read_archive). Throws drops::Error naming the file,
/// and the line for a malformed row or comment. Thread-safe.
ArchiveFile read_archive_file(const std::filesystem::path& path);

}  // namespace drops::experiment
