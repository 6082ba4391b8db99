#include "drops/io/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::io {
namespace {

const std::vector<std::string> kParams = {"m1", "m2", "l1", "l2", "b1", "b2"};
const std::vector<std::string> kLegChoices = {"intact", "leg0", "leg1", "leg2",
                                              "leg3",   "leg4", "leg5"};
const std::vector<std::string> kDamageChoices = {"none", "leg0", "leg1", "leg2",
                                                 "leg3", "leg4", "leg5"};
/// "intact"/"none" -> -1, "legk" -> k.
int leg_index(const std::string& name) {
  return name == "intact" || name == "none" ? -1 : name[3] - '0';
}

std::vector<KeySpec> build_schema() {
  std::vector<KeySpec> s;
  auto add = [&](KeySpec k) { s.push_back(std::move(k)); };
  const double big = 1e9;
  add({"task", "enum", "pendubot", 0, 0, {"pendubot", "hexapod"}, "-",
       "the learning problem: pendubot swing-up (paper §V-A) or hexapod locomotion (§V-B, needs a "
       "build with DART)"});
  add({"seed", "int", "1", 0, 4294967295.0, {}, "-",
       "the run's only seed: every random stream derives from it (same numbers with any thread count)"});
  add({"episodes", "int", "10", 1, 1000, {}, "-", "real episodes in total, including the first one"});
  add({"threads", "int", "0", 0, 1024, {}, "-", "worker threads (0 = all hardware threads)"});
  add({"output", "string", "runs", 0, 0, {}, "-", "parent directory of run directories"});
  add({"name", "string", "", 0, 0, {}, "-",
       "run directory name (empty = <task>-<model>-<prior>-seed<seed>-<date>-<time>)"});
  for (const auto& p : kParams) {
    const bool mass = p[0] == 'm', len = p[0] == 'l';
    const std::string unit = mass ? "kg" : len ? "m" : "N m s";
    const std::string what = mass ? "mass of link " : len ? "length of link " : "viscous friction of joint ";
    add({"system." + p, "double", p[0] == 'b' ? "0.1" : "0.5", mass || len ? 0.01 : 0.0, 100, {},
         unit, "actual (\"real\") system: " + what + p.substr(1) + " (Table I, actual)"});
  }
  add({"prior.preset", "enum", "tunable-useful", 0, 0, pendubot::preset_names(), "-",
       "starting prior of Table I: tunable-useful (A), tunable (B), tunable-misleading (C), "
       "partially-tunable (D), or actual"});
  for (const auto& p : kParams) {
    add({"prior." + p, "double", "", 0.0, 100, {}, p[0] == 'm' ? "kg" : p[0] == 'l' ? "m" : "N m s",
         "prior's " + p + " (empty = the preset's value); a custom prior is the preset plus these"});
  }
  add({"prior.tunable", "names", "[m1, m2, l1, l2]", 0, 0, kParams, "-",
       "parameters that GP-MI and MI may tune (the others stay fixed)"});
  for (const auto& p : kParams) {
    const bool ml = p[0] != 'b';
    add({"prior.bounds." + p, "interval", ml ? "[0.05, 1.0]" : "[0.0, 1.0]", ml ? 0.01 : 0.0, 100,
         {}, ml ? (p[0] == 'm' ? "kg" : "m") : "N m s",
         std::string("search interval of ") + p + " when tunable" +
             (ml ? " (lower >= 0.01: the inertia matrix is singular at 0)" : "")});
  }
  add({"pendubot.dt", "double", "0.05", 1e-4, 1, {}, "s", "control period"});
  add({"pendubot.duration", "double", "2.5", 0.01, 100, {}, "s", "episode length"});
  add({"pendubot.max_torque", "double", "3.5", 1e-3, 100, {}, "N m", "torque bound |u|"});
  add({"pendubot.substeps", "int", "5", 1, 1000, {}, "-", "RK4 substeps per control period"});
  add({"pendubot.reward_sigma", "double", "0.5", 1e-3, 10, {}, "m", "width sigma_c of the reward"});
  add({"pendubot.solved_radius", "double", "0.15", 1e-3, 2, {}, "m",
       "solved: the tip stays within this distance of upright ..."});
  add({"pendubot.solved_window", "double", "0.5", 0, 100, {}, "s",
       "... for the whole last solved_window seconds of the episode"});
  add({"hexapod.horizon", "int", "40", 1, 10000, {}, "-",
       "hexapod: control steps of 0.1 s per episode (40 = the paper's 4 s)"});
  add({"hexapod.prior.start", "enum", "intact", 0, 0, kLegChoices, "-",
       "hexapod: the prior simulator of episode 1 and of gp_prior, GP-MI's starting point: the "
       "intact robot or leg k removed (legs 0 rear-left, 1 mid-left, 2 front-left, 3 front-right, "
       "4 mid-right, 5 rear-right)"});
  add({"hexapod.prior.choices", "names", "[intact, leg0, leg1, leg2, leg3, leg4, leg5]", 0, 0,
       kLegChoices, "-", "hexapod: the prior family GP-MI and MI search exhaustively (the paper's 7)"});
  add({"hexapod.damage.removed_leg", "enum", "none", 0, 0, kDamageChoices, "-",
       "hexapod: the leg removed from the \"real\" robot (the paper's damage: a rear leg, leg0 or leg5)"});
  add({"hexapod.damage.shortened_leg", "enum", "none", 0, 0, kDamageChoices, "-",
       "hexapod: a leg of the real robot whose tibia is shortened (damage outside the prior family)"});
  add({"hexapod.damage.tibia_factor", "double", "0.5", 0.05, 1, {}, "-",
       "hexapod: the shortened tibia's length as a fraction of the intact one"});
  add({"hexapod.damage.blocked_leg", "enum", "none", 0, 0, kDamageChoices, "-",
       "hexapod: a leg of the real robot with one joint blocked (damage outside the prior family)"});
  add({"hexapod.damage.blocked_joint", "int", "1", 0, 2, {}, "-",
       "hexapod: which joint of blocked_leg is blocked (0 hip, 1 femur, 2 tibia)"});
  add({"hexapod.damage.blocked_angle", "double", "0", -1.5707963267948966, 1.5707963267948966, {},
       "rad", "hexapod: the angle the blocked joint is held at (within its limits)"});
  add({"hexapod.noise", "bool", "true", 0, 0, {}, "-",
       "hexapod: measurement noise on the real robot's state (motion capture, encoders)"});
  add({"hexapod.guard", "enum", "stop", 0, 0, {"stop", "clamp"}, "-",
       "hexapod: what the prior does with an implausible predicted state (non-finite, beyond joint "
       "limits, body height out of range): stop that rollout, or clamp the state and go on; every "
       "event is counted in the episode summary"});
  add({"model.type", "enum", "gp_mi", 0, 0, {"gp", "gp_prior", "gp_mi", "mi"}, "-",
       "gp: Black-DROPS; gp_prior: with priors; gp_mi: with GP-MI; mi: with MI (no GP)"});
  add({"model.rprop.iterations", "int", "300", 1, 100000, {}, "-",
       "Rprop iterations of the final kernel fit per output GP"});
  add({"model.rprop.tolerance", "double", "1e-3", 0, big, {}, "nats",
       "stop a kernel fit early when the log-likelihood gains less than this over `patience` "
       "iterations (0 = always run every iteration)"});
  add({"model.rprop.patience", "int", "10", 1, 100000, {}, "-", "window of the tolerance test"});
  add({"model.rprop.penalty", "enum", "auto", 0, 0, {"auto", "on", "off"}, "-",
       "PILCO's soft walls on extreme length scales and signal-to-noise ratios in the kernel fits "
       "(auto = on for the hexapod, whose GPs on 40-400 points in 66 input dimensions otherwise "
       "interpolate noise, and off for the pendubot; the reference used them for its no-prior "
       "variant: model.type gp with penalty on); see docs/hexapod.md"});
  add({"model.rprop.max_length_scale_ratio", "double", "", 1.001, 1e6, {}, "-",
       "soft walls: length scale l_d within [s_d / ratio, ratio s_d], s_d the spread of input d "
       "(empty = 100, PILCO's value, for the pendubot; 10 for the hexapod, measured in docs/hexapod.md)"});
  add({"model.rprop.max_snr", "double", "500", 1.001, 1e9, {}, "-",
       "soft walls: signal-to-noise ratio sigma_f / sigma_n at most this (PILCO: 500)"});
  add({"model.gp_mi.search", "enum", "alternating", 0, 0, {"alternating", "nested"}, "-",
       "nested: paper's Algorithm 2 (Rprop inside every Subplex evaluation); alternating: "
       "block-coordinate ascent on the same score (much faster)"});
  add({"model.gp_mi.score", "enum", "sum_likelihoods", 0, 0, {"sum_likelihoods", "sum_log_likelihoods"},
       "-", "GP-MI's score: log sum_i exp(loglik_i), the paper's sum of the likelihoods, or "
       "sum_i loglik_i, the joint likelihood of the output GPs (every output counts; see docs/hexapod.md)"});
  add({"model.gp_mi.max_evaluations", "int", "1000", 1, 1000000, {}, "-",
       "Subplex evaluations per phi search"});
  add({"model.gp_mi.tolerance", "double", "1e-4", 0, 1, {}, "-",
       "Subplex relative tolerance on phi and on the score"});
  add({"model.gp_mi.rounds", "int", "5", 1, 100, {}, "-", "alternating search: maximum rounds"});
  add({"model.gp_mi.inner_rprop_iterations", "int", "50", 1, 100000, {}, "-",
       "Rprop iterations of kernel refits inside the phi search"});
  add({"model.gp_mi.max_points", "int", "0", 0, 1000000, {}, "-",
       "transitions used inside the phi search, evenly spaced (0 = all); the final fit uses all"});
  add({"model.mi.max_evaluations", "int", "2000", 1, 1000000, {}, "-", "Subplex evaluations of MI"});
  add({"model.mi.tolerance", "double", "1e-6", 0, 1, {}, "-", "Subplex relative tolerance of MI"});
  add({"policy.hidden_units", "int", "10", 1, 1000, {}, "-", "tanh units of the network policy"});
  add({"policy.bound", "double", "", 1e-3, 1000, {}, "-",
       "policy parameters are searched in [-bound, bound] (empty = 5 for the pendubot's network; "
       "0.5 for the hexapod's gait, whose parameters in [0, 1] are theta + 0.5)"});
  add({"optimizer.max_evaluations", "int", "", 10, 100000000, {}, "-",
       "CMA-ES policy evaluations per optimization, all restarts (empty = 10000 for the pendubot, "
       "2000 for the hexapod, whose rollouts cost about 50 times more)"});
  add({"optimizer.run_evaluations", "int", "", 0, 100000000, {}, "-",
       "CMA-ES evaluations of one run before it restarts (empty = a quarter of "
       "optimizer.max_evaluations; 0 = no per-run budget): with a noisy objective the tolerances rarely end a run, so "
       "this is what makes restarts happen"});
  add({"optimizer.restarts", "int", "3", 0, 100, {}, "-",
       "large-population (IPOP) restarts after the first run; BIPOP's small runs come in between"});
  add({"optimizer.restart_from", "enum", "mixed", 0, 0, {"mixed", "random", "start"}, "-",
       "where restarts begin: mixed = BIPOP's small (local) runs from the start policy and its large "
       "runs from random points; random = every restart from a random point (Hansen 2009); start = "
       "every restart from the start policy"});
  add({"optimizer.tol_fun", "double", "0.01", 0, 1e6, {}, "return",
       "a run stops when its best returns of the last 10 + 30n/lambda generations (TolHistFun), or "
       "those and all of the last generation's (TolFun), lie within this range"});
  add({"optimizer.stagnation", "bool", "true", 0, 0, {}, "-",
       "a run stops when its best and median returns stopped improving (Hansen 2009's Stagnation)"});
  add({"optimizer.lambda", "int", "0", 0, 100000, {}, "-",
       "population size of the first run (0 = 4 + floor(3 ln n), 17 for 81 parameters)"});
  add({"optimizer.sigma0", "double", "0", 0, 1000, {}, "-", "initial step size (0 = policy.bound)"});
  add({"optimizer.elitism", "bool", "true", 0, 0, {}, "-", "re-inject the best-ever candidate"});
  add({"optimizer.active", "bool", "true", 0, 0, {}, "-", "active covariance update (aCMA)"});
  add({"optimizer.bipop", "bool", "true", 0, 0, {}, "-", "BIPOP restarts (false = IPOP)"});
  add({"optimizer.uncertainty_handling", "bool", "false", 0, 0, {}, "-",
       "Hansen et al. 2009 uncertainty handling for the noisy rollout objective"});
  add({"optimizer.keep_start", "bool", "true", 0, 0, {}, "-",
       "the best policy so far is the start and a candidate: each search starts from the policy of "
       "the best real episode, evaluates it on the current model like any candidate and runs it again "
       "unless a candidate beats it (as the reference's CMA-ES wrapper); false = the start only "
       "centres the first CMA-ES run"});
  add({"optimizer.selection", "enum", "reevaluate", 0, 0, {"reevaluate", "best_seen"}, "-",
       "which evaluated policy is run: reevaluate = the best mean return when the start, the best "
       "evaluated policies and each run's final mean are re-evaluated with many rollouts (robust to "
       "lucky rollouts); best_seen = the best single evaluation (the paper's reference)"});
  add({"optimizer.reevaluation_rollouts", "int", "", 1, 100000, {}, "-",
       "selection reevaluate: rollouts per re-evaluated policy, on common random numbers (empty = 50 "
       "for the pendubot, 20 for the hexapod, whose rollouts cost about 50 times more)"});
  add({"optimizer.reevaluation_candidates", "int", "10", 1, 10000, {}, "-",
       "selection reevaluate: best distinct evaluated policies re-evaluated (besides the start and "
       "the runs' final means)"});
  add({"optimizer.prior_optimizations", "int", "2", 1, 100, {}, "-",
       "with a prior: successive optimizations on the prior alone for episode 1"});
  add({"rollouts.count", "int", "1", 1, 10000, {}, "-",
       "Monte-Carlo rollouts averaged per policy evaluation"});
  add({"rollouts.clip", "double", "1", 0, 100, {}, "sigma",
       "clip each predictive draw to mean +- clip * sigma (0 = no clipping)"});
  add({"rollouts.batch", "int", "8", 1, 1024, {}, "-",
       "rollouts advanced together through batched GP predictions"});
  add({"rollouts.predicted", "int", "20", 1, 100000, {}, "-",
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

const KeySpec* find_spec(const std::string& key) {
  for (const auto& s : schema())
    if (s.key == key) return &s;
  return nullptr;
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

[[noreturn]] void unknown_key(const std::string& key, const std::string& value) {
  std::vector<std::string> keys;
  for (const auto& s : schema()) keys.push_back(s.key);
  fail(key, value, "unknown key" + did_you_mean(key, keys) +
                       "; run 'drops config --markdown' for every key");
}

double parse_double(const std::string& key, const YAML::Node& n) {
  const std::string text = node_text(n);
  if (!n.IsScalar()) fail(key, text, "expected a number");
  try {
    std::size_t pos = 0;
    const double v = std::stod(n.Scalar(), &pos);
    if (pos != n.Scalar().size()) throw std::invalid_argument("trailing");
    if (!std::isfinite(v)) throw std::invalid_argument("non-finite");
    return v;
  } catch (const std::exception&) {
    fail(key, text, "expected a finite number");
  }
}

void check_range(const KeySpec& s, double v, const std::string& text) {
  if (s.min < s.max && (v < s.min || v > s.max)) {
    std::ostringstream o;
    o << "out of range: allowed [" << s.min << ", " << s.max << "]" << (s.unit != "-" ? " " + s.unit : "");
    fail(s.key, text, o.str());
  }
}

/// Validates one value against its spec; returns the canonical text stored in Settings.
std::string validate(const KeySpec& s, const YAML::Node& n) {
  const std::string text = node_text(n);
  if (s.type == "string") {
    if (!n.IsScalar()) fail(s.key, text, "expected a string");
    return n.Scalar();
  }
  if (s.type == "enum") {
    if (!n.IsScalar() || std::find(s.allowed.begin(), s.allowed.end(), n.Scalar()) == s.allowed.end()) {
      std::string allowed;
      for (const auto& a : s.allowed) allowed += (allowed.empty() ? "" : ", ") + a;
      fail(s.key, text, "allowed values: " + allowed);
    }
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
    if (!n.IsSequence()) fail(s.key, text, "expected a list such as [m1, m2]");
    std::set<std::string> seen;
    for (const auto& e : n) {
      if (!e.IsScalar() || std::find(s.allowed.begin(), s.allowed.end(), e.Scalar()) == s.allowed.end()) {
        std::string allowed;
        for (const auto& a : s.allowed) allowed += (allowed.empty() ? "" : ", ") + a;
        fail(s.key, text, "allowed names: " + allowed);
      }
      if (!seen.insert(e.Scalar()).second) fail(s.key, text, "'" + e.Scalar() + "' is listed twice");
    }
    return text;
  }
  fail(s.key, text, "internal: unknown type " + s.type);
}

void flatten(const YAML::Node& node, const std::string& prefix, Settings& out) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      const std::string k = kv.first.as<std::string>();
      const std::string key = prefix.empty() ? k : prefix + "." + k;
      // A schema key whose value is a map is a type error; a non-schema prefix recurses.
      if (find_spec(key) || !kv.second.IsMap()) {
        const KeySpec* s = find_spec(key);
        if (!s) unknown_key(key, node_text(kv.second));
        out[key] = validate(*s, kv.second);
      } else {
        bool is_prefix = false;
        for (const auto& s : schema())
          if (s.key.rfind(key + ".", 0) == 0) is_prefix = true;
        if (!is_prefix) unknown_key(key, node_text(kv.second));
        flatten(kv.second, key, out);
      }
    }
  } else if (!node.IsNull()) {
    throw ConfigError("config: the document must be a mapping of keys, got '" + node_text(node) + "'");
  }
}

YAML::Node parse_yaml(const std::string& text, const std::string& where) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(where + ": invalid YAML: " + e.what());
  }
}

