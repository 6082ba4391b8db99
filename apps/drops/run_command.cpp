// `drops run` (an algorithm on a configured experiment, or --resume of an interrupted run) and
// `drops config` (the resolved configuration, or the schema as Markdown).

#include <unistd.h>

#include <filesystem>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::app {
namespace {

struct RunArgs {
  std::vector<std::string> args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::string output, name;
  std::optional<std::string> resume;  ///< --resume DIR (given, even empty: an error)
  bool quiet = false;
};

}  // namespace

/// Runs the experiment of `settings` (read from the configuration file `source`, empty: none), or
/// continues the run in `resume_dir`, with the progress display of `drops run` on stderr
/// (experiment::run_experiment formats the lines). Shared by `drops run` and `drops direct`.
int run_experiment(const experiment::Registry& registry, const experiment::Settings& settings,
                   const std::string& source, const std::string& resume_dir, bool quiet) {
  experiment::RunOutput out;
  out.quiet = quiet;
  out.live = !quiet && isatty(STDERR_FILENO);
  out.line = [](const std::string& text) { std::cerr << text << "\n"; };
  out.status = [](const std::string& text) { std::cerr << "\r\033[K" << text << std::flush; };
  out.clear_status = [] { std::cerr << "\r\033[K"; };
  out.should_stop = [] { return interrupt_requested(); };
  install_interrupt_handler();
  try {
    const experiment::RunOutcome r =
        experiment::run_experiment(registry, settings, source, resume_dir, out);
    return r.status == "interrupted" ? 130 : 0;
  } catch (const experiment::RunDirectoryBusy& ex) {
    std::cerr << "drops: " << ex.what() << "\n";
    return 3;
  }
}

namespace {

int run_main(const experiment::Registry& registry, const RunArgs& a) {
  std::string file;
  std::vector<std::string> overrides;
  split_args(a.args, file, overrides);
  if (a.threads) overrides.push_back("threads=" + std::to_string(*a.threads));

  experiment::Settings settings;
  std::string source = file;
  const bool resuming = a.resume.has_value();
  if (resuming) {
    if (!file.empty())
      throw ConfigError("--resume takes the run directory's own config.yaml; drop '" + file + "'");
    if (a.seed || !a.output.empty() || !a.name.empty())
      throw ConfigError("--resume continues a run as configured; --seed, --output and --name "
                        "cannot be changed");
    settings = experiment::resume_settings(registry, *a.resume, overrides);
    source = (std::filesystem::path(*a.resume) / "config.yaml").string();
  } else {
    if (a.seed) overrides.push_back("seed=" + std::to_string(*a.seed));
    if (!a.output.empty()) overrides.push_back("output=" + a.output);
    if (!a.name.empty()) overrides.push_back("name=" + a.name);
    settings = settings_from(registry, file, overrides);
  }
  return run_experiment(registry, settings, source, a.resume.value_or(""), a.quiet);
}

}  // namespace

void add_run_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* run = app.add_subcommand(
      "run",
      "Run an algorithm on an experiment. Without arguments: the default experiment (the "
      "first task, Black-DROPS with GP-MI, 10 episodes, seed 1). Exit codes: 0 done, 1 error, "
      "2 configuration error, 3 run directory in use, 130 interrupted (resumable).");
  auto args = std::make_shared<RunArgs>();
  run->add_option("args", args->args,
                  "[CONFIG.yaml] [key=value ...] (see 'drops config --markdown')");
  run->add_option("--seed", args->seed, "seed of the run (same as seed=N)");
  run->add_option("--threads", args->threads, "worker threads, 0 = all (same as threads=N)");
  run->add_option("--output", args->output, "parent directory of the run directory (default runs)");
  run->add_option("--name", args->name, "name of the run directory");
  run->add_option("--resume", args->resume,
                  "continue the interrupted run in this directory from its last finished episode "
                  "(same results as an uninterrupted run; episodes=N may extend it); a run with "
                  "no finished episode starts from its beginning there");
  run->add_flag("-q,--quiet", args->quiet, "only the final line on stderr");
  run->callback([&action, &registry, args] {
    action = [&registry, args] { return run_main(registry, *args); };
  });
}

void add_config_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* config = app.add_subcommand(
      "config", "Print the resolved configuration (defaults, a config file and overrides applied)");
  auto args = std::make_shared<std::vector<std::string>>();
  auto markdown = std::make_shared<bool>(false);
  config->add_option("args", *args, "[CONFIG.yaml] [key=value ...]");
  config->add_flag("--markdown", *markdown, "print every key of every task as Markdown tables");
  config->callback([&action, &registry, args, markdown] {
    action = [&registry, args, markdown] {
      if (*markdown) {
        // The schema is the same whatever the configuration: a file or key=value given with it
        // would be silently ignored.
        if (!args->empty()) {
          std::string given;
          for (const auto& a : *args) given += (given.empty() ? "'" : " '") + a + "'";
          throw ConfigError("--markdown prints the schema of every task and takes no config file "
                            "or key=value; drop " + given);
        }
        std::cout << experiment::schema_markdown(registry);
        return 0;
      }
      std::string file;
      std::vector<std::string> overrides;
      split_args(*args, file, overrides);
      const auto s = settings_from(registry, file, overrides);
      make_experiment_from(registry, s, file);  // full validation
      std::cout << experiment::to_yaml(registry, s);
      return 0;
    };
  });
}

}  // namespace drops::app
