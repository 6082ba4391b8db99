// `drops report` and `drops plot` are being written (issue 3); this file registers them meanwhile.
#include "command.hpp"
namespace drops::app {
void add_report_command(CLI::App& app, Action& action) {
  auto* c = app.add_subcommand("report", "(not available yet)");
  c->callback([&action] { action = [] { return 1; }; });
}
void add_plot_command(CLI::App& app, Action& action) {
  auto* c = app.add_subcommand("plot", "(not available yet)");
  c->callback([&action] { action = [] { return 1; }; });
}
}  // namespace drops::app
