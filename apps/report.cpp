// `drops report CAMPAIGN_DIR` and `drops plot RUN_DIR`: run directories read back, a campaign
// aggregated into tables (CSV, Markdown), figures drawn by python/drops_plot.py (matplotlib).
#include "report.hpp"

#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "command.hpp"
#include "drops/core/errors.hpp"
#include "run_directory.hpp"

extern char** environ;

namespace drops::app {
namespace fs = std::filesystem;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------- reading ----------

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read " + path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

double number_or_nan(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : kNaN;
}

// Node at a dotted key ("model.type"); an undefined node when any part is missing.
YAML::Node find_key(const YAML::Node& node, const std::string& dotted) {
  if (!node || !node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  const auto dot = dotted.find('.');
  const YAML::Node child = node[dotted.substr(0, dot)];
  if (!child) return YAML::Node(YAML::NodeType::Undefined);
  if (dot == std::string::npos) return child;
  return find_key(child, dotted.substr(dot + 1));
}

std::string node_text(const YAML::Node& node) {
  if (!node) return "?";
  if (node.IsNull()) return "null";
  if (node.IsScalar()) return node.Scalar();
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

// {first: N, count: M, step: S} with scalar values (a nested `rollouts: {count: [1, 3]}` is not).
bool is_range(const YAML::Node& v) {
  if (!v.IsMap() || !(v["first"] || v["count"])) return false;
  for (const auto& kv : v) {
    const std::string k = kv.first.as<std::string>();
    if ((k != "first" && k != "count" && k != "step") || !kv.second.IsScalar()) return false;
  }
  return true;
}

// Grid axes (dotted keys) of campaign.yaml with more than one value. An axis is a list of values
// or a range {first: N, count: M, step: S}; nested mappings spell dotted keys (docs/campaigns.md).
void collect_axes(const YAML::Node& node, const std::string& prefix,
                  std::vector<std::string>& axes) {
  for (const auto& kv : node) {
    const std::string key = prefix + kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    if (is_range(v)) {
      long count = 0;
      try {
        count = v["count"] ? v["count"].as<long>() : 0;
      } catch (const YAML::Exception&) {
      }
      if (count > 1) axes.push_back(key);
    } else if (v.IsMap()) {
      collect_axes(v, key + ".", axes);
    } else if (v.IsSequence() && v.size() > 1) {
      axes.push_back(key);
    }
  }
}

std::vector<std::string> extra_grid_axes(const fs::path& campaign_yaml) {
  std::vector<std::string> axes;
  if (!fs::exists(campaign_yaml)) return axes;
  YAML::Node root;
  try {
    root = YAML::LoadFile(campaign_yaml.string());
  } catch (const YAML::Exception& e) {
    throw ConfigError("cannot parse " + campaign_yaml.string() + ": " + e.what());
  }
  const YAML::Node grid = root["grid"];
  if (!grid || !grid.IsMap()) return axes;
  std::vector<std::string> all;
  collect_axes(grid, "", all);
  for (const auto& a : all)
    if (a != "seed" && a != "model.type" && a != "prior.preset" &&
        a.rfind("hexapod.damage.", 0) != 0)
      axes.push_back(a);
  return axes;
}

// ---------- ordering ----------

int prior_rank(const std::string& prior) {
  static const std::vector<std::string> order = {"tunable-useful", "tunable", "tunable-misleading",
                                                 "partially-tunable", "actual"};
  const auto it = std::find(order.begin(), order.end(), prior);
  return it == order.end() ? 100 : static_cast<int>(it - order.begin());
}

int model_rank(const std::string& model) {
  static const std::vector<std::string> order = {"gp_mi", "gp_prior", "mi", "gp"};
  const auto it = std::find(order.begin(), order.end(), model);
  return it == order.end() ? 100 : static_cast<int>(it - order.begin());
}

bool group_before(const GroupReport& a, const GroupReport& b) {
  return std::tuple(prior_rank(a.prior), a.prior, model_rank(a.model_type), a.variant) <
         std::tuple(prior_rank(b.prior), b.prior, model_rank(b.model_type), b.variant);
}

// "A tunable-useful" for the presets of paper Table I, else the preset name.
std::string prior_label(const std::string& prior) {
  static const char* letters = "ABCD";
  const int r = prior_rank(prior);
  return r < 4 ? fmt::format("{} {}", letters[r], prior) : prior;
}

std::string model_long_name(const std::string& model) {
  if (model == "gp_mi") return "Black-DROPS with GP-MI";
  if (model == "gp_prior") return "Black-DROPS with priors";
  if (model == "mi") return "Black-DROPS with MI";
  if (model == "gp") return "Black-DROPS";
  return model;
}

// ---------- writing ----------

std::string num(double x) { return fmt::format("{:.10g}", x); }

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// Markdown numbers: 2 decimals; +∞ (a median first solve) reads "not solved".
std::string md(double x, int decimals = 2) {
  if (std::isinf(x) && x > 0) return "not solved";
  if (std::isnan(x)) return "–";
  return fmt::format("{:.{}f}", x, decimals);
}

std::string md_rate(double rate, int count, int runs) {
  if (runs == 0) return "–";
  return fmt::format("{:.2f} ({}/{})", rate, count, runs);
}

// ---------- running python/drops_plot.py ----------

fs::path python_dir() {
  const char* env = std::getenv("DROPS_PYTHON_DIR");
  if (env && *env) return env;
  return DROPS_PYTHON_DIR;
}

void run_plot_script(const std::vector<std::string>& args, const std::string& command) {
  const std::string missing = fmt::format(
      "{} needs Debian's python3-matplotlib and python3-numpy (for /usr/bin/python3); run "
      "scripts/install-deps{}",
      command, command == "drops report" ? ", or pass --no-figures" : "");
  const fs::path python = "/usr/bin/python3";
  if (!fs::exists(python)) throw Error(missing + " (/usr/bin/python3 not found)");
  const fs::path script = python_dir() / "drops_plot.py";
  if (!fs::exists(script))
    throw Error("cannot find " + script.string() +
                "; set DROPS_PYTHON_DIR to the python/ folder of the drops sources");

  std::vector<std::string> argv_s = {python.string(), script.string()};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_s) argv.push_back(s.data());
  argv.push_back(nullptr);
  // Debian's interpreter with its own packages: drop variables that would point it at another
  // Python installation (pyenv, virtualenvs); draw off-screen.
  std::vector<std::string> env_s;
  for (char** e = environ; *e; ++e) {
    const std::string v = *e;
    if (v.rfind("PYTHONHOME=", 0) == 0 || v.rfind("PYTHONPATH=", 0) == 0 ||
        v.rfind("MPLBACKEND=", 0) == 0)
      continue;
    env_s.push_back(v);
  }
  env_s.push_back("MPLBACKEND=Agg");
  std::vector<char*> envp;
  for (auto& s : env_s) envp.push_back(s.data());
  envp.push_back(nullptr);

  pid_t pid = 0;
  const int rc = posix_spawn(&pid, python.c_str(), nullptr, nullptr, argv.data(), envp.data());
  if (rc != 0) throw Error(fmt::format("cannot start {}: {}", python.string(), std::strerror(rc)));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR)
      throw Error(fmt::format("waiting for {}: {}", script.string(), std::strerror(errno)));
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 3) throw Error(missing);
  throw Error(fmt::format("{} failed ({}); see its message above", script.string(),
                          WIFEXITED(status) ? fmt::format("exit code {}", WEXITSTATUS(status))
                                            : std::string("killed by a signal")));
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

}  // namespace

