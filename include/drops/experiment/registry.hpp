#pragma once
/// \file Tasks and algorithms as plugins. A task (a robot of the paper, your own robot)
/// contributes its configuration keys and builds, from validated settings, everything an
/// experiment needs: the task, the real system, the policy family, the simulator prior and the
/// names the run directory writes. An algorithm contributes its keys and builds an
/// algo::Algorithm. Registration is explicit: the application's main() calls each task's
/// register function (e.g. my_robot::register_task(registry)); nothing registers itself.

#include <any>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/algo/black_drops.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/description_prior.hpp"
#include "drops/experiment/state_files.hpp"

namespace drops::experiment {

/// A per-episode quantity that a task reports next to the return (e.g. a walking robot's
/// speed): one of TaskSetup::metric_names, with how reports label it. Empty name: none.
struct ReportMetric {
  std::string name;   ///< a metric name, e.g. "walking_speed_m_s"
  std::string label;  ///< e.g. "walking speed"
  std::string unit;   ///< e.g. "m/s"
  std::string file;   ///< stem of the report's table and figure, e.g. "speed" (speed.csv, speed.png)
  /// The metric of the model's prediction of the same quantity, drawn beside it (optional), e.g.
  /// "predicted_speed_m_s".
  std::string predicted;
  /// A reference value drawn as a line (NaN: none), e.g. the paper's 0.22 m/s, and its label.
  double reference = std::numeric_limits<double>::quiet_NaN();
  std::string reference_label;
};

/// Where a run appears in a campaign report: one panel per distinct `label`, panels sorted by
/// `rank`, then label (e.g. the priors of the paper's Table I in order, A to D).
struct Panel {
  std::string label;  ///< e.g. "tunable-useful" or "leg5 removed"
  int rank = 0;
  std::string title;  ///< the figure's panel title, e.g. "A: tunable & useful" (empty: label)
  /// Whether the panel is the run's starting prior (e.g. the priors of the paper's Table I). A
  /// run that uses neither a model nor the prior (a direct search) is then drawn in a panel of
  /// its own (model_free_panel()), not under a prior it does not use. False when the panel
  /// describes what every run of it shares whatever the algorithm, e.g. the real robot's damage:
  /// such runs stay in it.
  bool chosen_by_prior = true;
};

/// How figures and tables name a quantity (a component of phi, a trajectory column).
struct Label {
  std::string text;  ///< e.g. "θ₁" or "torque u" (plain Unicode text; empty: the name itself)
  std::string unit;  ///< e.g. "rad", "N·m" (empty: shown without a unit)
};

/// How reports show the runs of a task (TaskPlugin::report_info), recorded in each run's
/// summary.json.
struct ReportInfo {
  Panel panel;                  ///< the run's panel
  ReportMetric metric;          ///< shown next to the return (optional)
  bool success_criterion = true;  ///< whether "solved" means something for this task's reports
  /// Labels of the values of a discrete phi's first entry (e.g. -1 -> "intact", 5 -> "leg5");
  /// not empty exactly when phi is discrete (reports then count runs per value instead of
  /// taking medians).
  std::map<double, std::string> phi_value_labels;
  /// Names of the tunable entries of phi (the plots draw them even when they never change).
  std::vector<std::string> phi_tunable;
  /// Labels and units of phi's entries, by name (TaskSetup::prior_parameters.names). An entry
  /// without one is shown by its name, without a unit.
  std::map<std::string, Label> phi_labels;
  /// Labels and units of the trajectory columns, by name (TaskSetup::state_names, action_names,
  /// state_extra_names). A column without one is shown by its name, without a unit. Figures of a
  /// trajectory with more than 12 state and action columns draw only the labelled states.
  std::map<std::string, Label> column_labels;
};

/// The panel of runs that use neither a model nor the task's prior when the task's panels are
/// chosen by the prior (Panel::chosen_by_prior): label "no model", drawn after the task's panels.
Panel model_free_panel();
/// The report information of one run: `task` (TaskPlugin::report_info of its settings) with the
/// panel replaced by model_free_panel() when the run uses neither a model nor the prior and the
/// task's panel is chosen by the prior. Thread-safe.
ReportInfo run_report_info(ReportInfo task, bool uses_prior, bool uses_model);

/// How reports show a variant (a model variant of Black-DROPS, or an algorithm): its name in
/// legends, its place in tables and figures, its colour in figures. Recorded in each run's
/// summary.json ("variant_style"), so that reports and figures need no list of variants.
struct VariantStyle {
  static constexpr int kUnranked = 100;  ///< the rank of a variant that states none
  std::string label;     ///< legend name, e.g. "Black-DROPS with GP-MI" (empty: the variant's name)
  int rank = kUnranked;  ///< order in reports, >= 0: lower first, equal ranks by name
  /// Figure colour "#rrggbb" (empty: one that the figure's other variants leave free).
  std::string colour;
  /// Returns true when rank >= 0 and colour is empty or "#" and 6 hex digits; otherwise false and
  /// the reason in *why.
  bool IsValid(std::string* why) const;
};

/// A model variant of Black-DROPS (paper Algorithm 1): what `model.type: NAME` selects. The
/// built-in ones (gp, gp_prior, gp_mi, mi) are registered by register_builtin_algorithms; a model
/// of one's own is registered the same way (Registry::add_model_variant) and then selected by
/// its name, reported under its style.
struct ModelVariant {
  std::string name;         ///< the value of model.type, [a-z0-9_]+
  std::string description;  ///< one line for the help of model.type, e.g. "Black-DROPS with MI"
  VariantStyle style;       ///< how reports show its runs
  /// Whether the model uses the task's simulator prior: the task must then have one, episode 1
  /// plans on the prior alone (model::make_prior_only_model) and run names carry the prior's
  /// label; a variant without it never sees the prior (its factory gets null).
  bool uses_prior = true;
  /// Builds the model once per run (BlackDropsOptions::model_factory) from the model.* options,
  /// the task, the prior and its starting parameters. Called from the thread that runs the
  /// algorithm.
  algo::ModelFactory factory;
};

/// What a task offers particular algorithms (TaskSetup::algorithm_data): one entry per algorithm
/// that needs more than the task, the real system, the policy and the prior, of a type that
/// algorithm defines, under the algorithm's name. A new algorithm brings its own entry type
/// without a change to TaskSetup. Setting is not thread-safe; finding is.
class AlgorithmData {
 public:
  /// Sets (or replaces) the entry of `algorithm` to `value`.
  template <class T>
  void set(const std::string& algorithm, T value) {
    entries_[algorithm] = std::move(value);
  }
  /// The entry of `algorithm`, or null when the task gave none. Throws drops::Error when the
  /// entry is not a T (the task and the algorithm disagree on its type).
  template <class T>
  const T* find(const std::string& algorithm) const {
    const auto it = entries_.find(algorithm);
    if (it == entries_.end()) return nullptr;
    const T* value = std::any_cast<T>(&it->second);
    if (!value)
      throw Error("the task's entry for algorithm '" + algorithm + "' is a " +
                  it->second.type().name() + ", not the type the algorithm reads");
    return value;
  }
  /// Removes the entry of `algorithm` (no-op when there is none).
  void erase(const std::string& algorithm) { entries_.erase(algorithm); }

