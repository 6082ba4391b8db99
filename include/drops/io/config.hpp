#pragma once
/// \file Experiment configuration: a schema of every key (type, default, range, unit, meaning),
/// YAML loading with key=value overrides, validation with actionable messages, and the resolved
/// experiment. docs/configuration.md is generated from the same schema (drops config --markdown).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "pendubot/pendubot.hpp"

namespace drops::io {

/// One configuration key.
struct KeySpec {
  std::string key;         ///< dotted path, e.g. "model.type"
  std::string type;        ///< "int", "double", "bool", "string", "enum", "names", "interval"
  std::string default_value;  ///< as YAML text ("" = derived, see doc)
  double min = 0, max = 0;    ///< numeric range (inclusive) when min < max
  std::vector<std::string> allowed;  ///< enum values, or the names allowed in a "names" list
  std::string unit;        ///< physical unit or "-"
  std::string doc;         ///< meaning
};

/// " (did you mean 'x'?)" naming the candidate closest to word by edit distance (Levenshtein) when
/// it is within 4 edits, else "". Used for every unknown-key message.
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

/// The full schema, in documentation order.
const std::vector<KeySpec>& schema();

/// A validated set of values for every schema key (defaults filled in), as YAML scalars/sequences
/// in text form, keyed by dotted path.
using Settings = std::map<std::string, std::string>;

/// Reads a YAML document (text) and applies key=value overrides (value parsed as YAML, so
/// "prior.bounds.m1=[0.1, 1]" works). Throws ConfigError naming the key, the value and what is
/// allowed for unknown keys, wrong types and out-of-range values. An empty text gives the defaults.
Settings load_settings(const std::string& yaml_text, const std::vector<std::string>& overrides);
/// Reads a YAML file; throws ConfigError when it cannot be read or parsed (with the file name).
Settings load_settings_file(const std::string& path, const std::vector<std::string>& overrides);

/// As load_settings, for the config.yaml of a run directory (every key resolved by the drops that
/// wrote it). A key added to drops after that run was written, whose default changed what a run
/// does, gets the value that reproduces the old behaviour instead of today's default: the policy
/// search keys of 2026-11-22 (optimizer.selection best_seen, optimizer.run_evaluations 0,
/// optimizer.stagnation false, optimizer.tol_fun 1e-12, optimizer.restart_from random). So a
/// resumed or repeated old run goes on as it began, and a campaign sees that it differs from one
/// with today's defaults. Throws as load_settings.
Settings load_run_settings(const std::string& yaml_text, const std::vector<std::string>& overrides);
/// load_run_settings of a file (errors name the file).
Settings load_run_settings_file(const std::string& path, const std::vector<std::string>& overrides);
/// True when `path` is the config.yaml of a run directory (its folder holds episodes.csv or
/// summary.json).
bool is_run_config(const std::string& path);

/// The hexapod's settings (task "hexapod"), as plain values: drops::io does not depend on DART;
/// the app builds the robot, the prior family and the task from them (apps/task_setup.cpp).
/// Legs: -1 none / intact, 0 rear-left, 1 mid-left, 2 front-left, 3 front-right, 4 mid-right,
/// 5 rear-right (settings.md §6).
struct HexapodSettings {
  int horizon = 40;                  ///< control steps of 0.1 s per episode
  int prior_start = -1;              ///< removed leg of the starting prior (-1: intact)
  std::vector<int> prior_choices;    ///< GP-MI's discrete family (sorted, contains prior_start)
  int removed_leg = -1;              ///< the real robot's removed leg
  int shortened_leg = -1;            ///< the real robot's leg with a shortened tibia
  double tibia_factor = 0.5;         ///< that tibia's length / intact length, (0, 1]
  int blocked_leg = -1;              ///< the real robot's leg with a blocked joint
  int blocked_joint = 1;             ///< 0 hip, 1 femur, 2 tibia
  double blocked_angle = 0;          ///< rad
  bool noise = true;                 ///< measurement noise on the real robot's state
  bool guard_clamp = false;          ///< state guard: clamp (true) or stop (false)
};

/// The experiment described by settings.
struct Experiment {
  std::string task = "pendubot";
  std::string prior_preset;
  std::uint64_t seed = 1;
  int threads = 0;
  std::string output = "runs";
  std::string name;
  pendubot::TaskOptions task_options;
  pendubot::Params actual;              ///< the "real" pendubot
  /// The real system's phi in the prior's parametrisation (pendubot: the 6 actual parameters;
  /// hexapod: its removed leg, -1 when intact), for reports.
  std::vector<double> phi_actual;
  HexapodSettings hexapod;              ///< task "hexapod" only
  model::PriorParameters prior;         ///< starting phi, tunable set and bounds
  policy::NeuralNetPolicyOptions policy;
  algo::BlackDropsOptions algo;
};

/// Replaces the empty value of each key whose default depends on the task by that value
/// (policy.bound 5 / 0.5, optimizer.max_evaluations 10000 / 2000,
/// model.rprop.max_length_scale_ratio 100 / 10 for the pendubot / the hexapod), so settings
/// written before a default became task-dependent compare equal to today's. Thread-safe.
void resolve_derived_defaults(Settings& settings);

/// Builds the experiment (after resolve_derived_defaults); throws ConfigError for combinations
/// the schema cannot check alone (e.g. a tunable parameter whose bounds allow a singular prior).
Experiment make_experiment(const Settings& settings);

/// Settings as a nested YAML document (the resolved config written into each run directory).
std::string to_yaml(const Settings& settings);

/// The schema as a Markdown table (docs/configuration.md).
std::string schema_markdown();

}  // namespace drops::io