// ---------- statistics ----------

double quantile(std::vector<double> values, double p) {
  if (values.empty()) throw InvalidArgument("quantile: expected at least one value, got none");
  if (!(p >= 0.0 && p <= 1.0))
    throw InvalidArgument(fmt::format("quantile: expected p in [0, 1], got {}", p));
  for (double v : values)
    if (std::isnan(v)) throw InvalidArgument("quantile: expected no NaN among the values");
  std::sort(values.begin(), values.end());
  const double h = static_cast<double>(values.size() - 1) * p;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  const double frac = h - static_cast<double>(lo);
  if (frac == 0.0 || values[lo] == values[hi]) return values[lo];
  return values[lo] + frac * (values[hi] - values[lo]);
}

// ---------- one run ----------

namespace {

// The hexapod's panel: the "real" robot's damage from config.yaml (RunResult::prior).
std::string hexapod_damage_label(const YAML::Node& config) {
  std::vector<std::string> parts;
  for (const auto& [key, word] : {std::pair{"hexapod.damage.removed_leg", "removed"},
                                  std::pair{"hexapod.damage.shortened_leg", "shortened"},
                                  std::pair{"hexapod.damage.blocked_leg", "blocked"}}) {
    const YAML::Node n = find_key(config, key);
    if (n && n.IsScalar() && n.Scalar() != "none") parts.push_back(n.Scalar() + " " + word);
  }
  return parts.empty() ? "intact" : join(parts, ", ");
}

}  // namespace

