#include "drops/experiment/experiment.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/experiment/campaign.hpp"
#include "drops/experiment/identify.hpp"
#include "drops/experiment/run_directory.hpp"
#include "experiment_plugins.hpp"

namespace drops::experiment {

opt::CmaesOptions cmaes_options(const Settings& st) {
  return base_options(st).black_drops.search.cmaes;
}

algo::BlackDropsOptions black_drops_options(const Registry& registry, const Settings& st) {
  const BaseOptions base = base_options(st);
  algo::BlackDropsOptions a = base.black_drops;
  const ModelVariant& variant = registry.model_variant(base.model_type);
  a.model_factory = variant.factory;
  a.model_factory_uses_prior = variant.uses_prior;
  if (!(a.balance.exit >= a.balance.enter))
    throw ConfigError("config key 'policy.balance.exit' = '" + st.at("policy.balance.exit") +
                      "': must be >= policy.balance.enter = " + st.at("policy.balance.enter"));
  std::string why;
  if (!a.IsValid(&why)) throw ConfigError("config: " + why);
  return a;
}

namespace {

/// The pilco.* keys, each declared with the PilcoOptions field it sets (keys of the "pilco"
/// plugin; "pilco_prior" reads them too).
KeyTable<algo::PilcoOptions> make_pilco_key_table() {
  KeyTable<algo::PilcoOptions> t;
  t.add("pilco.cost_width", [](auto& o) -> auto& { return o.cost_width; })
      .optional()
      .range(1e-6, 1e6)
      .unit("task distance")
      .help("algorithms pilco, pilco_prior: width w of the saturating cost 1 - exp(-d^2 / (2 "
            "w^2)) (empty = the task's reward width, so that PILCO optimises the task's expected "
            "return: e.g. 0.5 m; pilco-matlab's double-pendulum swing-up uses 0.25)");
  t.add("pilco.centres", [](auto& o) -> auto& { return o.centres; })
      .range(1, 100000)
      .help("centres (pseudo-inputs) of the RBF policy (paper §V-A, pilco-matlab: 200)");
  t.add("pilco.random_rollouts", [](auto& o) -> auto& { return o.random_rollouts; })
      .range(1, 1000)
      .help("episodes with uniformly random actions before the first learned policy "
            "(pilco-matlab: 1); for pilco_prior they begin the simulation phase");
  t.add("pilco.sim_episodes", [](auto& o) -> auto& { return o.sim_episodes; })
      .range(2, 100000)
      .help("algorithm pilco_prior: PILCO episodes on the simulator prior before the real ones, "
            "the random ones included (paper §V-A: 40); no interaction time");
  t.add("pilco.policy_evaluations", [](auto& o) -> auto& { return o.lbfgs.max_evaluations; })
      .range(1, 100000000)
      .help("L-BFGS evaluations of J(theta) and its gradient per policy optimisation "
            "(pilco-matlab: 150 line searches of BFGS)");
  t.add("pilco.policy_tolerance", [](auto& o) -> auto& { return o.lbfgs.ftol_rel; })
      .also([](auto& o) -> auto& { return o.lbfgs.xtol_rel; })
      .range(0, 1)
      .help("L-BFGS stops when an iteration changes J or theta by less than this, relatively");
  t.add("pilco.discount", [](auto& o) -> auto& { return o.discount; })
      .range(1e-6, 1)
      .help("discount gamma of J = sum_t gamma^t E[c(x_t)] (pilco-matlab: 1)");
  t.add("pilco.rprop_iterations", [](auto& o) -> auto& { return o.rprop.max_iterations; })
      .range(1, 100000)
      .help("Rprop iterations per dynamics GP and episode (warm-started; pilco-matlab: 300 line "
            "searches of BFGS)");
  t.add("pilco.max_snr", [](auto& o) -> auto& { return o.rprop.max_snr; })
      .range(1.001, 1e9)
      .help("soft walls of the dynamics GPs: signal-to-noise ratio at most this (pilco-matlab's "
            "train.m: 1000)");
  t.add("pilco.max_length_scale_ratio",
        [](auto& o) -> auto& { return o.rprop.max_length_scale_ratio; })
      .range(1.001, 1e6)
      .help("soft walls: length scales within this factor of the input's spread (pilco-matlab: "
            "100)");
  t.add("pilco.max_points", [](auto& o) -> auto& { return o.max_points; })
      .range(1, 1000000)
      .help("beyond this many transitions the dynamics GPs are sparse (FITC with this many "
            "inducing inputs, a random subset of the data; pilco-matlab's double-pendulum "
            "swing-up: 300)");
  return t;
}

const KeyTable<algo::PilcoOptions>& pilco_key_table() {
  static const KeyTable<algo::PilcoOptions> t = make_pilco_key_table();
  return t;
}

}  // namespace

algo::PilcoOptions pilco_options(const Settings& st, bool with_prior) {
  const algo::BlackDropsOptions base = base_options(st).black_drops;
  algo::PilcoOptions o;
  o.with_prior = with_prior;
  o.episodes = base.episodes;
  o.seed = base.seed;
  pilco_key_table().apply(st, o);
  std::string why;
  if (!o.IsValid(&why)) throw ConfigError("config: PILCO: " + why);
  return o;
}

namespace {

/// The model variants of the paper (§IV, §V-A), built by model::make_model: their names, the
/// help of model.type, and how reports show them (legend, order, colour), in one place.
std::vector<ModelVariant> builtin_model_variants() {
  const auto made_as = [](model::ModelType type) -> algo::ModelFactory {
    return [type](const model::ModelOptions& options, std::shared_ptr<const rollout::Task> task,
                  std::shared_ptr<const model::MeanFunction> prior,
                  const model::PriorParameters& parameters) {
      model::ModelOptions o = options;
      o.type = type;
      return model::make_model(o, std::move(task), std::move(prior), parameters);
    };
  };
  return {
      {"gp", "Black-DROPS", {"Black-DROPS", 3, "#7f7f7f"}, false, made_as(model::ModelType::kGp)},
      {"gp_prior", "with priors", {"Black-DROPS with priors", 1, "#d62728"}, true,
       made_as(model::ModelType::kGpPrior)},
      {"gp_mi", "with GP-MI", {"Black-DROPS with GP-MI", 0, "#1f77b4"}, true,
       made_as(model::ModelType::kGpMi)},
      {"mi", "with MI (no GP)", {"Black-DROPS with MI", 2, "#2ca02c"}, true,
       made_as(model::ModelType::kMi)},
  };
}

/// Black-DROPS and its variants (paper Algorithm 1; the model variant of model.type, looked up
/// in the registry that owns this plugin).
class BlackDropsPlugin final : public AlgorithmPlugin {
 public:
  explicit BlackDropsPlugin(const Registry& registry) : registry_(registry) {}
  std::string name() const override { return "black_drops"; }
  std::string description() const override {
    return "Black-DROPS (paper Algorithm 1) with the model of model.type, one of the registered "
           "model variants";
  }
  std::string variant(const Settings& s) const override { return s.at("model.type"); }
  VariantStyle variant_style(const Settings& s) const override {
    return registry_.model_variant(s.at("model.type")).style;
  }
  bool uses_prior(const Settings& s) const override {
    return registry_.model_variant(s.at("model.type")).uses_prior;
  }
  std::unique_ptr<algo::Algorithm> make(const Settings& s, const TaskSetup& setup) const override {
    const algo::BlackDropsOptions o = black_drops_options(registry_, s);
    if (o.uses_prior() && !setup.prior)
      throw ConfigError("config key 'model.type' = '" + s.at("model.type") +
                        "': this task has no simulator prior; use model.type gp");
    if (o.balance.mode != control::BalanceMode::kOff && setup.task && !setup.task->goal())
      throw ConfigError("config key 'policy.balance.mode' = '" + s.at("policy.balance.mode") +
                        "': the task '" + setup.task->name() +
                        "' declares no goal state; use policy.balance.mode off");
    algo::BlackDropsOptions with_data = o;
    with_data.recorded_data = setup.recorded_data;
    with_data.keep_first_episode = setup.keep_first_episode;
    return std::make_unique<algo::BlackDrops>(with_data);
  }
  bool takes_recorded_data(const Settings&) const override { return true; }
  bool takes_balance(const Settings&) const override { return true; }

