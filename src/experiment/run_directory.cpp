// The run directory's writer and reader.
#include "drops/experiment/run_directory.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <sstream>

#include "drops/experiment/registry.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kCheckpointFormat = 1;

std::string phi_text(const VectorXd& phi) {
  std::string s;
  for (Eigen::Index i = 0; i < phi.size(); ++i) s += fmt::format("{}{:.6g}", i ? " " : "", phi[i]);
  return s;
}

std::vector<double> to_std(const VectorXd& v) { return {v.data(), v.data() + v.size()}; }

VectorXd to_eigen(const nlohmann::json& j, const std::string& what) {
  if (!j.is_array()) throw Error("checkpoint.json: " + what + " is not an array");
  VectorXd v(static_cast<Eigen::Index>(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number()) throw Error("checkpoint.json: " + what + " holds a non-number");
    v[static_cast<Eigen::Index>(i)] = j[i].get<double>();
  }
  return v;
}

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

/// An algorithm's details as a JSON object (non-finite numbers as null).
nlohmann::json details_json(const algo::Details& d) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : d.numbers) j[k] = number(v);
  for (const auto& [k, v] : d.texts) j[k] = v;
  return j;
}

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

nlohmann::json report_json(const ReportInfo& r) {
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& [v, l] : r.phi_value_labels) labels.push_back({v, l});
  return {{"phi_tunable", r.phi_tunable},
          {"panel", {{"label", r.panel.label}, {"rank", r.panel.rank}, {"title", r.panel.title}}},
          {"metric",
           {{"name", r.metric.name},
            {"label", r.metric.label},
            {"unit", r.metric.unit},
            {"file", r.metric.file},
            {"predicted", r.metric.predicted},
            {"reference", number(r.metric.reference)},
            {"reference_label", r.metric.reference_label}}},
          {"success_criterion", r.success_criterion},
          {"phi_value_labels", labels}};
}

ReportInfo report_from_json(const nlohmann::json& j) {
  ReportInfo r;
  const auto& p = j.at("panel");
  r.panel.label = p.value("label", std::string());
  r.panel.rank = p.value("rank", 0);
  r.panel.title = p.value("title", std::string());
  const auto& m = j.at("metric");
  r.metric.name = m.value("name", std::string());
  r.metric.label = m.value("label", std::string());
  r.metric.unit = m.value("unit", std::string());
  r.metric.file = m.value("file", std::string());
  r.metric.predicted = m.value("predicted", std::string());
  r.metric.reference = m.contains("reference") && m["reference"].is_number()
                           ? m["reference"].get<double>()
                           : kNaN;
  r.metric.reference_label = m.value("reference_label", std::string());
  r.success_criterion = j.value("success_criterion", true);
  if (j.contains("phi_tunable")) r.phi_tunable = j["phi_tunable"].get<std::vector<std::string>>();
  for (const auto& e : j.value("phi_value_labels", nlohmann::json::array()))
    r.phi_value_labels[e.at(0).get<double>()] = e.at(1).get<std::string>();
  return r;
}

}  // namespace

void write_file_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw Error("cannot write " + tmp.string());
    out << text;
    out.flush();
    if (!out) throw Error("cannot write " + tmp.string());
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw Error("cannot write " + path.string() + ": " + ec.message());
}

std::string now_iso() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string local_timestamp() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::tm tm{};
  localtime_r(&t, &tm);
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

std::string trajectory_csv(const rollout::Trajectory& tr, const TaskSetup& setup) {
  const double dt = setup.task->dt();
  std::string text = "t";
  for (const auto& n : setup.state_names) text += "," + n;
  for (const auto& n : setup.action_names) text += "," + n;
  text += ",reward";
  for (const auto& n : setup.state_extra_names) text += "," + n;
  text += "\n";
  const std::string no_action(static_cast<std::size_t>(tr.actions.cols()), ',');
  for (Eigen::Index t = 0; t < tr.states.rows(); ++t) {
    text += fmt::format("{:.4f}", static_cast<double>(t) * dt);
    for (Eigen::Index i = 0; i < tr.states.cols(); ++i)
      text += fmt::format(",{:.10g}", tr.states(t, i));
    if (t < tr.actions.rows()) {
      for (Eigen::Index i = 0; i < tr.actions.cols(); ++i)
        text += fmt::format(",{:.10g}", tr.actions(t, i));
    } else {
      text += no_action;
    }
    text += t > 0 ? fmt::format(",{:.10g}", tr.rewards[t - 1]) : ",";
    if (setup.state_extras)
      for (double v : setup.state_extras(tr.states.row(t).transpose()))
        text += fmt::format(",{:.6g}", v);
    text += "\n";
  }
  return text;
}