RunResult read_run(const fs::path& dir, const std::vector<std::string>& extra_axes) {
  if (!fs::is_directory(dir)) throw Error(dir.string() + " is not a directory");
  RunResult run;
  run.dir = dir;
  run.name = dir.filename().string();
  if (run.name.empty()) run.name = dir.parent_path().filename().string();

  YAML::Node config;
  try {
    if (fs::exists(dir / "config.yaml")) config = YAML::LoadFile((dir / "config.yaml").string());
  } catch (const YAML::Exception& e) {
    run.status = "unreadable";
    run.error = "config.yaml: " + std::string(e.what());
    return run;
  }
  if (config) {
    if (const YAML::Node n = find_key(config, "model.type"); n && n.IsScalar())
      run.model_type = n.Scalar();
    if (const YAML::Node n = find_key(config, "task"); n && n.IsScalar()) run.task = n.Scalar();
    if (run.task == "hexapod") {
      run.prior = hexapod_damage_label(config);
    } else if (const YAML::Node n = find_key(config, "prior.preset"); n && n.IsScalar()) {
      run.prior = n.Scalar();
    }
    if (const YAML::Node n = find_key(config, "seed"); n && n.IsScalar()) {
      try {
        run.seed = n.as<std::int64_t>();
      } catch (const YAML::Exception&) {
      }
    }
    if (const YAML::Node n = find_key(config, "prior.tunable"); n && n.IsSequence())
      for (const auto& t : n) run.phi_tunable.push_back(node_text(t));
  }

  const fs::path summary_path = dir / "summary.json";
  if (!fs::exists(summary_path)) {
    run.status = "not started";
  } else {
    try {
      const nlohmann::json s = nlohmann::json::parse(read_text(summary_path));
      run.status = s.value("status", std::string("running"));
      run.error = s.value("error", std::string());
      if (run.model_type.empty()) run.model_type = s.value("model", std::string());
      if (run.task.empty()) run.task = s.value("task", std::string());
      if (run.prior.empty()) run.prior = s.value("prior", std::string());
      if (run.seed < 0 && s.contains("seed") && s["seed"].is_number_integer())
        run.seed = s["seed"].get<std::int64_t>();
      run.episodes_planned = s.value("episodes_planned", 0);
      if (s.contains("phi_names")) run.phi_names = s["phi_names"].get<std::vector<std::string>>();
      if (s.contains("phi_actual"))
        for (const auto& v : s["phi_actual"])
          run.phi_actual.push_back(v.is_number() ? v.get<double>() : kNaN);
      for (const auto& e : s.value("episodes", nlohmann::json::array())) {
        EpisodeResult ep;
        ep.episode = e.value("episode", static_cast<int>(run.episodes.size()) + 1);
        ep.interaction_time_s = number_or_nan(e, "interaction_time_s");
        ep.real_return = number_or_nan(e, "real_return");
        ep.predicted_return = number_or_nan(e, "predicted_return");
        ep.solved = e.value("solved", false);
        ep.random_policy = e.value("random_policy", false);
        ep.walking_speed_m_s = number_or_nan(e, "walking_speed_m_s");
        if (e.contains("phi"))
          for (const auto& v : e["phi"]) ep.phi.push_back(v.is_number() ? v.get<double>() : kNaN);
        run.episodes.push_back(std::move(ep));
      }
    } catch (const nlohmann::json::exception& e) {
      run.status = "unreadable";
      run.error = "summary.json: " + std::string(e.what());
      run.episodes.clear();
    } catch (const Error& e) {
      run.status = "unreadable";
      run.error = e.what();
    }
  }
  std::sort(run.episodes.begin(), run.episodes.end(),
            [](const EpisodeResult& a, const EpisodeResult& b) { return a.episode < b.episode; });
  for (const auto& ep : run.episodes) {
    if (ep.solved && !run.first_solved_episode) {
      run.first_solved_episode = ep.episode;
      run.first_solved_time_s = ep.interaction_time_s;
    }
  }
  run.solved = run.first_solved_episode.has_value();

  run.variant = run.model_type;
  for (const auto& axis : extra_axes)
    run.variant += " " + axis + "=" + (config ? node_text(find_key(config, axis)) : "?");
  return run;
}

// ---------- aggregation ----------

std::vector<GroupReport> aggregate_runs(const std::vector<RunResult>& runs) {
  std::vector<GroupReport> groups;
  std::vector<std::vector<const RunResult*>> members;
  std::map<std::pair<std::string, std::string>, std::size_t> index;
  for (const auto& run : runs) {
    if (run.status == "unreadable") continue;
    if (run.model_type.empty() && run.prior.empty()) continue;  // not started, no config.yaml
    const auto key = std::pair(run.variant, run.prior);
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, groups.size()).first;
      GroupReport g;
      g.variant = run.variant;
      g.model_type = run.model_type;
      g.task = run.task;
      g.prior = run.prior;
      groups.push_back(std::move(g));
      members.emplace_back();
    }
    GroupReport& g = groups[it->second];
    if (!run.started()) {
      ++g.not_started;
      continue;
    }
    members[it->second].push_back(&run);
  }

  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    GroupReport& g = groups[gi];
    const auto& rs = members[gi];
    g.runs = static_cast<int>(rs.size());
    if (rs.empty()) continue;
    std::vector<double> first_episode, first_time, final_return, final_speed;
    int max_episode = 0;
    for (const RunResult* r : rs) {
      g.run_names.push_back(r->name);
      if (r->status == "complete")
        ++g.complete;
      else if (r->status == "running")
        ++g.running;
      else if (r->status == "interrupted")
        ++g.interrupted;
      else if (r->status == "failed")
        ++g.failed;
      if (r->solved) ++g.solved_runs;
      if (!r->episodes.empty()) {
        if (r->episodes.back().solved) ++g.solved_last_runs;
        if (std::isfinite(r->episodes.back().real_return))
          final_return.push_back(r->episodes.back().real_return);
        if (std::isfinite(r->episodes.back().walking_speed_m_s))
          final_speed.push_back(r->episodes.back().walking_speed_m_s);
        max_episode = std::max(max_episode, r->episodes.back().episode);
      }
      first_episode.push_back(r->first_solved_episode ? *r->first_solved_episode : kInf);
      first_time.push_back(r->solved ? r->first_solved_time_s : kInf);
      if (g.phi_names.empty() && !r->phi_names.empty()) {
        g.phi_names = r->phi_names;
        g.phi_actual = r->phi_actual;
      }
    }
    g.success_rate = static_cast<double>(g.solved_runs) / g.runs;
    g.solved_last_rate = static_cast<double>(g.solved_last_runs) / g.runs;
    g.median_first_solve_episode = quantile(first_episode, 0.5);
    std::erase_if(first_time, [](double t) { return std::isnan(t); });
    g.median_first_solve_time_s = first_time.empty() ? kNaN : quantile(first_time, 0.5);
    if (!final_return.empty()) g.median_final_return = quantile(final_return, 0.5);
    if (!final_speed.empty()) g.median_final_speed_m_s = quantile(final_speed, 0.5);

    const std::size_t nphi = g.phi_names.size();
    for (int k = 1; k <= max_episode; ++k) {
      EpisodeStats st;
      st.episode = k;
      std::vector<double> returns, times, speeds;
      std::vector<std::vector<double>> phis(nphi);
      std::map<double, int> phi_counts;
      for (const RunResult* r : rs) {
        const auto it = std::find_if(r->episodes.begin(), r->episodes.end(),
                                     [k](const EpisodeResult& e) { return e.episode == k; });
        if (it == r->episodes.end()) continue;
        if (std::isfinite(it->real_return)) returns.push_back(it->real_return);
        if (std::isfinite(it->interaction_time_s)) times.push_back(it->interaction_time_s);
        if (std::isfinite(it->walking_speed_m_s)) speeds.push_back(it->walking_speed_m_s);
        if (!it->phi.empty() && !std::isnan(it->phi[0])) ++phi_counts[it->phi[0]];
        if (it->phi.size() == nphi)
          for (std::size_t i = 0; i < nphi; ++i)
            if (!std::isnan(it->phi[i])) phis[i].push_back(it->phi[i]);
      }
      if (returns.empty() && times.empty()) continue;
      st.runs = static_cast<int>(returns.size());
      st.interaction_time_s = times.empty() ? kNaN : quantile(times, 0.5);
      st.median = returns.empty() ? kNaN : quantile(returns, 0.5);
      st.q25 = returns.empty() ? kNaN : quantile(returns, 0.25);
      st.q75 = returns.empty() ? kNaN : quantile(returns, 0.75);
      for (const auto& v : phis) st.phi_median.push_back(v.empty() ? kNaN : quantile(v, 0.5));
      st.phi_counts.assign(phi_counts.begin(), phi_counts.end());
      st.speed_runs = static_cast<int>(speeds.size());
      if (!speeds.empty()) {
        st.speed_median = quantile(speeds, 0.5);
        st.speed_q25 = quantile(speeds, 0.25);
        st.speed_q75 = quantile(speeds, 0.75);
      }
      g.episodes.push_back(std::move(st));
    }
  }
  std::sort(groups.begin(), groups.end(), group_before);
  return groups;
}