 private:
  const Registry& registry_;  // owns this plugin
};

/// The direct search on the real system (algo::DirectSearch).
class DirectPlugin final : public AlgorithmPlugin {
 public:
  std::string name() const override { return "direct"; }
  std::string description() const override {
    return "BIPOP-CMA-ES on the real system itself, one real episode per evaluation, no model: "
           "a model-free baseline and, with a large budget, the ceiling of the policy family. Its "
           "budget is optimizer.max_evaluations real episodes; `episodes` must stay at its "
           "default";
  }
  std::vector<KeySpec> keys() const override { return key_table().specs(); }
  VariantStyle variant_style(const Settings&) const override {
    return {"CMA-ES on the real system (no model)", 7, "#8c564b"};
  }
  bool uses_prior(const Settings&) const override { return false; }
  bool uses_model(const Settings&) const override { return false; }
  std::unique_ptr<algo::Algorithm> make(const Settings& s, const TaskSetup& setup) const override {
    // Its budget is optimizer.max_evaluations real episodes: an `episodes` other than the
    // default would be ignored, and on a physical robot that is thousands of episodes run
    // where a few were asked for.
    const algo::BlackDropsOptions base = base_options(s).black_drops;
    if (base.episodes != BaseOptions().black_drops.episodes)
      throw ConfigError("config key 'episodes' = '" + s.at("episodes") +
                        "': algorithm direct runs optimizer.max_evaluations real episodes (" +
                        s.at("optimizer.max_evaluations") +
                        " here), not `episodes`; set optimizer.max_evaluations=" +
                        s.at("episodes") + " instead");
    algo::DirectSearchOptions o;
    o.seed = base.seed;
    o.theta_bound = base.search.theta_bound;
    o.cmaes = base.search.cmaes;
    const std::string start = key_table().read(s).start;
    if (!start.empty()) o.start = read_start(start, setup.policy->param_dim(), o.theta_bound);
    std::string why;
    if (!o.IsValid(&why)) throw ConfigError("config: " + why);
    return std::make_unique<algo::DirectSearch>(o);
  }

