// The configuration schema (base keys + algorithms' + the task's), YAML loading and validation.
#include "drops/experiment/config.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/identify.hpp"
#include "drops/experiment/keys.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::experiment {
namespace {

// A key or value as messages show it: at most 200 characters, the length said when longer (a
// 1 MB value is not echoed whole).
std::string shown(const std::string& text) {
  constexpr std::size_t kMax = 200;
  if (text.size() <= kMax) return text;
  std::size_t cut = kMax;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // UTF-8
  return text.substr(0, cut) + fmt::format("... ({} characters)", text.size());
}

[[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& what) {
  throw ConfigError("config key '" + shown(key) + "' = '" + shown(value) + "': " + what);
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
  if (s.type == "string" || s.type == "path") {
    if (n.IsNull()) return "";
    if (!n.IsScalar()) fail(s.key, text, "expected a string");
    return n.Scalar();
  }
  // Any other key given no value (~ or empty) takes its default: the task's when the task sets
  // one, "" for an optional key (whose help says what empty means).
  if (n.IsNull() || (n.IsScalar() && n.Scalar().empty())) return s.default_value;
  if (s.type == "enum") {
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
    const double v = parse_double(s.key, n);
    if (v != std::floor(v)) fail(s.key, text, "expected an integer");
    check_range(s, v, text);
    return std::to_string(static_cast<long long>(v));
  }
  if (s.type == "double") {
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
  if (s.type == "list") {
    if (!n.IsSequence()) fail(s.key, text, "expected a list such as [a, b] or [{a: 1}, {a: 2}]");
    YAML::Emitter e;
    e.SetSeqFormat(YAML::Flow);
    e.SetMapFormat(YAML::Flow);
    e << n;
    return e.c_str();
  }
  if (s.type == "paths") {
    if (!n.IsSequence()) fail(s.key, text, "expected a list of paths such as [a.csv, b.csv]");
    for (const auto& e : n)
      if (!e.IsScalar() || e.Scalar().empty())
        fail(s.key, text, "expected a list of paths such as [a.csv, b.csv]");
    YAML::Emitter e;
    e.SetSeqFormat(YAML::Flow);
    e << n;
    return e.c_str();
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
  if (s.type == "numbers") {
    if (!n.IsSequence() || n.size() == 0) fail(s.key, text, "expected a list such as [0.1, 0.5]");
    for (const auto& e : n) check_range(s, parse_double(s.key, e), text);
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
        throw ConfigError("config: a key is not a plain name: '" + shown(node_text(kv.first)) +
                          "'");
      }
      const std::string key = prefix.empty() ? k : prefix + "." + k;
      if (is_key(key) || !kv.second.IsMap())
        out.emplace_back(key, kv.second);
      else
        flatten(kv.second, key, is_key, out);
    }
  } else if (!node.IsNull()) {
    throw ConfigError("config: the document must be a mapping of keys, got '" +
                      shown(node_text(node)) + "'");
  }
}

// A configuration file: a regular file of at most kMaxConfigFileBytes (a directory or a device
// such as /dev/zero is refused before it is read). Throws ConfigError with the reason.
std::string read_config_file(const std::string& path) {
  try {
    return read_file_text(path, kMaxConfigFileBytes);
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& e) {
    throw ConfigError(file_error("config file", e.what()));
  }
}

// A task whose schema() exists: a registered task, or kNoTask (drops identify without a task).
bool has_schema(const Registry& registry, const std::string& task) {
  return task == kNoTask || registry.has_task(task);
}

/// Every key of the registry: base, algorithms', every task's (for the keys of other tasks).
bool known_anywhere(const Registry& registry, const std::string& key) {
  for (const auto& s : base_keys())
    if (s.key == key) return true;
  for (const auto& a : registry.algorithm_names())
    for (const auto& s : registry.algorithm(a).keys())
      if (s.key == key) return true;
  for (const auto& s : identify_keys())
    if (s.key == key) return true;
  for (const auto& s : run_data_keys())
    if (s.key == key) return true;
  for (const auto& s : no_task_keys())
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
  static const std::vector<KeySpec> s = base_key_table().specs();
  return s;
}

std::vector<KeySpec> schema(const Registry& registry, const std::string& task) {
  std::vector<KeySpec> s = registered_base_keys(registry);
  for (const auto& a : registry.algorithm_names())
    for (auto& k : registry.algorithm(a).keys()) s.push_back(std::move(k));
  for (auto& k : identify_keys()) s.push_back(std::move(k));
  if (task == kNoTask) {
    for (auto& k : no_task_keys()) s.push_back(std::move(k));
    return s;
  }
  for (auto& k : run_data_keys()) s.push_back(std::move(k));
  const TaskPlugin& t = registry.task(task);
  for (auto& k : t.keys()) s.push_back(std::move(k));
  // The task's defaults of shared keys, validated by their declarations.
  for (const auto& [key, value] : t.shared_defaults()) {
    const auto it =
        std::find_if(s.begin(), s.end(), [&](const KeySpec& k) { return k.key == key; });
    if (it == s.end())
      throw ConfigError("task '" + task + "' sets the default of '" + key +
                        "', which is no key of its schema");
    try {
      it->default_value = validate(*it, parse_yaml(value, "default of " + key));
    } catch (const ConfigError& e) {
      throw ConfigError("task '" + task + "', its default: " + e.what());
    }
  }
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
      throw ConfigError("override '" + shown(o) +
                        "': expected key=value, e.g. model.type=gp_prior");
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
  if (task != kNoTask) registry.task(task);  // ConfigError naming the available tasks
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
  Settings s;
  try {
    s = load_settings(registry, text, overrides);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  resolve_path_keys(registry, s, path);
  return s;
}

void resolve_path_keys(const Registry& registry, Settings& settings,
                       const std::string& config_file) {
  // A relative "path" key: in the configuration file's directory, then the working directory.
  namespace fs = std::filesystem;
  const auto task = settings.find("task");
  if (task == settings.end() || !has_schema(registry, task->second)) return;
  for (const auto& spec : schema(registry, task->second)) {
    const auto resolve = [&](std::string& v) {
      if (v.empty() || fs::path(v).is_absolute()) return;
      std::error_code ec;
      const fs::path beside = fs::path(config_file).parent_path() / v;
      v = (fs::exists(beside, ec) ? fs::absolute(beside, ec) : fs::absolute(v, ec))
              .lexically_normal()
              .string();
    };
    if (spec.type == "path") {
      resolve(settings[spec.key]);
    } else if (spec.type == "paths") {
      const auto it = settings.find(spec.key);
      if (it == settings.end() || it->second.empty()) continue;
      YAML::Node list = YAML::Load(it->second);
      YAML::Node out(YAML::NodeType::Sequence);
      for (const auto& e : list) {
        std::string v = e.as<std::string>();
        resolve(v);
        out.push_back(v);
      }
      YAML::Emitter em;
      em.SetSeqFormat(YAML::Flow);
      em << out;
      it->second = em.c_str();
    }
  }
}

void resolve_derived_defaults(const Registry& registry, Settings& settings) {
  const auto task = settings.find("task");
  if (task == settings.end() || !registry.has_task(task->second)) return;
  // A key left empty whose default the task sets (e.g. an algorithm's key whose empty value
  // means "the algorithm's default") takes the task's value.
  for (const auto& [key, value] : registry.task(task->second).shared_defaults()) {
    const auto it = settings.find(key);
    if (it != settings.end() && it->second.empty()) it->second = value;
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
  if (type == "interval" || type == "names" || type == "list" || type == "numbers" ||
      type == "paths")
    return YAML::Load(v);
  if (type == "string" || type == "enum" || type == "path") return YAML::Node(v);
  if (v.empty()) return YAML::Node(YAML::NodeType::Null);
  return YAML::Load(v);
}
}  // namespace

std::string to_yaml(const Registry& registry, const Settings& settings) {
  std::vector<KeySpec> keys;
  const auto task = settings.find("task");
  if (task != settings.end() && has_schema(registry, task->second))
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
  o << "\n## `drops identify`\n\nModel learning from recorded logs (docs/identify.md): the "
       "task gives the prior and the state and action names, model.* the model.\n\n";
  markdown_table(o, identify_keys());
  o << "\n### `drops identify` without a task (`task: none`)\n\nThe prior is the description "
       "file of `prior.model` (required, with `identify.dt`): the state is the angles then the "
       "velocities of its joints `prior.joints`, the action the torques of `prior.actuated` "
       "(docs/identify.md). Its keys beside the ones above:\n\n";
  markdown_table(o, no_task_keys());
  o << "\n## Runs that start from recorded data\n\n`drops run` with logs of the real system "
       "as its first data (docs/logs.md, \"Starting a run from recorded data\"): the logs' "
       "columns and resampling are declared by the identify.* keys above.\n\n";
  markdown_table(o, run_data_keys());
  for (const auto& t : registry.task_names()) {
    const TaskPlugin& p = registry.task(t);
    o << "\n## Task `" << t << "`\n\n" << p.description() << "\n\n";
    const auto shared = p.shared_defaults();
    if (!shared.empty()) {
      const std::vector<KeySpec> keys = schema(registry, t);  // validates the task's defaults
      o << "Its defaults of shared keys:";
      bool first = true;
      for (const auto& [k, v] : shared) {
        const auto it =
            std::find_if(keys.begin(), keys.end(), [&](const KeySpec& s) { return s.key == k; });
        o << (first ? " " : ", ") << "`" << k << "` = `" << it->default_value << "`";
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

std::string key_text(double v) { return fmt::format("{}", v); }
std::string key_text(long long v) { return fmt::format("{}", v); }

std::size_t choice_index(const Settings& settings, const std::string& key,
                         const std::vector<std::string>& names) {
  const std::string& v = settings.at(key);
  const auto it = std::find(names.begin(), names.end(), v);
  if (it == names.end()) fail(key, v, "allowed values: " + joined(names));
  return static_cast<std::size_t>(it - names.begin());
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
std::vector<double> get_numbers(const Settings& s, const std::string& key) {
  try {
    std::vector<double> out;
    for (const auto& n : YAML::Load(s.at(key))) out.push_back(n.as<double>());
    return out;
  } catch (const YAML::Exception&) {
    fail(key, s.at(key), "expected a list of numbers such as [0.1, 0.5]");
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
