// A campaign's runs aggregated into statistics, tables and plot data.
#include "drops/experiment/report.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cctype>
#include <set>
#include <sstream>
#include <tuple>

#include "drops/experiment/campaign.hpp"
#include "drops/experiment/registry.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double x) { return fmt::format("{:.10g}", x); }

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// Markdown numbers: 2 decimals; +inf (a median first solve) reads "not solved".
std::string md(double x, int decimals = 2) {
  if (std::isinf(x) && x > 0) return "not solved";
  if (std::isnan(x)) return "–";
  return fmt::format("{:.{}f}", x, decimals);
}

std::string md_rate(double rate, int count, int runs) {
  if (runs == 0) return "–";
  return fmt::format("{:.2f} ({}/{})", rate, count, runs);
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

std::string label_with_unit(const std::string& label, const std::string& unit) {
  return unit.empty() ? label : label + " (" + unit + ")";
}

std::string panel_title(const GroupReport& g) {
  return g.report.panel.title.empty() ? g.prior : g.report.panel.title;
}

bool group_before(const GroupReport& a, const GroupReport& b) {
  return std::tuple(a.report.panel.rank, a.prior, a.variant_style.rank, a.variant) <
         std::tuple(b.report.panel.rank, b.prior, b.variant_style.rank, b.variant);
}

Quartiles quartiles(const std::vector<double>& v) {
  Quartiles q;
  q.runs = static_cast<int>(v.size());
  if (v.empty()) return q;
  q.median = quantile(v, 0.5);
  q.q25 = quantile(v, 0.25);
  q.q75 = quantile(v, 0.75);
  return q;
}

}  // namespace

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

std::string variant_long_name(const VariantStyle& style, const std::string& model_type) {
  return style.label.empty() ? model_type : style.label;
}

bool GroupReport::has_metric() const {
  return std::any_of(episodes.begin(), episodes.end(),
                     [](const EpisodeStats& e) { return e.metric.runs > 0; });
}