CampaignReport aggregate_campaign(const fs::path& campaign_dir) {
  if (!fs::is_directory(campaign_dir))
    throw ConfigError("campaign directory '" + campaign_dir.string() + "' does not exist");
  CampaignReport report;
  report.dir = campaign_dir;
  report.extra_axes = extra_grid_axes(campaign_dir / "campaign.yaml");

  std::vector<fs::path> dirs;
  if (fs::is_directory(campaign_dir / "runs")) {
    report.runs_dir = campaign_dir / "runs";
    for (const auto& e : fs::directory_iterator(report.runs_dir))
      if (e.is_directory()) dirs.push_back(e.path());
  } else {
    // A folder of plain `drops run` outputs: only subdirectories that look like run directories.
    report.runs_dir = campaign_dir;
    for (const auto& e : fs::directory_iterator(campaign_dir))
      if (e.is_directory() &&
          (fs::exists(e.path() / "summary.json") || fs::exists(e.path() / "config.yaml")))
        dirs.push_back(e.path());
  }
  if (dirs.empty())
    throw ConfigError("no run directories in '" + report.runs_dir.string() +
                      "': expected <dir>/runs/<run>/summary.json as written by drops campaign");
  std::sort(dirs.begin(), dirs.end());
  for (const auto& d : dirs) report.runs.push_back(read_run(d, report.extra_axes));
  report.groups = aggregate_runs(report.runs);
  return report;
}

// ---------- writers ----------

void write_summary_csv(const CampaignReport& report, const fs::path& path) {
  std::string t =
      "variant,prior,runs,complete,running,interrupted,failed,not_started,solved_runs,"
      "success_rate,solved_last_rate,median_first_solve_episode,median_first_solve_time_s,"
      "median_final_return,median_final_speed_m_s\n";
  for (const auto& g : report.groups)
    t += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(g.variant),
                     csv_field(g.prior), g.runs, g.complete, g.running, g.interrupted, g.failed,
                     g.not_started, g.solved_runs, num(g.success_rate), num(g.solved_last_rate),
                     num(g.median_first_solve_episode), num(g.median_first_solve_time_s),
                     num(g.median_final_return), num(g.median_final_speed_m_s));
  write_file_atomically(path, t);
}

void write_returns_csv(const CampaignReport& report, const fs::path& path) {
  std::string t = "variant,prior,episode,interaction_time_s,runs,median,q25,q75\n";
  for (const auto& g : report.groups)
    for (const auto& e : g.episodes)
      t += fmt::format("{},{},{},{},{},{},{},{}\n", csv_field(g.variant), csv_field(g.prior),
                       e.episode, num(e.interaction_time_s), e.runs, num(e.median), num(e.q25),
                       num(e.q75));
  write_file_atomically(path, t);
}

void write_speed_csv(const CampaignReport& report, const fs::path& path) {
  std::string t = "variant,prior,episode,interaction_time_s,runs,median,q25,q75\n";
  for (const auto& g : report.groups) {
    if (!g.has_speed()) continue;
    for (const auto& e : g.episodes)
      t += fmt::format("{},{},{},{},{},{},{},{}\n", csv_field(g.variant), csv_field(g.prior),
                       e.episode, num(e.interaction_time_s), e.speed_runs, num(e.speed_median),
                       num(e.speed_q25), num(e.speed_q75));
  }
  write_file_atomically(path, t);
}

