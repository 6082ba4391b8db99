// drops::cli::run: the command line over a registry of tasks and algorithms.
#include "drops/cli.hpp"

#include <iostream>

#include "command.hpp"
#include "drops/core/errors.hpp"


namespace drops::cli {

int run(int argc, char** argv, const experiment::Registry& registry, const std::string& program) {
  CLI::App app{program +
               ": data-efficient robot learning with black-box simulator priors\n"
               "(Black-DROPS with GP-MI, Chatzilygeroudis & Mouret, ICRA 2018)"};
  app.name(program);
  app.set_version_flag("--version", "drops " DROPS_VERSION);
  app.require_subcommand(1);
  app::Action action;
  app::add_run_command(app, action, registry);
  app::add_config_command(app, action, registry);
  app::add_campaign_command(app, action, registry);
  app::add_report_command(app, action, registry);
  app::add_plot_command(app, action, registry);
  app::add_direct_command(app, action, registry);
  app::add_identify_command(app, action, registry);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::ParseError& e) {
    // A word that names no subcommand (`drops foo`): CLI11 would only say that one is required.
    if (app.get_subcommands().empty())
      for (const auto& word : app.remaining())
        if (!word.empty() && word[0] != '-') {
          std::string names;
          for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
            names += (names.empty() ? "" : ", ") + sub->get_name();
          std::cerr << program << ": unknown subcommand '" << word << "' (available: " << names
                    << ")\nRun with --help for more information.\n";
          return 2;
        }
    app.exit(e);  // prints the usage error
    return 2;     // usage errors are configuration errors (CLI11's own codes are 100+)
  }
  try {
    return action ? action() : 0;
  } catch (const ConfigError& e) {
    std::cerr << program << ": configuration error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace drops::cli