std::vector<GroupReport> aggregate_runs(const std::vector<RunResult>& runs) {
  std::vector<GroupReport> groups;
  std::vector<std::vector<const RunResult*>> members;
  std::map<std::pair<std::string, std::string>, std::size_t> index;
  for (const auto& run : runs) {
    if (run.status == "unreadable") continue;
    if (run.model_type.empty() && run.report.panel.label.empty()) continue;  // nothing known
    const auto key = std::pair(run.variant, run.report.panel.label);
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, groups.size()).first;
      GroupReport g;
      g.variant = run.variant;
      g.model_type = run.model_type;
      g.variant_style = run.variant_style;
      g.task = run.task;
      g.prior = run.report.panel.label;
      g.report = run.report;
      g.uses_prior = run.uses_prior;
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
    const std::string& metric = g.report.metric.name;
    std::vector<double> first_episode, first_time, final_return, final_metric;
    // The calibrated episodes in GroupReport's three sets: new policies, replays, episode 1.
    struct CalibrationSet {
      std::vector<double> gaps;
      int inside = 0;
      void summarise(int& count, double& inside_rate, double& median_gap) const {
        count = static_cast<int>(gaps.size());
        if (gaps.empty()) return;
        inside_rate = static_cast<double>(inside) / static_cast<double>(gaps.size());
        median_gap = quantile(gaps, 0.5);
      }
    } new_policies, replays, prior_only;
    int max_episode = 0;
    for (const RunResult* r : rs) {
      g.run_names.push_back(r->name);
      for (const auto& e : r->episodes) {
        if (!e.has_calibration || !std::isfinite(e.gap)) continue;
        // Episode 1 was predicted before any real data, by the prior simulator alone.
        // (A run from recorded data planned episode 1 on a model learned from them.)
        CalibrationSet& set = e.episode == 1 && !r->first_episode_on_recorded_data ? prior_only
                              : e.replay                                           ? replays
                                                                                   : new_policies;
        set.gaps.push_back(e.gap);
        set.inside += e.inside_band ? 1 : 0;
      }
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
        const auto& last = r->episodes.back();
        if (last.solved) ++g.solved_last_runs;
        if (std::isfinite(last.real_return)) final_return.push_back(last.real_return);
        if (!metric.empty() && std::isfinite(last.metric(metric)))
          final_metric.push_back(last.metric(metric));
        max_episode = std::max(max_episode, last.episode);
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
    if (!final_metric.empty()) g.median_final_metric = quantile(final_metric, 0.5);
    new_policies.summarise(g.calibrated_episodes, g.inside_band_rate, g.median_gap);
    replays.summarise(g.replayed_episodes, g.replay_inside_band_rate, g.replay_median_gap);
    prior_only.summarise(g.prior_only_episodes, g.prior_only_inside_band_rate,
                         g.prior_only_median_gap);

    const std::size_t nphi = g.phi_names.size();
    for (int k = 1; k <= max_episode; ++k) {
      EpisodeStats st;
      st.episode = k;
      std::vector<double> returns, times, metrics;
      std::vector<std::vector<double>> phis(nphi);
      std::map<double, int> phi_counts;
      for (const RunResult* r : rs) {
        const auto it = std::find_if(r->episodes.begin(), r->episodes.end(),
                                     [k](const EpisodeResult& e) { return e.episode == k; });
        if (it == r->episodes.end()) continue;
        if (std::isfinite(it->real_return)) returns.push_back(it->real_return);
        if (std::isfinite(it->interaction_time_s)) times.push_back(it->interaction_time_s);
        if (!metric.empty() && std::isfinite(it->metric(metric)))
          metrics.push_back(it->metric(metric));
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
      st.metric = quartiles(metrics);
      g.episodes.push_back(std::move(st));
    }
  }
  std::sort(groups.begin(), groups.end(), group_before);
  return groups;
}

namespace {

/// The value of a dotted key in a YAML document as text ("?" when absent).
std::string yaml_value(const YAML::Node& root, const std::string& dotted) {
  YAML::Node n = YAML::Clone(root);
  std::stringstream ss(dotted);
  std::string part;
  while (std::getline(ss, part, '.')) {
    if (!n || !n.IsMap()) return "?";
    n = n[part];
  }
  if (!n) return "?";
  if (n.IsScalar()) return n.Scalar();
  YAML::Emitter e;
  e << YAML::Flow << n;
  return e.c_str();
}

}  // namespace

CampaignReport aggregate_campaign(const Registry& registry, const fs::path& campaign_dir) {
  if (!fs::is_directory(campaign_dir))
    throw ConfigError("campaign directory '" + campaign_dir.string() + "' does not exist");
  CampaignReport report;
  report.dir = campaign_dir;
  // The grid axes with more than one value, as written (the campaign may be of a task this build
  // does not offer).
  const CampaignDirectory campaign(campaign_dir);
  std::vector<std::string> axes;
  if (const auto spec = campaign.read_spec(registry, campaign_dir.filename().string(), false))
    for (const auto& a : spec->grid)
      if (a.values.size() > 1 && a.key != "seed" && a.key != "algorithm" &&
          a.key != "model.type" && a.key != "task")
        axes.push_back(a.key);

  std::vector<fs::path> dirs;
  if (fs::is_directory(campaign.runs())) {
    report.runs_dir = campaign.runs();
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
  std::vector<std::vector<std::string>> values;  // per run, per axis
  for (const auto& d : dirs) {
    report.runs.push_back(read_run(d, &registry));
    YAML::Node config;
    try {
      if (fs::exists(d / "config.yaml")) config = YAML::LoadFile((d / "config.yaml").string());
    } catch (const YAML::Exception&) {
    }
    std::vector<std::string> v;
    for (const auto& a : axes) v.push_back(config ? yaml_value(config, a) : "?");
    values.push_back(std::move(v));
  }
  // An axis names variants when runs of one panel and model differ in it (an axis that chooses
  // the panel, e.g. a starting prior or a damage of the real robot, does not).
  for (std::size_t a = 0; a < axes.size(); ++a) {
    std::map<std::pair<std::string, std::string>, std::set<std::string>> seen;
    bool splits = false;
    for (std::size_t r = 0; r < report.runs.size(); ++r) {
      auto& s = seen[{report.runs[r].model_type, report.runs[r].report.panel.label}];
      s.insert(values[r][a]);
      splits = splits || s.size() > 1;
    }
    if (!splits) continue;
    report.extra_axes.push_back(axes[a]);
    for (std::size_t r = 0; r < report.runs.size(); ++r)
      report.runs[r].variant += " " + axes[a] + "=" + values[r][a];
  }
  // The task and its resolved settings (e.g. a torque limit) in which runs of one panel and model
  // differ, outside the grid axes: the groups are split by them too, never merged without a word.
  // Settings are compared between runs of the same task only.
  std::set<std::string> keys = {"task"};
  for (const auto& r : report.runs)
    for (const auto& [k, v] : r.task_settings) keys.insert(k);
  auto value_of = [](const RunResult& r, const std::string& key) -> const std::string* {
    if (key == "task") return r.task.empty() ? nullptr : &r.task;
    const auto it = r.task_settings.find(key);
    return it == r.task_settings.end() ? nullptr : &it->second;
  };
  for (const auto& key : keys) {
    if (std::find(report.extra_axes.begin(), report.extra_axes.end(), key) !=
        report.extra_axes.end())
      continue;
    std::map<std::tuple<std::string, std::string, std::string>, std::set<std::string>> seen;
    bool splits = false;
    for (const auto& r : report.runs) {
      const std::string* v = value_of(r, key);
      if (r.status == "unreadable" || !v) continue;
      auto& s = seen[{r.model_type, r.report.panel.label, key == "task" ? "" : r.task}];
      s.insert(*v);
      splits = splits || s.size() > 1;
    }
    if (!splits) continue;
    report.split_settings.push_back(key);
    for (auto& r : report.runs)
      if (const std::string* v = value_of(r, key)) r.variant += " " + key + "=" + *v;
  }
  report.groups = aggregate_runs(report.runs);
  return report;
}

// ---------- writers ----------

void write_summary_csv(const CampaignReport& report, const fs::path& path) {
  std::string t =
      "variant,prior,runs,complete,running,interrupted,failed,not_started,solved_runs,"
      "success_rate,solved_last_rate,median_first_solve_episode,median_first_solve_time_s,"
      "median_final_return,median_final_metric,metric,calibrated_episodes,inside_band_rate,"
      "median_gap,replayed_episodes,replay_inside_band_rate,replay_median_gap,"
      "prior_only_episodes,prior_only_inside_band_rate,prior_only_median_gap\n";
  for (const auto& g : report.groups)
    t += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                     csv_field(g.variant), csv_field(g.prior), g.runs, g.complete, g.running,
                     g.interrupted, g.failed, g.not_started, g.solved_runs, num(g.success_rate),
                     num(g.solved_last_rate), num(g.median_first_solve_episode),
                     num(g.median_first_solve_time_s), num(g.median_final_return),
                     num(g.median_final_metric), csv_field(g.report.metric.name),
                     g.calibrated_episodes, num(g.inside_band_rate), num(g.median_gap),
                     g.replayed_episodes, num(g.replay_inside_band_rate),
                     num(g.replay_median_gap), g.prior_only_episodes,
                     num(g.prior_only_inside_band_rate), num(g.prior_only_median_gap));
  write_file_atomically(path, t);
}

namespace {
std::string variant_label(const GroupReport& g) {
  const std::string rest = g.variant.size() > g.model_type.size()
                               ? g.variant.substr(g.model_type.size() + 1)
                               : std::string();
  const std::string name = variant_long_name(g.variant_style, g.model_type);
  return rest.empty() ? name : name + ", " + rest;
}

template <class Get>
std::string long_table(const CampaignReport& report, bool (GroupReport::*keep)() const, Get get) {
  std::string t = "variant,prior,episode,interaction_time_s,runs,median,q25,q75,variant_label,"
                  "panel_title,variant_colour\n";
  for (const auto& g : report.groups) {
    if (keep && !(g.*keep)()) continue;
    for (const auto& e : g.episodes) {
      const Quartiles q = get(e);
      t += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(g.variant),
                       csv_field(g.prior), e.episode, num(e.interaction_time_s), q.runs,
                       num(q.median), num(q.q25), num(q.q75), csv_field(variant_label(g)),
                       csv_field(panel_title(g)), csv_field(g.variant_style.colour));
    }
  }
  return t;
}
}  // namespace

