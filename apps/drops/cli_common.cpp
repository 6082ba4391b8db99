// Shared command-line pieces (cli_common.hpp).

#include "cli_common.hpp"

#include <atomic>
#include <csignal>

#include "drops/core/errors.hpp"

namespace drops::app {
namespace {

std::atomic<int> g_interrupts{0};

extern "C" void on_sigint(int) {
  if (g_interrupts.fetch_add(1) >= 1) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
}

}  // namespace

void split_args(const std::vector<std::string>& args, std::string& file,
                std::vector<std::string>& overrides) {
  for (const auto& a : args) {
    if (a.find('=') != std::string::npos) {
      overrides.push_back(a);
    } else if (file.empty()) {
      file = a;
    } else {
      throw ConfigError("more than one config file given ('" + file + "' and '" + a +
                        "'); overrides are written key=value");
    }
  }
}

experiment::Settings settings_from(const experiment::Registry& registry, const std::string& file,
                                   const std::vector<std::string>& overrides) {
  if (file.empty()) return experiment::load_settings(registry, "", overrides);
  // A run directory's config.yaml repeats that run, also when it predates a key (see
  // experiment::load_run_settings).
  return experiment::is_run_config(file)
             ? experiment::load_run_settings_file(registry, file, overrides)
             : experiment::load_settings_file(registry, file, overrides);
}

void install_interrupt_handler() {
  g_interrupts = 0;
  std::signal(SIGINT, on_sigint);
}

bool interrupt_requested() { return g_interrupts.load() > 0; }

}  // namespace drops::app
