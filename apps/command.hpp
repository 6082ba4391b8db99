#pragma once
// How a subcommand plugs into the `drops` command line: each apps/<name>.cpp adds its CLI11
// subcommand and, when the user chose it, stores the action to run after parsing. Exit codes
// shared by every subcommand: 0 success, 1 error, 2 configuration or usage error, 130 interrupted.

#include <CLI/CLI.hpp>

#include <functional>

namespace drops::app {

/// The chosen subcommand's action; returns the process exit code. Exceptions: drops::ConfigError
/// (exit 2) and std::exception (exit 1) are reported by main().
using Action = std::function<int()>;

/// `drops run` (also `--resume DIR`).
void add_run_command(CLI::App& app, Action& action);
/// `drops config`.
void add_config_command(CLI::App& app, Action& action);
/// `drops campaign FILE [-j N] [--mpi]`.
void add_campaign_command(CLI::App& app, Action& action);
/// `drops report CAMPAIGN_DIR`.
void add_report_command(CLI::App& app, Action& action);
/// `drops direct [CONFIG] [key=value ...]`: the policy optimized on the real system, no model.
void add_direct_command(CLI::App& app, Action& action);
/// `drops plot RUN_DIR`.
void add_plot_command(CLI::App& app, Action& action);

}  // namespace drops::app
