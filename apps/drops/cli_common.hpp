#pragma once
// Pieces shared by the subcommands that take an experiment on the command line (`drops run`,
// `drops config`, `drops direct`): positional arguments, the settings they resolve to, and the
// Ctrl-C convention (the first SIGINT or SIGTERM asks the command to stop after its current step,
// a second one ends the process).

#include <string>
#include <vector>

#include "drops/experiment/config.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run.hpp"

namespace drops::app {

/// Splits positional arguments into an optional config file (the one argument without '=') and
/// key=value overrides, in order. Throws ConfigError when more than one file is given.
void split_args(const std::vector<std::string>& args, std::string& file,
                std::vector<std::string>& overrides);

/// The settings of `file` (empty: the defaults) with `overrides` applied
/// (experiment::load_settings_file / load_settings; a run directory's config.yaml holds every key,
/// so `drops run RUN_DIR/config.yaml` repeats that run). Throws ConfigError on an unknown key or a
/// bad value (the message names it).
experiment::Settings settings_from(const experiment::Registry& registry, const std::string& file,
                                   const std::vector<std::string>& overrides);

/// make_experiment(registry, settings), with `source` (the configuration file the settings came
/// from; empty: none) named in the ConfigErrors it throws for what the schema alone cannot check.
experiment::Experiment make_experiment_from(const experiment::Registry& registry,
                                            const experiment::Settings& settings,
                                            const std::string& source);

/// Installs the SIGINT and SIGTERM handler and clears the count: after it, interrupt_requested()
/// is true once Ctrl-C was pressed or SIGTERM received (the run stops after its current step,
/// keeps what it recorded and ends with status "interrupted"); a second signal restores the
/// default action and re-raises it (the process ends at once). Call from the main thread;
/// interrupt_requested() is thread-safe.
void install_interrupt_handler();
bool interrupt_requested();

}  // namespace drops::app