// ---------------------------------------------------------------------------------------------
// Writer.

RunDirectory::RunDirectory(const fs::path& dir, const Experiment& experiment)
    : dir_(dir), experiment_(experiment) {}

RunDirectory::~RunDirectory() {
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

void RunDirectory::lock() {
  const fs::path p = dir_ / ".lock";
  lock_fd_ = ::open(p.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw Error("cannot open " + p.string());
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0)
    throw RunDirectoryBusy("run directory " + dir_.string() + " is in use by another process");
}

RunDirectory::RunDirectory(const fs::path& dir, const std::string& config_yaml,
                           const Experiment& e)
    : dir_(dir), experiment_(e) {
  if (fs::exists(dir / "episodes.csv"))
    throw Error("run directory " + dir.string() +
                " already holds a run; choose another name=, remove it, or continue it with "
                "drops run --resume " + dir.string());
  std::error_code ec;
  fs::create_directories(dir / "episodes", ec);
  if (ec) throw Error("cannot create run directory " + dir.string() + ": " + ec.message());
  lock();
  write_file_atomically(dir / "config.yaml", config_yaml);
  episodes_csv_.open(dir / "episodes.csv", std::ios::trunc);
  if (!episodes_csv_) throw Error("cannot write " + (dir / "episodes.csv").string());
  episodes_csv_ << "episode,interaction_time_s,real_return,predicted_return,solved,phi,"
                   "model_learning_s,policy_optimization_s,evaluations";
  for (const auto& m : e.setup.metric_names) episodes_csv_ << "," << m;
  episodes_csv_ << "\n";
  episodes_csv_.flush();
  const auto& p = e.setup.prior_parameters;
  summary_ = {{"task", e.task},
              {"algorithm", e.algorithm},
              {"model", e.variant},
              {"uses_prior", e.uses_prior},
              {"prior", e.setup.prior_label},
              {"report", report_json(e.report)},
              {"seed", e.seed},
              {"episodes_planned", e.runner->episodes()},
              {"phi_names", p.names},
              {"phi_actual", e.setup.phi_actual},
              {"started", now_iso()},
              {"episodes", nlohmann::json::array()}};
  write_summary("running");
}

void RunDirectory::record(const algo::EpisodeRecord& rec) {
  const TaskSetup& setup = experiment_.setup;
  if (rec.keep_trajectories) {
    const fs::path ep = dir_ / "episodes" / fmt::format("{:03d}", rec.episode);
    fs::create_directories(ep);
    write_file_atomically(ep / "real.csv", trajectory_csv(rec.real, setup));
    if (rec.predicted.states.rows() > 0)
      write_file_atomically(ep / "predicted.csv", trajectory_csv(rec.predicted, setup));
    std::string theta;
    for (Eigen::Index i = 0; i < rec.theta.size(); ++i)
      theta += fmt::format("{:.17g}\n", rec.theta[i]);
    write_file_atomically(ep / "policy.csv", theta);
  }
  const std::vector<double> metrics = setup.metrics ? setup.metrics(rec) : std::vector<double>{};

  episodes_csv_ << fmt::format("{},{:.3f},{:.6f},{:.6f},{},{},{:.3f},{:.3f},{}", rec.episode,
                               rec.interaction_time, rec.real_return, rec.predicted_return,
                               rec.solved ? 1 : 0, phi_text(rec.phi), rec.model_seconds,
                               rec.policy_seconds, rec.evaluations);
  for (double m : metrics) episodes_csv_ << fmt::format(",{:.6g}", m);
  episodes_csv_ << "\n";
  episodes_csv_.flush();

  nlohmann::json e = {{"episode", rec.episode},
                      {"interaction_time_s", rec.interaction_time},
                      {"real_return", rec.real_return},
                      {"predicted_return", number(rec.predicted_return)},
                      {"solved", rec.solved},
                      {"random_policy", rec.random_policy},
                      {"phi", std::vector<double>(rec.phi.data(), rec.phi.data() + rec.phi.size())},
                      {"model_learning_s", rec.model_seconds},
                      {"policy_optimization_s", rec.policy_seconds},
                      {"evaluations", rec.evaluations},
                      {"nonfinite_model_steps", rec.nonfinite_model_steps},
                      {"nonfinite_prior_outputs", rec.model.nonfinite_prior_outputs},
                      {"phi_evaluations", rec.model.phi_evaluations},
                      {"rprop_iterations", rec.model.rprop_iterations},
                      {"trajectories", rec.keep_trajectories}};
  if (rec.random_policy) {
    e["policy_search"] = "random";
  } else if (!rec.policy_search.runs.empty()) {
    e["policy_search"] = rec.policy_search.BriefReport();
    // Each CMA-ES run (values are returns: the optimizer's values negated) and the selection.
    nlohmann::json runs = nlohmann::json::array();
    for (const auto& r : rec.policy_search.runs)
      runs.push_back({{"lambda", r.lambda},
                      {"sigma0", r.sigma0},
                      {"from", r.from_start ? "start" : "random"},
                      {"regime", r.small ? "small" : "large"},
                      {"evaluations", r.evaluations},
                      {"generations", r.generations},
                      {"best_return", number(-r.best_value)},
                      {"stop", r.stop_reason}});
    e["policy_search_runs"] = runs;
    e["policy_selection"] = {{"selected", rec.selected},
                             {"candidates", rec.reevaluated_candidates},
                             {"reevaluated_return", number(rec.reevaluated_return)},
                             {"start_return", number(-rec.policy_search.start_value)},
                             {"best_single_return", number(-rec.policy_search.best_value)}};
  } else if (!rec.selected.empty()) {
    e["policy_search"] = rec.selected;
  }
  for (std::size_t i = 0; i < metrics.size() && i < setup.metric_names.size(); ++i)
    e[setup.metric_names[i]] = number(metrics[i]);
  if (!rec.details.empty()) e["details"] = details_json(rec.details);
  summary_["episodes"].push_back(e);
  if (rec.solved && !summary_.contains("first_solved_episode"))
    summary_["first_solved_episode"] = rec.episode;
  write_summary("running");
}

void RunDirectory::record_phase(const algo::PhaseRecord& phase) {
  nlohmann::json p = details_json(phase.summary);
  nlohmann::json eps = nlohmann::json::array();
  for (const auto& d : phase.episodes) eps.push_back(details_json(d));
  p["episodes"] = eps;
  summary_["phases"][phase.name] = p;
  write_summary("running");
}

void RunDirectory::save_state(const algo::RunState& st) {
  nlohmann::json data_x = nlohmann::json::array(), data_u = nlohmann::json::array(),
                 data_dx = nlohmann::json::array();
  for (const auto& t : st.data) {
    data_x.push_back(to_std(t.x));
    data_u.push_back(to_std(t.u));
    data_dx.push_back(to_std(t.dx));
  }
  nlohmann::json h = nlohmann::json::array();
  for (const auto& v : st.model.h_params) h.push_back(to_std(v));
  nlohmann::json extra = nlohmann::json::object();
  for (const auto& [k, v] : st.extra) extra[k] = to_std(v);
  const nlohmann::json j = {{"format", kCheckpointFormat},
                            {"algorithm", experiment_.algorithm},
                            {"seed", experiment_.seed},
                            {"model_type", experiment_.variant},
                            {"episodes_done", st.episodes_done},
                            {"best_theta", to_std(st.best_theta)},
                            {"best_return", st.best_return},
                            {"first_solved_episode", st.first_solved_episode},
                            {"model", {{"phi", to_std(st.model.phi)}, {"h_params", h}}},
                            {"extra", extra},
                            {"data", {{"x", data_x}, {"u", data_u}, {"dx", data_dx}}}};
  // nlohmann writes the shortest decimal form that reads back to the same double.
  write_file_atomically(dir_ / "checkpoint.json", j.dump() + "\n");
}

algo::RunState read_checkpoint(const fs::path& dir) {
  const fs::path cp = dir / "checkpoint.json";
  if (!fs::exists(cp))
    throw Error("run " + dir.string() +
                " has no checkpoint.json: no episode finished, so there is nothing to continue; "
                "remove the directory and start the run again");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(cp));
  } catch (const std::exception& e) {
    throw Error("cannot read " + cp.string() + ": " + e.what());
  }
  try {
    if (j.at("format").get<int>() != kCheckpointFormat)
      throw Error(cp.string() + ": checkpoint format " + j.at("format").dump() +
                  " is not supported");
    algo::RunState st;
    st.episodes_done = j.at("episodes_done").get<int>();
    st.best_theta = to_eigen(j.at("best_theta"), "best_theta");
    st.best_return = j.at("best_return").get<double>();
    st.first_solved_episode = j.at("first_solved_episode").get<int>();
    st.model.phi = to_eigen(j.at("model").at("phi"), "model.phi");
    for (const auto& h : j.at("model").at("h_params"))
      st.model.h_params.push_back(to_eigen(h, "h_params"));
    if (j.contains("extra"))
      for (const auto& [k, v] : j["extra"].items()) st.extra[k] = to_eigen(v, "extra." + k);
    const auto& d = j.at("data");
    const std::size_t n = d.at("x").size();
    if (d.at("u").size() != n || d.at("dx").size() != n)
      throw Error(cp.string() + ": data.x, data.u and data.dx differ in length");
    st.data.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      st.data[i].x = to_eigen(d["x"][i], "data.x");
      st.data[i].u = to_eigen(d["u"][i], "data.u");
      st.data[i].dx = to_eigen(d["dx"][i], "data.dx");
    }
    return st;
  } catch (const nlohmann::json::exception& e) {
    throw Error(cp.string() + " is malformed: " + e.what());
  }
}

