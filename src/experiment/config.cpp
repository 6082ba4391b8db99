// The configuration schema (base keys + algorithms' + the task's), YAML loading and validation.
#include "drops/experiment/config.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "drops/algo/black_drops.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/registry.hpp"

namespace drops::experiment {
namespace {

/// Shortest text that reads back as v ("0.01", "1e-12", "300").
std::string num(double v) { return fmt::format("{}", v); }
std::string boolean(bool v) { return v ? "true" : "false"; }

std::string score_name(model::GpMiScore v) {
  return v == model::GpMiScore::kSumOfLogLikelihoods ? "sum_log_likelihoods" : "sum_likelihoods";
}

std::string candidate_start_name(model::GpMiCandidateStart v) {
  return v == model::GpMiCandidateStart::kInitial ? "initial" : "best_so_far";
}

std::string restart_name(opt::CmaesRestartStart r) {
  return r == opt::CmaesRestartStart::kRandom ? "random"
         : r == opt::CmaesRestartStart::kStart ? "start"
                                                : "mixed";
}

/// Values of the base keys whose schema default is empty (or, for an enum, "auto") because some
/// task changes it: what they are when the task says nothing (the Options structs' defaults).
std::map<std::string, std::string> fallback_defaults() {
  const algo::BlackDropsOptions d;
  return {{"policy.bound", num(d.search.theta_bound)},
          {"optimizer.max_evaluations", num(static_cast<double>(d.search.cmaes.max_evaluations))},
          {"optimizer.reevaluation_rollouts", num(d.search.reevaluation.rollouts)},
          {"model.rprop.max_length_scale_ratio", num(d.model.rprop.max_length_scale_ratio)},
          {"model.rprop.penalty", d.model.rprop.penalty ? "on" : "off"},
          {"model.gp_mi.score", score_name(d.model.gp_mi.score)},
          {"model.gp_mi.candidate_start", candidate_start_name(d.model.gp_mi.candidate_start)},
          {"optimizer.trust_region", d.trust_region.enabled ? "true" : "false"}};
}

std::vector<KeySpec> build_base_keys() {
  const algo::BlackDropsOptions d;  // the single source of the defaults
  const auto& m = d.model;
  const auto& c = d.search.cmaes;
  const auto& ps = d.search;
  std::vector<KeySpec> s;
  auto add = [&](KeySpec k) { s.push_back(std::move(k)); };
  const double big = 1e9;
  add({"task", "string", "", 0, 0, {}, "-",
       "the learning problem, one of the registered tasks (empty = the first registered: the "
       "first task of the drops command line); `drops config --markdown` lists each task's keys"});
  // Allowed values: the registry's algorithms (registered_base_keys).
  add({"algorithm", "string", "", 0, 0, {}, "-",
       "the learning algorithm, one of the registered algorithms (each described in its own "
       "section; empty = the first registered: black_drops, Algorithm 1 with the model of "
       "model.type, for the drops command line)"});
  add({"seed", "int", num(static_cast<double>(d.seed)), 0, 4294967295.0, {}, "-",
       "the run's only seed: every random stream derives from it (same numbers with any thread count)"});
  add({"episodes", "int", num(d.episodes), 1, 1000, {}, "-",
       "real episodes in total, including the first one"});
  add({"threads", "int", "0", 0, 1024, {}, "-", "worker threads (0 = all hardware threads)"});
  add({"output", "string", "runs", 0, 0, {}, "-", "parent directory of run directories"});
  add({"name", "string", "", 0, 0, {}, "-",
       "run directory name (empty = <task>-<variant>-<prior>-seed<seed>-<date>-<time>)"});
  // Allowed values and help: the registry's model variants (registered_base_keys).
  add({"model.type", "enum", model::to_string(m.type), 0, 0, {}, "-",
       "the model variant of Black-DROPS, one of the registered model variants"});
  add({"model.rprop.iterations", "int", num(m.rprop.max_iterations), 1, 100000, {}, "-",
       "Rprop iterations of the final kernel fit per output GP"});
  add({"model.rprop.tolerance", "double", num(m.rprop.tolerance), 0, big, {}, "nats",
       "stop a kernel fit early when the log-likelihood gains less than this over `patience` "
       "iterations (0 = always run every iteration)"});
  add({"model.rprop.patience", "int", num(m.rprop.patience), 1, 100000, {}, "-",
       "window of the tolerance test"});
  add({"model.rprop.penalty", "enum", "auto", 0, 0, {"auto", "on", "off"}, "-",
       "PILCO's soft walls on extreme length scales and signal-to-noise ratios in the kernel fits "
       "(auto = the task's choice, off unless the task says otherwise: a task whose GPs have few "
       "points in many input dimensions needs them, or they interpolate noise; the reference used "
       "them for its no-prior variant: model.type gp with penalty on)"});
  add({"model.rprop.max_length_scale_ratio", "double", "", 1.001, 1e6, {}, "-",
       "soft walls: length scale l_d within [s_d / ratio, ratio s_d], s_d the spread of input d "
       "(empty = the task's choice: " + num(m.rprop.max_length_scale_ratio) +
           ", PILCO's value, unless the task says otherwise)"});
  add({"model.rprop.max_snr", "double", num(m.rprop.max_snr), 1.001, 1e9, {}, "-",
       "soft walls: signal-to-noise ratio sigma_f / sigma_n at most this (PILCO: 500)"});
  add({"model.gp_mi.search", "enum",
       m.gp_mi.search == model::GpMiSearch::kNested ? "nested" : "alternating", 0, 0,
       {"alternating", "nested"}, "-",
       "nested: paper's Algorithm 2 (Rprop inside every Subplex evaluation); alternating: "
       "block-coordinate ascent on the same score (much faster)"});
  add({"model.gp_mi.score", "enum", "auto", 0, 0,
       {"auto", "sum_likelihoods", "sum_log_likelihoods"}, "-",
       "GP-MI's score: log sum_i exp(loglik_i), the paper's sum of the likelihoods, or "
       "sum_i loglik_i, the joint likelihood of the output GPs (every output counts); auto = "
       "the task's choice, " +
           score_name(m.gp_mi.score) + " unless the task says otherwise"});
  add({"model.gp_mi.candidate_start", "enum", "auto", 0, 0, {"auto", "best_so_far", "initial"},
       "-",
       "nested search (and a discrete phi): each candidate's kernel fit starts from the best "
       "candidate's kernels so far, or from a new GP's (equal terms for every candidate; "
       "docs/architecture.md); auto = the task's choice, " +
           candidate_start_name(m.gp_mi.candidate_start) + " unless the task says otherwise"});
  add({"model.gp_mi.max_evaluations", "int", num(m.gp_mi.max_evaluations), 1, 1000000, {}, "-",
       "Subplex evaluations per phi search"});
  add({"model.gp_mi.tolerance", "double", num(m.gp_mi.xtol_rel), 0, 1, {}, "-",
       "Subplex relative tolerance on phi and on the score"});
  add({"model.gp_mi.rounds", "int", num(m.gp_mi.rounds), 1, 100, {}, "-",
       "alternating search: maximum rounds"});
  add({"model.gp_mi.inner_rprop_iterations", "int", num(m.gp_mi.inner_rprop_iterations), 1,
       100000, {}, "-", "Rprop iterations of kernel refits inside the phi search"});
  add({"model.gp_mi.max_points", "int", num(m.gp_mi.max_points), 0, 1000000, {}, "-",
       "transitions used inside the phi search, evenly spaced (0 = all); the final fit uses all"});
  add({"model.mi.max_evaluations", "int", num(m.mi.max_evaluations), 1, 1000000, {}, "-",
       "Subplex evaluations of MI"});
  add({"model.mi.tolerance", "double", num(m.mi.xtol_rel), 0, 1, {}, "-",
       "Subplex relative tolerance of MI"});
  add({"policy.bound", "double", "", 1e-3, 1000, {}, "-",
       "policy parameters are searched in [-bound, bound] (empty = the task's choice: " +
           num(ps.theta_bound) + " unless the task says otherwise)"});
  add({"optimizer.max_evaluations", "int", "", 10, 100000000, {}, "-",
       "CMA-ES policy evaluations per optimization, all restarts (empty = the task's choice: " +
           num(static_cast<double>(c.max_evaluations)) +
           " unless the task says otherwise); for algorithm=direct, the number "
           "of real episodes"});
  add({"optimizer.run_evaluations", "int", "", 0, 100000000, {}, "-",
       "CMA-ES evaluations of one run before it restarts (empty = a quarter of "
       "optimizer.max_evaluations; 0 = no per-run budget): with a noisy objective the tolerances "
       "rarely end a run, so this is what makes restarts happen"});
  add({"optimizer.restarts", "int", num(c.max_restarts), 0, 100, {}, "-",
       "large-population (IPOP) restarts after the first run; BIPOP's small runs come in between"});
  add({"optimizer.restart_from", "enum", restart_name(c.restart_start), 0, 0,
       {"mixed", "random", "start"}, "-",
       "where restarts begin: mixed = BIPOP's small (local) runs from the start policy and its large "
       "runs from random points; random = every restart from a random point (Hansen 2009); start = "
       "every restart from the start policy"});
  add({"optimizer.tol_fun", "double", num(c.tol_fun), 0, 1e6, {}, "return",
       "a run stops when its best returns of the last 10 + 30n/lambda generations (TolHistFun), or "
       "those and all of the last generation's (TolFun), lie within this range"});
  add({"optimizer.stagnation", "bool", boolean(c.stagnation), 0, 0, {}, "-",
       "a run stops when its best and median returns stopped improving (Hansen 2009's Stagnation)"});
  add({"optimizer.lambda", "int", num(c.lambda), 0, 100000, {}, "-",
       "population size of the first run (0 = 4 + floor(3 ln n), 17 for 81 parameters)"});
  add({"optimizer.sigma0", "double", num(c.sigma0), 0, 1000, {}, "-",
       "initial step size (0 = policy.bound)"});
  add({"optimizer.elitism", "bool", boolean(c.elitism), 0, 0, {}, "-",
       "re-inject the best-ever candidate"});
  add({"optimizer.active", "bool", boolean(c.active), 0, 0, {}, "-",
       "active covariance update (aCMA)"});
  add({"optimizer.bipop", "bool", boolean(c.bipop), 0, 0, {}, "-",
       "BIPOP restarts (false = IPOP)"});
  add({"optimizer.uncertainty_handling", "bool", boolean(c.uncertainty_handling), 0, 0, {}, "-",
       "Hansen et al. 2009 uncertainty handling for the noisy rollout objective"});
  add({"optimizer.keep_start", "bool", boolean(ps.keep_start_point), 0, 0, {}, "-",
       "the best policy so far is the start and a candidate: each search starts from the policy of "
       "the best real episode, evaluates it on the current model like any candidate and runs it again "
       "unless a candidate beats it (as the reference's CMA-ES wrapper); false = the start only "
       "centres the first CMA-ES run"});
  add({"optimizer.trust_region", "bool", "", 0, 0, {}, "-",
       "from episode 2 on, search only within r * policy.bound of the best real policy, with "
       "CMA-ES's sigma0 scaled by r (r = 1: the whole box); r starts at 1, doubles after a new "
       "policy beat the best real return and halves after one that did not (TuRBO's rule; "
       "docs/architecture.md, \"The policy search and what drops does differently\"); empty = "
       "the task's choice: " +
           std::string(boolean(d.trust_region.enabled)) + " unless the task says otherwise"});
  add({"optimizer.trust_region_min", "double", num(d.trust_region.min_radius), 1e-6, 1, {}, "-",
       "optimizer.trust_region: the smallest radius r, a fraction of policy.bound"});
  add({"optimizer.selection", "enum",
       ps.selection == algo::PolicySelection::kBestSeen ? "best_seen" : "reevaluate", 0, 0,
       {"reevaluate", "best_seen"}, "-",
       "which evaluated policy is run: reevaluate = the best value (rollouts.statistic) when the "
       "start, the best evaluated policies and each run's final mean are re-evaluated with many "
       "rollouts (robust to lucky rollouts); best_seen = the best single evaluation (the paper's "
       "reference)"});
  add({"optimizer.reevaluation_rollouts", "int", "", 1, 100000, {}, "-",
       "selection reevaluate: rollouts per re-evaluated policy, on common random numbers (empty = "
       "the task's choice: " + num(ps.reevaluation.rollouts) +
           " unless the task says otherwise)"});
  add({"optimizer.reevaluation_candidates", "int", num(ps.reevaluation.candidates), 1, 10000, {},
       "-",
       "selection reevaluate: best distinct evaluated policies re-evaluated (besides the start and "
       "the runs' final means)"});
  add({"optimizer.prior_optimizations", "int", num(d.prior_optimizations), 1, 100, {}, "-",
       "with a prior: successive optimizations on the prior alone for episode 1"});
  add({"rollouts.count", "int", num(ps.rollouts.rollouts), 1, 10000, {}, "-",
       "Monte-Carlo rollouts per policy evaluation, combined by rollouts.statistic"});
  add({"rollouts.statistic", "enum",
       ps.rollouts.statistic == rollout::ReturnStatistic::kMedian ? "median" : "mean", 0, 0,
       {"mean", "median"}, "-",
       "how a policy's rollout returns combine into its value on the model, in the search "
       "(rollouts.count > 1) and in the re-evaluation of optimizer.selection reevaluate: mean = "
       "the expected return (the paper's); median = robust to a minority of rollouts, e.g. rare "
       "predicted falls (docs/architecture.md, \"The policy search and what drops does "
       "differently\"). The reported predicted return is always the mean"});
  add({"rollouts.clip", "double", num(ps.rollouts.clip), 0, 100, {}, "sigma",
       "clip each predictive draw to mean +- clip * sigma (0 = no clipping)"});
  add({"rollouts.batch", "int", num(ps.rollouts.batch), 1, 1024, {}, "-",
       "rollouts advanced together through batched GP predictions"});
  add({"rollouts.predicted", "int", num(d.predicted_rollouts), 1, 100000, {}, "-",
       "rollouts used to report each episode's predicted return"});
  return s;
}

[[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& what) {
  throw ConfigError("config key '" + key + "' = '" + value + "': " + what);
}

std::string node_text(const YAML::Node& n) {
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  e << n;
  return e.c_str();
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

double parse_double(const std::string& key, const YAML::Node& n) {
  const std::string text = node_text(n);
  if (!n.IsScalar()) fail(key, text, "expected a number");
  try {
    // What std::stod reads but YAML does not (hexadecimal, leading blanks) is refused: every
    // reader of the value, yaml-cpp's included, must read the same number.
    const std::string& t = n.Scalar();
    if (t.empty() || std::isspace(static_cast<unsigned char>(t.front())) ||
        t.find_first_of("xX") != std::string::npos)
      throw std::invalid_argument("not a decimal number");
    std::size_t pos = 0;
    const double v = std::stod(t, &pos);
    if (pos != t.size()) throw std::invalid_argument("trailing");
    if (!std::isfinite(v)) throw std::invalid_argument("non-finite");
    return v;
  } catch (const std::exception&) {
    fail(key, text, "expected a finite decimal number");
  }
}

void check_range(const KeySpec& s, double v, const std::string& text) {
  if (s.min < s.max && (v < s.min || v > s.max)) {
    std::ostringstream o;
    o << "out of range: allowed [" << s.min << ", " << s.max << "]"
      << (s.unit != "-" ? " " + s.unit : "");
    fail(s.key, text, o.str());
  }
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& a : v) s += (s.empty() ? "" : ", ") + a;
  return s;
}

/// Validates one value against its spec; returns the canonical text stored in Settings.
std::string validate(const KeySpec& s, const YAML::Node& n) {
  const std::string text = node_text(n);
  if (s.type == "string") {
    if (n.IsNull()) return "";
    if (!n.IsScalar()) fail(s.key, text, "expected a string");
    return n.Scalar();
  }
  if (s.type == "enum") {
    // An enum whose default depends on the task (empty default) may be left empty.
    if (s.default_value.empty() && (n.IsNull() || (n.IsScalar() && n.Scalar().empty()))) return "";
    if (!n.IsScalar() ||
        std::find(s.allowed.begin(), s.allowed.end(), n.Scalar()) == s.allowed.end())
      fail(s.key, text, "allowed values: " + joined(s.allowed));
    return n.Scalar();
  }
  if (s.type == "bool") {
    if (n.IsScalar()) {
      const std::string v = n.Scalar();
      if (v == "true" || v == "yes" || v == "on" || v == "1") return "true";
      if (v == "false" || v == "no" || v == "off" || v == "0") return "false";
    }
    fail(s.key, text, "expected true or false");
  }
  if (s.type == "int") {
    if (s.default_value.empty() && (n.IsNull() || (n.IsScalar() && n.Scalar().empty()))) return "";
    const double v = parse_double(s.key, n);
    if (v != std::floor(v)) fail(s.key, text, "expected an integer");
    check_range(s, v, text);
    return std::to_string(static_cast<long long>(v));
  }
  if (s.type == "double") {
    if (s.default_value.empty() && (n.IsNull() || (n.IsScalar() && n.Scalar().empty()))) return "";
    const double v = parse_double(s.key, n);
    check_range(s, v, text);
    return n.Scalar();
  }
  if (s.type == "interval") {
    if (!n.IsSequence() || n.size() != 2) fail(s.key, text, "expected [lower, upper]");
    const double lo = parse_double(s.key, n[0]), hi = parse_double(s.key, n[1]);
    check_range(s, lo, text);
    check_range(s, hi, text);
    if (!(lo < hi)) fail(s.key, text, "expected lower < upper");
    return text;
  }
  if (s.type == "names") {
    if (!n.IsSequence()) fail(s.key, text, "expected a list such as [a, b]");
    std::set<std::string> seen;
    for (const auto& e : n) {
      if (!e.IsScalar() ||
          std::find(s.allowed.begin(), s.allowed.end(), e.Scalar()) == s.allowed.end())
        fail(s.key, text, "allowed names: " + joined(s.allowed));
      if (!seen.insert(e.Scalar()).second)
        fail(s.key, text, "'" + e.Scalar() + "' is listed twice");
    }
    return text;
  }
  fail(s.key, text, "internal: unknown type " + s.type);
}

YAML::Node parse_yaml(const std::string& text, const std::string& where) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(where + ": invalid YAML: " + e.what());
  }
}

/// The document's keys, dotted, with their YAML nodes. A map under a key that no schema knows is
/// descended into; `is_key(k)` says whether k is a key (then its value is kept whole, even a map,
/// so that validation reports the type error).
void flatten(const YAML::Node& node, const std::string& prefix,
             const std::function<bool(const std::string&)>& is_key,
             std::vector<std::pair<std::string, YAML::Node>>& out) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      std::string k;
      try {
        k = kv.first.as<std::string>();
      } catch (const YAML::Exception&) {
        throw ConfigError("config: a key is not a plain name: '" + node_text(kv.first) + "'");
      }
      const std::string key = prefix.empty() ? k : prefix + "." + k;
      if (is_key(key) || !kv.second.IsMap())
        out.emplace_back(key, kv.second);
      else
        flatten(kv.second, key, is_key, out);
    }
  } else if (!node.IsNull()) {
    throw ConfigError("config: the document must be a mapping of keys, got '" + node_text(node) +
                      "'");
  }
}

