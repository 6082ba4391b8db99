// The campaign file: parsing, expansion into runs, settings comparison (docs/campaigns.md).
#include "drops/experiment/campaign.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;
namespace {

const std::vector<std::string> kTopKeys = {"name", "output", "jobs", "threads", "grid", "settings"};

bool contains(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

std::string node_text(const YAML::Node& n) {
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  e.SetMapFormat(YAML::Flow);
  e << n;
  return e.c_str();
}

/// A value as the text given to load_settings overrides: scalars as written, others as flow YAML.
std::string value_text(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : node_text(n); }

[[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& what) {
  throw ConfigError("campaign key '" + key + "' = '" + value + "': " + what);
}

int parse_int(const std::string& key, const YAML::Node& n, long min, long max) {
  const std::string text = node_text(n);
  long v = 0;
  bool ok = n.IsScalar();
  if (ok) {
    try {
      std::size_t pos = 0;
      v = std::stol(n.Scalar(), &pos);
      ok = pos == n.Scalar().size();
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok) fail(key, text, "expected an integer");
  if (v < min || v > max) fail(key, text, fmt::format("out of range: allowed [{}, {}]", min, max));
  return static_cast<int>(v);
}

/// Every key any registered task or algorithm knows (for telling keys from prefixes).
std::vector<std::string> all_keys(const Registry& registry) {
  std::vector<std::string> keys;
  for (const auto& s : base_keys()) keys.push_back(s.key);
  for (const auto& a : registry.algorithm_names())
    for (const auto& s : registry.algorithm(a).keys()) keys.push_back(s.key);
  for (const auto& t : registry.task_names())
    for (const auto& s : registry.task(t).keys()) keys.push_back(s.key);
  return keys;
}

bool is_key(const std::vector<std::string>& keys, const std::string& k) { return contains(keys, k); }
bool is_prefix(const std::vector<std::string>& keys, const std::string& p) {
  for (const auto& k : keys)
    if (k.rfind(p + ".", 0) == 0) return true;
  return false;
}

/// {first: N, count: M[, step: S]}: a mapping whose keys are among first, count and step and
/// name at least first or count (so that a nested `rollouts: {count: [1, 3]}` is a key, not a range).
bool is_range(const YAML::Node& n) {
  if (!n.IsMap() || !(n["first"] || n["count"])) return false;
  for (const auto& kv : n) {
    const std::string k = kv.first.Scalar();
    if (k != "first" && k != "count" && k != "step") return false;
    if (kv.second.IsSequence()) return false;
  }
  return true;
}

std::vector<std::string> range_values(const std::string& key, const YAML::Node& n) {
  long first = 0, count = 0, step = 1;
  bool has_first = false, has_count = false;
  for (const auto& kv : n) {
    const std::string k = kv.first.Scalar();
    if (k == "first") {
      first = parse_int(key + ".first", kv.second, -2147483647L, 2147483647L);
      has_first = true;
    } else if (k == "count") {
      count = parse_int(key + ".count", kv.second, 1, 100000);
      has_count = true;
    } else if (k == "step") {
      step = parse_int(key + ".step", kv.second, 1, 2147483647L);
    } else {
      fail(key + "." + k, node_text(kv.second),
           "unknown key in a range; a range is {first: N, count: M} (optional step: S)");
    }
  }
  if (!has_first || !has_count)
    fail(key, node_text(n), "a range needs both keys, e.g. {first: 1, count: 5}");
  std::vector<std::string> values;
  for (long i = 0; i < count; ++i) values.push_back(std::to_string(first + i * step));
  return values;
}

std::string owned_key_reason(const std::string& key) {
  return key == "threads" ? "threads per run are set by the campaign's top-level 'threads' key"
                          : "the campaign sets each run's output and name (runs/<run name>)";
}

/// The axes of the grid mapping, in file order, with their values (not yet validated).
void collect_axes(const std::vector<std::string>& keys, const YAML::Node& n,
                  const std::string& prefix, std::vector<GridAxis>& grid, bool validate) {
  for (const auto& kv : n) {
    const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
    const YAML::Node& v = kv.second;
    // Without validation (reading a campaign back) every non-range mapping is a prefix.
    if (v.IsMap() && !is_range(v) &&
        (validate ? !is_key(keys, key) && is_prefix(keys, key) : true)) {
      collect_axes(keys, v, key, grid, validate);
      continue;
    }
    const std::string where = "grid." + key;
    if (validate && !is_key(keys, key))
      fail(where, node_text(v),
           "not a drops config key" + did_you_mean(key, keys) +
               "; run 'drops config --markdown' for every key");
    if (contains(campaign_owned_keys(), key)) fail(where, node_text(v), owned_key_reason(key));
    for (const auto& a : grid)
      if (a.key == key) fail(where, node_text(v), "this axis is given twice");
    GridAxis axis{key, {}};
    if (is_range(v)) {
      axis.values = range_values(where, v);
    } else if (v.IsSequence()) {
      for (const auto& e : v) {
        if (e.IsMap() || e.IsNull())
          fail(where, node_text(v), "each value must be a scalar or a list");
        axis.values.push_back(value_text(e));
      }
    } else {
      fail(where, node_text(v),
           "expected a list of values, e.g. [a, b], or {first: 1, count: 5}; a value shared by "
           "every run belongs under 'settings:'");
    }
    if (axis.values.empty()) fail(where, node_text(v), "expected at least one value");
    grid.push_back(std::move(axis));
  }
}

/// Dotted keys present in a settings block (nested or dotted form).
void settings_keys(const std::vector<std::string>& keys, const YAML::Node& n,
                   const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& kv : n) {
    const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
    if (kv.second.IsMap() && !is_key(keys, key))
      settings_keys(keys, kv.second, key, out);
    else
      out.push_back(key);
  }
}

bool valid_dir_name(const std::string& s) { return is_directory_name(s); }

/// Numbers compared as numbers, sequences element by element, everything else as text.
bool same_value(const std::string& a, const std::string& b) {
  if (a == b) return true;
  YAML::Node na, nb;
  try {
    na = YAML::Load(a);
    nb = YAML::Load(b);
  } catch (const YAML::Exception&) {
    return false;
  }
  if (na.IsNull() || nb.IsNull()) {
    const auto empty = [](const YAML::Node& n) {
      return n.IsNull() || (n.IsScalar() && n.Scalar().empty());
    };
    return empty(na) && empty(nb);
  }
  if (na.IsSequence() && nb.IsSequence()) {
    if (na.size() != nb.size()) return false;
    for (std::size_t i = 0; i < na.size(); ++i)
      if (!same_value(value_text(na[i]), value_text(nb[i]))) return false;
    return true;
  }
  if (na.IsScalar() && nb.IsScalar()) {
    auto number = [](const std::string& s, double& v) {
      try {
        std::size_t pos = 0;
        v = std::stod(s, &pos);
        return pos == s.size();
      } catch (const std::exception&) {
        return false;
      }
    };
    double x = 0, y = 0;
    if (number(na.Scalar(), x) && number(nb.Scalar(), y)) return x == y;
    return na.Scalar() == nb.Scalar();
  }
  return false;
}

}  // namespace

const std::vector<std::string>& campaign_owned_keys() {
  static const std::vector<std::string> k = {"output", "name", "threads"};
  return k;
}

std::string run_name_part(const std::string& key, const std::string& value_text) {
  std::string text = value_text;
  if (key == "seed") {
    try {
      std::size_t pos = 0;
      const double v = std::stod(text, &pos);
      if (pos == text.size() && v == std::floor(v))
        text = std::to_string(static_cast<long long>(v));
    } catch (const std::exception&) {
    }
    return "seed" + text;
  }
  if (!text.empty() && text.front() == '[') {
    try {
      const YAML::Node n = YAML::Load(text);
      if (n.IsSequence()) {
        std::vector<std::string> parts;
        for (const auto& e : n) parts.push_back(e.IsScalar() ? e.Scalar() : node_text(e));
        text = join(parts, "_");
      }
    } catch (const YAML::Exception&) {
    }
  }
  for (char& c : text)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-')) c = '_';
  return text;
}

CampaignSpec parse_campaign(const Registry& registry, const std::string& yaml_text,
                            const std::string& default_name, bool validate) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(std::string("invalid YAML: ") + e.what());
  }
  if (!root.IsMap())
    throw ConfigError("a campaign file is a mapping with the keys " + join(kTopKeys, ", ") +
                      " (see docs/campaigns.md)");
  const std::vector<std::string> keys = all_keys(registry);
  CampaignSpec spec;
  spec.name = default_name;
  bool has_grid = false;
  for (const auto& kv : root) {
    const std::string key = kv.first.Scalar();
    const YAML::Node& v = kv.second;
    if (key == "name" || key == "output") {
      if (!v.IsScalar() || v.Scalar().empty())
        fail(key, node_text(v), "expected a non-empty string");
      if (key == "name" && !valid_dir_name(v.Scalar()))
        fail(key, v.Scalar(), "expected a directory name of letters, digits, '_', '.' and '-'");
      (key == "name" ? spec.name : spec.output) = v.Scalar();
    } else if (key == "jobs") {
      spec.jobs = parse_int(key, v, 1, 4096);
    } else if (key == "threads") {
      spec.threads = parse_int(key, v, 1, 1024);
    } else if (key == "grid") {
      if (!v.IsMap() || v.size() == 0)
        fail(key, node_text(v),
             "expected a mapping of drops config keys to lists of values, e.g. "
             "{model.type: [gp_mi, mi], seed: {first: 1, count: 5}}");
      collect_axes(validate ? keys : std::vector<std::string>{}, v, "", spec.grid, validate);
      has_grid = true;
    } else if (key == "settings") {
      if (v.IsNull()) continue;
      if (!v.IsMap()) fail(key, node_text(v), "expected a mapping of drops config keys");
      std::vector<std::string> present;
      settings_keys(keys, v, "", present);
      for (const auto& k : present)
        if (contains(campaign_owned_keys(), k))
          throw ConfigError("campaign key 'settings." + k + "': " + owned_key_reason(k));
      YAML::Emitter e;
      e << v;
      spec.settings_yaml = std::string(e.c_str()) + "\n";
    } else {
      std::string what = "unknown key" + did_you_mean(key, kTopKeys);
      if (is_key(keys, key) || is_prefix(keys, key))
        what +=
            "; drops config keys go under 'settings:' (shared by every run) or 'grid:' (varied)";
      fail(key, node_text(v), what + "; allowed keys: " + join(kTopKeys, ", "));
    }
  }
  if (!has_grid)
    throw ConfigError(
        "campaign key 'grid' is missing: expected a mapping of drops config keys to "
        "lists of values, e.g. grid: {model.type: [gp_mi, mi], seed: [1, 2]}");
  if (!valid_dir_name(spec.name))
    throw ConfigError("campaign name '" + spec.name +
                      "' (the file's stem) is not a directory name of letters, digits, '_', '.' "
                      "and '-'; set the key 'name'");
  // A grid key must not also be a shared setting.
  std::vector<std::string> shared;
  if (!spec.settings_yaml.empty()) settings_keys(keys, YAML::Load(spec.settings_yaml), "", shared);
  for (const auto& a : spec.grid)
    if (contains(shared, a.key))
      throw ConfigError("campaign key 'settings." + a.key +
                        "': also a grid axis; give it in one place only");
  if (!validate) return spec;
  // The shared settings, and each grid value on its own, against the schema of the campaign's
  // task (of each task, when the task is an axis); duplicates compared after canonicalisation.
  std::vector<std::string> tasks = {""};
  for (const auto& a : spec.grid)
    if (a.key == "task") tasks = a.values;
  for (const auto& t : tasks) {
    const std::vector<std::string> task_override =
        t.empty() ? std::vector<std::string>{} : std::vector<std::string>{"task=" + t};
    try {
      load_settings(registry, spec.settings_yaml, task_override);
    } catch (const ConfigError& ex) {
      throw ConfigError(std::string("settings: ") + ex.what());
    }
    for (const auto& axis : spec.grid) {
      std::map<std::string, std::string> canonical;
      for (const auto& v : axis.values) {
        std::vector<std::string> o = task_override;
        o.push_back(axis.key + "=" + v);
        Settings s;
        try {
          s = load_settings(registry, spec.settings_yaml, o);
        } catch (const ConfigError& e) {
          throw ConfigError(std::string("grid: ") + e.what());
        }
        if (!canonical.emplace(s.at(axis.key), v).second)
          fail("grid." + axis.key, "[" + join(axis.values, ", ") + "]",
               "value '" + v + "' is listed twice");
      }
    }
  }
  return spec;
}