std::vector<double> interval(const std::string& text) {
  const YAML::Node n = YAML::Load(text);
  return {n[0].as<double>(), n[1].as<double>()};
}

}  // namespace

const std::vector<KeySpec>& schema() {
  static const std::vector<KeySpec> s = build_schema();
  return s;
}

Settings load_settings(const std::string& yaml_text, const std::vector<std::string>& overrides) {
  Settings out;
  for (const auto& s : schema()) out[s.key] = s.default_value;
  flatten(parse_yaml(yaml_text, "config"), "", out);
  for (const auto& o : overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0)
      throw ConfigError("override '" + o + "': expected key=value, e.g. model.type=gp_prior");
    const std::string key = o.substr(0, eq), value = o.substr(eq + 1);
    const KeySpec* s = find_spec(key);
    if (!s) unknown_key(key, value);
    YAML::Node n = value.empty() ? YAML::Node(std::string()) : parse_yaml(value, "override " + key);
    if (s->type == "string" || s->type == "enum") n = YAML::Node(value);
    out[key] = validate(*s, n);
  }
  return out;
}

namespace {
std::string read_config_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError("cannot read config file '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

Settings load_settings_file(const std::string& path, const std::vector<std::string>& overrides) {
  const std::string text = read_config_file(path);
  try {
    return load_settings(text, overrides);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

Settings load_run_settings(const std::string& yaml_text, const std::vector<std::string>& overrides) {
  // Keys added after a run may have been written, with the value that reproduces the old runs.
  static const std::pair<const char*, const char*> kLegacy[] = {
      {"optimizer.selection", "best_seen"},
      {"optimizer.run_evaluations", "0"},
      {"optimizer.stagnation", "false"},
      {"optimizer.tol_fun", "1e-12"},
      {"optimizer.restart_from", "random"},
  };
  Settings present;
  flatten(parse_yaml(yaml_text, "config"), "", present);
  std::vector<std::string> all;
  for (const auto& [key, value] : kLegacy)
    if (!present.count(key)) all.push_back(std::string(key) + "=" + value);
  all.insert(all.end(), overrides.begin(), overrides.end());
  return load_settings(yaml_text, all);
}

Settings load_run_settings_file(const std::string& path,
                                const std::vector<std::string>& overrides) {
  const std::string text = read_config_file(path);
  try {
    return load_run_settings(text, overrides);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

bool is_run_config(const std::string& path) {
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  std::error_code ec;
  return std::filesystem::exists(dir / "episodes.csv", ec) ||
         std::filesystem::exists(dir / "summary.json", ec);
}

namespace {
// The hexapod part of make_experiment: plain settings (the hexapod target builds the robot from
// them, apps/task_setup.cpp) and the discrete prior family of GP-MI (paper §V-B: 7 priors).
void hexapod_experiment(const Settings& st, Experiment& e) {
  auto& h = e.hexapod;
  h.horizon = std::stoi(st.at("hexapod.horizon"));
  h.prior_start = leg_index(st.at("hexapod.prior.start"));
  h.prior_choices.clear();
  for (const auto& n : YAML::Load(st.at("hexapod.prior.choices")))
    h.prior_choices.push_back(leg_index(n.as<std::string>()));
  std::sort(h.prior_choices.begin(), h.prior_choices.end());
  if (h.prior_choices.empty())
    throw ConfigError("config key 'hexapod.prior.choices' = '[]': name at least one prior");
  if (std::find(h.prior_choices.begin(), h.prior_choices.end(), h.prior_start) ==
      h.prior_choices.end())
    throw ConfigError("config key 'hexapod.prior.start' = '" + st.at("hexapod.prior.start") +
                      "': not among hexapod.prior.choices = " + st.at("hexapod.prior.choices"));
  h.removed_leg = leg_index(st.at("hexapod.damage.removed_leg"));
  h.shortened_leg = leg_index(st.at("hexapod.damage.shortened_leg"));
  h.tibia_factor = std::stod(st.at("hexapod.damage.tibia_factor"));
  h.blocked_leg = leg_index(st.at("hexapod.damage.blocked_leg"));
  h.blocked_joint = std::stoi(st.at("hexapod.damage.blocked_joint"));
  h.blocked_angle = std::stod(st.at("hexapod.damage.blocked_angle"));
  h.noise = st.at("hexapod.noise") == "true";
  h.guard_clamp = st.at("hexapod.guard") == "clamp";
  for (int leg : {h.shortened_leg, h.blocked_leg})
    if (leg >= 0 && leg == h.removed_leg)
      throw ConfigError("config: hexapod.damage: leg" + std::to_string(leg) +
                        " is removed; it cannot also be shortened or blocked");

  // The prior family: phi = [removed_leg], one discrete tunable entry.
  auto& p = e.prior;
  p.names = {"removed_leg"};
  p.values = VectorXd::Constant(1, h.prior_start);
  p.tunable = {0};
  p.lower = VectorXd::Constant(1, h.prior_choices.front());
  p.upper = VectorXd::Constant(1, h.prior_choices.back());
  p.choices = {std::vector<double>(h.prior_choices.begin(), h.prior_choices.end())};
  e.prior_preset = st.at("hexapod.prior.start");
  e.phi_actual = {static_cast<double>(h.removed_leg)};
}
}  // namespace

void resolve_derived_defaults(Settings& settings) {
  const auto task = settings.find("task");
  const bool hexapod = task != settings.end() && task->second == "hexapod";
  const std::pair<const char*, const char*> derived[] = {
      {"policy.bound", hexapod ? "0.5" : "5"},
      {"optimizer.max_evaluations", hexapod ? "2000" : "10000"},
      {"optimizer.reevaluation_rollouts", hexapod ? "20" : "50"},
      {"model.rprop.max_length_scale_ratio", hexapod ? "10" : "100"},
  };
  for (const auto& [key, value] : derived) {
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

Experiment make_experiment(const Settings& settings) {
  Settings st = settings;
  resolve_derived_defaults(st);
  auto str = [&](const std::string& k) { return st.at(k); };
  auto dbl = [&](const std::string& k) { return std::stod(st.at(k)); };
  auto integer = [&](const std::string& k) { return std::stoll(st.at(k)); };
  auto boolean = [&](const std::string& k) { return st.at(k) == "true"; };
  Experiment e;
  e.task = str("task");
  e.seed = static_cast<std::uint64_t>(integer("seed"));
  e.threads = static_cast<int>(integer("threads"));
  e.output = str("output");
  e.name = str("name");
  e.prior_preset = str("prior.preset");

  auto& to = e.task_options;
  to.dt = dbl("pendubot.dt");
  to.duration = dbl("pendubot.duration");
  to.max_torque = dbl("pendubot.max_torque");
  to.substeps = static_cast<int>(integer("pendubot.substeps"));
  to.reward_sigma = dbl("pendubot.reward_sigma");
  to.solved_radius = dbl("pendubot.solved_radius");
  to.solved_window = dbl("pendubot.solved_window");
  if (to.duration < to.dt)
    throw ConfigError("config key 'pendubot.duration' = '" + str("pendubot.duration") +
                      "': must be >= pendubot.dt");

  VectorXd actual(6);
  for (int i = 0; i < 6; ++i) actual[i] = dbl("system." + kParams[static_cast<std::size_t>(i)]);
  e.actual = pendubot::Params::from_phi(actual);
  to.goal_l1 = e.actual.l1;  // the reward uses the actual lengths (settings.md §2)
  to.goal_l2 = e.actual.l2;

  e.phi_actual.assign(actual.data(), actual.data() + actual.size());
  if (e.task == "pendubot") {
    auto& p = e.prior;
    p.names = kParams;
    p.values = pendubot::preset(e.prior_preset).to_phi();
    for (int i = 0; i < 6; ++i) {
      const std::string k = "prior." + kParams[static_cast<std::size_t>(i)];
      if (!st.at(k).empty()) p.values[i] = dbl(k);
    }
    try {
      pendubot::Params::from_phi(p.values).check();
    } catch (const InvalidArgument& ex) {
      throw ConfigError(std::string("prior: ") + ex.what());
    }
    const YAML::Node tun = YAML::Load(st.at("prior.tunable"));
    for (const auto& n : tun) {
      const auto it = std::find(kParams.begin(), kParams.end(), n.as<std::string>());
      p.tunable.push_back(static_cast<int>(it - kParams.begin()));
    }
    std::sort(p.tunable.begin(), p.tunable.end());
    p.lower.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.upper.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.choices.assign(p.tunable.size(), {});
    for (std::size_t k = 0; k < p.tunable.size(); ++k) {
      const std::string& name = kParams[static_cast<std::size_t>(p.tunable[k])];
      const auto b = interval(st.at("prior.bounds." + name));
      p.lower[static_cast<Eigen::Index>(k)] = b[0];
      p.upper[static_cast<Eigen::Index>(k)] = b[1];
      const double v = p.values[p.tunable[k]];
      if (v < b[0] || v > b[1]) {
        std::ostringstream o;
        o << "config key 'prior.bounds." << name << "' = '" << st.at("prior.bounds." + name)
          << "': the prior's starting " << name << " = " << v << " lies outside it";
        throw ConfigError(o.str());
      }
    }

    e.policy.observation_dim = 6;
    e.policy.hidden_units = static_cast<int>(integer("policy.hidden_units"));
    e.policy.action_dim = 1;
    e.policy.input_scale = VectorXd(6);
    e.policy.input_scale << 10, 10, 1, 1, 1, 1;
    e.policy.max_action = to.max_torque;

  } else {
    hexapod_experiment(st, e);
  }

  auto& a = e.algo;
  a.episodes = static_cast<int>(integer("episodes"));
  a.seed = e.seed;
  const bool hexapod = e.task == "hexapod";
  a.theta_bound = dbl("policy.bound");
  a.model.type = model::parse_model_type(str("model.type"));
  a.model.rprop.max_iterations = static_cast<int>(integer("model.rprop.iterations"));
  a.model.rprop.tolerance = dbl("model.rprop.tolerance");
  a.model.rprop.patience = static_cast<int>(integer("model.rprop.patience"));
  const std::string penalty = str("model.rprop.penalty");
  a.model.rprop.penalty = penalty == "on" || (penalty == "auto" && hexapod);
  a.model.rprop.max_length_scale_ratio = dbl("model.rprop.max_length_scale_ratio");
  a.model.rprop.max_snr = dbl("model.rprop.max_snr");
  a.model.gp_mi.search = str("model.gp_mi.search") == "nested" ? model::GpMiSearch::kNested
                                                              : model::GpMiSearch::kAlternating;
  a.model.gp_mi.max_evaluations = static_cast<int>(integer("model.gp_mi.max_evaluations"));
  a.model.gp_mi.score = str("model.gp_mi.score") == "sum_log_likelihoods"
                            ? model::GpMiScore::kSumOfLogLikelihoods
                            : model::GpMiScore::kSumOfLikelihoods;
  a.model.gp_mi.xtol_rel = a.model.gp_mi.ftol_rel = dbl("model.gp_mi.tolerance");
  a.model.gp_mi.rounds = static_cast<int>(integer("model.gp_mi.rounds"));
  a.model.gp_mi.inner_rprop_iterations = static_cast<int>(integer("model.gp_mi.inner_rprop_iterations"));
  a.model.gp_mi.max_points = static_cast<int>(integer("model.gp_mi.max_points"));
  a.model.mi.max_evaluations = static_cast<int>(integer("model.mi.max_evaluations"));
  a.model.mi.xtol_rel = a.model.mi.ftol_rel = dbl("model.mi.tolerance");
  a.cmaes.max_evaluations = integer("optimizer.max_evaluations");
  a.cmaes.max_restarts = static_cast<int>(integer("optimizer.restarts"));
  a.cmaes.max_run_evaluations = integer("optimizer.run_evaluations");
  const std::string restart_from = str("optimizer.restart_from");
  a.cmaes.restart_start = restart_from == "random"  ? opt::CmaesRestartStart::kRandom
                          : restart_from == "start" ? opt::CmaesRestartStart::kStart
                                                    : opt::CmaesRestartStart::kMixed;
  a.cmaes.tol_fun = a.cmaes.tol_hist_fun = dbl("optimizer.tol_fun");
  a.cmaes.stagnation = boolean("optimizer.stagnation");
  a.cmaes.lambda = static_cast<int>(integer("optimizer.lambda"));
  a.cmaes.sigma0 = dbl("optimizer.sigma0");
  a.cmaes.elitism = boolean("optimizer.elitism");
  a.cmaes.active = boolean("optimizer.active");
  a.cmaes.bipop = boolean("optimizer.bipop");
  a.cmaes.uncertainty_handling = boolean("optimizer.uncertainty_handling");
  a.prior_optimizations = static_cast<int>(integer("optimizer.prior_optimizations"));
  a.keep_start_point = boolean("optimizer.keep_start");
  a.selection = str("optimizer.selection") == "best_seen" ? algo::PolicySelection::kBestSeen
                                                          : algo::PolicySelection::kReevaluate;
  a.reevaluation_rollouts = static_cast<int>(integer("optimizer.reevaluation_rollouts"));
  a.reevaluation_candidates = static_cast<int>(integer("optimizer.reevaluation_candidates"));
  a.rollouts.rollouts = static_cast<int>(integer("rollouts.count"));
  a.rollouts.clip = dbl("rollouts.clip");
  a.rollouts.batch = static_cast<int>(integer("rollouts.batch"));
  a.predicted_rollouts = static_cast<int>(integer("rollouts.predicted"));
  std::string why;
  if (!a.IsValid(&why)) throw ConfigError("config: " + why);
  return e;
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
}  // namespace

std::string to_yaml(const Settings& settings) {
  Tree root;
  for (const auto& spec : schema()) {
    const std::string& v = settings.at(spec.key);
    Tree* node = &root;
    std::stringstream ss(spec.key);
    std::string part;
    while (std::getline(ss, part, '.')) node = &node->child(part);
    if (spec.type == "interval" || spec.type == "names")
      node->leaf = YAML::Load(v);
    else if (spec.type == "string" || spec.type == "enum")
      node->leaf = YAML::Node(v);
    else if (v.empty())
      node->leaf = YAML::Node(YAML::NodeType::Null);
    else
      node->leaf = YAML::Load(v);
  }
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  emit(e, root);
  return std::string(e.c_str()) + "\n";
}

std::string schema_markdown() {
  std::ostringstream o;
  o << "| key | type | default | range / allowed | unit | meaning |\n";
  o << "|---|---|---|---|---|---|\n";
  for (const auto& s : schema()) {
    std::string range;
    if (!s.allowed.empty()) {
      for (const auto& a : s.allowed) range += (range.empty() ? "" : ", ") + a;
    } else if (s.min < s.max) {
      std::ostringstream r;
      r.precision(12);
      r << "[" << s.min << ", " << s.max << "]";
      range = r.str();
    }
    o << "| `" << s.key << "` | " << s.type << " | `" << (!s.default_value.empty()           ? s.default_value
                                   : s.key.rfind("prior.", 0) == 0 ? "(preset)"
                                                                   : "\"\"")
      << "` | " << range << " | " << s.unit << " | " << s.doc << " |\n";
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

}  // namespace drops::io
