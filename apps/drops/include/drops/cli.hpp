#pragma once
/// \file The `drops` command line as a library: an application that registers its own tasks (your
/// robot) gets every subcommand of drops for them (run, config, campaign, report, plot, direct)
/// with one call from its main(). docs/your-own-robot.md shows how.
///
///   int main(int argc, char** argv) {
///     drops::use_single_threaded_blas();       // drops/core/parallel.hpp
///     drops::experiment::Registry registry;
///     drops::experiment::register_builtin_algorithms(registry);
///     my_robot::register_task(registry);       // the first task registered is the default
///     return drops::cli::run(argc, argv, registry, "my-drops");
///   }

#include <string>

#include "drops/experiment/registry.hpp"

namespace drops::cli {

/// Parses argv, runs the chosen subcommand and returns the process exit code: 0 success, 1
/// error, 2 configuration or usage error, 3 a run or campaign directory in use by another
/// process, 130 interrupted (resumable). Prints to stdout and stderr; installs signal handlers
/// for the duration of a run. `program` names the program in help texts. The registry must hold
/// at least one task and one algorithm. Not reentrant.
int run(int argc, char** argv, const experiment::Registry& registry,
        const std::string& program = "drops");

}  // namespace drops::cli