void write_returns_csv(const CampaignReport& report, const fs::path& path) {
  write_file_atomically(path, long_table(report, nullptr, [](const EpisodeStats& e) {
                          return Quartiles{e.runs, e.median, e.q25, e.q75};
                        }));
}

bool write_metric_csv(const CampaignReport& report, const fs::path& path) {
  if (std::none_of(report.groups.begin(), report.groups.end(),
                   [](const GroupReport& g) { return g.has_metric(); }))
    return false;
  write_file_atomically(path, long_table(report, &GroupReport::has_metric,
                                         [](const EpisodeStats& e) { return e.metric; }));
  return true;
}

bool write_calibration_csv(const CampaignReport& report, const fs::path& path) {
  std::string t =
      "variant,prior,run,episode,quantile,inside_band,gap,replay,variant_label,panel_title,"
      "variant_colour\n";
  bool any = false;
  for (const auto& g : report.groups)
    for (const auto& name : g.run_names) {
      const auto r = std::find_if(report.runs.begin(), report.runs.end(),
                                  [&](const RunResult& x) { return x.name == name; });
      if (r == report.runs.end()) continue;
      for (const auto& e : r->episodes) {
        if (!e.has_calibration) continue;
        any = true;
        t += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(g.variant),
                         csv_field(g.prior), csv_field(name), e.episode,
                         num(e.calibration_quantile), e.inside_band ? 1 : 0, num(e.gap),
                         e.replay ? 1 : 0, csv_field(variant_label(g)),
                         csv_field(panel_title(g)), csv_field(g.variant_style.colour));
      }
    }
  if (any) write_file_atomically(path, t);
  return any;
}

