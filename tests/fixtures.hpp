#pragma once
// What the tests share: a registry with the built-in algorithms and the pendubot (the task that
// most tests learn on), and the pendubot experiment of some overrides.
#include <memory>
#include <string>
#include <vector>

#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"

namespace drops::fixtures {

/// The built-in algorithms and the pendubot.
inline const experiment::Registry& registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    pendubot::register_task(*reg);
    return reg;
  }();
  return *r;
}

/// The settings of a YAML text and overrides (experiment::load_settings).
inline experiment::Settings settings(const std::string& yaml,
                                     const std::vector<std::string>& overrides = {}) {
  return experiment::load_settings(registry(), yaml, overrides);
}

/// The pendubot experiment of `overrides` (the drops command line's defaults otherwise).
inline experiment::Experiment experiment(const std::vector<std::string>& overrides = {},
                                         const std::string& yaml = "") {
  return experiment::make_experiment(registry(), settings(yaml, overrides));
}

}  // namespace drops::fixtures