std::unique_ptr<RunDirectory> RunDirectory::reopen(const fs::path& dir, const Experiment& e,
                                                   algo::RunState* state) {
  std::unique_ptr<RunDirectory> rd(new RunDirectory(dir, e));
  if (!fs::exists(dir / "config.yaml"))
    throw Error(dir.string() + " is not a run directory (no config.yaml)");
  rd->lock();
  if (!e.runner->resumable())
    throw Error("run " + dir.string() + ": algorithm '" + e.algorithm +
                "' cannot be resumed; start it again");
  *state = read_checkpoint(dir);
  nlohmann::json cp, summary;
  try {
    cp = nlohmann::json::parse(read_text(dir / "checkpoint.json"));
    summary = nlohmann::json::parse(read_text(dir / "summary.json"));
  } catch (const std::exception& ex) {
    throw Error("cannot read the summary of " + dir.string() + ": " + ex.what());
  }
  const std::string algorithm = cp.value("algorithm", std::string("black_drops"));
  if (cp.value("seed", std::uint64_t{0}) != e.seed || algorithm != e.algorithm ||
      cp.value("model_type", std::string()) != e.variant)
    throw Error(dir.string() + ": checkpoint.json does not belong to the run's config.yaml "
                "(seed, algorithm or model differ)");
  const int k = state->episodes_done;

  // Drop whatever was recorded after the checkpoint.
  {
    std::ifstream in(dir / "episodes.csv");
    std::string line, kept;
    int row = 0;
    while (std::getline(in, line)) {
      if (row++ == 0) {
        kept += line + "\n";
        continue;
      }
      if (line.empty()) continue;
      const int ep = std::atoi(line.c_str());
      if (ep >= 1 && ep <= k) kept += line + "\n";
    }
    write_file_atomically(dir / "episodes.csv", kept);
  }
  if (fs::exists(dir / "episodes"))
    for (const auto& entry : fs::directory_iterator(dir / "episodes")) {
      const int ep = std::atoi(entry.path().filename().c_str());
      if (ep > k) fs::remove_all(entry.path());
    }
  try {
    nlohmann::json eps = nlohmann::json::array();
    for (const auto& ep : summary.at("episodes"))
      if (ep.at("episode").get<int>() <= k) eps.push_back(ep);
    summary["episodes"] = eps;
    summary.erase("first_solved_episode");
    for (const auto& ep : eps)
      if (ep.at("solved").get<bool>()) {
        summary["first_solved_episode"] = ep.at("episode");
        break;
      }
  } catch (const nlohmann::json::exception& ex) {
    throw Error((dir / "summary.json").string() + " is malformed: " + ex.what());
  }
  summary["episodes_planned"] = e.runner->episodes();
  summary.erase("finished");
  summary.erase("error");
  // What the writer records about the run, brought up to date (older runs lack some of it).
  summary["algorithm"] = e.algorithm;
  summary["uses_prior"] = e.uses_prior;
  summary["report"] = report_json(e.report);
  if (!summary.contains("resumed")) summary["resumed"] = nlohmann::json::array();
  summary["resumed"].push_back(now_iso());
  if (summary.contains("seconds") && summary["seconds"].is_number())
    rd->previous_seconds_ = summary["seconds"].get<double>();
  rd->summary_ = summary;
  rd->episodes_csv_.open(dir / "episodes.csv", std::ios::app);
  if (!rd->episodes_csv_) throw Error("cannot append to " + (dir / "episodes.csv").string());
  rd->write_summary("running");
  return rd;
}