 private:
  /// The values of the direct search's own keys.
  struct DirectKeys {
    std::string start;  ///< direct.start: a file of theta0 ("" = none)
  };
  static const KeyTable<DirectKeys>& key_table() {
    static const KeyTable<DirectKeys> t = [] {
      KeyTable<DirectKeys> k;
      k.add("direct.start", &DirectKeys::start)
          .help("algorithm direct: a file of policy parameters, one per line (e.g. a run's "
                "episodes/NNN/policy.csv), evaluated first and kept unless beaten (empty = the "
                "centre of the box, not evaluated on its own)");
      return k;
    }();
    return t;
  }
  /// theta0 from a file of one value per line. Throws ConfigError naming the file and line.
  static VectorXd read_start(const std::string& path, int n, double bound) {
    const std::string key = "config key 'direct.start' = '" + path + "': ";
    std::istringstream in;
    try {
      in.str(read_file_text(path, kMaxConfigFileBytes));
    } catch (const Error& e) {
      throw ConfigError(key + e.what());
    }
    std::vector<double> v;
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty()) continue;
      std::size_t used = 0;
      double x = 0;
      try {
        x = std::stod(line, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || !std::isfinite(x))
        throw ConfigError(key + "line " + std::to_string(v.size() + 1) + ": '" + line +
                          "' is not a finite number");
      if (std::abs(x) > bound)
        throw ConfigError(key + "line " + std::to_string(v.size() + 1) + ": " + line +
                          " is outside the policy box [-policy.bound, policy.bound]");
      v.push_back(x);
    }
    if (static_cast<int>(v.size()) != n)
      throw ConfigError(key + "holds " + std::to_string(v.size()) +
                        " values; the policy has " + std::to_string(n) + " parameters");
    return Eigen::Map<VectorXd>(v.data(), n);
  }
};

/// PILCO (with_prior false) and PILCO with priors (algo::Pilco), on tasks that describe themselves
/// to PILCO (a pilco::TaskModel under "pilco" in TaskSetup::algorithm_data). The "pilco" plugin
/// owns the pilco.* keys; both read them.
class PilcoPlugin final : public AlgorithmPlugin {
 public:
  explicit PilcoPlugin(bool with_prior) : with_prior_(with_prior) {}
  std::string name() const override { return with_prior_ ? "pilco_prior" : "pilco"; }
  std::string description() const override {
    return with_prior_
               ? "PILCO with priors (Cutler & How 2015): PILCO on the simulator prior first "
                 "(pilco.sim_episodes), then on the real system with the simulator GPs' means as "
                 "the prior mean and the simulator's policy as the first real policy"
               : "PILCO (Deisenroth & Rasmussen 2011): GP dynamics with analytic moment matching, "
                 "an RBF policy optimised by L-BFGS on the analytic gradient of the expected cost";
  }
  std::vector<KeySpec> keys() const override {
    if (with_prior_) return {};
    return pilco_key_table().specs();
  }
  VariantStyle variant_style(const Settings&) const override {
    return with_prior_ ? VariantStyle{"PILCO with priors", 5, "#17becf"}
                       : VariantStyle{"PILCO", 6, "#ff7f0e"};
  }
  bool uses_prior(const Settings&) const override { return with_prior_; }
  std::unique_ptr<algo::Algorithm> make(const Settings& s, const TaskSetup& setup) const override {
    const std::string head = "config key 'algorithm' = '" + name() + "': ";
    const auto* task_model = setup.algorithm_data.find<pilco::TaskModel>("pilco");
    if (!task_model)
      throw ConfigError(head + "task '" + s.at("task") +
                        "' does not describe itself to PILCO (a pilco::TaskModel under \"pilco\" "
                        "in TaskSetup::algorithm_data: its angles, the inputs of the policy and "
                        "the GP, the cost); choose another algorithm");
    if (with_prior_ && !setup.prior)
      throw ConfigError(head + "task '" + s.at("task") + "' has no simulator prior; use pilco");
    if (setup.task && setup.task->has_action_reward())
      throw ConfigError(head + "task '" + s.at("task") +
                        "' rewards actions too (Task::action_reward, e.g. a torque cost), which "
                        "PILCO's expected cost, a function of the state, would leave out; remove "
                        "the action reward or choose another algorithm");
    const algo::PilcoOptions o = pilco_options(s, with_prior_);
    if (o.cost_width == 0.0 && !(task_model->reward_width > 0))
      throw ConfigError("config key 'pilco.cost_width' is empty but task '" + s.at("task") +
                        "' gives no reward width: set it");
    try {
      return std::make_unique<algo::Pilco>(o, *task_model);
    } catch (const InvalidArgument& e) {
      throw ConfigError(head + e.what());
    }
  }

