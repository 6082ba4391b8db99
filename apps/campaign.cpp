// `drops campaign` is being written (issue 3); this file registers the subcommand meanwhile.
#include "command.hpp"
namespace drops::app {
void add_campaign_command(CLI::App& app, Action& action) {
  auto* c = app.add_subcommand("campaign", "(not available yet)");
  c->callback([&action] { action = [] { return 1; }; });
}
}  // namespace drops::app
