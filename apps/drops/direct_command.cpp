// `drops direct`: `drops run algorithm=direct` under its own name, with the options the direct
// search had before it was an algorithm (--evaluations, --start).

#include <optional>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"

namespace drops::app {

int run_experiment(const experiment::Registry& registry, const experiment::Settings& settings,
                   const std::string& source, const std::string& resume_dir, bool quiet);

namespace {

struct DirectArgs {
  std::vector<std::string> args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::optional<long> evaluations;
  std::string output, name, start;
  bool quiet = false;
};

int direct_main(const experiment::Registry& registry, const DirectArgs& a) {
  std::vector<std::string> overrides;
  std::string file;
  split_args(a.args, file, overrides);
  overrides.insert(overrides.begin(), "algorithm=direct");
  if (a.seed) overrides.push_back("seed=" + std::to_string(*a.seed));
  if (a.threads) overrides.push_back("threads=" + std::to_string(*a.threads));
  if (a.evaluations)
    overrides.push_back("optimizer.max_evaluations=" + std::to_string(*a.evaluations));
  if (!a.start.empty()) overrides.push_back("direct.start=" + a.start);
  if (!a.output.empty()) overrides.push_back("output=" + a.output);
  if (!a.name.empty()) overrides.push_back("name=" + a.name);
  experiment::Settings settings;
  try {
    settings = settings_from(registry, file, overrides);
  } catch (const ConfigError& e) {
    // The range of --evaluations is optimizer.max_evaluations's: name the option that set it.
    const std::string what = e.what();
    if (a.evaluations && what.find("'optimizer.max_evaluations'") != std::string::npos)
      throw ConfigError("--evaluations " + std::to_string(*a.evaluations) + " sets " + what);
    throw;
  }
  return run_experiment(registry, settings, file, "", a.quiet);
}

}  // namespace

void add_direct_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* cmd = app.add_subcommand(
      "direct",
      "Optimize the policy directly on the \"real\" system with BIPOP-CMA-ES, one real episode "
      "per evaluation and no model (a model-free baseline; with a large budget, the ceiling of "
      "the policy family): the same as 'drops run algorithm=direct'. Every episode is a row of "
      "the run directory's episodes.csv; the ones that improved on the best keep their "
      "trajectories. Exit codes: 0 done, 1 error, 2 configuration error, 130 interrupted.");
  auto args = std::make_shared<DirectArgs>();
  cmd->add_option("args", args->args,
                  "[CONFIG.yaml] [key=value ...] (see 'drops config --markdown')");
  cmd->add_option("--evaluations", args->evaluations,
                  "real episodes at most (same as optimizer.max_evaluations=N)");
  cmd->add_option("--start", args->start,
                  "start point: a file of policy parameters, one per line (e.g. a run's "
                  "episodes/NNN/policy.csv); evaluated first and kept if the search does not beat "
                  "it (same as direct.start=FILE; default: the centre of the box)");
  cmd->add_option("--seed", args->seed, "seed of the search (same as seed=N)");
  cmd->add_option("--threads", args->threads, "worker threads, 0 = all (same as threads=N)");
  cmd->add_option("--output", args->output, "parent directory of the run directory (default runs)");
  cmd->add_option("--name", args->name,
                  "name of the run directory (default <task>-direct-seed<seed>-<time>)");
  cmd->add_flag("-q,--quiet", args->quiet, "only the final line on stderr");
  cmd->callback([&action, &registry, args] {
    action = [&registry, args] { return direct_main(registry, *args); };
  });
}

}  // namespace drops::app
