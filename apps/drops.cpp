// The drops command line. Each subcommand lives in its own apps/*.cpp (see command.hpp):
//   run       Algorithm 1 on one configured experiment (run_command.cpp), also --resume DIR
//   config    the resolved configuration or the schema as Markdown (run_command.cpp)
//   campaign  a grid of runs in parallel processes or over MPI (campaign.cpp)
//   report    aggregated tables and figures of a campaign (report.cpp)
//   plot      figures of one run (report.cpp)
//   direct    the policy optimized on the real system, no model (direct_command.cpp)

#include <iostream>

#include "command.hpp"
#include "drops/core/errors.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "drops: data-efficient robot learning with black-box simulator priors\n"
      "(Black-DROPS with GP-MI, Chatzilygeroudis & Mouret, ICRA 2018)"};
  app.set_version_flag("--version", "drops 0.1.0");
  app.require_subcommand(1);
  drops::app::Action action;
  drops::app::add_run_command(app, action);
  drops::app::add_config_command(app, action);
  drops::app::add_campaign_command(app, action);
  drops::app::add_report_command(app, action);
  drops::app::add_plot_command(app, action);
  drops::app::add_direct_command(app, action);
  CLI11_PARSE(app, argc, argv);
  try {
    return action ? action() : 0;
  } catch (const drops::ConfigError& e) {
    std::cerr << "drops: configuration error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "drops: error: " << e.what() << "\n";
    return 1;
  }
}