void write_phi_csv(const CampaignReport& report, const fs::path& path) {
  std::string t = "variant,prior,episode,parameter,median,actual\n";
  for (const auto& g : report.groups)
    for (const auto& e : g.episodes)
      for (std::size_t i = 0; i < e.phi_median.size() && i < g.phi_names.size(); ++i)
        t += fmt::format("{},{},{},{},{},{}\n", csv_field(g.variant), csv_field(g.prior), e.episode,
                         csv_field(g.phi_names[i]), num(e.phi_median[i]),
                         num(i < g.phi_actual.size() ? g.phi_actual[i] : kNaN));
  write_file_atomically(path, t);
}

namespace {

// The hexapod's prior φ = removed leg (-1 = intact).
std::string hexapod_prior_name(double removed_leg) {
  return removed_leg < 0 ? std::string("intact") : fmt::format("leg{:g}", removed_leg);
}

bool identifies_discrete_prior(const GroupReport& g) {
  return g.task == "hexapod" && g.model_type != "gp" && !g.episodes.empty();
}

std::string panel_title(const GroupReport& g) {
  return g.task == "hexapod" ? "Real robot " + g.prior : "Prior " + prior_label(g.prior);
}

// The groups of one panel (a prior, or the hexapod's damage) with episodes, and the last
// episode any of them reached.
struct Panel {
  std::vector<const GroupReport*> groups;
  int max_k = 0;
};

// The panels of `report` in group order, each with the groups `keep` accepts; panels left empty
// are dropped.
template <class Keep>
std::vector<Panel> panels(const CampaignReport& report, Keep keep) {
  std::vector<std::string> priors;
  for (const auto& g : report.groups)
    if (std::find(priors.begin(), priors.end(), g.prior) == priors.end()) priors.push_back(g.prior);
  std::vector<Panel> out;
  for (const auto& prior : priors) {
    Panel p;
    for (const auto& g : report.groups)
      if (g.prior == prior && !g.episodes.empty() && keep(g)) {
        p.groups.push_back(&g);
        p.max_k = std::max(p.max_k, g.episodes.back().episode);
      }
    if (!p.groups.empty()) out.push_back(std::move(p));
  }
  return out;
}

// The statistics of group g at episode k; nullptr when no run reached k.
const EpisodeStats* stats_at(const GroupReport& g, int k) {
  const auto it = std::find_if(g.episodes.begin(), g.episodes.end(),
                               [k](const EpisodeStats& e) { return e.episode == k; });
  return it == g.episodes.end() ? nullptr : &*it;
}

// One Markdown table per panel (prior, or the hexapod's damage) of the groups `keep` accepts:
// a row per episode, a column per variant, the cell cell(group, stats at k).
template <class Keep, class Cell>
std::string episode_cells(const CampaignReport& report, Keep keep, Cell cell) {
  std::string t;
  for (const auto& [gs, max_k] : panels(report, keep)) {
    t += fmt::format("\n### {}\n\n| episode |", panel_title(*gs.front()));
    for (const auto* g : gs) t += " " + g->variant + " |";
    t += "\n|---:|";
    for (std::size_t i = 0; i < gs.size(); ++i) t += "---|";
    t += "\n";
    for (int k = 1; k <= max_k; ++k) {
      t += fmt::format("| {} |", k);
      for (const auto* g : gs) {
        const EpisodeStats* e = stats_at(*g, k);
        t += ' ';
        t += e ? cell(*g, *e) : std::string("–");
        t += " |";
      }
      t += "\n";
    }
  }
  return t;
}

// Median [q25, q75] tables per panel of the quantity get(stats) = (runs, median, q25, q75), with
// `decimals` decimals and one interaction-time column when every group agrees on it.
template <class Keep, class Get>
std::string episode_tables(const CampaignReport& report, Keep keep, Get get, int decimals) {
  std::string t;
  for (const auto& [gs, max_k] : panels(report, keep)) {
    // One time column when every group agrees on the interaction time of each episode.
    std::map<int, std::set<double>> times;
    for (const auto* g : gs)
      for (const auto& e : g->episodes) times[e.episode].insert(e.interaction_time_s);
    bool same_time = true;
    for (const auto& [k, s] : times) same_time = same_time && s.size() == 1;

    t += fmt::format("\n### {}\n\n| episode |{}", panel_title(*gs.front()),
                     same_time ? " interaction time (s) |" : "");
    for (const auto* g : gs) t += " " + g->variant + " |";
    t += "\n|---:|" + std::string(same_time ? "---:|" : "");
    for (std::size_t i = 0; i < gs.size(); ++i) t += "---|";
    t += "\n";
    for (int k = 1; k <= max_k; ++k) {
      if (!times.count(k)) continue;
      t += fmt::format("| {} |", k);
      if (same_time) t += " " + md(*times[k].begin()) + " |";
      for (const auto* g : gs) {
        const EpisodeStats* e = stats_at(*g, k);
        if (!e || std::get<0>(get(*e)) == 0) {
          t += " – |";
          continue;
        }
        const auto [runs, median, q25, q75] = get(*e);
        t += fmt::format(" {} [{}, {}]", md(median, decimals), md(q25, decimals),
                         md(q75, decimals));
        if (!same_time) t += fmt::format(" at {} s", md(e->interaction_time_s));
        if (runs < g->runs) t += fmt::format(" ({} run{})", runs, runs == 1 ? "" : "s");
        t += " |";
      }
      t += "\n";
    }
  }
  return t;
}

}  // namespace

