#include "run_directory.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <ctime>

#include "drops/core/errors.hpp"

namespace drops::app {
namespace fs = std::filesystem;

namespace {

void write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw Error("cannot write " + tmp.string());
    out << text;
    out.flush();
    if (!out) throw Error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

std::string phi_text(const VectorXd& phi) {
  std::string s;
  for (Eigen::Index i = 0; i < phi.size(); ++i) s += fmt::format("{}{:.6g}", i ? " " : "", phi[i]);
  return s;
}

void write_trajectory(const fs::path& path, const rollout::Trajectory& tr, double dt) {
  std::string text = "t,dtheta1,dtheta2,theta1,theta2,u,reward\n";
  for (Eigen::Index t = 0; t < tr.states.rows(); ++t) {
    text += fmt::format("{:.4f}", t * dt);
    for (Eigen::Index i = 0; i < tr.states.cols(); ++i) text += fmt::format(",{:.10g}", tr.states(t, i));
    if (t < tr.actions.rows()) {
      for (Eigen::Index i = 0; i < tr.actions.cols(); ++i) text += fmt::format(",{:.10g}", tr.actions(t, i));
    } else {
      text += ",";
    }
    text += t > 0 ? fmt::format(",{:.10g}\n", tr.rewards[t - 1]) : ",\n";
  }
  write_atomically(path, text);
}

std::string now_iso() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

}  // namespace

RunDirectory::RunDirectory(const fs::path& dir, const io::Settings& settings,
                           const io::Experiment& experiment)
    : dir_(dir), experiment_(experiment) {
  if (fs::exists(dir / "episodes.csv"))
    throw Error("run directory " + dir.string() +
                " already holds a run; choose another name= or remove it");
  std::error_code ec;
  fs::create_directories(dir / "episodes", ec);
  if (ec) throw Error("cannot create run directory " + dir.string() + ": " + ec.message());
  write_atomically(dir / "config.yaml", io::to_yaml(settings));
  episodes_csv_.open(dir / "episodes.csv", std::ios::trunc);
  if (!episodes_csv_) throw Error("cannot write " + (dir / "episodes.csv").string());
  episodes_csv_ << "episode,interaction_time_s,real_return,predicted_return,solved,phi,"
                   "model_learning_s,policy_optimization_s,evaluations\n";
  episodes_csv_.flush();
  const VectorXd actual = experiment.actual.to_phi();
  const std::vector<double> phi_actual(actual.data(), actual.data() + actual.size());
  summary_ = {{"task", experiment.task},
              {"model", model::to_string(experiment.algo.model.type)},
              {"prior", experiment.prior_preset},
              {"seed", experiment.seed},
              {"episodes_planned", experiment.algo.episodes},
              {"phi_names", experiment.prior.names},
              {"phi_actual", phi_actual},
              {"started", now_iso()},
              {"episodes", nlohmann::json::array()}};
  write_summary("running");
}

void RunDirectory::record(const algo::EpisodeRecord& rec) {
  const fs::path ep = dir_ / "episodes" / fmt::format("{:03d}", rec.episode);
  fs::create_directories(ep);
  const double dt = experiment_.task_options.dt;
  write_trajectory(ep / "real.csv", rec.real, dt);
  if (rec.predicted.states.rows() > 0) write_trajectory(ep / "predicted.csv", rec.predicted, dt);
  std::string theta;
  for (Eigen::Index i = 0; i < rec.theta.size(); ++i) theta += fmt::format("{:.17g}\n", rec.theta[i]);
  write_atomically(ep / "policy.csv", theta);

  episodes_csv_ << fmt::format("{},{:.3f},{:.6f},{:.6f},{},{},{:.3f},{:.3f},{}\n", rec.episode,
                               rec.interaction_time, rec.real_return, rec.predicted_return,
                               rec.solved ? 1 : 0, phi_text(rec.phi), rec.model_seconds,
                               rec.policy_seconds, rec.evaluations);
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
  summary_["episodes"].push_back(e);
  if (rec.solved && !summary_.contains("first_solved_episode"))
    summary_["first_solved_episode"] = rec.episode;
  write_summary("running");
}

void RunDirectory::finish(const algo::BlackDropsSummary& s, const std::string& status,
                          const std::string& error) {
  summary_["episodes_done"] = s.episodes_done;
  summary_["best_real_return"] = s.best_real_return;
  summary_["seconds"] = s.seconds;
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
  write_atomically(dir_ / "summary.json", summary_.dump(2) + "\n");
}

}  // namespace drops::app
