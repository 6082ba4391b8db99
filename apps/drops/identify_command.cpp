// `drops identify CONFIG [key=value ...]`: a model learned from recorded logs, without a policy
// search (experiment::identify), written to <output>/<name>/.

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/identify.hpp"

namespace drops::app {

namespace {

struct IdentifyArgs {
  std::vector<std::string> args;
  bool quiet = false;
};

int identify_main(const experiment::Registry& registry, const IdentifyArgs& a) {
  std::vector<std::string> overrides;
  std::string file;
  split_args(a.args, file, overrides);
  const experiment::Settings settings = settings_from(registry, file, overrides);
  const experiment::BaseOptions base = experiment::base_options(settings);
  const std::string task_name = settings.at("task");
  experiment::TaskSetup setup = registry.task(task_name).make(settings);
  const experiment::ModelVariant& variant = registry.model_variant(base.model_type);
  experiment::IdentifyModel what;
  what.type = variant.name;
  what.factory = variant.factory;
  what.uses_prior = variant.uses_prior;
  what.options = experiment::black_drops_options(registry, settings).model;
  what.task = setup.task;
  what.prior = setup.prior;
  what.parameters = setup.prior_parameters;
  std::vector<std::string> states = setup.state_names, actions = setup.action_names;
  for (int i = static_cast<int>(states.size()); i < setup.task->state_dim(); ++i)
    states.push_back("x_" + std::to_string(i + 1));
  for (int i = static_cast<int>(actions.size()); i < setup.task->action_dim(); ++i)
    actions.push_back("u_" + std::to_string(i + 1));
  const experiment::IdentifyOptions options =
      experiment::identify_options(settings, setup.task->dt(), states, actions);
  const std::string name =
      base.name.empty() ? fmt::format("identify-{}-{}", task_name, variant.name) : base.name;
  if (!experiment::is_directory_name(name))
    throw ConfigError("config key 'name' = '" + name + "' is not a directory name");
  const std::filesystem::path dir = std::filesystem::path(base.output) / name;
  auto say = [&](const std::string& line) {
    if (!a.quiet) std::cerr << "drops identify: " << line << "\n";
  };
  say(fmt::format("task {}, model {}, dt {} s, {} fit and {} validation log(s)", task_name,
                  variant.name, setup.task->dt(), options.logs.size(),
                  options.validation.size()));
  const auto result = experiment::identify(
      what, options, say, [&](const std::string& phase, int evaluations, double best) {
        if (!a.quiet)
          std::cerr << fmt::format("drops identify: {} {} evaluations, best {:.6g}\n", phase,
                                   evaluations, best);
      });
  const auto files = experiment::write_identify_directory(
      dir, result, options, experiment::to_yaml(registry, settings));
  if (!a.quiet) std::cerr << result.summary.BriefReport();
  std::cout << dir.string() << "\n";
  return 0;
}

}  // namespace

void add_identify_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* cmd = app.add_subcommand(
      "identify",
      "Learn a dynamics model (model.type: gp, gp_prior, gp_mi, mi) from recorded logs, without "
      "a policy search, and measure it on validation logs: the task gives the prior and the "
      "state and action names, identify.* the logs and their columns (docs/identify.md). "
      "Writes <output>/<name>/ (default name identify-<task>-<model.type>): phi.csv, "
      "errors.csv, model.json with data.csv, report.md; prints its path. Exit codes: 0 done, "
      "1 error (a log's error names the file, line and column), 2 configuration error.");
  auto args = std::make_shared<IdentifyArgs>();
  cmd->add_option("args", args->args, "CONFIG.yaml [key=value ...] (see 'drops config --markdown')")
      ->required();
  cmd->add_flag("-q,--quiet", args->quiet, "no progress lines");
  cmd->callback([&action, &registry, args] {
    action = [&registry, args] { return identify_main(registry, *args); };
  });
}

}  // namespace drops::app