void write_report_markdown(const CampaignReport& report, const fs::path& path) {
  std::map<std::string, int> counts;
  for (const auto& r : report.runs) ++counts[r.status];
  static const std::vector<std::string> known = {"complete", "running",     "interrupted",
                                                 "failed",   "not started", "unreadable"};
  std::vector<std::string> parts;
  for (const auto& s : known)
    if (counts.count(s)) parts.push_back(fmt::format("{} {}", counts[s], s));
  for (const auto& [s, n] : counts)
    if (std::find(known.begin(), known.end(), s) == known.end())
      parts.push_back(fmt::format("{} {}", n, s));

  std::string t = fmt::format("# Campaign report: {}\n\n", report.dir.string());
  t += fmt::format("{} run directories in `{}`: {}.\n", report.runs.size(),
                   report.runs_dir.string(), join(parts, ", "));
  t += "Statistics cover the started runs (every status but \"not started\" and \"unreadable\") "
       "with the episodes they have finished so far; docs/reports.md defines them.\n";
  if (!report.extra_axes.empty())
    t += fmt::format("Variants are split by the campaign grid axes {}.\n",
                     join(report.extra_axes, ", "));

  const bool all_hexapod =
      !report.groups.empty() &&
      std::all_of(report.groups.begin(), report.groups.end(),
                  [](const GroupReport& g) { return g.task == "hexapod"; });
  const std::string panel = all_hexapod ? "real robot" : "prior";
  const bool any_speed = std::any_of(report.groups.begin(), report.groups.end(),
                                     [](const GroupReport& g) { return g.has_speed(); });
  // The hexapod has no success criterion: its summary shows the final return and speed.
  t += "\n## Summary\n\n| variant | " + panel + " | runs | complete |" +
       std::string(all_hexapod ? ""
                               : " solved at least once | solved at last episode | median first "
                                 "solve (episode) | median first solve (s) |") +
       " median final return |" + (any_speed ? " median final speed (m/s) |" : "") +
       "\n|---|---|---:|---:|" + (all_hexapod ? "" : "---:|---:|---:|---:|") + "---:|" +
       (any_speed ? "---:|" : "") + "\n";
  std::vector<std::string> models;
  for (const auto& g : report.groups) {
    t += fmt::format("| {} | {} | {} | {} |", g.variant, prior_label(g.prior), g.runs, g.complete);
    if (!all_hexapod)
      t += fmt::format(" {} | {} | {} | {} |", md_rate(g.success_rate, g.solved_runs, g.runs),
                       md_rate(g.solved_last_rate, g.solved_last_runs, g.runs),
                       g.runs ? md(g.median_first_solve_episode) : "–",
                       g.runs ? md(g.median_first_solve_time_s) : "–");
    t += " " + md(g.median_final_return) + " |";
    if (any_speed) t += " " + md(g.median_final_speed_m_s, 3) + " |";
    t += "\n";
    if (std::find(models.begin(), models.end(), g.model_type) == models.end())
      models.push_back(g.model_type);
  }
  std::sort(models.begin(), models.end(), [](const auto& a, const auto& b) {
    return std::pair(model_rank(a), a) < std::pair(model_rank(b), b);
  });
  std::vector<std::string> legend;
  for (const auto& m : models) legend.push_back(fmt::format("{} = {}", m, model_long_name(m)));
  t += "\n" + join(legend, "; ") +
       (all_hexapod ? std::string(".\n")
                    : ". \"not solved\": at least half of the runs never solved (never solved "
                      "counts as +∞).\n");

  t += "\n## Real return per episode: median [25th, 75th percentile]\n\n"
       "\"(n runs)\" marks episodes that fewer runs than the group's have reached.\n";
  t += episode_tables(report, [](const GroupReport&) { return true; },
                      [](const EpisodeStats& e) {
                        return std::tuple(e.runs, e.median, e.q25, e.q75);
                      },
                      2);
  if (std::any_of(report.groups.begin(), report.groups.end(),
                  [](const GroupReport& g) { return g.has_speed(); })) {
    t += "\n## Walking speed per episode (m/s): median [25th, 75th percentile]\n\n"
         "Forward distance over the episode's duration on the \"real\" robot.\n";
    t += episode_tables(report, [](const GroupReport& g) { return g.has_speed(); },
                        [](const EpisodeStats& e) {
                          return std::tuple(e.speed_runs, e.speed_median, e.speed_q25,
                                            e.speed_q75);
                        },
                        3);
  }
  if (std::any_of(report.groups.begin(), report.groups.end(), identifies_discrete_prior)) {
    t += "\n## Prior identified per episode (runs per prior)\n\n"
         "The prior the model used at each episode (the intact robot or the leg removed; "
         "gp_prior keeps its start).\n";
    t += episode_cells(report, identifies_discrete_prior, [](const GroupReport&,
                                                             const EpisodeStats& e) {
      std::vector<std::string> parts;
      for (const auto& [value, n] : e.phi_counts)
        parts.push_back(fmt::format("{} ×{}", hexapod_prior_name(value), n));
      return parts.empty() ? std::string("–") : join(parts, ", ");
    });
  }

  // Median φ at each group's last episode (the gp variant uses no prior: left out; so is the
  // hexapod, whose φ is a discrete leg index, shown above as the prior identified per episode).
  std::vector<std::string> names;
  std::vector<const GroupReport*> with_phi;
  for (const auto& g : report.groups) {
    if (g.model_type == "gp" || g.task == "hexapod" || g.episodes.empty() || g.phi_names.empty())
      continue;
    with_phi.push_back(&g);
    for (const auto& n : g.phi_names)
      if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  }
  if (!with_phi.empty()) {
    t +=
        "\n## Prior parameters φ at the last episode (median over the runs)\n\n| variant | prior | "
        "episode |";
    for (const auto& n : names) t += " " + n + " |";
    t += "\n|---|---|---:|";
    for (std::size_t i = 0; i < names.size(); ++i) t += "---:|";
    t += "\n";
    auto value_of = [](const std::vector<std::string>& ns, const std::vector<double>& vs,
                       const std::string& n) {
      const auto it = std::find(ns.begin(), ns.end(), n);
      const auto i = static_cast<std::size_t>(it - ns.begin());
      return it == ns.end() || i >= vs.size() ? std::string("–") : fmt::format("{:.3f}", vs[i]);
    };
    for (const auto* g : with_phi) {
      const auto& last = g->episodes.back();
      t += fmt::format("| {} | {} | {} |", g->variant, prior_label(g->prior), last.episode);
      for (const auto& n : names) t += " " + value_of(g->phi_names, last.phi_median, n) + " |";
      t += "\n";
    }
    t += "| actual (real system) | | |";
    for (const auto& n : names)
      t += " " + value_of(with_phi.front()->phi_names, with_phi.front()->phi_actual, n) + " |";
    t += "\n";
  }

  t += "\n## Runs\n\n| run | variant | prior | seed | status | episodes | first solved | last "
       "return |\n|---|---|---|---:|---|---:|---:|---:|\n";
  for (const auto& r : report.runs) {
    std::string status = r.status;
    if (!r.error.empty()) {
      std::string e = r.error.substr(0, 120);
      std::replace(e.begin(), e.end(), '|', '/');
      std::replace(e.begin(), e.end(), '\n', ' ');
      status += ": " + e;
    }
    t += fmt::format(
        "| {} | {} | {} | {} | {} | {} | {} | {} |\n", r.name, r.variant.empty() ? "?" : r.variant,
        r.prior.empty() ? "?" : r.prior, r.seed >= 0 ? std::to_string(r.seed) : "?", status,
        r.started() ? fmt::format("{}/{}", r.episodes.size(), r.episodes_planned) : "–",
        r.first_solved_episode ? std::to_string(*r.first_solved_episode)
                               : (r.started() ? "never" : "–"),
        r.episodes.empty() ? "–" : md(r.episodes.back().real_return));
  }
  write_file_atomically(path, t);
}