 private:
  bool with_prior_;
};

}  // namespace

void register_builtin_algorithms(Registry& registry) {
  registry.add_algorithm(std::make_unique<BlackDropsPlugin>(registry));
  for (auto& v : builtin_model_variants()) registry.add_model_variant(std::move(v));
  registry.add_algorithm(std::make_unique<DirectPlugin>());
  registry.add_algorithm(make_ite_plugin());
  registry.add_algorithm(std::make_unique<PilcoPlugin>(false));
  registry.add_algorithm(std::make_unique<PilcoPlugin>(true));
}

std::string Experiment::default_run_name(const std::string& stamp) const {
  std::string n = task + "-" + variant;
  if (uses_prior && !setup.prior_label.empty()) n += "-" + setup.prior_label;
  n += "-seed" + std::to_string(seed);
  if (!stamp.empty()) n += "-" + stamp;
  return n;
}

bool is_directory_name(const std::string& s) {
  if (s.empty() || s.size() > 200) return false;
  const auto ok = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
  };
  if (!(std::isalnum(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), ok);
}

bool is_column_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  const auto ok = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.';
  };
  if (!(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), ok);
}

namespace {

// A name as a message shows it: quoted, escaped, at most 80 characters.
std::string quoted_name(const std::string& s) {
  std::string q = "'";
  for (std::size_t i = 0; i < s.size() && i < 80; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c == '\n')
      q += "\\n";
    else if (c < 0x20 || c >= 0x7F)
      q += fmt::format("\\x{:02x}", c);
    else
      q += static_cast<char>(c);
  }
  return q + (s.size() > 80 ? "...'" : "'");
}

}  // namespace