std::string read_config_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError("cannot read config file '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Every key of the registry: base, algorithms', every task's (for the keys of other tasks).
bool known_anywhere(const Registry& registry, const std::string& key) {
  for (const auto& s : base_keys())
    if (s.key == key) return true;
  for (const auto& a : registry.algorithm_names())
    for (const auto& s : registry.algorithm(a).keys())
      if (s.key == key) return true;
  return registry.task_of_key(key) != nullptr;
}

/// base_keys() with the values of algorithm and model.type that `registry` offers (its algorithms
/// and model variants, in registration order) and model.type's help.
std::vector<KeySpec> registered_base_keys(const Registry& registry) {
  std::vector<KeySpec> keys = base_keys();
  for (auto& k : keys) {
    if (k.key == "algorithm") k.allowed = registry.algorithm_names();
    if (k.key != "model.type") continue;
    k.allowed = registry.model_variant_names();
    std::string doc;
    for (const auto& n : k.allowed)
      doc += (doc.empty() ? "" : "; ") + n + ": " + registry.model_variant(n).description;
    if (!doc.empty()) k.doc = doc;
  }
  return keys;
}

}  // namespace

const std::vector<KeySpec>& base_keys() {
  static const std::vector<KeySpec> s = build_base_keys();
  return s;
}