void RunDirectory::finish(const algo::RunSummary& s, const std::string& status,
                          const std::string& error) {
  summary_["episodes_done"] = s.episodes_done;
  summary_["best_real_return"] = s.best_real_return;
  summary_["seconds"] = previous_seconds_ + s.seconds;  // over every session of the run
  summary_["finished"] = now_iso();
  if (!s.search.runs.empty()) {
    nlohmann::json runs = nlohmann::json::array();
    for (const auto& r : s.search.runs)
      runs.push_back({{"lambda", r.lambda},
                      {"sigma0", r.sigma0},
                      {"from", r.from_start ? "start" : "random"},
                      {"regime", r.small ? "small" : "large"},
                      {"evaluations", r.evaluations},
                      {"generations", r.generations},
                      {"best_return", number(-r.best_value)},
                      {"stop", r.stop_reason}});
    summary_["search"] = {{"summary", s.search.BriefReport()},
                          {"runs", runs},
                          {"restarts", s.search.restarts},
                          {"start_return", number(-s.search.start_value)},
                          {"best_theta", to_std(s.search.best_x)}};
  }
  if (!error.empty()) summary_["error"] = error;
  write_summary(status);
}

void RunDirectory::write_summary(const std::string& status) {
  summary_["status"] = status;
  summary_["episodes_done"] = summary_["episodes"].size();
  bool solved = false;
  int best = 0;
  double best_return = -std::numeric_limits<double>::infinity();
  for (const auto& ep : summary_["episodes"]) {
    solved = solved || ep["solved"].get<bool>();
    if (ep["real_return"].is_number() && ep["real_return"].get<double>() > best_return) {
      best_return = ep["real_return"].get<double>();
      best = ep["episode"].get<int>();
    }
  }
  summary_["solved"] = solved;
  if (best > 0) summary_["best_episode"] = best;
  write_file_atomically(dir_ / "summary.json", summary_.dump(2) + "\n");
}