void check_setup_names(const std::string& task, const TaskSetup& setup, bool uses_prior) {
  const auto fail = [&](const std::string& list, const std::string& name, const std::string& why) {
    throw InvalidArgument("task '" + task + "': " + list + " " + quoted_name(name) + " " + why);
  };
  const std::string grammar =
      "is not a column name (1 to 64 of A-Z a-z 0-9 _ ., not starting with a digit or '.')";
  std::set<std::string> columns;
  const auto check = [&](const std::vector<std::string>& names, const std::string& list,
                         std::set<std::string>& seen, bool trajectory) {
    for (const auto& n : names) {
      if (!is_column_name(n)) fail(list, n, grammar);
      if (trajectory)
        for (const auto& r : reserved_trajectory_columns())
          if (n == r) fail(list, n, "is reserved (the trajectory files' own column)");
      if (!seen.insert(n).second)
        fail(list, n, "is named twice (the trajectory columns and each list must be distinct)");
    }
  };
  check(setup.state_names, "state name", columns, true);
  check(setup.action_names, "action name", columns, true);
  check(setup.state_extra_names, "state extra", columns, true);
  std::set<std::string> metrics = {"episode", "interaction_time_s", "real_return",
                                   "predicted_return", "solved", "phi", "model_learning_s",
                                   "policy_optimization_s", "evaluations"};
  check(setup.metric_names, "metric", metrics, false);
  std::set<std::string> phi;
  check(setup.prior_parameters.names, "prior parameter", phi, false);
  if (uses_prior && !setup.prior_label.empty() && !is_directory_name(setup.prior_label))
    fail("prior label", setup.prior_label,
         "is not a directory name (1 to 200 of A-Z a-z 0-9 _ . -, the first a letter, a digit or "
         "'_'): it names run directories");
}

namespace {

// The description file of prior.model as the task's prior (TaskSetup::joints).
void use_description_prior(const Registry& registry, Experiment& e) {
  const Settings& st = e.settings;
  if (!e.setup.joints)
    throw ConfigError("config key 'prior.model' = '" + st.at("prior.model") + "': task '" +
                      e.task +
                      "' declares no joints (TaskSetup::joints), so it cannot use a description "
                      "file as its prior");
  if (!e.setup.task) throw ConfigError("config key 'prior.model': task '" + e.task + "' has none");
  DescriptionPriorSetup d =
      make_description_prior(registry.description_prior_factory(), description_prior_spec(st),
                             *e.setup.joints, e.setup.task->dt());
  if (d.prior->state_dim() != e.setup.task->state_dim() ||
      d.prior->action_dim() != e.setup.task->action_dim())
    throw ConfigError(fmt::format(
        "config key 'prior.model' = '{}': the prior's state and action have {} and {} "
        "dimensions, task '{}' {} and {}",
        st.at("prior.model"), d.prior->state_dim(), d.prior->action_dim(), e.task,
        e.setup.task->state_dim(), e.setup.task->action_dim()));
  e.setup.prior = std::move(d.prior);
  e.setup.prior_parameters = std::move(d.parameters);
  e.setup.phi_actual.assign(e.setup.prior_parameters.names.size(),
                            std::numeric_limits<double>::quiet_NaN());
  for (auto& [k, v] : d.declaration) e.setup.declaration[k] = v;
  e.setup.prior_label = description_prior_label(st);
}

}  // namespace