CampaignSpec load_campaign_file(const Registry& registry, const std::string& path, bool validate) {
  std::string text;
  try {
    text = read_file_text(path, kMaxConfigFileBytes);
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& e) {
    throw ConfigError(file_error("campaign file", e.what()));
  }
  try {
    return parse_campaign(registry, text, fs::path(path).stem().string(), validate);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

std::vector<CampaignRun> expand_campaign(const Registry& registry, const CampaignSpec& spec,
                                         bool build) {
  const std::size_t n_axes = spec.grid.size();
  // Execution order: the seed axis outermost, then the others in file order (last fastest).
  std::vector<std::size_t> order;
  for (std::size_t a = 0; a < n_axes; ++a)
    if (spec.grid[a].key == "seed") order.push_back(a);
  for (std::size_t a = 0; a < n_axes; ++a)
    if (spec.grid[a].key != "seed") order.push_back(a);
  std::size_t total = 1;
  for (const auto& a : spec.grid) total *= a.values.size();

  std::vector<CampaignRun> runs;
  std::map<std::string, std::size_t> names;
  std::vector<std::size_t> idx(n_axes, 0);  // value index per axis
  for (std::size_t r = 0; r < total; ++r) {
    std::size_t rest = r;
    for (std::size_t o = n_axes; o-- > 0;) {
      const std::size_t a = order[o];
      idx[a] = rest % spec.grid[a].values.size();
      rest /= spec.grid[a].values.size();
    }
    CampaignRun run;
    std::vector<std::string> parts, overrides;
    for (std::size_t a = 0; a < n_axes; ++a) {
      const auto& axis = spec.grid[a];
      const std::string& v = axis.values[idx[a]];
      run.values.emplace_back(axis.key, v);
      parts.push_back(run_name_part(axis.key, v));
      overrides.push_back(axis.key + "=" + v);
    }
    run.name = join(parts, "-");
    overrides.push_back("output=runs");
    overrides.push_back("name=" + run.name);
    overrides.push_back("threads=" + std::to_string(spec.threads));
    try {
      run.settings = load_settings(registry, spec.settings_yaml, overrides);
      if (build) make_experiment(registry, run.settings);
    } catch (const ConfigError& e) {
      throw ConfigError("run " + run.name + ": " + e.what());
    }
    if (const auto it = names.find(run.name); it != names.end()) {
      throw ConfigError("runs " + std::to_string(it->second + 1) + " and " + std::to_string(r + 1) +
                        " would both be named '" + run.name +
                        "': two values of a grid axis differ only in characters outside "
                        "[A-Za-z0-9_.-]");
    }
    names.emplace(run.name, r);
    runs.push_back(std::move(run));
  }
  return runs;
}

bool same_settings(const Settings& a, const Settings& b, const std::vector<std::string>& ignore,
                   std::string* key) {
  std::set<std::string> keys;
  for (const auto& [k, v] : a) keys.insert(k);
  for (const auto& [k, v] : b) keys.insert(k);
  for (const auto& k : keys) {
    if (contains(ignore, k)) continue;
    const auto ia = a.find(k), ib = b.find(k);
    if (ia == a.end() || ib == b.end() || !same_value(ia->second, ib->second)) {
      if (key) *key = k;
      return false;
    }
  }
  return true;
}

bool same_setting_value(const std::string& a, const std::string& b) { return same_value(a, b); }

std::string campaign_difference(const Registry& registry, const CampaignSpec& old_spec,
                                const CampaignSpec& spec) {
  if (old_spec.grid.size() != spec.grid.size())
    return fmt::format("the grid has {} axes there and {} here", old_spec.grid.size(),
                       spec.grid.size());
  for (std::size_t a = 0; a < spec.grid.size(); ++a) {
    const auto& x = old_spec.grid[a];
    const auto& y = spec.grid[a];
    if (x.key != y.key)
      return fmt::format("grid axis {} is '{}' there and '{}' here", a + 1, x.key, y.key);
    bool same = x.values.size() == y.values.size();
    for (std::size_t i = 0; same && i < x.values.size(); ++i)
      same = same_value(x.values[i], y.values[i]);
    if (!same)
      return fmt::format("grid axis '{}' is [{}] there and [{}] here", x.key, join(x.values, ", "),
                         join(y.values, ", "));
  }
  std::string key;
  const Settings b = load_settings(registry, spec.settings_yaml, {});
  // A key the old file left to its default and this one pins is not a change of the campaign:
  // the default may have changed since, and pinning its old value keeps the file's meaning. The
  // runs made decide: check_run_config compares each one's config.yaml with this file.
  const auto keys = all_keys(registry);
  std::vector<std::string> old_keys;
  std::vector<std::string> new_keys;
  if (!old_spec.settings_yaml.empty())
    settings_keys(keys, YAML::Load(old_spec.settings_yaml), "", old_keys);
  if (!spec.settings_yaml.empty()) settings_keys(keys, YAML::Load(spec.settings_yaml), "", new_keys);
  // The old settings with those keys pinned, so that what derives from them (e.g.
  // optimizer.run_evaluations) derives again.
  std::vector<std::string> pinned;
  for (const auto& k : new_keys)
    if (!contains(old_keys, k) && b.count(k) != 0) pinned.push_back(k + "=" + b.at(k));
  const Settings a = load_settings(registry, old_spec.settings_yaml, pinned);
  if (!same_settings(a, b, {}, &key)) {
    auto get = [&](const Settings& s) {
      const auto it = s.find(key);
      return it == s.end() ? std::string("(absent)") : it->second;
    };
    return fmt::format("setting '{}' is '{}' there and '{}' here", key, get(a), get(b));
  }
  return "";
}

void CampaignDirectory::write(const Registry& registry, const std::string& file_text,
                              const std::vector<CampaignRun>& runs) const {
  std::error_code ec;
  fs::create_directories(this->runs(), ec);
  if (!ec) fs::create_directories(configs(), ec);
  if (ec) throw Error("cannot create " + dir_.string() + ": " + ec.message());
  write_file_atomically(campaign_file(), file_text);
  for (const auto& r : runs) {
    const fs::path p = run_config(r.name);
    const std::string text = to_yaml(registry, r.settings);
    if (!fs::exists(p, ec) || read_file_text(p) != text) write_file_atomically(p, text);
  }
}

std::optional<CampaignSpec> CampaignDirectory::read_spec(const Registry& registry,
                                                         const std::string& default_name,
                                                         bool validate) const {
  if (!fs::exists(campaign_file())) return std::nullopt;
  try {
    return parse_campaign(registry, read_file_text(campaign_file()), default_name, validate);
  } catch (const Error& e) {
    throw ConfigError(campaign_file().string() + " cannot be read (" + e.what() + ")");
  }
}

std::string CampaignDirectory::run_status(const std::string& name) const {
  try {
    const fs::path p = run(name) / "summary.json";
    if (!fs::exists(p)) return "";
    return nlohmann::json::parse(read_file_text(p)).value("status", "");
  } catch (const std::exception&) {
    return "";
  }
}

bool CampaignDirectory::run_has_checkpoint(const std::string& name) const {
  return fs::exists(run(name) / "checkpoint.json");
}

void CampaignDirectory::check_kept_run(const Registry& registry, const CampaignRun& r) const {
  const fs::path run_dir = run(r.name);
  const std::string where = "run " + r.name + " in " + dir_.string();
  try {
    check_run_directory_format(run_dir);
  } catch (const Error& e) {
    throw ConfigError(where + " cannot be kept: " + e.what() +
                      "; or use a new campaign name (key 'name') or another --output");
  }
  Settings existing;
  try {
    existing = load_settings(registry, read_file_text(run_dir / "config.yaml"), {});
  } catch (const std::exception& e) {
    throw ConfigError(where + ": its config.yaml cannot be compared with this campaign (" +
                      e.what() + "); use a new campaign name (key 'name') or another --output");
  }
  // Compare what the runs do: an empty task-dependent default equals its value.
  Settings wanted = r.settings;
  // The run resolved its relative paths (prior.model) when it read its configs/<run>.yaml.
  resolve_path_keys(registry, wanted, run_config(r.name).string());
  resolve_derived_defaults(registry, existing);
  resolve_derived_defaults(registry, wanted);
  std::string key;
  if (!same_settings(existing, wanted, campaign_owned_keys(), &key)) {
    const auto get = [&](const Settings& s) {
      const auto it = s.find(key);
      return it == s.end() ? std::string("(absent)") : it->second;
    };
    throw ConfigError(where + " was made with different settings: key '" + key + "' is '" +
                      get(existing) + "' there and '" + get(wanted) +
                      "' in this campaign; use a new campaign name (key 'name') or another "
                      "--output");
  }
}

}  // namespace drops::experiment
