#pragma once
// How a subcommand plugs into the `drops` command line: each apps/drops/<name>.cpp adds its CLI11
// subcommand and, when the user chose it, stores the action to run after parsing. Exit codes
// shared by every subcommand: 0 success, 1 error, 2 configuration or usage error, 3 directory in
// use, 130 interrupted.

#include <CLI/CLI.hpp>

#include <functional>

#include "drops/experiment/registry.hpp"

namespace drops::app {

/// The chosen subcommand's action; returns the process exit code. Exceptions: drops::ConfigError
/// (exit 2) and std::exception (exit 1) are reported by drops::cli::run().
using Action = std::function<int()>;

/// `drops run` (also `--resume DIR`). The registry outlives the parse and the action.
void add_run_command(CLI::App& app, Action& action, const experiment::Registry& registry);
/// `drops config`.
void add_config_command(CLI::App& app, Action& action, const experiment::Registry& registry);
/// `drops campaign`.
void add_campaign_command(CLI::App& app, Action& action, const experiment::Registry& registry);
/// `drops report CAMPAIGN_DIR`.
void add_report_command(CLI::App& app, Action& action, const experiment::Registry& registry);
/// `drops plot RUN_DIR`.
void add_plot_command(CLI::App& app, Action& action, const experiment::Registry& registry);
/// `drops direct [CONFIG] [key=value ...]`: `drops run algorithm=direct` under its old name.
void add_direct_command(CLI::App& app, Action& action, const experiment::Registry& registry);

/// `drops identify CONFIG [key=value ...]`: a model learned from recorded logs.
void add_identify_command(CLI::App& app, Action& action, const experiment::Registry& registry);

}  // namespace drops::app
