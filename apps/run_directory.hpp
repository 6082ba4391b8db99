#pragma once
// The run directory written by `drops run` (the library itself never writes files).
//
// <output>/<name>/
//   config.yaml            resolved configuration (every key)
//   episodes.csv           one row per finished episode (appended and flushed at episode end)
//   summary.json           status, progress and results (rewritten atomically after each episode)
//   episodes/NNN/real.csv       real trajectory: t, states, action, reward
//   episodes/NNN/predicted.csv  mean-propagated trajectory on the model that chose the policy
//   episodes/NNN/policy.csv     policy parameters theta (one per line)

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "drops/algo/black_drops.hpp"
#include "drops/io/config.hpp"

namespace drops::app {

class RunDirectory {
 public:
  /// Creates the directory (throws drops::Error if it exists and holds an episodes.csv, or cannot
  /// be created) and writes config.yaml and the header of episodes.csv.
  RunDirectory(const std::filesystem::path& dir, const io::Settings& settings,
               const io::Experiment& experiment);
  /// Writes every file of one finished episode, then appends its row and rewrites summary.json.
  void record(const algo::EpisodeRecord& rec);
  /// Rewrites summary.json with the final status ("complete", "interrupted" or "failed").
  void finish(const algo::BlackDropsSummary& summary, const std::string& status,
              const std::string& error = "");
  const std::filesystem::path& path() const { return dir_; }

 private:
  void write_summary(const std::string& status);
  std::filesystem::path dir_;
  io::Experiment experiment_;
  std::ofstream episodes_csv_;
  nlohmann::json summary_;
};

}  // namespace drops::app