Experiment make_experiment(const Registry& registry, const Settings& settings) {
  Experiment e;
  e.settings = settings;
  resolve_derived_defaults(registry, e.settings);
  const Settings& st = e.settings;
  const BaseOptions base = base_options(st);
  e.task = base.task;
  e.algorithm = base.algorithm;
  if (e.task == kNoTask)
    throw ConfigError(
        "config key 'task' = 'none': a configuration without a task is for drops identify (a "
        "description file's joints, prior.model); drops run needs a task (available: " +
        fmt::format("{}", fmt::join(registry.task_names(), ", ")) + ")");
  const TaskPlugin& task = registry.task(e.task);
  const AlgorithmPlugin& algorithm = registry.algorithm(e.algorithm);
  e.seed = base.black_drops.seed;
  e.threads = base.threads;
  e.output = base.output;
  e.name = base.name;
  if (!e.name.empty() && !is_directory_name(e.name))
    throw ConfigError("config key 'name' = " + quoted_name(e.name) +
                      ": expected one directory name (1 to 200 of A-Z a-z 0-9 _ . -, the first a "
                      "letter, a digit or '_'); the run directory is <output>/<name>, so a path "
                      "goes in the key output");
  if (e.output.find('\0') != std::string::npos)
    throw ConfigError("config key 'output' = " + quoted_name(e.output) +
                      ": a path cannot hold a NUL character");
  e.variant = algorithm.variant(st);
  e.setup = task.make(st);
  if (uses_description_prior(st))
    use_description_prior(registry, e);
  else if (st.count("prior.parameters") && st.at("prior.parameters") != "[]")
    throw ConfigError("config key 'prior.parameters' = '" + st.at("prior.parameters") +
                      "': it sets the phi of a description file, but prior.model is empty");
  // Trajectory columns of a task that does not name them.
  const auto generic = [&e](std::vector<std::string>& names, const char* symbol, int dim) {
    if (names.empty())
      for (int i = 1; i <= dim; ++i) names.push_back(symbol + std::string("_") + std::to_string(i));
    if (names.size() != static_cast<std::size_t>(dim))
      throw InvalidArgument("task '" + e.task + "': expected " + std::to_string(dim) + " " +
                            symbol + " column names (TaskSetup), got " +
                            std::to_string(names.size()));
  };
  if (e.setup.task) {
    generic(e.setup.state_names, "x", e.setup.task->state_dim());
    generic(e.setup.action_names, "u", e.setup.task->action_dim());
  }
  check_setup_names(e.task, e.setup, algorithm.uses_prior(st));
  if (st.count("policy.balance.mode") && st.at("policy.balance.mode") != "off" &&
      !algorithm.takes_balance(st))
    throw ConfigError("config key 'policy.balance.mode' = '" + st.at("policy.balance.mode") +
                      "': algorithm '" + e.algorithm +
                      "' does not catch and balance (black_drops does); use policy.balance.mode off");
  // Recorded data (data.logs): read, resampled and checked before anything runs.
  if (st.count("data.logs") && st.at("data.logs") != "[]" && !st.at("data.logs").empty()) {
    if (!algorithm.takes_recorded_data(st))
      throw ConfigError("config key 'data.logs' = '" + st.at("data.logs") + "': algorithm '" +
                        e.algorithm + "' does not start from recorded data (black_drops does)");
    if (!e.setup.task) throw ConfigError("config key 'data.logs': task '" + e.task + "' has none");
    RunData data = read_run_data(st, e.setup.task->dt(), e.setup.state_names, e.setup.action_names);
    e.setup.recorded_data = std::move(data.transitions);
    e.setup.keep_first_episode = data.keep_first_episode;
    for (auto& [k, v] : data.declaration) e.setup.declaration[k] = v;
  }
  e.runner = algorithm.make(st, e.setup);
  e.state_files = algorithm.state_files(st, e.setup);
  e.uses_prior = algorithm.uses_prior(st);
  e.variant_style = algorithm.variant_style(st);
  e.uses_model = algorithm.uses_model(st);
  e.report = run_report_info(task.report_info(st), e.uses_prior, e.uses_model);
  return e;
}

}  // namespace drops::experiment