void write_phi_csv(const CampaignReport& report, const fs::path& path) {
  std::string t = "variant,prior,episode,parameter,median,actual\n";
  for (const auto& g : report.groups)
    for (const auto& e : g.episodes)
      for (std::size_t i = 0; i < e.phi_median.size() && i < g.phi_names.size(); ++i)
        t += fmt::format("{},{},{},{},{},{}\n", csv_field(g.variant), csv_field(g.prior),
                         e.episode, csv_field(g.phi_names[i]), num(e.phi_median[i]),
                         num(i < g.phi_actual.size() ? g.phi_actual[i] : kNaN));
  write_file_atomically(path, t);
}

namespace {

bool identifies_discrete_prior(const GroupReport& g) {
  return g.uses_prior && !g.report.phi_value_labels.empty() && !g.episodes.empty();
}

// The groups of one panel with episodes, and the last episode any of them reached.
struct PanelGroups {
  std::vector<const GroupReport*> groups;
  int max_k = 0;
};

// The panels of `report` in group order, each with the groups `keep` accepts; panels left empty
// are dropped.
template <class Keep>
std::vector<PanelGroups> panels(const CampaignReport& report, Keep keep) {
  std::vector<std::string> priors;
  for (const auto& g : report.groups)
    if (std::find(priors.begin(), priors.end(), g.prior) == priors.end()) priors.push_back(g.prior);
  std::vector<PanelGroups> out;
  for (const auto& prior : priors) {
    PanelGroups p;
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

// One Markdown table per panel of the groups `keep` accepts: a row per episode, a column per
// variant, the cell cell(group, stats at k).
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

// Median [q25, q75] tables per panel of the quantity get(stats), with `decimals` decimals and one
// interaction-time column when every group agrees on it.
template <class Keep, class Get>
std::string episode_tables(const CampaignReport& report, Keep keep, Get get, int decimals) {
  std::string t;
  for (const auto& [gs, max_k] : panels(report, keep)) {
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
      if (same_time) t += fmt::format(" {} |", md(*times[k].begin()));
      for (const auto* g : gs) {
        const EpisodeStats* e = stats_at(*g, k);
        const Quartiles q = e ? get(*e) : Quartiles{};
        if (!e || q.runs == 0) {
          t += " – |";
          continue;
        }
        t += fmt::format(" {} [{}, {}]", md(q.median, decimals), md(q.q25, decimals),
                         md(q.q75, decimals));
        if (!same_time) t += fmt::format(" at {} s", md(e->interaction_time_s));
        if (q.runs < g->runs) t += fmt::format(" ({} run{})", q.runs, q.runs == 1 ? "" : "s");
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
  if (!report.split_settings.empty())
    t += fmt::format(
        "**Runs of one panel and variant differ in the task settings {}: their groups "
        "are split by {}.**\n",
        join(report.split_settings, ", "),
        report.split_settings.size() == 1 ? "its value" : "their values");

  const bool success = std::any_of(report.groups.begin(), report.groups.end(),
                                   [](const GroupReport& g) { return g.report.success_criterion; });
  const GroupReport* with_metric = nullptr;
  for (const auto& g : report.groups)
    if (g.has_metric() && !with_metric) with_metric = &g;
  const std::string metric_head =
      with_metric
          ? " median final " +
                label_with_unit(with_metric->report.metric.label, with_metric->report.metric.unit) +
                " |"
          : "";
  // A task without a success criterion shows the final return and metric only.
  t += "\n## Summary\n\n| variant | panel | runs | complete |" +
       std::string(success ? " solved at least once | solved at last episode | median first "
                             "solve (episode) | median first solve (s) |"
                           : "") +
       " median final return |" + metric_head + "\n|---|---|---:|---:|" +
       (success ? "---:|---:|---:|---:|" : "") + "---:|" + (with_metric ? "---:|" : "") + "\n";
  std::vector<const GroupReport*> models;  // the first group of each model_type
  for (const auto& g : report.groups) {
    t += fmt::format("| {} | {} | {} | {} |", g.variant, panel_title(g), g.runs, g.complete);
    if (success)
      t += fmt::format(" {} | {} | {} | {} |", md_rate(g.success_rate, g.solved_runs, g.runs),
                       md_rate(g.solved_last_rate, g.solved_last_runs, g.runs),
                       g.runs ? md(g.median_first_solve_episode) : "–",
                       g.runs ? md(g.median_first_solve_time_s) : "–");
    t += " " + md(g.median_final_return) + " |";
    if (with_metric) t += " " + md(g.median_final_metric, 3) + " |";
    t += "\n";
    if (std::none_of(models.begin(), models.end(),
                     [&](const GroupReport* m) { return m->model_type == g.model_type; }))
      models.push_back(&g);
  }
  std::sort(models.begin(), models.end(), [](const GroupReport* a, const GroupReport* b) {
    return std::pair(a->variant_style.rank, a->model_type) <
           std::pair(b->variant_style.rank, b->model_type);
  });
  std::vector<std::string> legend;
  for (const auto* m : models)
    legend.push_back(
        fmt::format("{} = {}", m->model_type, variant_long_name(m->variant_style, m->model_type)));
  t += "\n" + join(legend, "; ") +
       (success ? ". \"not solved\": at least half of the runs never solved (never solved "
                  "counts as +∞).\n"
                : std::string(".\n"));

  // How well the models predicted the policies they chose: the real return against the
  // predicted rollouts' returns, new policies and replays of the best one apart.
  if (std::any_of(report.groups.begin(), report.groups.end(), [](const GroupReport& g) {
        return g.calibrated_episodes + g.replayed_episodes + g.prior_only_episodes > 0;
      })) {
    t += "\n## Calibration of the model's predictions\n\n"
         "Per episode a model predicted: whether the real return fell inside the 5–95 % band of "
         "the returns of the model's Monte-Carlo rollouts of that policy, and the gap predicted − "
         "real (> 0: optimistic). From episode 2 on, new policies and replays of the best "
         "policy already run are counted apart; a calibrated model has about 90 % inside the "
         "band. Episode 1, predicted before any real data by the prior simulator alone (its "
         "rollouts agree where the simulator is deterministic), is counted apart too.\n\n"
         "| variant | panel | new policies | inside 5–95 % | median gap | replays | inside "
         "5–95 % | median gap | episode 1 | inside 5–95 % | median gap |\n"
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& g : report.groups) {
      if (g.calibrated_episodes + g.replayed_episodes + g.prior_only_episodes == 0) continue;
      auto rate = [](double r) {
        return std::isfinite(r) ? fmt::format("{:.0f} %", 100 * r) : std::string("–");
      };
      auto gap = [](double x) { return std::isfinite(x) ? fmt::format("{:.3g}", x) : "–"; };
      t += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", g.variant,
                       panel_title(g), g.calibrated_episodes, rate(g.inside_band_rate),
                       gap(g.median_gap), g.replayed_episodes, rate(g.replay_inside_band_rate),
                       gap(g.replay_median_gap), g.prior_only_episodes,
                       rate(g.prior_only_inside_band_rate), gap(g.prior_only_median_gap));
    }
  }

  t += "\n## Real return per episode: median [25th, 75th percentile]\n\n"
       "\"(n runs)\" marks episodes that fewer runs than the group's have reached.\n";
  t += episode_tables(
      report, [](const GroupReport&) { return true; },
      [](const EpisodeStats& e) { return Quartiles{e.runs, e.median, e.q25, e.q75}; }, 2);
  if (with_metric) {
    std::string label = with_metric->report.metric.label;
    if (!label.empty()) label[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(label[0])));
    const std::string& unit = with_metric->report.metric.unit;
    t += fmt::format("\n## {} per episode{}: median [25th, 75th percentile]\n", label,
                     unit.empty() ? "" : " (" + unit + ")");
    t += episode_tables(
        report, [](const GroupReport& g) { return g.has_metric(); },
        [](const EpisodeStats& e) { return e.metric; }, 3);
  }
  if (std::any_of(report.groups.begin(), report.groups.end(), identifies_discrete_prior)) {
    t += "\n## Prior identified per episode (runs per prior)\n\n"
         "The prior the model used at each episode (a variant without identification keeps its "
         "start).\n";
    t += episode_cells(report, identifies_discrete_prior,
                       [](const GroupReport& g, const EpisodeStats& e) {
                         std::vector<std::string> parts;
                         for (const auto& [value, n] : e.phi_counts) {
                           const auto it = g.report.phi_value_labels.find(value);
                           const std::string label = it == g.report.phi_value_labels.end()
                                                         ? fmt::format("{:g}", value)
                                                         : it->second;
                           parts.push_back(fmt::format("{} ×{}", label, n));
                         }
                         return parts.empty() ? std::string("–") : join(parts, ", ");
                       });
  }

  // Median phi at each group's last episode (variants without a prior, and discrete phi shown
  // above as the prior identified per episode, are left out).
  std::vector<std::string> names;
  std::vector<const GroupReport*> with_phi;
  for (const auto& g : report.groups) {
    if (!g.uses_prior || !g.report.phi_value_labels.empty() || g.episodes.empty() ||
        g.phi_names.empty())
      continue;
    with_phi.push_back(&g);
    for (const auto& n : g.phi_names)
      if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  }
  if (!with_phi.empty()) {
    t += "\n## Prior parameters φ at the last episode (median over the runs)\n\n| variant | panel "
         "| episode |";
    for (const auto& n : names) t += " " + n + " |";
    t += "\n|---|---|---:|";
    for (std::size_t i = 0; i < names.size(); ++i) t += "---:|";
    t += "\n";
    auto value_of = [](const std::vector<std::string>& ns, const std::vector<double>& vs,
                       const std::string& n) {
      const auto it = std::find(ns.begin(), ns.end(), n);
      const auto i = static_cast<std::size_t>(it - ns.begin());
      return it == ns.end() || i >= vs.size() ? std::string("–") : fmt::format("{:.4g}", vs[i]);
    };
    for (const auto* g : with_phi) {
      const auto& last = g->episodes.back();
      t += fmt::format("| {} | {} | {} |", g->variant, panel_title(*g), last.episode);
      for (const auto& n : names) t += fmt::format(" {} |", value_of(g->phi_names, last.phi_median, n));
      t += "\n";
    }
    t += "| actual (real system) | | |";
    for (const auto& n : names)
      t += " " + value_of(with_phi.front()->phi_names, with_phi.front()->phi_actual, n) + " |";
    t += "\n";
  }

  t += "\n## Runs\n\n| run | variant | panel | seed | status | episodes | first solved | last "
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
        r.report.panel.label.empty() ? "?" : r.report.panel.label,
        r.seed >= 0 ? std::to_string(r.seed) : "?", status,
        r.started() ? fmt::format("{}/{}", r.episodes.size(), r.episodes_planned) : "–",
        r.first_solved_episode ? std::to_string(*r.first_solved_episode)
                               : (r.started() ? "never" : "–"),
        r.episodes.empty() ? "–" : md(r.episodes.back().real_return));
  }
  write_file_atomically(path, t);
}