std::vector<KeySpec> schema(const Registry& registry, const std::string& task) {
  std::vector<KeySpec> s = registered_base_keys(registry);
  for (const auto& a : registry.algorithm_names())
    for (auto& k : registry.algorithm(a).keys()) s.push_back(std::move(k));
  for (auto& k : registry.task(task).keys()) s.push_back(std::move(k));
  return s;
}

Settings load_settings(const Registry& registry, const std::string& yaml_text,
                       const std::vector<std::string>& overrides) {
  // 1. The document and the overrides as (dotted key, YAML node), in order.
  std::vector<std::pair<std::string, YAML::Node>> entries;
  auto is_key = [&](const std::string& k) { return known_anywhere(registry, k); };
  flatten(parse_yaml(yaml_text, "config"), "", is_key, entries);
  for (const auto& o : overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0)
      throw ConfigError("override '" + o + "': expected key=value, e.g. model.type=gp_prior");
    const std::string key = o.substr(0, eq), value = o.substr(eq + 1);
    YAML::Node n =
        value.empty() ? YAML::Node(std::string()) : parse_yaml(value, "override " + key);
    if (n.IsScalar()) n = YAML::Node(value);  // strings and enums verbatim
    entries.emplace_back(key, n);
  }
  // 2. The task (and algorithm) decide the schema.
  std::string task = registry.default_task();
  for (const auto& [k, n] : entries)
    if (k == "task") {
      if (!n.IsScalar()) fail("task", node_text(n), "expected a task name");
      if (!n.Scalar().empty()) task = n.Scalar();
    }
  registry.task(task);  // ConfigError naming the available tasks
  const std::vector<KeySpec> keys = schema(registry, task);
  auto spec = [&](const std::string& k) -> const KeySpec* {
    for (const auto& s : keys)
      if (s.key == k) return &s;
    return nullptr;
  };
  std::vector<std::string> names;
  for (const auto& s : keys) names.push_back(s.key);
  // 3. Defaults, then each entry validated.
  Settings out;
  for (const auto& s : keys) out[s.key] = s.default_value;
  out["task"] = task;
  for (const auto& [k, n] : entries) {
    const KeySpec* s = spec(k);
    if (!s) {
      if (const TaskPlugin* owner = registry.task_of_key(k)) {
        fail(k, node_text(n), "this key belongs to task '" + owner->name() +
                                  "'; this experiment's task is '" + task + "'");
      }
      fail(k, node_text(n), "unknown key" + did_you_mean(k, names) +
                                "; run 'drops config --markdown' for every key");
    }
    if (k == "task") continue;
    out[k] = validate(*s, n);
  }
  if (out["algorithm"].empty()) out["algorithm"] = registry.default_algorithm();
  registry.algorithm(out["algorithm"]);  // ConfigError naming the available algorithms
  resolve_derived_defaults(registry, out);
  return out;
}