// ---------- drops plot helpers ----------

std::vector<int> default_plot_episodes(const RunResult& run) {
  if (run.episodes.empty()) return {};
  const int last = run.episodes.back().episode;
  if (run.first_solved_episode && *run.first_solved_episode != last)
    return {*run.first_solved_episode, last};
  return {last};
}

std::vector<int> parse_episode_list(const std::string& text, int last) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    const std::string s = b == std::string::npos ? "" : item.substr(b, e - b + 1);
    std::size_t used = 0;
    int k = 0;
    try {
      k = std::stoi(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (s.empty() || used != s.size())
      throw ConfigError(fmt::format(
          "--episodes '{}': '{}' is not an episode number (expected e.g. 1,5,10)", text, s));
    if (k < 1 || k > last)
      throw ConfigError(fmt::format(
          "--episodes '{}': episode {} is not in the run (allowed 1 to {})", text, k, last));
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
  }
  if (out.empty())
    throw ConfigError(fmt::format("--episodes '{}': expected episode numbers, e.g. 1,5,10", text));
  return out;
}

std::vector<std::string> plotted_phi_names(const RunResult& run) {
  std::vector<std::string> out;
  if (run.model_type == "gp") return out;
  for (std::size_t i = 0; i < run.phi_names.size(); ++i) {
    double lo = kInf, hi = -kInf;
    for (const auto& e : run.episodes)
      if (i < e.phi.size() && std::isfinite(e.phi[i])) {
        lo = std::min(lo, e.phi[i]);
        hi = std::max(hi, e.phi[i]);
      }
    const bool changes = hi > lo;
    const bool tunable = std::find(run.phi_tunable.begin(), run.phi_tunable.end(),
                                   run.phi_names[i]) != run.phi_tunable.end();
    if (changes || tunable) out.push_back(run.phi_names[i]);
  }
  return out;
}

// ---------- the commands ----------

namespace {

void create_output_dir(const fs::path& out) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw Error("cannot create output directory " + out.string() + ": " + ec.message());
}

}  // namespace

std::vector<fs::path> write_report(const CampaignReport& report, const fs::path& out_dir,
                                   bool figures) {
  create_output_dir(out_dir);
  write_summary_csv(report, out_dir / "summary.csv");
  write_returns_csv(report, out_dir / "returns.csv");
  write_phi_csv(report, out_dir / "phi.csv");
  write_report_markdown(report, out_dir / "report.md");
  std::vector<fs::path> files = {out_dir / "report.md", out_dir / "summary.csv",
                                 out_dir / "returns.csv", out_dir / "phi.csv"};
  const bool speed = std::any_of(report.groups.begin(), report.groups.end(),
                                 [](const GroupReport& g) { return g.has_speed(); });
  if (speed) {
    write_speed_csv(report, out_dir / "speed.csv");
    files.push_back(out_dir / "speed.csv");
  }
  if (figures) {
    try {
      run_plot_script(
          {"report", (out_dir / "returns.csv").string(), (out_dir / "returns.png").string()},
          "drops report");
    } catch (const Error& e) {
      throw Error(fmt::format("{} (the tables are written in {})", e.what(), out_dir.string()));
    }
    files.push_back(out_dir / "returns.png");
    if (speed) {
      try {
        run_plot_script({"report", (out_dir / "speed.csv").string(),
                         (out_dir / "speed.png").string(), "--quantity", "speed"},
                        "drops report");
      } catch (const Error& e) {
        throw Error(fmt::format("{} (the tables are written in {})", e.what(), out_dir.string()));
      }
      files.push_back(out_dir / "speed.png");
    }
  }
  return files;
}