// ---------- drops plot ----------

std::vector<int> default_plot_episodes(const RunResult& run) {
  // Episodes with trajectories (a direct search keeps only its improvements).
  std::vector<int> with;
  for (const auto& e : run.episodes)
    if (fs::exists(episode_dir(run.dir, e.episode) / "real.csv"))
      with.push_back(e.episode);
  if (with.empty())  // none written yet (or not a run directory): every episode is a candidate
    for (const auto& e : run.episodes) with.push_back(e.episode);
  if (with.empty()) return {};
  const int last = with.back();
  if (run.first_solved_episode && *run.first_solved_episode != last &&
      std::find(with.begin(), with.end(), *run.first_solved_episode) != with.end())
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
  if (!run.uses_prior) return out;
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

void write_plot_data(const RunResult& run, const std::vector<int>& episodes,
                     const fs::path& path) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json eps = nlohmann::json::array();
  for (const auto& e : run.episodes) {
    nlohmann::json m = nlohmann::json::object();
    for (const auto& [k, v] : e.metrics) m[k] = number(v);
    nlohmann::json phi = nlohmann::json::array();
    for (double v : e.phi) phi.push_back(number(v));
    // The posterior's standard deviation per entry of phi (null where it has none).
    nlohmann::json phi_sd = nlohmann::json::array();
    for (const auto& name : run.phi_names) {
      const auto it = std::find(e.posterior_names.begin(), e.posterior_names.end(), name);
      const auto i = static_cast<std::size_t>(it - e.posterior_names.begin());
      phi_sd.push_back(i < e.posterior_sd.size() ? number(e.posterior_sd[i]) : nullptr);
    }
    eps.push_back({{"episode", e.episode},
                   {"interaction_time_s", number(e.interaction_time_s)},
                   {"real_return", number(e.real_return)},
                   {"predicted_return", number(e.predicted_return)},
                   {"solved", e.solved},
                   {"phi", phi},
                   {"phi_sd", phi_sd},
                   {"metrics", m}});
  }
  // The last episode's correlation of phi's posterior (the trade-offs the model sees).
  nlohmann::json phi_correlation = nullptr;
  for (auto e = run.episodes.rbegin(); e != run.episodes.rend(); ++e)
    if (e->posterior_names.size() >= 2) {
      nlohmann::json rows = nlohmann::json::array();
      for (const auto& r : e->posterior_correlation) {
        nlohmann::json row = nlohmann::json::array();
        for (double v : r) row.push_back(number(v));
        rows.push_back(row);
      }
      phi_correlation = {{"episode", e->episode}, {"names", e->posterior_names}, {"matrix", rows}};
      break;
    }
  auto table = [&](const TrajectoryTable& t) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& r : t.rows) {
      nlohmann::json row = nlohmann::json::array();
      for (double v : r) row.push_back(number(v));
      rows.push_back(row);
    }
    return nlohmann::json{{"columns", t.columns}, {"rows", rows}};
  };
  nlohmann::json trajectories = nlohmann::json::object();
  for (int k : episodes) {
    const fs::path dir = episode_dir(run.dir, k);
    nlohmann::json ep = {{"real", table(read_trajectory_csv(dir / "real.csv"))}};
    if (fs::exists(dir / "predicted.csv"))
      ep["predicted"] = table(read_trajectory_csv(dir / "predicted.csv"));
    trajectories[std::to_string(k)] = ep;
  }
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& [v, l] : run.report.phi_value_labels) labels.push_back({v, l});
  // How the figures name each quantity: the task's label and unit, else the name and no unit.
  auto label = [](const std::map<std::string, Label>& labels, const std::string& name) {
    const auto it = labels.find(name);
    const bool known = it != labels.end();
    return nlohmann::json{{"name", name},
                          {"text", known && !it->second.text.empty() ? it->second.text : name},
                          {"unit", known ? it->second.unit : ""},
                          {"labelled", known}};
  };
  nlohmann::json phi_labels = nlohmann::json::array();
  for (const auto& n : run.phi_names) phi_labels.push_back(label(run.report.phi_labels, n));
  // The role of each trajectory column: time, state, action, reward or extra (after the reward),
  // from summary.json's state and action names.
  nlohmann::json columns = nlohmann::json::array();
  if (!episodes.empty()) {
    const TrajectoryTable t = read_trajectory_csv(
        episode_dir(run.dir, episodes.front()) / "real.csv");
    auto in = [](const std::vector<std::string>& v, const std::string& n) {
      return std::find(v.begin(), v.end(), n) != v.end();
    };
    bool after_reward = false;
    for (std::size_t i = 0; i < t.columns.size(); ++i) {
      const std::string& c = t.columns[i];
      std::string kind;
      if (c == "t" && i == 0) {
        kind = "time";
      } else if (c == "reward" && !after_reward) {
        kind = "reward";
        after_reward = true;
      } else if (after_reward) {
        kind = "extra";
      } else {
        kind = in(run.action_names, c) ? "action" : "state";
      }
      nlohmann::json col = label(run.report.column_labels, c);
      col["kind"] = kind;
      if (c == "t" && !col["labelled"].get<bool>()) col.update({{"text", "time"}, {"unit", "s"}});
      columns.push_back(col);
    }
  }
  const nlohmann::json j = {
      {"name", run.name},
      {"task", run.task},
      {"variant", run.model_type},
      {"variant_label", variant_long_name(run.variant_style, run.model_type)},
      {"variant_colour", run.variant_style.colour},
      {"panel_title",
       run.report.panel.title.empty() ? run.report.panel.label : run.report.panel.title},
      {"phi_names", run.phi_names},
      {"phi_actual", run.phi_actual},
      {"phi_plotted", plotted_phi_names(run)},
      {"phi_value_labels", labels},
      {"phi_labels", phi_labels},
      {"phi_correlation", phi_correlation},
      {"columns", columns},
      {"metric",
       {{"name", run.report.metric.name},
        {"label",
         run.report.metric.label.empty() ? run.report.metric.name : run.report.metric.label},
        {"unit", run.report.metric.unit},
        {"file", run.report.metric.file},
        {"predicted", run.report.metric.predicted},
        {"reference", number(run.report.metric.reference)},
        {"reference_label", run.report.metric.reference_label}}},
      {"episodes", eps},
      {"trajectories", trajectories}};
  write_file_atomically(path, j.dump() + "\n");
}

}  // namespace drops::experiment
