// Shared command-line pieces (cli_common.hpp).

#include "cli_common.hpp"

#include <atomic>
#include <csignal>
#include <signal.h>

#include "drops/core/errors.hpp"

namespace drops::app {
namespace {

std::atomic<int> g_interrupts{0};

// SIGINT (Ctrl-C) and SIGTERM (kill, a batch system's time limit) alike: the first asks the run to
// stop after its current step, a second one ends the process at once with that signal.
extern "C" void on_stop_signal(int sig) {
  if (g_interrupts.fetch_add(1) >= 1) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
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
  return experiment::load_settings_file(registry, file, overrides);
}

experiment::Experiment make_experiment_from(const experiment::Registry& registry,
                                            const experiment::Settings& settings,
                                            const std::string& source) {
  return experiment::make_experiment(registry, settings, source);
}

void install_interrupt_handler() {
  g_interrupts = 0;
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool interrupt_requested() { return g_interrupts.load() > 0; }

}  // namespace drops::app
