#pragma once
/// \file Experiment configuration: a schema of every key (type, default, range, unit, meaning)
/// assembled from the sections that the experiment, the algorithms and the tasks contribute (the
/// registry, registry.hpp), YAML loading with key=value overrides, validation with actionable
/// messages, and the resolved settings. docs/configuration.md is generated from the same schema
/// (drops config --markdown).

#include <map>
#include <string>
#include <vector>

namespace drops::experiment {

class Registry;

/// One configuration key.
struct KeySpec {
  std::string key;            ///< dotted path, e.g. "model.type"
  /// "int", "double", "bool", "string", "enum", "names", "interval", "path" (a string; relative:
  /// looked for in the configuration file's directory, then the working directory, and made
  /// absolute by load_settings_file), "list" (any YAML list, e.g. file names or
  /// maps, read by the key's own reader), "numbers" (a list of numbers, each in the range),
  /// "paths" (a list of paths, each resolved as a "path")
  std::string type;
  std::string default_value;  ///< as YAML text ("" = derived, see doc)
  double min = 0, max = 0;    ///< numeric range (inclusive) when min < max
  std::vector<std::string> allowed;  ///< enum values, or the names allowed in a "names" list
  std::string unit;           ///< physical unit or "-"
  std::string doc;            ///< meaning
};

/// A validated set of values for every key of an experiment's schema (defaults filled in), as
/// YAML scalars/sequences in text form, keyed by dotted path.
using Settings = std::map<std::string, std::string>;

/// " (did you mean 'x'?)" naming the candidate closest to word by edit distance (Levenshtein) when
/// it is within 4 edits, else "". Used for every unknown-key message. Thread-safe.
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

/// The keys of the experiment itself (task, algorithm, seed, episodes, threads, output, name) and
/// of the model-based policy search shared by the algorithms (model.*, policy.bound, optimizer.*,
/// rollouts.*), in documentation order: the specs of their declarations (base_key_table(),
/// experiment.hpp), with the defaults of the options structs they set. model.type allows no value
/// here (its values are a registry's model variants, see schema()). Thread-safe.
const std::vector<KeySpec>& base_keys();

/// The schema of an experiment on `task` (a registered task): base_keys() with model.type's
/// values and help from the registry's model variants, every registered algorithm's keys, then
/// the task's own keys; the defaults that the task sets (TaskPlugin::shared_defaults) replace the
/// keys' own, each validated by its key's spec. Throws ConfigError when the task is unknown, or
/// sets the default of a key its schema lacks or a default its key refuses (naming the task, the
/// key and the value).
std::vector<KeySpec> schema(const Registry& registry, const std::string& task);

/// Reads a YAML document (text) and applies key=value overrides (value parsed as YAML, so
/// "prior.bounds.m1=[0.1, 1]" works). The task is the value of `task` after the overrides
/// (default: the registry's default task); its schema (schema()) decides which keys exist. Fills
/// the defaults (the task's schema's; resolve_derived_defaults). Throws ConfigError
/// naming the key, the value and what is allowed for unknown keys, wrong types and out-of-range
/// values. An empty text gives the defaults.
Settings load_settings(const Registry& registry, const std::string& yaml_text,
                       const std::vector<std::string>& overrides);
/// Makes every relative value of a "path" key (and each of a "paths" key) of settings' task
/// absolute, as load_settings_file does for the file it reads: the path beside config_file when
/// that exists, else relative to the working directory. Settings of an unknown task are left as
/// they are. Not thread-safe with a concurrent change of the working directory.
void resolve_path_keys(const Registry& registry, Settings& settings,
                       const std::string& config_file);
/// Reads a YAML file; throws ConfigError when it cannot be read or parsed (with the file name).
/// The value of a "path" key that is relative becomes absolute: the file's directory joined with
/// it when that exists, else the working directory joined with it.
Settings load_settings_file(const Registry& registry, const std::string& path,
                            const std::vector<std::string>& overrides);

/// Replaces the empty value of a key whose default the task sets (TaskPlugin::shared_defaults) by
/// the task's, also for string keys and for settings not read by load_settings (which does it for
/// the others). A default that follows other keys is the key's own (KeyTable's derived()). Leaves
/// settings of an unknown task unchanged. Thread-safe.
void resolve_derived_defaults(const Registry& registry, Settings& settings);

/// Settings as a nested YAML document in schema order (the resolved config written into each run
/// directory). Keys missing from the schema of settings' task are written last, in key order.
std::string to_yaml(const Registry& registry, const Settings& settings);

/// The schema of every registered task as Markdown: the experiment's and algorithms' keys, then one
/// table per task (docs/configuration.md).
std::string schema_markdown(const Registry& registry);

// Typed access to validated settings (keys must exist: std::out_of_range otherwise). A value that
// does not convert (settings that did not come from load_settings) throws ConfigError naming the
// key and the value.
double get_double(const Settings& s, const std::string& key);
long long get_int(const Settings& s, const std::string& key);
bool get_bool(const Settings& s, const std::string& key);
/// The numbers of an "interval" value ("[lower, upper]").
std::vector<double> get_interval(const Settings& s, const std::string& key);
/// The numbers of a "numbers" value ("[0.1, 0.5]").
std::vector<double> get_numbers(const Settings& s, const std::string& key);
/// The entries of a "names" or "list" value ("[a, b]").
std::vector<std::string> get_names(const Settings& s, const std::string& key);

}  // namespace drops::experiment