std::vector<fs::path> plot_run(const fs::path& run_dir, const std::string& episodes_text,
                               const fs::path& out_dir) {
  if (!fs::is_directory(run_dir))
    throw ConfigError("run directory '" + run_dir.string() + "' does not exist");
  const RunResult run = read_run(run_dir);
  if (run.status == "not started")
    throw ConfigError("'" + run_dir.string() +
                      "' holds no summary.json: not a run directory, or the run has not started");
  if (run.status == "unreadable") throw Error("cannot read " + run_dir.string() + ": " + run.error);
  if (run.episodes.empty())
    throw Error("run " + run_dir.string() + " has no finished episode yet; nothing to plot");
  const int last = run.episodes.back().episode;
  const std::vector<int> episodes =
      episodes_text.empty() ? default_plot_episodes(run) : parse_episode_list(episodes_text, last);
  for (int k : episodes) {
    const fs::path real = run_dir / "episodes" / fmt::format("{:03d}", k) / "real.csv";
    if (!fs::exists(real)) throw Error("missing " + real.string());
  }
  create_output_dir(out_dir);
  std::vector<std::string> ks;
  for (int k : episodes) ks.push_back(std::to_string(k));
  const std::vector<std::string> phi = plotted_phi_names(run);
  run_plot_script({"run", run_dir.string(), out_dir.string(), "--episodes", join(ks, ","), "--phi",
                   join(phi, ",")},
                  "drops plot");
  std::vector<fs::path> files = {out_dir / "returns.png"};
  if (!phi.empty()) files.push_back(out_dir / "phi.png");
  // The hexapod adds speed.png, path-NNN.png and gait-NNN.png (python/drops_plot.py).
  if (fs::exists(out_dir / "speed.png")) files.push_back(out_dir / "speed.png");
  for (int k : episodes) {
    files.push_back(out_dir / fmt::format("trajectories-{:03d}.png", k));
    for (const char* extra : {"path", "gait"}) {
      const fs::path f = out_dir / fmt::format("{}-{:03d}.png", extra, k);
      if (fs::exists(f)) files.push_back(f);
    }
  }
  return files;
}

namespace {

struct ReportArgs {
  std::string campaign_dir;
  std::string output;
  bool no_figures = false;
};

int report_main(const ReportArgs& args) {
  const CampaignReport report = aggregate_campaign(args.campaign_dir);
  for (const auto& r : report.runs)
    if (r.status == "unreadable")
      fmt::print(stderr, "drops report: warning: {} is unreadable ({}); left out\n", r.dir.string(),
                 r.error);
  const fs::path out =
      args.output.empty() ? fs::path(args.campaign_dir) / "report" : fs::path(args.output);
  const std::vector<fs::path> files = write_report(report, out, !args.no_figures);
  int started = 0;
  for (const auto& r : report.runs) started += r.started() ? 1 : 0;
  fmt::print("drops report: {} groups from {} run directories ({} started) in {}\n",
             report.groups.size(), report.runs.size(), started, report.runs_dir.string());
  for (const auto& f : files) fmt::print("  {}\n", f.string());
  return 0;
}

struct PlotArgs {
  std::string run_dir;
  std::string episodes;
  std::string output;
};

int plot_main(const PlotArgs& args) {
  const fs::path out =
      args.output.empty() ? fs::path(args.run_dir) / "plots" : fs::path(args.output);
  const std::vector<fs::path> files = plot_run(args.run_dir, args.episodes, out);
  fmt::print("drops plot: {}\n", args.run_dir);
  for (const auto& f : files) fmt::print("  {}\n", f.string());
  if (std::none_of(files.begin(), files.end(),
                   [](const fs::path& f) { return f.filename() == "phi.png"; }))
    fmt::print("  (no phi.png: the gp variant uses no prior)\n");
  return 0;
}

}  // namespace

void add_report_command(CLI::App& app, Action& action) {
  static ReportArgs args;
  auto* sub = app.add_subcommand(
      "report",
      "Aggregate a campaign: summary.csv, returns.csv, phi.csv, report.md and returns.png "
      "(median return with the 25-75 % band per prior and variant; see docs/reports.md)");
  sub->add_option("CAMPAIGN_DIR", args.campaign_dir,
                  "campaign directory written by drops campaign (holds runs/)")
      ->required();
  sub->add_option("--output,-o", args.output, "where to write (default CAMPAIGN_DIR/report)");
  sub->add_flag("--no-figures", args.no_figures, "tables only: do not run python/matplotlib");
  sub->callback([&action] { action = [] { return report_main(args); }; });
}

void add_plot_command(CLI::App& app, Action& action) {
  static PlotArgs args;
  auto* sub = app.add_subcommand(
      "plot",
      "Figures of one run: returns.png, phi.png and trajectories-NNN.png (real vs predicted)");
  sub->add_option("RUN_DIR", args.run_dir, "run directory written by drops run")->required();
  sub->add_option("--episodes", args.episodes,
                  "episodes whose trajectories to draw, e.g. 1,5,10 (default: the first solved "
                  "and the last)");
  sub->add_option("--output,-o", args.output, "where to write (default RUN_DIR/plots)");
  sub->callback([&action] { action = [] { return plot_main(args); }; });
}

}  // namespace drops::app
