#include "run_directory.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::app {
namespace fs = std::filesystem;

namespace {

std::string phi_text(const VectorXd& phi) {
  std::string s;
  for (Eigen::Index i = 0; i < phi.size(); ++i) s += fmt::format("{}{:.6g}", i ? " " : "", phi[i]);
  return s;
}

std::vector<double> to_std(const VectorXd& v) { return {v.data(), v.data() + v.size()}; }

VectorXd to_eigen(const nlohmann::json& j, const char* what) {
  if (!j.is_array()) throw Error(std::string("checkpoint.json: ") + what + " is not an array");
  VectorXd v(static_cast<Eigen::Index>(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number())
      throw Error(std::string("checkpoint.json: ") + what + " holds a non-number");
    v[static_cast<Eigen::Index>(i)] = j[i].get<double>();
  }
  return v;
}

constexpr int kCheckpointFormat = 1;

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
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

RunDirectory::RunDirectory(const fs::path& dir, const io::Experiment& experiment,
                           const TaskSetup& setup)
    : dir_(dir), experiment_(experiment), setup_(setup) {}

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
    for (Eigen::Index i = 0; i < tr.states.cols(); ++i) text += fmt::format(",{:.10g}", tr.states(t, i));
    if (t < tr.actions.rows()) {
      for (Eigen::Index i = 0; i < tr.actions.cols(); ++i) text += fmt::format(",{:.10g}", tr.actions(t, i));
    } else {
      text += no_action;
    }
    text += t > 0 ? fmt::format(",{:.10g}", tr.rewards[t - 1]) : ",";
    if (setup.state_extras)
      for (double v : setup.state_extras(tr.states.row(t).transpose())) text += fmt::format(",{:.6g}", v);
    text += "\n";
  }
  return text;
}

void RunDirectory::write_trajectory(const fs::path& path, const rollout::Trajectory& tr) const {
  write_file_atomically(path, trajectory_csv(tr, setup_));
}

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

RunDirectory::RunDirectory(const fs::path& dir, const io::Settings& settings,
                           const io::Experiment& experiment, const TaskSetup& setup)
    : dir_(dir), experiment_(experiment), setup_(setup) {
  if (fs::exists(dir / "episodes.csv"))
    throw Error("run directory " + dir.string() +
                " already holds a run; choose another name=, remove it, or continue it with "
                "drops run --resume " + dir.string());
  std::error_code ec;
  fs::create_directories(dir / "episodes", ec);
  if (ec) throw Error("cannot create run directory " + dir.string() + ": " + ec.message());
  lock();
  write_file_atomically(dir / "config.yaml", io::to_yaml(settings));
  episodes_csv_.open(dir / "episodes.csv", std::ios::trunc);
  if (!episodes_csv_) throw Error("cannot write " + (dir / "episodes.csv").string());
  episodes_csv_ << "episode,interaction_time_s,real_return,predicted_return,solved,phi,"
                   "model_learning_s,policy_optimization_s,evaluations";
  for (const auto& m : setup.metric_names) episodes_csv_ << "," << m;
  episodes_csv_ << "\n";
  episodes_csv_.flush();
  summary_ = {{"task", experiment.task},
              {"model", model::to_string(experiment.algo.model.type)},
              {"prior", experiment.prior_preset},
              {"seed", experiment.seed},
              {"episodes_planned", experiment.algo.episodes},
              {"phi_names", experiment.prior.names},
              {"phi_actual", experiment.phi_actual},
              {"started", now_iso()},
              {"episodes", nlohmann::json::array()}};
  write_summary("running");
}

void RunDirectory::record(const algo::EpisodeRecord& rec) {
  const fs::path ep = dir_ / "episodes" / fmt::format("{:03d}", rec.episode);
  fs::create_directories(ep);
  write_trajectory(ep / "real.csv", rec.real);
  if (rec.predicted.states.rows() > 0) write_trajectory(ep / "predicted.csv", rec.predicted);
  const std::vector<double> metrics = setup_.metrics ? setup_.metrics(rec) : std::vector<double>{};
  std::string theta;
  for (Eigen::Index i = 0; i < rec.theta.size(); ++i) theta += fmt::format("{:.17g}\n", rec.theta[i]);
  write_file_atomically(ep / "policy.csv", theta);

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
                      {"predicted_return", std::isfinite(rec.predicted_return)
                                               ? nlohmann::json(rec.predicted_return)
                                               : nlohmann::json(nullptr)},
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
                      {"policy_search", rec.random_policy ? "random" : rec.policy_search.BriefReport()}};
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  if (!rec.random_policy) {
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
  }
  for (std::size_t i = 0; i < metrics.size() && i < setup_.metric_names.size(); ++i)
    e[setup_.metric_names[i]] = std::isfinite(metrics[i]) ? nlohmann::json(metrics[i]) : nlohmann::json(nullptr);
  summary_["episodes"].push_back(e);
  if (rec.solved && !summary_.contains("first_solved_episode"))
    summary_["first_solved_episode"] = rec.episode;
  write_summary("running");
}

