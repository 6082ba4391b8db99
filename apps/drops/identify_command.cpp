// `drops identify CONFIG [key=value ...]`: a model learned from recorded logs, without a policy
// search (experiment::identify), written to <output>/<name>/.

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/identify.hpp"
#include "figures.hpp"

namespace drops::app {

namespace {

struct IdentifyArgs {
  std::vector<std::string> args;
  bool quiet = false;
  bool no_figures = false;
};

int identify_main(const experiment::Registry& registry, const IdentifyArgs& a) {
  std::vector<std::string> overrides;
  std::string file;
  split_args(a.args, file, overrides);
  const experiment::Settings settings = settings_from(registry, file, overrides);
  auto say = [&](const std::string& line) {
    if (!a.quiet) std::cerr << "drops identify: " << line << "\n";
  };
  const experiment::IdentifyRun run = experiment::identify_from_settings(
      registry, settings, say, [&](const std::string& phase, int evaluations, double best) {
        if (!a.quiet)
          std::cerr << fmt::format("drops identify: {} {} evaluations, best {:.6g}\n", phase,
                                   evaluations, best);
      });
  const auto& result = run.result;
  const auto& dir = run.directory;
  if (!a.no_figures) {
    try {
      plot_identify(dir);
    } catch (const Error& e) {
      throw Error(
          fmt::format("{} (the tables and the model are written in {}; --no-figures "
                      "skips the figures)",
                      e.what(), dir.string()));
    }
  }
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
      "errors.csv, model.json with data.csv, report.md, validation-NN.png, phi.png; prints its "
      "path. Exit codes: 0 done, "
      "1 error (a log's error names the file, line and column), 2 configuration error (also a "
      "log without a declared column).");
  auto args = std::make_shared<IdentifyArgs>();
  cmd->add_option("args", args->args, "CONFIG.yaml [key=value ...] (see 'drops config --markdown')")
      ->required();
  cmd->add_flag("-q,--quiet", args->quiet, "no progress lines");
  cmd->add_flag("--no-figures", args->no_figures,
                "no validation-NN.png and phi.png (they need /usr/bin/python3 with matplotlib)");
  cmd->callback([&action, &registry, args] {
    action = [&registry, args] { return identify_main(registry, *args); };
  });
}

}  // namespace drops::app
