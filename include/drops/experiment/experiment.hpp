#pragma once
/// \file An experiment resolved from its settings: the task built by its plugin and the algorithm
/// built by its plugin, plus what every run records (seed, threads, names).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "drops/algo/black_drops.hpp"
#include "drops/algo/direct_search.hpp"
#include "drops/algo/ite.hpp"
#include "drops/algo/pilco.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/keys.hpp"
#include "drops/experiment/registry.hpp"

namespace drops::experiment {

/// The values of the base keys (base_keys()): the experiment's own and Algorithm 1's. Each field
/// that a key sets is declared with that key once, in base_key_table(); the default member
/// initialisers here (and those of the options structs inside) are the keys' defaults.
struct BaseOptions {
  std::string task;             ///< key task ("" = the registry's first task)
  std::string algorithm;        ///< key algorithm ("" = the registry's first algorithm)
  int threads = 0;              ///< key threads: worker threads, 0 = all hardware threads
  std::string output = "runs";  ///< key output: parent directory of run directories
  std::string name;             ///< key name: run directory name ("" = default_run_name)
  /// Algorithm 1's options (keys seed, episodes, model.*, policy.bound, optimizer.*, rollouts.*);
  /// the other algorithms take their seed, episodes, policy bound and CMA-ES settings from here.
  algo::BlackDropsOptions black_drops;
  /// Key model.type: a model variant registered in the Registry (its factory is looked up there).
  std::string model_type = model::to_string(black_drops.model.type);
};

/// The declarations of the base keys, bound to BaseOptions' fields (base_keys() are its specs()).
/// Thread-safe.
const KeyTable<BaseOptions>& base_key_table();

/// The keys of the network policy (policy::NeuralNetPolicyOptions: policy.hidden_units) for a
/// task whose policy family it is: the task includes them in its own table (KeyTable::include)
/// or declares them with its own defaults (specs(options)). Thread-safe.
const KeyTable<policy::NeuralNetPolicyOptions>& neural_net_policy_key_table();

/// The base keys' values of validated settings (load_settings). Throws ConfigError naming the key
/// for a value that does not convert. Thread-safe.
BaseOptions base_options(const Settings& settings);

/// The experiment described by settings (make_experiment).
struct Experiment {
  Settings settings;          ///< resolved, every key of the task's schema
  std::string task;           ///< task name
  std::string algorithm;      ///< algorithm name
  std::string variant;        ///< AlgorithmPlugin::variant (e.g. "gp_mi")
  VariantStyle variant_style;  ///< AlgorithmPlugin::variant_style (label, order, colour)
  bool uses_prior = true;     ///< AlgorithmPlugin::uses_prior
  bool uses_model = true;     ///< AlgorithmPlugin::uses_model
  // seed, threads, output, name: the keys' values (their defaults: BaseOptions').
  std::uint64_t seed = 0;     ///< key seed: the run's seed
  int threads = 0;            ///< key threads: 0 = all hardware threads
  std::string output;         ///< key output: parent directory of run directories
  std::string name;           ///< key name: run directory name ("" = default_run_name())
  TaskSetup setup;
  ReportInfo report;          ///< run_report_info of TaskPlugin::report_info of the settings
  std::unique_ptr<algo::Algorithm> runner;  ///< the configured algorithm
  /// Makes the files of the algorithm's side state for a run directory (AlgorithmPlugin::
  /// state_files); empty when the algorithm keeps none.
  StateFilesFactory state_files;
  /// "<task>-<variant>-<prior>-seed<seed>" (without the prior when the algorithm uses none),
  /// followed by "-" and `stamp` when not empty.
  std::string default_run_name(const std::string& stamp) const;
};

/// Whether `s` is a name drops accepts for one directory of its own: a run directory (key name), a
/// prior's label in a default run name, a campaign: 1 to 200 characters of ASCII letters,
/// digits, '_', '.' and '-', the first a letter, a digit or '_' (so never ".", "..", a hidden
/// name, an option-like "-x", a path with '/' or an absolute path). Thread-safe.
bool is_directory_name(const std::string& s);
/// Whether `s` is a name drops accepts for a column of its files (a state, an action, a state
/// extra, a metric, a prior parameter phi_i): 1 to 64 characters of ASCII letters, digits, '_'
/// and '.', the first a letter or '_' (e.g. "theta1", "Link2.mass"). Thread-safe.
bool is_column_name(const std::string& s);
/// The trajectory files' own columns, which no state, action or extra may be named: "t" and
/// "reward".
inline const std::vector<std::string>& reserved_trajectory_columns() {
  static const std::vector<std::string> k = {"t", "reward"};
  return k;
}
/// Checks the names of a task's files (TaskSetup): state, action and extra names, metric names
/// and the prior's parameter names follow is_column_name; the trajectory columns (states,
/// actions, extras) are distinct and none is reserved; metric and parameter names are distinct;
/// the prior's label follows is_directory_name when `uses_prior`. Throws InvalidArgument naming
/// the task, the list and the name. Thread-safe.
void check_setup_names(const std::string& task, const TaskSetup& setup, bool uses_prior);

/// Builds the experiment of validated settings (load_settings): the task (TaskPlugin::make) and
/// the algorithm (AlgorithmPlugin::make). Throws ConfigError for combinations the schema cannot
/// check alone (the message names the key), among them a key name that is not a directory name
/// (is_directory_name) or an output path with a NUL character, and InvalidArgument for a task
/// whose names break the run files (check_setup_names). With prior.model set, the task's prior
/// is the description file's (make_description_prior, TaskSetup::joints); prior.parameters
/// without prior.model is a ConfigError.
Experiment make_experiment(const Registry& registry, const Settings& settings);

/// The options of Algorithm 1 from settings (model.*, policy.bound, optimizer.*, rollouts.*,
/// episodes, seed), with the factory of the model variant of model.type registered in
/// `registry`. Throws ConfigError when they are invalid (BlackDropsOptions::IsValid) or the
/// model variant is not registered.
algo::BlackDropsOptions black_drops_options(const Registry& registry, const Settings& settings);

/// IT&E's behaviour descriptor of a task: its "ite" entry in TaskSetup::algorithm_data, or null
/// when the task offers none. Throws drops::Error when that entry has another type.
const ite::BehaviourDescriptor* task_behaviour(const TaskSetup& setup);
/// The file in which the archive cache (ite.archive_cache) keeps the archive of these settings:
/// DIR/TASK-PRIOR-seedSEED-HASH.csv, HASH over every setting that can change the archive (the
/// real system's keys and the adaptation's do not). A complete archive file put there is what a
/// run of these settings adapts with. Throws ConfigError when ite.archive_cache is empty.
/// Thread-safe.
std::filesystem::path ite_archive_cache_file(const Settings& settings, const TaskSetup& setup);
/// The options of IT&E from settings (ite.*, policy.bound, episodes, seed) and the task's
/// behaviour descriptor (task_behaviour); reads the archive file of ite.archive. Throws
/// ConfigError naming the task when it has no behaviour descriptor, and naming the key for an
/// invalid value or an archive file that cannot be read or does not fit the task.
algo::IteOptions ite_options(const Settings& settings, const TaskSetup& setup);
/// The options of PILCO (with_prior false) or PILCO with priors from settings (pilco.*, episodes,
/// seed). Throws ConfigError when they are invalid (PilcoOptions::IsValid). Thread-safe.
algo::PilcoOptions pilco_options(const Settings& settings, bool with_prior);

/// The CMA-ES options of the optimizer.* keys. Thread-safe.
opt::CmaesOptions cmaes_options(const Settings& settings);

}  // namespace drops::experiment