void RunDirectory::save_state(const algo::BlackDropsState& st) {
  nlohmann::json data_x = nlohmann::json::array(), data_u = nlohmann::json::array(),
                 data_dx = nlohmann::json::array();
  for (const auto& t : st.data) {
    data_x.push_back(to_std(t.x));
    data_u.push_back(to_std(t.u));
    data_dx.push_back(to_std(t.dx));
  }
  nlohmann::json h = nlohmann::json::array();
  for (const auto& v : st.model.h_params) h.push_back(to_std(v));
  const nlohmann::json j = {{"format", kCheckpointFormat},
                            {"seed", experiment_.seed},
                            {"model_type", model::to_string(experiment_.algo.model.type)},
                            {"episodes_done", st.episodes_done},
                            {"best_theta", to_std(st.best_theta)},
                            {"best_return", st.best_return},
                            {"first_solved_episode", st.first_solved_episode},
                            {"model", {{"phi", to_std(st.model.phi)}, {"h_params", h}}},
                            {"data", {{"x", data_x}, {"u", data_u}, {"dx", data_dx}}}};
  // nlohmann writes the shortest decimal form that reads back to the same double.
  write_file_atomically(dir_ / "checkpoint.json", j.dump() + "\n");
}

std::unique_ptr<RunDirectory> RunDirectory::reopen(const fs::path& dir,
                                                   const io::Experiment& experiment,
                                                   const TaskSetup& setup,
                                                   algo::BlackDropsState* state) {
  std::unique_ptr<RunDirectory> rd(new RunDirectory(dir, experiment, setup));
  if (!fs::exists(dir / "config.yaml"))
    throw Error(dir.string() + " is not a run directory (no config.yaml)");
  rd->lock();
  const fs::path cp = dir / "checkpoint.json";
  if (!fs::exists(cp))
    throw Error("run " + dir.string() +
                " has no checkpoint.json: no episode finished, so there is nothing to continue; "
                "remove the directory and start the run again");
  nlohmann::json j, summary;
  try {
    std::ifstream in(cp);
    j = nlohmann::json::parse(in);
    std::ifstream sin(dir / "summary.json");
    summary = nlohmann::json::parse(sin);
  } catch (const std::exception& e) {
    throw Error("cannot read the checkpoint of " + dir.string() + ": " + e.what());
  }
  try {
    if (j.at("format").get<int>() != kCheckpointFormat)
      throw Error("checkpoint format " + j.at("format").dump() + " is not supported");
    if (j.at("seed").get<std::uint64_t>() != experiment.seed ||
        j.at("model_type").get<std::string>() != model::to_string(experiment.algo.model.type))
      throw Error("checkpoint.json does not belong to the run's config.yaml (seed or model differ)");
    algo::BlackDropsState st;
    st.episodes_done = j.at("episodes_done").get<int>();
    st.best_theta = to_eigen(j.at("best_theta"), "best_theta");
    st.best_return = j.at("best_return").get<double>();
    st.first_solved_episode = j.at("first_solved_episode").get<int>();
    st.model.phi = to_eigen(j.at("model").at("phi"), "model.phi");
    for (const auto& h : j.at("model").at("h_params")) st.model.h_params.push_back(to_eigen(h, "h_params"));
    const auto& d = j.at("data");
    const std::size_t n = d.at("x").size();
    if (d.at("u").size() != n || d.at("dx").size() != n)
      throw Error("checkpoint.json: data.x, data.u and data.dx differ in length");
    st.data.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      st.data[i].x = to_eigen(d["x"][i], "data.x");
      st.data[i].u = to_eigen(d["u"][i], "data.u");
      st.data[i].dx = to_eigen(d["dx"][i], "data.dx");
    }
    *state = std::move(st);
  } catch (const nlohmann::json::exception& e) {
    throw Error("checkpoint.json of " + dir.string() + " is malformed: " + e.what());
  }
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
  for (const auto& entry : fs::directory_iterator(dir / "episodes")) {
    const int ep = std::atoi(entry.path().filename().c_str());
    if (ep > k) fs::remove_all(entry.path());
  }
  nlohmann::json eps = nlohmann::json::array();
  for (const auto& e : summary.at("episodes"))
    if (e.at("episode").get<int>() <= k) eps.push_back(e);
  summary["episodes"] = eps;
  summary.erase("first_solved_episode");
  for (const auto& e : eps)
    if (e.at("solved").get<bool>()) {
      summary["first_solved_episode"] = e.at("episode");
      break;
    }
  summary["episodes_planned"] = experiment.algo.episodes;
  summary.erase("finished");
  summary.erase("error");
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

void RunDirectory::finish(const algo::BlackDropsSummary& s, const std::string& status,
                          const std::string& error) {
  summary_["episodes_done"] = s.episodes_done;
  summary_["best_real_return"] = s.best_real_return;
  summary_["seconds"] = previous_seconds_ + s.seconds;  // over every session of the run
  summary_["finished"] = now_iso();
  if (!error.empty()) summary_["error"] = error;
  write_summary(status);
}

void RunDirectory::write_summary(const std::string& status) {
  summary_["status"] = status;
  summary_["episodes_done"] = summary_["episodes"].size();
  bool solved = false;
  for (const auto& e : summary_["episodes"]) solved = solved || e["solved"].get<bool>();
  summary_["solved"] = solved;
  write_file_atomically(dir_ / "summary.json", summary_.dump(2) + "\n");
}

}  // namespace drops::app