Settings load_settings_file(const Registry& registry, const std::string& path,
                            const std::vector<std::string>& overrides) {
  const std::string text = read_config_file(path);
  try {
    return load_settings(registry, text, overrides);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

void resolve_derived_defaults(const Registry& registry, Settings& settings) {
  const auto task = settings.find("task");
  if (task == settings.end() || !registry.has_task(task->second)) return;
  const auto shared = registry.task(task->second).shared_defaults();
  for (const auto& [key, fallback] : fallback_defaults()) {
    const auto it = settings.find(key);
    if (it == settings.end()) continue;
    // Empty, or "auto" for an enum (no other value of these keys can be "auto").
    if (!it->second.empty() && it->second != "auto") continue;
    const auto t = shared.find(key);
    it->second = t != shared.end() ? t->second : fallback;
  }
  // Other keys with an empty default (an algorithm's, e.g. ite.evaluations) take the task's value
  // when it gives one; otherwise they stay empty and their algorithm applies its own default.
  for (const auto& [key, value] : shared) {
    const auto it = settings.find(key);
    if (it != settings.end() && it->second.empty()) it->second = value;
  }
  // A run's budget follows the total: a quarter of it (at least 4 runs per search).
  const auto run = settings.find("optimizer.run_evaluations");
  const auto total = settings.find("optimizer.max_evaluations");
  if (run != settings.end() && run->second.empty() && total != settings.end()) {
    try {
      run->second = std::to_string(std::stoll(total->second) / 4);
    } catch (const std::exception&) {
      // a malformed total is reported by the validation of optimizer.max_evaluations
    }
  }
}

namespace {
/// Nested view of the dotted keys, in schema order.
struct Tree {
  std::vector<std::pair<std::string, Tree>> children;
  YAML::Node leaf;
  Tree& child(const std::string& name) {
    for (auto& c : children)
      if (c.first == name) return c.second;
    children.emplace_back(name, Tree{});
    return children.back().second;
  }
};

void emit(YAML::Emitter& e, const Tree& t) {
  e << YAML::BeginMap;
  for (const auto& [name, sub] : t.children) {
    e << YAML::Key << name << YAML::Value;
    if (sub.children.empty())
      e << sub.leaf;
    else
      emit(e, sub);
  }
  e << YAML::EndMap;
}

YAML::Node leaf_node(const KeySpec* spec, const std::string& v) {
  const std::string type = spec ? spec->type : "string";
  if (type == "interval" || type == "names") return YAML::Load(v);
  if (type == "string" || type == "enum") return YAML::Node(v);
  if (v.empty()) return YAML::Node(YAML::NodeType::Null);
  return YAML::Load(v);
}
}  // namespace

std::string to_yaml(const Registry& registry, const Settings& settings) {
  std::vector<KeySpec> keys;
  const auto task = settings.find("task");
  if (task != settings.end() && registry.has_task(task->second))
    keys = schema(registry, task->second);
  else
    keys = base_keys();
  Tree root;
  std::set<std::string> done;
  auto put = [&](const std::string& key, const KeySpec* spec) {
    const auto it = settings.find(key);
    if (it == settings.end()) return;
    Tree* node = &root;
    std::stringstream ss(key);
    std::string part;
    while (std::getline(ss, part, '.')) node = &node->child(part);
    node->leaf = leaf_node(spec, it->second);
    done.insert(key);
  };
  for (const auto& s : keys) put(s.key, &s);
  for (const auto& [k, v] : settings)
    if (!done.count(k)) put(k, nullptr);
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  emit(e, root);
  return std::string(e.c_str()) + "\n";
}

namespace {
void markdown_table(std::ostringstream& o, const std::vector<KeySpec>& keys) {
  o << "| key | type | default | range / allowed | unit | meaning |\n";
  o << "|---|---|---|---|---|---|\n";
  for (const auto& s : keys) {
    std::string range;
    if (!s.allowed.empty()) {
      range = joined(s.allowed);
    } else if (s.min < s.max) {
      std::ostringstream r;
      r.precision(12);
      r << "[" << s.min << ", " << s.max << "]";
      range = r.str();
    }
    o << "| `" << s.key << "` | " << s.type << " | `"
      << (s.default_value.empty() ? "\"\"" : s.default_value) << "` | " << range << " | "
      << s.unit << " | " << s.doc << " |\n";
  }
}
}  // namespace

std::string schema_markdown(const Registry& registry) {
  std::ostringstream o;
  o << "## The experiment and the policy search\n\n";
  markdown_table(o, registered_base_keys(registry));
  for (const auto& a : registry.algorithm_names()) {
    const auto keys = registry.algorithm(a).keys();
    o << "\n## Algorithm `" << a << "`\n\n" << registry.algorithm(a).description() << "\n";
    if (keys.empty()) continue;
    o << "\n";
    markdown_table(o, keys);
  }
  for (const auto& t : registry.task_names()) {
    const TaskPlugin& p = registry.task(t);
    o << "\n## Task `" << t << "`\n\n" << p.description() << "\n\n";
    const auto shared = p.shared_defaults();
    if (!shared.empty()) {
      o << "Its defaults of shared keys:";
      bool first = true;
      for (const auto& [k, v] : shared) {
        o << (first ? " " : ", ") << "`" << k << "` = `" << v << "`";
        first = false;
      }
      o << ".\n\n";
    }
    markdown_table(o, p.keys());
  }
  return o.str();
}

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = 5;  // suggest only within 4 edits
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

// Settings hold validated text; these conversions fail only for settings that did not come from
// load_settings, and then say which key and value.
double get_double(const Settings& s, const std::string& key) {
  try {
    return std::stod(s.at(key));
  } catch (const std::invalid_argument&) {
    fail(key, s.at(key), "expected a number");
  } catch (const std::out_of_range&) {
    if (!s.count(key)) throw;
    fail(key, s.at(key), "out of range");
  }
}
long long get_int(const Settings& s, const std::string& key) {
  try {
    return std::stoll(s.at(key));
  } catch (const std::invalid_argument&) {
    fail(key, s.at(key), "expected an integer");
  } catch (const std::out_of_range&) {
    if (!s.count(key)) throw;
    fail(key, s.at(key), "out of range");
  }
}
bool get_bool(const Settings& s, const std::string& key) { return s.at(key) == "true"; }
std::vector<double> get_interval(const Settings& s, const std::string& key) {
  try {
    const YAML::Node n = YAML::Load(s.at(key));
    if (!n.IsSequence() || n.size() != 2) fail(key, s.at(key), "expected [lower, upper]");
    return {n[0].as<double>(), n[1].as<double>()};
  } catch (const YAML::Exception&) {
    fail(key, s.at(key), "expected [lower, upper] of two numbers");
  }
}
std::vector<std::string> get_names(const Settings& s, const std::string& key) {
  try {
    std::vector<std::string> out;
    for (const auto& n : YAML::Load(s.at(key))) out.push_back(n.as<std::string>());
    return out;
  } catch (const YAML::Exception&) {
    fail(key, s.at(key), "expected a list of names such as [a, b]");
  }
}

}  // namespace drops::experiment
