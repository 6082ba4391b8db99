#pragma once
/// \file Running a configured experiment into its run directory: what `drops run` and the Python
/// module's `drops.run` / `drops.resume` share. The run directory is created (or reopened to
/// continue it), the algorithm runs with every finished episode, phase and state recorded, and
/// the progress lines are formatted here and handed to the caller's RunOutput, which prints them
/// (the library itself never prints).

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/registry.hpp"

namespace drops::experiment {

/// Where a run's progress goes: the lines of `drops run`, formatted by run_experiment() and
/// printed by the caller. The functions are called on the thread that called run_experiment().
struct RunOutput {
  /// Only the final line (done, interrupted or nothing to do) and the warnings a user must act on
  /// (a real system that returned a non-finite state); no header, episode or phase lines.
  bool quiet = false;
  /// The output is a terminal: status() is called (at most every 100 ms) with a line that
  /// replaces the previous one in place, and an archive being built is not reported once a minute.
  bool live = false;
  /// One finished line, without its newline. Required.
  std::function<void(const std::string&)> line;
  /// live: the status line that replaces the last one (without newline). May be empty.
  std::function<void(const std::string&)> status;
  /// live: erases the status line before a finished line is printed. May be empty.
  std::function<void()> clear_status;
  /// Polled often (Callbacks::should_stop): true stops the run after its current step (it ends
  /// with status "interrupted", every finished episode on disk). May be empty (never stops).
  std::function<bool()> should_stop;
};

/// What run_experiment() did.
struct RunOutcome {
  /// The algorithm's summary; for a resumed run that had nothing left to do, the episodes done,
  /// first solved episode and best return of its checkpoint.
  algo::RunSummary summary;
  std::filesystem::path directory;  ///< the run directory
  /// summary.json's final status: "complete" or "interrupted".
  std::string status;
  /// A resumed run that already had its episodes: nothing was run.
  bool nothing_to_do = false;
  /// For an interrupted run: how to continue it (or why it cannot be); empty otherwise.
  std::string hint;
};

/// make_experiment(registry, settings), with `source` (the configuration file the settings came
/// from; empty: none) prefixed to the ConfigErrors it throws for what the schema alone cannot
/// check ("configs/x.yaml: ..."), unless the message already starts with it.
Experiment make_experiment(const Registry& registry, const Settings& settings,
                           const std::string& source);

/// The settings to continue the run in `dir`: its config.yaml with `overrides` (key=value) applied,
/// of which only episodes= (extend the run) and threads= are allowed.
/// Throws ConfigError when another key is overridden (naming it) or `dir` is empty; drops::Error
/// when `dir` is not a directory, has no config.yaml or is of another run-directory format
/// version (check_run_directory_format); ConfigError from load_settings_file for a bad value.
/// Thread-safe.
Settings resume_settings(const Registry& registry, const std::filesystem::path& dir,
                         const std::vector<std::string>& overrides);

/// Runs the experiment of `settings` (validated by load_settings; read from the configuration
/// file `source`, empty: none) into a new run directory (output/name, or output/<default name>
/// with a timestamp), or, when `resume_dir` is not empty, continues the run there (settings from
/// resume_settings(registry, resume_dir, ...)) from its last finished episode. Every finished
/// episode, phase and state is recorded as it comes (RunDirectory); the final status is
/// "complete" or "interrupted" (output.should_stop), or "failed" when the algorithm throws, in
/// which case the exception is rethrown after summary.json says so. The lines of `drops run` go to
/// `output` (a header, per-episode and per-phase lines, the final line "done: ...; results in
/// DIR" or "interrupted: ..." with the hint, or "nothing to do: ..."). Limits drops's threads to
/// the experiment's `threads` for the duration of the call.
/// Throws ConfigError (make_experiment), RunDirectoryBusy when another process holds the run
/// directory, RunDirectoryDamaged and drops::Error from RunDirectory::reopen, and whatever the
/// algorithm or output's functions throw. Not reentrant (drops::parallel_for); call it from one
/// thread at a time.
RunOutcome run_experiment(const Registry& registry, const Settings& settings,
                          const std::string& source, const std::string& resume_dir,
                          const RunOutput& output);

}  // namespace drops::experiment
