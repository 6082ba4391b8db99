#pragma once
// The documented ranges are what validation accepts: a check over a task's schema, shared by the
// tests of every task (tests/test_config.cpp, tasks/hexapod/tests/test_hexapod_plugin.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"

namespace drops::fixtures {

/// v as YAML reads it back exactly (17 significant digits).
inline std::string exact_text(double v) {
  std::ostringstream o;
  o.precision(17);
  o << v;
  return o.str();
}

/// For every numeric key (int, double, interval) with a range of `task`'s schema: the experiment's
/// and the task's keys with the default algorithm, each algorithm's own keys with that algorithm
/// (the algorithms the task supports: their experiment with default values builds).
/// Both ends of the range (an interval: [min, max]) must build an experiment (make_experiment
/// throws no ConfigError), and a value just outside (min - 1 or max + 1 for an int, a relative
/// 1e-9 beyond for a double, an interval reaching beyond either end) must be refused by
/// load_settings with a message naming the key. `context(key)` gives the overrides another key
/// needs to make room (constraints between keys). Returns the number of accepted values checked;
/// failures are reported through gtest.
inline int check_documented_ranges(
    const experiment::Registry& registry, const std::string& task,
    const std::function<std::vector<std::string>(const std::string& key)>& context) {
  std::vector<std::pair<std::string, experiment::KeySpec>> keys;  // (algorithm, key)
  for (const auto& k : experiment::base_keys()) keys.emplace_back("", k);
  for (const auto& a : registry.algorithm_names()) {
    try {  // an algorithm the task does not support (PILCO on a task that does not describe
           // itself to it) has no range to check there
      experiment::make_experiment(
          registry, experiment::load_settings(registry, "", {"task=" + task, "algorithm=" + a}));
    } catch (const ConfigError&) {
      continue;
    }
    for (const auto& k : registry.algorithm(a).keys()) keys.emplace_back(a, k);
  }
  for (const auto& k : registry.task(task).keys()) keys.emplace_back("", k);
  int checked = 0;
  for (const auto& [algorithm, k] : keys) {
    if (!(k.min < k.max) || (k.type != "int" && k.type != "double" && k.type != "interval"))
      continue;
    auto value = [&](double lo, double hi) {
      if (k.type == "interval") return "[" + exact_text(lo) + ", " + exact_text(hi) + "]";
      return k.type == "int" ? std::to_string(static_cast<long long>(lo)) : exact_text(lo);
    };
    auto step = [&](double v) { return k.type == "int" ? 1.0 : 1e-9 * std::max(1.0, std::abs(v)); };
    const double below = k.min - step(k.min), above = k.max + step(k.max);
    std::vector<std::string> inside{value(k.min, k.max)}, outside;
    if (k.type == "interval") {
      outside = {value(below, k.max), value(k.min, above)};
    } else {
      inside.push_back(value(k.max, k.max));
      for (const double v : {below, above})
        if (k.type != "int" || std::abs(v) < 9e15) outside.push_back(value(v, v));  // exact ints
    }
    std::vector<std::string> base{"task=" + task};
    if (!algorithm.empty()) base.push_back("algorithm=" + algorithm);
    for (auto& c : context(k.key)) base.push_back(std::move(c));
    for (const auto& v : inside) {
      auto ov = base;
      ov.push_back(k.key + "=" + v);
      std::string what;
      try {
        experiment::make_experiment(registry, experiment::load_settings(registry, "", ov));
      } catch (const ConfigError& e) {
        what = e.what();
      }
      EXPECT_EQ(what, "") << k.key << " = " << v;
      ++checked;
    }
    for (const auto& v : outside) {
      auto ov = base;
      ov.push_back(k.key + "=" + v);
      std::string what;
      try {
        experiment::load_settings(registry, "", ov);
      } catch (const ConfigError& e) {
        what = e.what();
      }
      EXPECT_NE(what.find(k.key), std::string::npos) << k.key << " = " << v << ": " << what;
    }
  }
  return checked;
}

}  // namespace drops::fixtures