 private:
  std::map<std::string, std::any> entries_;
};

/// Everything an experiment needs about its task, built by TaskPlugin::make.
struct TaskSetup {
  std::shared_ptr<const rollout::Task> task;
  std::unique_ptr<rollout::System> real;     ///< the "real" system
  std::unique_ptr<policy::Policy> policy;    ///< the policy family (parameters set by the algorithm)
  std::shared_ptr<const model::MeanFunction> prior;  ///< the simulator prior M(x, u; phi)
  model::PriorParameters prior_parameters;   ///< starting phi, tunable set and bounds
  std::vector<double> phi_actual;  ///< the real system's phi in the prior's parametrisation (reports)
  std::string prior_label;         ///< short name of the starting prior (run names, summaries)
  /// Column names of the trajectory files: state (dim E) and action (dim U). Left empty,
  /// make_experiment names them x_1..x_E and u_1..u_U.
  std::vector<std::string> state_names, action_names;
  /// Names of the task's per-episode metrics, appended to episodes.csv and summary.json (may be
  /// empty). metrics(record) returns one value per name; it is called once per episode, in order,
  /// from the thread that runs the algorithm.
  std::vector<std::string> metric_names;
  std::function<std::vector<double>(const algo::EpisodeRecord&)> metrics;
  /// Extra columns of the trajectory files computed from each state (e.g. a legged robot's foot
  /// heights for the gait diagram); names and a function of the state (dim E) returning one value
  /// per name. May be empty.
  std::vector<std::string> state_extra_names;
  std::function<std::vector<double>(const VectorXd&)> state_extras;
  /// The task's keys that change only the real system, not the task, the policy family or the
  /// prior (e.g. a robot's damage): settings that differ only in them share an IT&E archive
  /// (ite.archive_cache). Empty: every task key is assumed to matter.
  std::vector<std::string> real_system_keys;
  /// What the task offers particular algorithms beyond the pieces above, each algorithm's own
  /// type under its own name: the built-in ones read "ite" (ite::BehaviourDescriptor, IT&E's
  /// behaviour descriptor, computed on episodes of the prior at the starting phi) and "pilco"
  /// (pilco::TaskModel: angles, the inputs of the policy and the GP in PILCO's augmented space,
  /// the cost's target and distance, Sigma_0; read by pilco and pilco_prior). An algorithm
  /// refuses a task without its entry with a ConfigError.
  AlgorithmData algorithm_data;
  /// What the task declares beyond what the library reads from task, policy and prior (task_record
  /// in run_directory.hpp), as name -> text: e.g. a task written in Python records its classes,
  /// its policy's max_action and observation scale. Recorded in the run directory and compared
  /// when a run is resumed. May be empty.
  std::map<std::string, std::string> declaration;
  /// How the task's state and action map onto a robot description file's joints, for a task
  /// that offers a description-file prior (it includes description_prior_keys() in its keys):
  /// with prior.model set, make_experiment replaces `prior`, `prior_parameters` and
  /// `phi_actual` (unknown: NaN) by the file's (make_description_prior). Empty: none.
  std::optional<JointDeclaration> joints;
  /// The recorded transitions of data.logs (read_run_data), filled by make_experiment after
  /// TaskPlugin::make (a task leaves it empty); an algorithm whose plugin takes recorded data
  /// (AlgorithmPlugin::takes_recorded_data) starts its data with them.
  std::vector<Transition> recorded_data;
  bool keep_first_episode = false;  ///< data.keep_first_episode
  /// The problem the algorithm runs on (pointers into this setup).
  algo::Problem problem() const;
};

/// A task: its configuration section and the factory of its TaskSetup.
class TaskPlugin {
 public:
  virtual ~TaskPlugin() = default;
  /// The value of the `task` key, e.g. "cartpole"; [a-z0-9_]+.
  virtual std::string name() const = 0;
  /// One line for help texts and docs.
  virtual std::string description() const = 0;
  /// The task's own keys (they exist only in experiments on this task). Each key must be new: no
  /// base or algorithm key, no other task's key.
  virtual std::vector<KeySpec> keys() const = 0;
  /// The task's defaults of keys it does not declare (base keys such as policy.bound or
  /// model.gp_mi.score, algorithm keys such as ite.evaluations), as YAML text: they replace the
  /// keys' declared defaults in the task's schema (schema()), validated by the keys' specs, and
  /// are listed in its section of the Markdown. Keys not named keep their declared defaults.
  virtual std::map<std::string, std::string> shared_defaults() const { return {}; }
  /// Builds the task from validated settings. Throws ConfigError naming the key when the settings
  /// describe something impossible.
  virtual TaskSetup make(const Settings& settings) const = 0;
  /// The starting prior's short name (run names, summaries), without building anything.
  virtual std::string prior_label(const Settings& settings) const = 0;
  /// How reports show a run of these settings, without building anything.
  virtual ReportInfo report_info(const Settings& settings) const = 0;
  /// Whether `key` (one of keys()) sets only the simulator prior (its parameters, bounds, tunable
  /// set): reports do not tell runs that use no prior apart by such keys. Default: the keys that
  /// start with "prior." or "<name>.prior.".
  virtual bool is_prior_key(const std::string& key) const;
};

/// An algorithm: its configuration section and the factory of an algo::Algorithm.
class AlgorithmPlugin {
 public:
  virtual ~AlgorithmPlugin() = default;
  /// The value of the `algorithm` key, e.g. "black_drops".
  virtual std::string name() const = 0;
  /// One line for help texts and docs.
  virtual std::string description() const = 0;
  /// The algorithm's own keys (e.g. "direct.start"); the shared policy-search keys are base keys.
  virtual std::vector<KeySpec> keys() const { return {}; }
  /// The run's variant label (report groups, run names), e.g. the model type for Black-DROPS.
  virtual std::string variant(const Settings& settings) const { (void)settings; return name(); }
  /// How reports show the runs of these settings (default: labelled by the variant's name,
  /// unranked, a free colour).
  virtual VariantStyle variant_style(const Settings& settings) const {
    (void)settings;
    return {};
  }
  /// Whether runs use the task's simulator prior (run names then carry the prior's label).
  virtual bool uses_prior(const Settings& settings) const = 0;
  /// Whether runs learn or use a model of the system (false for a search on the real system
  /// alone, which reports then draw in a panel of its own; see Panel::chosen_by_prior).
  virtual bool uses_model(const Settings& settings) const {
    (void)settings;
    return true;
  }
  /// Whether make() uses TaskSetup::recorded_data (data.logs); make_experiment refuses data.logs
  /// for an algorithm that does not. Default: false.
  virtual bool takes_recorded_data(const Settings& settings) const {
    (void)settings;
    return false;
  }
  /// Whether the runs honour policy.balance.* (catch and balance, docs/balance.md);
  /// make_experiment refuses policy.balance.mode other than off for an algorithm that does not.
  /// Default: false.
  virtual bool takes_balance(const Settings& settings) const {
    (void)settings;
    return false;
  }
  /// Builds the algorithm for validated settings and the built task. Throws ConfigError naming
  /// the key on invalid combinations.
  virtual std::unique_ptr<algo::Algorithm> make(const Settings& settings,
                                                const TaskSetup& setup) const = 0;
  /// What makes the files of the algorithm's side state (algo::RunState::side_state), one
  /// StateFiles per run directory of these settings (it must not refer to `settings` or `setup`,
  /// which it outlives); empty when the algorithm keeps none (the default). make_experiment
  /// stores it as Experiment::state_files.
  virtual StateFilesFactory state_files(const Settings& settings, const TaskSetup& setup) const {
    (void)settings, (void)setup;
    return {};
  }
};

/// The tasks, algorithms and model variants an application offers. Not thread-safe while
/// registering; const members are thread-safe.
class Registry {
 public:
  Registry() = default;
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;
  /// Adds a task; the first one added is the default task. Throws InvalidArgument when its name is
  /// taken or one of its keys exists already.
  void add_task(std::unique_ptr<TaskPlugin> task);
  /// Records a task that this build cannot offer, with the reason (e.g. "built without DART: run
  /// scripts/install-deps, then scripts/build"), so that `task=NAME` gets that reason.
  void add_unavailable_task(const std::string& name, const std::string& reason);
  /// Adds an algorithm; the first one added is the default. Throws InvalidArgument when its name
  /// is taken (by an algorithm or a model variant) or one of its keys exists already.
  void add_algorithm(std::unique_ptr<AlgorithmPlugin> algorithm);
  /// Adds a model variant of Black-DROPS (selected by model.type; its name joins the allowed
  /// values of model.type in the schema). Throws InvalidArgument when its name is not
  /// [a-z0-9_]+ or is taken by a model variant or an algorithm, when its factory is empty or its
  /// style invalid (VariantStyle::IsValid).
  void add_model_variant(ModelVariant variant);
  /// The model variant called `name`. Throws ConfigError ("config key 'model.type' = ...")
  /// listing the registered ones.
  const ModelVariant& model_variant(const std::string& name) const;
  std::vector<std::string> model_variant_names() const;  ///< in registration order
  /// The task called `name`. Throws ConfigError ("config key 'task' = ...") listing the available
  /// tasks, or giving the reason recorded by add_unavailable_task.
  const TaskPlugin& task(const std::string& name) const;
  /// The algorithm called `name`. Throws ConfigError listing the available ones.
  const AlgorithmPlugin& algorithm(const std::string& name) const;
  bool has_task(const std::string& name) const;
  std::vector<std::string> task_names() const;       ///< in registration order
  std::vector<std::string> algorithm_names() const;  ///< in registration order
  /// The first registered task / algorithm. Throws ConfigError when none is registered.
  std::string default_task() const;
  std::string default_algorithm() const;
  /// The registered task whose keys include `key` (nullptr if none).
  const TaskPlugin* task_of_key(const std::string& key) const;
  /// Sets what loads a description file as a prior (prior.model; description_prior.hpp): the
  /// application registers drops::description's when it is built with MuJoCo.
  void set_description_prior_factory(DescriptionPriorFactory factory) {
    description_prior_factory_ = std::move(factory);
  }
  /// The factory of set_description_prior_factory (empty: none, a build without MuJoCo).
  const DescriptionPriorFactory& description_prior_factory() const {
    return description_prior_factory_;
  }

 private:
  std::vector<std::unique_ptr<TaskPlugin>> tasks_;
  std::vector<std::vector<KeySpec>> task_keys_;
  std::map<std::string, std::string> unavailable_;
  std::vector<std::unique_ptr<AlgorithmPlugin>> algorithms_;
  std::vector<ModelVariant> model_variants_;
  DescriptionPriorFactory description_prior_factory_;
};

/// Registers the algorithms of drops::core: "black_drops" (Black-DROPS and its variants, by
/// model.type; the default; with the four model variants of the paper, gp_mi, gp_prior, mi and
/// gp, declared in one table with their labels, report order and colours), "direct" (the direct
/// search on the real system), "ite" (IT&E: MAP-Elites on the prior, M-BOA on the real system;
/// tasks with a behaviour descriptor), "pilco" and "pilco_prior" (PILCO and PILCO with priors, on
/// tasks with a "pilco" entry in TaskSetup::algorithm_data; keys pilco.*).
void register_builtin_algorithms(Registry& registry);

}  // namespace drops::experiment