// ---------------------------------------------------------------------------------------------
// Reader.

double EpisodeResult::metric(const std::string& name) const {
  const auto it = metrics.find(name);
  return it == metrics.end() ? kNaN : it->second;
}

RunResult read_run(const fs::path& dir, const Registry* registry) {
  if (!fs::is_directory(dir)) throw Error(dir.string() + " is not a directory");
  RunResult run;
  run.dir = dir;
  run.name = dir.filename().string();
  if (run.name.empty()) run.name = dir.parent_path().filename().string();

  // config.yaml through the registry (the task's schema), when it knows the task.
  Settings config;
  bool have_config = false;
  if (registry && fs::exists(dir / "config.yaml")) {
    try {
      config = load_run_settings_file(*registry, (dir / "config.yaml").string(), {});
      have_config = true;
    } catch (const ConfigError&) {
      // an unknown task, or a file this drops cannot read: summary.json alone
    }
  }
  if (have_config) {
    run.task = config.at("task");
    run.algorithm = config.at("algorithm");
    const AlgorithmPlugin& algorithm = registry->algorithm(run.algorithm);
    run.model_type = algorithm.variant(config);
    run.uses_prior = algorithm.uses_prior(config);
    const TaskPlugin& task = registry->task(run.task);
    run.prior = task.prior_label(config);
    run.report = task.report_info(config);
    try {
      run.seed = get_int(config, "seed");
    } catch (const std::exception&) {
    }
  }

  const fs::path summary_path = dir / "summary.json";
  if (!fs::exists(summary_path)) {
    run.status = "not started";
  } else {
    try {
      const nlohmann::json s = nlohmann::json::parse(read_text(summary_path));
      run.status = s.value("status", std::string("running"));
      run.error = s.value("error", std::string());
      if (run.task.empty()) run.task = s.value("task", std::string());
      if (run.algorithm.empty()) run.algorithm = s.value("algorithm", std::string("black_drops"));
      if (run.model_type.empty()) run.model_type = s.value("model", std::string());
      if (!have_config) run.uses_prior = s.value("uses_prior", run.model_type != "gp");
      if (run.prior.empty()) run.prior = s.value("prior", std::string());
      if (s.contains("report")) run.report = report_from_json(s["report"]);
      if (run.report.panel.label.empty()) run.report.panel.label = run.prior;
      if (run.seed < 0 && s.contains("seed") && s["seed"].is_number_integer())
        run.seed = s["seed"].get<std::int64_t>();
      run.episodes_planned = s.value("episodes_planned", 0);
      if (s.contains("phi_names")) run.phi_names = s["phi_names"].get<std::vector<std::string>>();
      if (s.contains("phi_actual"))
        for (const auto& v : s["phi_actual"])
          run.phi_actual.push_back(v.is_number() ? v.get<double>() : kNaN);
      static const std::vector<std::string> kEpisodeKeys = {
          "episode", "interaction_time_s", "real_return", "predicted_return", "solved",
          "random_policy", "phi", "model_learning_s", "policy_optimization_s", "evaluations",
          "nonfinite_model_steps", "nonfinite_prior_outputs", "phi_evaluations",
          "rprop_iterations", "trajectories", "policy_search", "policy_search_runs",
          "policy_selection"};
      for (const auto& e : s.value("episodes", nlohmann::json::array())) {
        EpisodeResult ep;
        ep.episode = e.value("episode", static_cast<int>(run.episodes.size()) + 1);
        ep.interaction_time_s = number_or_nan(e, "interaction_time_s");
        ep.real_return = number_or_nan(e, "real_return");
        ep.predicted_return = number_or_nan(e, "predicted_return");
        ep.solved = e.value("solved", false);
        ep.random_policy = e.value("random_policy", false);
        if (e.contains("phi"))
          for (const auto& v : e["phi"]) ep.phi.push_back(v.is_number() ? v.get<double>() : kNaN);
        for (const auto& [k, v] : e.items())
          if (std::find(kEpisodeKeys.begin(), kEpisodeKeys.end(), k) == kEpisodeKeys.end() &&
              (v.is_number() || v.is_null()))
            ep.metrics[k] = v.is_number() ? v.get<double>() : kNaN;
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
  if (run.phi_tunable.empty()) run.phi_tunable = run.report.phi_tunable;
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
  return run;
}

int TrajectoryTable::column(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

TrajectoryTable read_trajectory_csv(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read " + path.string());
  TrajectoryTable t;
  std::string line;
  if (!std::getline(in, line)) throw Error(path.string() + " is empty");
  {
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) t.columns.push_back(c);
  }
  int row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty()) continue;
    std::vector<double> values;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      const std::string cell = line.substr(start, comma == std::string::npos ? std::string::npos
                                                                              : comma - start);
      double v = kNaN;
      if (!cell.empty()) {
        try {
          std::size_t used = 0;
          v = std::stod(cell, &used);
          if (used != cell.size()) throw std::invalid_argument(cell);
        } catch (const std::exception&) {
          throw Error(fmt::format("{} line {}: '{}' is not a number", path.string(), row, cell));
        }
      }
      values.push_back(v);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    if (values.size() != t.columns.size())
      throw Error(fmt::format("{} line {}: {} cells, the header has {}", path.string(), row,
                              values.size(), t.columns.size()));
    t.rows.push_back(std::move(values));
  }
  return t;
}

}  // namespace drops::experiment
