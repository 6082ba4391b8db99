// The run directory's writer and reader.
#include "drops/experiment/run_directory.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <ctime>
#include <set>
#include <sstream>

#include "drops/experiment/campaign.hpp"
#include "drops/experiment/registry.hpp"
#include "sha256.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Keys a resumed run may change (drops run --resume DIR episodes=N threads=T).
const std::set<std::string> kResumeKeys = {"episodes", "threads"};

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

double number_or_nan(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : kNaN;
}

/// Each CMA-ES run of a search (values are returns: the optimizer's values negated).
nlohmann::json runs_json(const opt::CmaesSummary& search) {
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& r : search.runs)
    runs.push_back({{"lambda", r.lambda},
                    {"sigma0", r.sigma0},
                    {"from", r.from_start ? "start" : "random"},
                    {"regime", r.small ? "small" : "large"},
                    {"evaluations", r.evaluations},
                    {"generations", r.generations},
                    {"best_return", number(-r.best_value)},
                    {"stop", r.stop_reason}});
  return runs;
}

nlohmann::json labels_json(const std::map<std::string, Label>& labels) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, l] : labels) j[name] = {{"text", l.text}, {"unit", l.unit}};
  return j;
}

std::map<std::string, Label> labels_from_json(const nlohmann::json& j) {
  std::map<std::string, Label> labels;
  for (const auto& [name, l] : j.items())
    labels[name] = {l.value("text", std::string()), l.value("unit", std::string())};
  return labels;
}

nlohmann::json report_json(const ReportInfo& r) {
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& [v, l] : r.phi_value_labels) labels.push_back({v, l});
  return {{"phi_tunable", r.phi_tunable},
          {"phi_labels", labels_json(r.phi_labels)},
          {"column_labels", labels_json(r.column_labels)},
          {"panel",
           {{"label", r.panel.label},
            {"rank", r.panel.rank},
            {"title", r.panel.title},
            {"chosen_by_prior", r.panel.chosen_by_prior}}},
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

nlohmann::json style_json(const VariantStyle& v) {
  return {{"label", v.label}, {"rank", v.rank}, {"colour", v.colour}};
}

/// A recorded VariantStyle; a field it lacks or that is invalid keeps `known`'s.
VariantStyle style_from_json(const nlohmann::json& j, const VariantStyle& known) {
  VariantStyle v = known;
  if (j.contains("label") && j["label"].is_string()) v.label = j["label"].get<std::string>();
  if (j.contains("rank") && j["rank"].is_number_integer() && j["rank"].get<int>() >= 0)
    v.rank = j["rank"].get<int>();
  VariantStyle c = v;
  if (j.contains("colour") && j["colour"].is_string()) c.colour = j["colour"].get<std::string>();
  if (c.IsValid(nullptr)) v = c;
  return v;
}

std::string episode_folder(int episode) { return fmt::format("{:03d}", episode); }

/// SHA-256 of a checkpoint's JSON without its "checksum" member.
std::string checkpoint_checksum(nlohmann::json j) {
  j.erase("checksum");
  return sha256_hex(j.dump());
}

/// Throws drops::Error unless j (the content of `file`, summary.json or checkpoint.json) carries
/// "format_version" kRunDirectoryFormatVersion.
void check_format_version(const nlohmann::json& j, const fs::path& file) {
  const std::string supported = std::to_string(kRunDirectoryFormatVersion);
  if (!j.is_object() || !j.contains("format_version"))
    throw Error(file.string() + " has no format_version: the run directory was written by a " +
                "drops from before its format was versioned, and this drops reads run-directory " +
                "format version " + supported + " only. Read or continue it with the drops " +
                "that wrote it, or run it again with this one");
  const nlohmann::json& v = j["format_version"];
  if (v.is_number_integer() && v.get<long long>() == kRunDirectoryFormatVersion) return;
  const std::string found = v.is_string() ? v.get<std::string>() : v.dump();
  throw Error(file.string() + ": run-directory format version " + found +
              ", but this drops reads version " + supported +
              " only. Read or continue the run with a drops that reads version " + found +
              ", or run it again with this one");
}

/// The dotted keys present in a YAML document: a mapping is descended into unless its dotted key
/// is in `keys` (a key whose value is a mapping).
void yaml_keys(const YAML::Node& node, const std::string& prefix, const std::set<std::string>& keys,
               std::set<std::string>& out) {
  if (!node.IsMap()) return;
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) continue;
    const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
    if (kv.second.IsMap() && !keys.count(key))
      yaml_keys(kv.second, key, keys, out);
    else
      out.insert(key);
  }
}

std::string plural(std::size_t n, const char* word) {
  return fmt::format("{} {}{}", n, word, n == 1 ? "" : "s");
}

/// The report block of summary.json (report_json). Throws nlohmann::json::exception when a
/// member is missing.
ReportInfo report_from_json(const nlohmann::json& j) {
  ReportInfo r;
  const auto& p = j.at("panel");
  r.panel.label = p.value("label", std::string());
  r.panel.rank = p.value("rank", 0);
  r.panel.title = p.value("title", std::string());
  r.panel.chosen_by_prior = p.at("chosen_by_prior").get<bool>();
  r.phi_labels = labels_from_json(j.at("phi_labels"));
  r.column_labels = labels_from_json(j.at("column_labels"));
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
  r.success_criterion = j.at("success_criterion").get<bool>();
  r.phi_tunable = j.at("phi_tunable").get<std::vector<std::string>>();
  for (const auto& e : j.value("phi_value_labels", nlohmann::json::array()))
    r.phi_value_labels[e.at(0).get<double>()] = e.at(1).get<std::string>();
  return r;
}

}  // namespace

nlohmann::json task_record(const Experiment& e) {
  const TaskSetup& s = e.setup;
  nlohmann::json j = {{"state_names", s.state_names},
                      {"action_names", s.action_names},
                      {"state_extra_names", s.state_extra_names}};
  if (s.task) {
    j["observation_dim"] = s.task->observation_dim();
    j["horizon"] = s.task->horizon();
    j["dt"] = number(s.task->dt());
    nlohmann::json x0 = nlohmann::json::array();
    const VectorXd x = s.task->initial_state();
    for (Eigen::Index i = 0; i < x.size(); ++i) x0.push_back(number(x[i]));
    j["initial_state"] = x0;
  }
  if (s.policy) j["policy_parameters"] = s.policy->param_dim();
  if (e.uses_prior && !s.prior_parameters.names.empty()) {
    const auto& p = s.prior_parameters;
    nlohmann::json params = nlohmann::json::array();
    for (std::size_t i = 0; i < p.names.size(); ++i) {
      nlohmann::json q = {{"name", p.names[i]},
                          {"value", number(p.values[static_cast<Eigen::Index>(i)])}};
      const auto t = std::find(p.tunable.begin(), p.tunable.end(), static_cast<int>(i));
      q["tunable"] = t != p.tunable.end();
      if (t != p.tunable.end()) {
        const auto k = static_cast<Eigen::Index>(t - p.tunable.begin());
        q["lower"] = number(p.lower[k]);
        q["upper"] = number(p.upper[k]);
      }
      params.push_back(q);
    }
    j["prior_parameters"] = params;
  }
  for (const auto& [k, v] : s.declaration) j["declaration"][k] = v;
  return j;
}

nlohmann::json summary_head(const Experiment& e) {
  const auto& p = e.setup.prior_parameters;
  return {{"format_version", kRunDirectoryFormatVersion},
          {"task", e.task},
          {"algorithm", e.algorithm},
          {"model", e.variant},
          {"variant_style", style_json(e.variant_style)},
          {"uses_prior", e.uses_prior},
          {"uses_model", e.uses_model},
          {"prior", e.setup.prior_label},
          {"report", report_json(e.report)},
          {"seed", e.seed},
          {"episodes_planned", e.runner ? e.runner->episodes() : 0},
          {"phi_names", p.names},
          {"phi_actual", e.setup.phi_actual},
          {"state_names", e.setup.state_names},
          {"action_names", e.setup.action_names},
          {"task_record", task_record(e)},
          {"started", now_iso()},
          {"episodes", nlohmann::json::array()}};
}

namespace {

std::string os_reason(int err) { return std::strerror(err); }

// What a path that is not a regular file is, for messages.
std::string file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a file";
}

std::string size_text(std::uintmax_t bytes) {
  if (bytes >= (std::uintmax_t{1} << 20))
    return fmt::format("{:.4g} MiB", static_cast<double>(bytes) / (1 << 20));
  return fmt::format("{} bytes", bytes);
}

// Closes a file descriptor on every path out.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::string read_file_text(const fs::path& path, std::uintmax_t max_bytes) {
  Fd f;
  // O_NONBLOCK: opening a FIFO without a writer must not wait; the kind is checked next.
  f.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (f.fd < 0) throw Error("cannot read " + path.string() + ": " + os_reason(errno));
  struct stat st {};
  if (::fstat(f.fd, &st) != 0)
    throw Error("cannot read " + path.string() + ": " + os_reason(errno));
  if (!S_ISREG(st.st_mode))
    throw Error(path.string() + " is not a regular file (" + file_kind(st.st_mode) + ")");
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes)
    throw Error(fmt::format("{} is larger than drops reads ({}, at most {})", path.string(),
                            size_text(size), size_text(max_bytes)));
  std::string text;
  text.reserve(static_cast<std::size_t>(size));
  char buf[65536];
  while (true) {
    const ssize_t n = ::read(f.fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error("cannot read " + path.string() + ": " + os_reason(errno));
    }
    if (n == 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    // A file that grows while it is read stops at the limit too.
    if (text.size() > max_bytes)
      throw Error(fmt::format("{} is larger than drops reads (more than {})", path.string(),
                              size_text(max_bytes)));
  }
  return text;
}

std::string file_error(const std::string& what, const std::string& message) {
  const std::string prefix = "cannot read ";
  if (message.rfind(prefix, 0) == 0) return prefix + what + " " + message.substr(prefix.size());
  return what + " " + message;
}

void write_file_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    Fd f;
    f.fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (f.fd < 0) throw Error("cannot write " + tmp.string() + ": " + os_reason(errno));
    std::size_t done = 0;
    while (done < text.size()) {
      const ssize_t n = ::write(f.fd, text.data() + done, text.size() - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        throw Error("cannot write " + tmp.string() + ": " + os_reason(errno));
      }
      done += static_cast<std::size_t>(n);
    }
    const int fd = f.fd;
    f.fd = -1;
    if (::close(fd) != 0) throw Error("cannot write " + tmp.string() + ": " + os_reason(errno));
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
    : dir_(dir),
      experiment_(experiment),
      state_files_(experiment.state_files ? experiment.state_files() : nullptr) {}

RunDirectory::~RunDirectory() {
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

void RunDirectory::lock() {
  const fs::path p = dir_ / ".lock";
  lock_fd_ = ::open(p.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw Error("cannot open " + p.string() + ": " + os_reason(errno));
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0)
    throw RunDirectoryBusy("run directory " + dir_.string() + " is in use by another process");
}

RunDirectory::RunDirectory(const fs::path& dir, const std::string& config_yaml,
                           const Experiment& e)
    : RunDirectory(dir, e) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create run directory " + dir.string() + ": " + ec.message());
  // The lock first: a run that another process starts in the same directory at the same moment
  // then either finds it busy or finds its episodes.csv.
  lock();
  if (fs::exists(dir / "episodes.csv"))
    throw Error("run directory " + dir.string() +
                " already holds a run; choose another name=, remove it, or continue it with "
                "drops run --resume " + dir.string());
  start(config_yaml);
}

std::unique_ptr<RunDirectory> RunDirectory::create_unique(const fs::path& parent,
                                                          const std::string& name,
                                                          const std::string& config_yaml,
                                                          const Experiment& e) {
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error("cannot create the output directory " + parent.string() + ": " + ec.message());
  fs::path dir;
  for (int i = 1;; ++i) {
    dir = parent / (i == 1 ? name : fmt::format("{}-{}", name, i));
    if (::mkdir(dir.c_str(), 0777) == 0) break;  // this process owns the new directory
    if (errno != EEXIST || i >= 1000)
      throw Error("cannot create run directory " + dir.string() + ": " + std::strerror(errno));
  }
  std::unique_ptr<RunDirectory> rd(new RunDirectory(dir, e));
  rd->lock();
  rd->start(config_yaml);
  return rd;
}

void RunDirectory::start(const std::string& config_yaml) {
  std::error_code ec;
  fs::create_directories(dir_ / "episodes", ec);
  if (ec) throw Error("cannot create " + (dir_ / "episodes").string() + ": " + ec.message());
  write_file_atomically(dir_ / "config.yaml", config_yaml);
  episodes_csv_.open(dir_ / "episodes.csv", std::ios::trunc | std::ios::binary);
  if (!episodes_csv_)
    throw Error("cannot write " + (dir_ / "episodes.csv").string() + ": " + os_reason(errno));
  const Experiment& e = experiment_;
  std::string header =
      "episode,interaction_time_s,real_return,predicted_return,solved,phi,model_learning_s,"
      "policy_optimization_s,evaluations";
  for (const auto& m : e.setup.metric_names) header += "," + m;
  append_row(header + "\n");
  summary_ = summary_head(e);
  write_summary("running");
}

void RunDirectory::restart(const std::string& config_yaml) {
  // What a first episode that did not finish may have left: its files (written before its row),
  // the algorithm's side state (built before the first episode), the summary of the session.
  std::vector<std::string> files = {"episodes.csv", "summary.json"};
  if (state_files_)
    for (const auto& f : state_files_->file_names()) files.push_back(f);
  for (const auto& f : files) fs::remove(dir_ / f);
  std::error_code ec;
  fs::remove_all(dir_ / "episodes", ec);
  if (ec) throw Error("cannot remove " + (dir_ / "episodes").string() + ": " + ec.message());
  start(config_yaml);
  repairs_.push_back("no checkpoint.json and no finished episode: nothing was recorded, so the "
                     "run starts from its beginning (config.yaml) in this directory");
}

void RunDirectory::append_row(const std::string& row) {
  episodes_csv_ << row;
  episodes_csv_.flush();
  if (!episodes_csv_)
    throw Error("cannot write " + (dir_ / "episodes.csv").string() + ": " + os_reason(errno));
  episodes_csv_text_ += row;
}

void RunDirectory::record_status(const algo::Status& status) {
  if (!state_files_) return;
  const double seconds =
      previous_seconds_ +
      std::chrono::duration<double>(std::chrono::steady_clock::now() - opened_).count();
  state_files_->on_status(status, seconds, dir_);
}

void RunDirectory::record(const algo::EpisodeRecord& rec) {
  const TaskSetup& setup = experiment_.setup;
  if (rec.keep_trajectories) {
    const std::string folder = "episodes/" + episode_folder(rec.episode);
    std::error_code ec;
    fs::create_directories(dir_ / folder, ec);
    if (ec) throw Error("cannot create " + (dir_ / folder).string() + ": " + ec.message());
    auto write = [&](const char* file, const std::string& text) {
      const std::string rel = folder + "/" + file;
      write_file_atomically(dir_ / rel, text);
      file_sha256_[rel] = sha256_hex(text);
    };
    write("real.csv", trajectory_csv(rec.real, setup));
    if (rec.predicted.states.rows() > 0) write("predicted.csv", trajectory_csv(rec.predicted, setup));
    std::string theta;
    for (Eigen::Index i = 0; i < rec.theta.size(); ++i)
      theta += fmt::format("{:.17g}\n", rec.theta[i]);
    write("policy.csv", theta);
  }
  const std::vector<double> metrics = setup.metrics ? setup.metrics(rec) : std::vector<double>{};

  // No model predicted the episode (a random first policy, a direct search): an empty field, which
  // CSV readers take as missing (summary.json holds null).
  const std::string predicted = std::isfinite(rec.predicted_return)
                                    ? fmt::format("{:.6f}", rec.predicted_return)
                                    : std::string();
  std::string row = fmt::format("{},{:.3f},{:.6f},{},{},{},{:.3f},{:.3f},{}", rec.episode,
                                rec.interaction_time, rec.real_return, predicted,
                                rec.solved ? 1 : 0, phi_text(rec.phi), rec.model_seconds,
                                rec.policy_seconds, rec.evaluations);
  for (double m : metrics) row += fmt::format(",{:.6g}", m);
  append_row(row + "\n");

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
                      {"phi_screened_out", rec.model.phi_screened_out},
                      {"rprop_iterations", rec.model.rprop_iterations},
                      {"trajectories", rec.keep_trajectories}};
  // The real system returned a non-finite state: the episode ended at that step (never solved;
  // only the finite transitions before it are data).
  if (rec.real.nonfinite_step >= 0) e["nonfinite_real_step"] = rec.real.nonfinite_step;
  // How sure the model is of phi (GP-MI's Laplace approximation, model::PhiPosterior).
  if (const auto& post = rec.model.phi_posterior; !post.empty()) {
    const VectorXd sd = post.stddev();
    const MatrixXd c = post.correlation();
    nlohmann::json corr = nlohmann::json::array();
    for (Eigen::Index i = 0; i < c.rows(); ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (Eigen::Index j = 0; j < c.cols(); ++j) row.push_back(number(c(i, j)));
      corr.push_back(row);
    }
    nlohmann::json mean = nlohmann::json::array(), sds = nlohmann::json::array();
    for (Eigen::Index i = 0; i < sd.size(); ++i) {
      mean.push_back(number(post.mean[i]));
      sds.push_back(number(sd[i]));
    }
    e["phi_posterior"] = {{"names", post.names}, {"mean", mean}, {"sd", sds}, {"correlation", corr}};
  }
  // The phi samples the rollouts used (model.gp_mi.rollout_phi: posterior).
  if (const auto& ps = rec.model.phi_sampling; ps.samples > 0)
    e["phi_samples"] = {{"samples", ps.samples}, {"clamped", ps.clamped}, {"rejected", ps.rejected}};
  // Where the real return fell in the model's predictive distribution of it.
  // The rollouts' returns are kept so that any other band can be computed from summary.json.
  if (const auto c = algo::calibration(rec)) {
    nlohmann::json returns = nlohmann::json::array();
    for (const double r : rec.predicted_returns) returns.push_back(number(r));
    e["calibration"] = {{"quantile", c->quantile},
                        {"band", {c->band_low, c->band_high}},
                        {"inside_band", c->inside_band},
                        {"gap", c->gap},
                        {"replay", rec.replay},
                        {"predicted_returns", returns}};
  }
  if (rec.random_policy) {
    e["policy_search"] = "random";
  } else if (!rec.policy_search.runs.empty()) {
    e["policy_search"] = rec.policy_search.BriefReport();
    // Each CMA-ES run and the selection.
    e["policy_search_runs"] = runs_json(rec.policy_search);
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
  p["complete"] = phase.complete;
  summary_["phases"][phase.name] = p;
  write_summary("running");
}

void RunDirectory::save_state(const algo::RunState& st) {
  // The side state first (its files carry their own progress), then the checkpoint.
  if (state_files_ && state_files_->save(st.side_state, dir_, &summary_)) write_summary("running");
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
  // What the checkpoint covers, checked by reopen(): the configuration and the recorded files.
  nlohmann::json files = nlohmann::json::object();
  files["episodes.csv"] = sha256_hex(episodes_csv_text_);
  files["summary.json"] = sha256_hex(summary_["episodes"].dump());
  for (const auto& [rel, sha] : file_sha256_) files[rel] = sha;
  nlohmann::json config = nlohmann::json::object();
  for (const auto& [k, v] : experiment_.settings) config[k] = v;
  nlohmann::json j = {{"format_version", kRunDirectoryFormatVersion},
                      {"algorithm", experiment_.algorithm},
                      {"seed", experiment_.seed},
                      {"model_type", experiment_.variant},
                      {"episodes_done", st.episodes_done},
                      {"best_theta", to_std(st.best_theta)},
                      {"best_return", number(st.best_return)},
                      {"first_solved_episode", st.first_solved_episode},
                      {"model", {{"phi", to_std(st.model.phi)}, {"h_params", h}}},
                      {"extra", extra},
                      {"data", {{"x", data_x}, {"u", data_u}, {"dx", data_dx}}},
                      {"validation",
                       {{"config", config},
                        {"sha256", files},
                        {"task", task_record(experiment_)}}}};
  // nlohmann writes the shortest decimal form that reads back to the same double, so the
  // checksum of the file read back and dumped again is this one.
  j["checksum"] = checkpoint_checksum(j);
  write_file_atomically(dir_ / "checkpoint.json", j.dump() + "\n");
  has_checkpoint_ = true;
}

namespace {

/// checkpoint.json parsed, its format version and its checksum checked.
nlohmann::json read_checkpoint_json(const fs::path& dir) {
  const fs::path cp = dir / "checkpoint.json";
  if (!fs::exists(cp)) throw Error("run " + dir.string() + " has no checkpoint.json");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file_text(cp));
  } catch (const nlohmann::json::exception& e) {
    throw RunDirectoryDamaged(cp.string() + " cannot be parsed (" + e.what() +
                              "): the file is damaged (drops replaces it atomically, so a crash "
                              "does not cut it); the run cannot be continued, start it again");
  }
  check_format_version(j, cp);
  if (!j.contains("checksum") || !j["checksum"].is_string() || !j.contains("validation"))
    throw RunDirectoryDamaged(cp.string() +
                              " lacks its checksum or validation block: the file "
                              "was edited; the run cannot be continued safely (start it again)");
  if (j["checksum"].get<std::string>() != checkpoint_checksum(j))
    throw RunDirectoryDamaged(cp.string() +
                              " does not match its own checksum: the file was edited or damaged "
                              "after drops wrote it; the run cannot be continued safely (restore "
                              "the file or start the run again)");
  return j;
}

algo::RunState state_from_json(const nlohmann::json& j, const fs::path& cp) {
  try {
    algo::RunState st;
    st.episodes_done = j.at("episodes_done").get<int>();
    st.best_theta = to_eigen(j.at("best_theta"), "best_theta");
    // null: no episode yet (-inf, which JSON cannot hold: a state saved before the first episode,
    // during IT&E's archive or after PILCO with priors' simulation phase)
    st.best_return = j.at("best_return").is_null() ? -std::numeric_limits<double>::infinity()
                                                   : j.at("best_return").get<double>();
    st.first_solved_episode = j.at("first_solved_episode").get<int>();
    st.model.phi = to_eigen(j.at("model").at("phi"), "model.phi");
    for (const auto& h : j.at("model").at("h_params"))
      st.model.h_params.push_back(to_eigen(h, "h_params"));
    for (const auto& [k, v] : j.at("extra").items()) st.extra[k] = to_eigen(v, "extra." + k);
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
    // 0 only for a state saved before the first real episode: with an archive (IT&E; reopen
    // checks it) or after a phase (PILCO with priors' simulation phase).
    if (st.episodes_done < 0)
      throw Error(cp.string() + ": episodes_done = " + std::to_string(st.episodes_done) +
                  " (a checkpoint is written after an episode, a phase, or with IT&E's archive)");
    return st;
  } catch (const nlohmann::json::exception& e) {
    throw Error(cp.string() + " is malformed: " + e.what());
  } catch (const Error& e) {
    const std::string what = e.what();
    // to_eigen's messages start with "checkpoint.json:"; name the full path.
    if (what.rfind("checkpoint.json:", 0) == 0)
      throw Error(cp.string() + what.substr(std::string("checkpoint.json").size()));
    throw;
  }
}

/// Whether the dotted key is in the document with no value (~ or empty).
bool left_empty(const YAML::Node& node, const std::string& dotted) {
  if (!node.IsMap()) return false;
  const auto dot = dotted.find('.');
  const YAML::Node child = node[dotted.substr(0, dot)];
  if (!child) return false;
  if (dot == std::string::npos)
    return child.IsNull() || (child.IsScalar() && child.Scalar().empty());
  return left_empty(child, dotted.substr(dot + 1));
}

/// The configuration the run was started with (checkpoint.json) against config.yaml as it is now
/// (its text) and the experiment resolved from it.
void check_config(const fs::path& dir, const nlohmann::json& started, const std::string& text,
                  const Settings& now) {
  const fs::path file = dir / "config.yaml";
  std::set<std::string> keys, present;
  for (const auto& [k, v] : started.items()) keys.insert(k);
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
    yaml_keys(doc, "", keys, present);
  } catch (const YAML::Exception& e) {
    throw RunDirectoryDamaged(file.string() + " cannot be parsed: " + e.what());
  }
  for (const auto& [k, v] : started.items()) {
    const std::string value = v.is_string() ? v.get<std::string>() : v.dump();
    if (!present.count(k))
      throw RunDirectoryDamaged(
          file.string() + " lacks the key '" + k + "' (the run was started with " + k + ": " +
          (value.empty() ? "\"\"" : value) +
          "): the file was cut or edited; restore it (checkpoint.json holds the run's "
          "configuration under validation.config) or start the run again");
    if (kResumeKeys.count(k)) continue;
    // Started empty and still left empty in config.yaml: the key's default, then as now (a run
    // started when an empty value stood for the task's choice).
    if (value.empty() && left_empty(doc, k)) continue;
    const auto it = now.find(k);
    const std::string current = it == now.end() ? std::string("(absent)") : it->second;
    if (it == now.end() || !same_setting_value(current, value))
      throw ConfigError(file.string() + ": key '" + k + "' is '" + current +
                        "', but the run was started with '" + value +
                        "' (checkpoint.json): a resumed run keeps its configuration (only "
                        "episodes and threads may change); restore the value or start a new run");
  }
}

// The members of two JSON objects that differ, each as "<key> <value there> in the run, <value
// here> now"; the object "declaration" is compared member by member.
void object_differences(const nlohmann::json& recorded, const nlohmann::json& now,
                        std::vector<std::string>& diffs) {
  const auto brief = [](const nlohmann::json& v) {
    std::string s = v.is_null() ? std::string("(none)") : v.dump();
    return s.size() > 120 ? s.substr(0, 120) + "..." : s;
  };
  std::set<std::string> keys;
  for (const auto& [k, v] : recorded.items()) keys.insert(k);
  for (const auto& [k, v] : now.items()) keys.insert(k);
  for (const auto& k : keys) {
    const nlohmann::json a = recorded.contains(k) ? recorded[k] : nlohmann::json();
    const nlohmann::json b = now.contains(k) ? now[k] : nlohmann::json();
    if (a == b) continue;
    if (k == "declaration" && a.is_object() && b.is_object())
      object_differences(a, b, diffs);
    else
      diffs.push_back(k + " " + brief(a) + " in the run, " + brief(b) + " now");
  }
}

/// Throws ConfigError listing what the robot of a resumed run declares differently from the run's
/// record (checkpoint.json's validation.task), each item with both values.
void check_task_record(const fs::path& cp_path, const nlohmann::json& recorded,
                       const nlohmann::json& now) {
  std::vector<std::string> diffs;
  object_differences(recorded, now, diffs);
  if (diffs.empty()) return;
  std::string list;
  for (const auto& d : diffs) list += (list.empty() ? "" : "; ") + d;
  throw ConfigError("the robot differs from the run's (" + cp_path.string() +
                    ", validation.task): " + list +
                    ". A run continues with the robot it was started with; start a new run for "
                    "another one");
}

/// Splits text after its first `lines` complete lines (each ending in '\n'); returns how many
/// complete lines it found (at most `lines`) and sets *end to the offset after the last of them.
int complete_lines(const std::string& text, int lines, std::size_t* end) {
  std::size_t pos = 0;
  int found = 0;
  while (found < lines) {
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) break;
    pos = nl + 1;
    ++found;
  }
  *end = pos;
  return found;
}

/// Finished episodes recorded in run directory `dir`: the whole rows of episodes.csv after its
/// header, or the entries of summary.json's "episodes" when it lists more (0 when neither file
/// holds one; a row cut mid-line by a crash is not a finished episode).
int recorded_episodes(const fs::path& dir) {
  int n = 0;
  if (fs::exists(dir / "episodes.csv")) {
    std::size_t end = 0;
    n = std::max(complete_lines(read_file_text(dir / "episodes.csv"), INT_MAX, &end) - 1, 0);
  }
  if (fs::exists(dir / "summary.json")) {
    try {
      const auto j = nlohmann::json::parse(read_file_text(dir / "summary.json"));
      if (j.is_object() && j.contains("episodes") && j["episodes"].is_array())
        n = std::max(n, static_cast<int>(j["episodes"].size()));
    } catch (const nlohmann::json::exception&) {
      // unreadable: episodes.csv alone says what was recorded
    }
  }
  return n;
}

}  // namespace

algo::RunState read_checkpoint(const fs::path& dir) {
  const nlohmann::json j = read_checkpoint_json(dir);
  return state_from_json(j, dir / "checkpoint.json");
}

void check_run_directory_format(const fs::path& dir) {
  for (const char* name : {"summary.json", "checkpoint.json"}) {
    const fs::path file = dir / name;
    if (!fs::exists(file)) continue;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_file_text(file));
    } catch (const nlohmann::json::exception&) {
      continue;  // damaged, not of another format: the reader that needs the file says so
    }
    check_format_version(j, file);
  }
}

std::unique_ptr<RunDirectory> RunDirectory::reopen(const fs::path& dir, const Experiment& e,
                                                   const std::string& config_yaml,
                                                   algo::RunState* state) {
  if (dir.empty()) throw Error("--resume needs the run directory to continue, got an empty path");
  std::unique_ptr<RunDirectory> rd(new RunDirectory(dir, e));
  if (!fs::is_directory(dir)) throw Error(dir.string() + " is not a run directory (no such directory)");
  if (!fs::exists(dir / "config.yaml"))
    throw Error(dir.string() + " is not a run directory (no config.yaml)");
  rd->lock();
  if (!e.runner->resumable())
    throw Error("run " + dir.string() + ": algorithm '" + e.algorithm +
                "' cannot be resumed; start it again");
  const fs::path cp_path = dir / "checkpoint.json";
  if (!fs::exists(cp_path)) {
    // No checkpoint: either no episode finished (the run was stopped or killed before its first
    // checkpoint), so nothing was recorded and the run starts from its beginning here; or the
    // file was deleted, and the recorded episodes cannot be continued without the state it held.
    // They are kept: the directory is left as it is.
    const int recorded = recorded_episodes(dir);
    if (recorded > 0)
      throw RunDirectoryDamaged(fmt::format(
          "{} is missing, although {} recorded in {}: the run cannot be continued without it "
          "(it holds the algorithm's state after the last finished episode); the recorded "
          "episodes are kept as they are. Restore checkpoint.json to continue the run, or start "
          "a new run under another name",
          cp_path.string(),
          recorded == 1 ? std::string("1 episode is") : fmt::format("{} episodes are", recorded),
          dir.string()));
    rd->restart(config_yaml);
    return rd;
  }
  // A run directory of another format version is refused before anything else is read.
  check_run_directory_format(dir);
  const nlohmann::json cp = read_checkpoint_json(dir);
  *state = state_from_json(cp, cp_path);
  const std::string algorithm = cp.value("algorithm", std::string());
  const std::string model_type = cp.value("model_type", std::string());
  const std::uint64_t seed = cp.value("seed", std::uint64_t{0});
  if (seed != e.seed || algorithm != e.algorithm || model_type != e.variant)
    throw RunDirectoryDamaged(
        cp_path.string() + " does not belong to the run's config.yaml (seed, algorithm or model " +
        "differ: " +
        fmt::format("{} {} seed {} there, {} {} seed {} in config.yaml", algorithm, model_type,
                    seed, e.algorithm, e.variant, e.seed) +
        ")");
  const int k = state->episodes_done;
  const nlohmann::json sha = cp["validation"].value("sha256", nlohmann::json::object());
  auto recorded_sha = [&](const std::string& rel) {
    return sha.contains(rel) && sha[rel].is_string() ? sha[rel].get<std::string>() : std::string();
  };

  // Every check comes before any change, so that a refused resume leaves the directory as it was.
  // 1. The configuration.
  const fs::path config_path = dir / "config.yaml";
  const std::string config_text = read_file_text(config_path);
  check_config(dir, cp["validation"].value("config", nlohmann::json::object()), config_text,
               e.settings);
  // The robot: a run recorded before drops recorded it (no validation.task) is not compared.
  if (cp["validation"].contains("task"))
    check_task_record(cp_path, cp["validation"]["task"], task_record(e));
  if (e.runner->episodes() < k)
    throw ConfigError(fmt::format(
        "{}: episodes = {}, but the run has already done {} episodes (checkpoint.json); a resumed "
        "run keeps or extends its episode count",
        config_path.string(), e.runner->episodes(), k));

  // 2. episodes.csv: the header and rows 1..k as recorded; anything after them is not covered.
  const fs::path csv_path = dir / "episodes.csv";
  if (!fs::exists(csv_path))
    throw RunDirectoryDamaged(csv_path.string() + " is missing, but checkpoint.json covers " +
                              plural(static_cast<std::size_t>(k), "episode") +
                              ": restore the file or start the run again");
  const std::string csv = read_file_text(csv_path);
  std::size_t covered_end = 0;
  const int lines = complete_lines(csv, k + 1, &covered_end);
  if (lines < k + 1)
    throw RunDirectoryDamaged(fmt::format(
        "{} holds {} complete rows, but checkpoint.json covers {} episodes: the file was cut or "
        "edited after episode {} was recorded; restore it or start the run again",
        csv_path.string(), std::max(lines - 1, 0), k, k));
  const std::string covered = csv.substr(0, covered_end);
  if (sha256_hex(covered) != recorded_sha("episodes.csv"))
    throw RunDirectoryDamaged(fmt::format(
        "{}: its header and rows 1-{} differ from what drops recorded (checksum in "
        "checkpoint.json): the file was edited or damaged; restore it or start the run again",
        csv_path.string(), k));
  const std::string after = csv.substr(covered_end);
  if (!after.empty()) {
    const auto n = static_cast<std::size_t>(std::count(after.begin(), after.end(), '\n') +
                                            (after.back() != '\n'));
    rd->repairs_.push_back(fmt::format(
        "removed {} of episodes.csv after episode {}: checkpoint.json does not cover {} (recorded "
        "after the last checkpoint{})",
        plural(n, "line"), k, n == 1 ? "it" : "them",
        after.back() != '\n' ? ", the last one cut mid-line by a crash" : ""));
  }

  // 3. summary.json: the records of episodes 1..k as written.
  const fs::path summary_path = dir / "summary.json";
  if (!fs::exists(summary_path))
    throw RunDirectoryDamaged(summary_path.string() + " is missing, but checkpoint.json covers " +
                              plural(static_cast<std::size_t>(k), "episode") +
                              ": restore the file or start the run again");
  nlohmann::json summary;
  try {
    summary = nlohmann::json::parse(read_file_text(summary_path));
  } catch (const std::exception& ex) {
    throw RunDirectoryDamaged(summary_path.string() + " cannot be parsed (" + ex.what() +
                              "): restore the file or start the run again");
  }
  nlohmann::json eps = nlohmann::json::array();
  int later_entries = 0;
  if (!summary.is_object() || !summary.contains("episodes") || !summary["episodes"].is_array())
    throw RunDirectoryDamaged(summary_path.string() +
                              " has no \"episodes\" list: restore the file or start the run again");
  for (const auto& ep : summary["episodes"]) {
    if (!ep.is_object() || !ep.contains("episode") || !ep["episode"].is_number_integer() ||
        !ep.contains("solved") || !ep["solved"].is_boolean())
      throw RunDirectoryDamaged(summary_path.string() + ": an entry of \"episodes\" lacks its "
                                "episode number or solved flag: " + ep.dump());
    if (ep["episode"].get<int>() <= k)
      eps.push_back(ep);
    else
      ++later_entries;
  }
  bool in_order = static_cast<int>(eps.size()) == k;
  for (int i = 0; in_order && i < k; ++i) in_order = eps[i]["episode"].get<int>() == i + 1;
  if (!in_order)
    throw RunDirectoryDamaged(fmt::format(
        "{} records {} of episodes 1-{}, not each once in order, but checkpoint.json covers {}: "
        "the file was edited or damaged; restore it or start the run again",
        summary_path.string(), plural(eps.size(), "entry"), k, k));
  if (sha256_hex(eps.dump()) != recorded_sha("summary.json"))
    throw RunDirectoryDamaged(fmt::format(
        "{}: the records of episodes 1-{} differ from what drops recorded (checksum in "
        "checkpoint.json): the file was edited or damaged; restore it or start the run again",
        summary_path.string(), k));
  if (later_entries > 0)
    rd->repairs_.push_back(fmt::format(
        "removed {} of summary.json after episode {} (recorded after the last checkpoint)",
        plural(static_cast<std::size_t>(later_entries), "episode entry"), k));

  // 4. episodes/NNN: the files of episodes 1..k as written; folders of later episodes go.
  for (const auto& [rel, value] : sha.items()) {
    if (rel.rfind("episodes/", 0) != 0) continue;
    const fs::path f = dir / rel;
    if (!fs::exists(f))
      throw RunDirectoryDamaged(f.string() +
                                " is missing, but checkpoint.json covers it: "
                                "restore the file or start the run again");
    if (sha256_hex(read_file_text(f)) != value.get<std::string>())
      throw RunDirectoryDamaged(f.string() +
                                " differs from what drops recorded (checksum in "
                                "checkpoint.json): the file was edited or damaged; restore it "
                                "or start the run again");
    rd->file_sha256_[rel] = value.get<std::string>();
  }
  // 5. The algorithm's side state (IT&E's archive), checked by its own reader: it is not among
  // the checksums, since it is written before checkpoint.json and may be newer than it.
  const bool side =
      rd->state_files_ && rd->state_files_->load(dir, &state->side_state, &rd->repairs_);
  if (!side && k == 0 && !(summary.contains("phases") && !summary["phases"].empty())) {
    // Before the first real episode a checkpoint holds a side state (IT&E's archive) or follows
    // a phase (PILCO with priors' simulation, recorded in summary.json "phases").
    const bool has_files = rd->state_files_ && !rd->state_files_->file_names().empty();
    throw RunDirectoryDamaged(
        cp_path.string() + " covers no episode and " +
        (has_files ? (dir / rd->state_files_->file_names().front()).string() + " is missing"
                   : std::string("no phase is recorded")) +
        ": restore the file or start the run again");
  }

  std::vector<fs::path> later_folders;
  if (fs::exists(dir / "episodes"))
    for (const auto& entry : fs::directory_iterator(dir / "episodes"))
      if (std::atoi(entry.path().filename().c_str()) > k) later_folders.push_back(entry.path());

  // Every check passed: repair and continue.
  if (!after.empty()) write_file_atomically(csv_path, covered);
  for (const auto& f : later_folders) fs::remove_all(f);
  if (!later_folders.empty())
    rd->repairs_.push_back(fmt::format("removed {} of episodes/ after episode {} (written after "
                                       "the last checkpoint)",
                                       plural(later_folders.size(), "folder"), k));
  summary["episodes"] = eps;
  summary.erase("first_solved_episode");
  for (const auto& ep : eps)
    if (ep["solved"].get<bool>()) {
      summary["first_solved_episode"] = ep["episode"];
      break;
    }
  summary["episodes_planned"] = e.runner->episodes();
  summary.erase("finished");
  summary.erase("error");
  if (!summary.contains("resumed") || !summary["resumed"].is_array())
    summary["resumed"] = nlohmann::json::array();
  summary["resumed"].push_back(now_iso());
  if (summary.contains("seconds") && summary["seconds"].is_number())
    rd->previous_seconds_ = summary["seconds"].get<double>();
  rd->summary_ = summary;
  // config.yaml says what this session runs (a new episode count, threads): `drops run
  // DIR/config.yaml` then repeats the run as it ends.
  if (config_text != config_yaml) write_file_atomically(config_path, config_yaml);
  rd->episodes_csv_text_ = covered;
  rd->episodes_csv_.open(csv_path, std::ios::app | std::ios::binary);
  if (!rd->episodes_csv_) throw Error("cannot append to " + csv_path.string());
  rd->has_checkpoint_ = true;
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
    summary_["search"] = {{"summary", s.search.BriefReport()},
                          {"runs", runs_json(s.search)},
                          {"restarts", s.search.restarts},
                          {"start_return", number(-s.search.start_value)},
                          {"best_theta", to_std(s.search.best_x)}};
  }
  if (!s.details.empty()) summary_["details"] = details_json(s.details);
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
      config = load_settings_file(*registry, (dir / "config.yaml").string(), {});
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
    run.variant_style = algorithm.variant_style(config);
    run.uses_prior = algorithm.uses_prior(config);
    run.uses_model = algorithm.uses_model(config);
    const TaskPlugin& task = registry->task(run.task);
    run.prior = task.prior_label(config);
    run.report = task.report_info(config);
    for (const auto& k : task.keys()) {
      if (!run.uses_prior && task.is_prior_key(k.key)) continue;
      std::string v = config.at(k.key);
      if (k.type == "double" || k.type == "int") {  // 3 and 3.0 are one setting
        try {
          std::size_t used = 0;
          const double x = std::stod(v, &used);
          if (used == v.size()) v = fmt::format("{}", x);
        } catch (const std::exception&) {
        }
      }
      run.task_settings[k.key] = v;
    }
    try {
      run.seed = static_cast<std::int64_t>(base_options(config).black_drops.seed);
    } catch (const std::exception&) {
    }
  }

  const fs::path summary_path = dir / "summary.json";
  if (!fs::exists(summary_path)) {
    run.status = "not started";
  } else {
    try {
      const nlohmann::json s = nlohmann::json::parse(read_file_text(summary_path));
      check_format_version(s, summary_path);
      run.status = s.value("status", std::string("running"));
      run.error = s.value("error", std::string());
      if (run.task.empty()) run.task = s.value("task", std::string());
      if (run.algorithm.empty()) run.algorithm = s.value("algorithm", std::string());
      if (run.model_type.empty()) run.model_type = s.value("model", std::string());
      if (s.contains("variant_style") && s["variant_style"].is_object())
        run.variant_style = style_from_json(s["variant_style"], run.variant_style);
      if (!have_config) {
        run.uses_prior = s.at("uses_prior").get<bool>();
        run.uses_model = s.at("uses_model").get<bool>();
      }
      if (run.prior.empty()) run.prior = s.value("prior", std::string());
      run.report = report_from_json(s.at("report"));
      if (run.report.panel.label.empty()) run.report.panel.label = run.prior;
      if (run.seed < 0 && s.contains("seed") && s["seed"].is_number_integer())
        run.seed = s["seed"].get<std::int64_t>();
      run.episodes_planned = s.value("episodes_planned", 0);
      if (s.contains("phi_names")) run.phi_names = s["phi_names"].get<std::vector<std::string>>();
      if (s.contains("phi_actual"))
        for (const auto& v : s["phi_actual"])
          run.phi_actual.push_back(v.is_number() ? v.get<double>() : kNaN);
      run.state_names = s.at("state_names").get<std::vector<std::string>>();
      run.action_names = s.at("action_names").get<std::vector<std::string>>();
      if (s.contains("task_record") && s["task_record"].contains("declaration")) {
        const auto& d = s["task_record"]["declaration"];
        if (d.contains("data.transitions") && d["data.transitions"].is_string()) {
          run.recorded_transitions = std::atoi(d["data.transitions"].get<std::string>().c_str());
          run.first_episode_on_recorded_data =
              d.value("data.keep_first_episode", std::string("false")) != "true";
        }
      }
      static const std::vector<std::string> kEpisodeKeys = {
          "episode", "interaction_time_s", "real_return", "predicted_return", "solved",
          "random_policy", "phi", "model_learning_s", "policy_optimization_s", "evaluations",
          "nonfinite_model_steps", "nonfinite_prior_outputs", "phi_evaluations",
          "phi_screened_out", "rprop_iterations", "trajectories", "policy_search", "policy_search_runs",
          "policy_selection", "calibration", "phi_posterior", "phi_samples"};
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
        if (e.contains("phi_posterior") && e["phi_posterior"].is_object()) {
          const auto& p = e["phi_posterior"];
          ep.posterior_names = p.value("names", std::vector<std::string>{});
          for (const auto& v : p.value("sd", nlohmann::json::array()))
            ep.posterior_sd.push_back(v.is_number() ? v.get<double>() : kNaN);
          for (const auto& row : p.value("correlation", nlohmann::json::array())) {
            std::vector<double> r;
            for (const auto& v : row) r.push_back(v.is_number() ? v.get<double>() : kNaN);
            ep.posterior_correlation.push_back(std::move(r));
          }
        }
        if (e.contains("calibration") && e["calibration"].is_object()) {
          const auto& c = e["calibration"];
          ep.has_calibration = true;
          ep.calibration_quantile = number_or_nan(c, "quantile");
          ep.inside_band = c.value("inside_band", false);
          ep.gap = number_or_nan(c, "gap");
          ep.replay = c.value("replay", false);
        }
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
  // A run not started yet has config.yaml's task report only: give it a run's panel (a no-op for
  // summary.json's, which is a run's already).
  run.report = run_report_info(std::move(run.report), run.uses_prior, run.uses_model);

  run.variant = run.model_type;
  if (run.recorded_transitions > 0) run.variant += " + recorded data";
  return run;
}

int TrajectoryTable::column(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

TrajectoryTable read_trajectory_csv(const fs::path& path) {
  std::istringstream in(read_file_text(path));
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

fs::path episode_dir(const fs::path& run_dir, int episode) {
  return run_dir / "episodes" / episode_folder(episode);
}

std::vector<double> read_policy_csv(const fs::path& path) {
  std::istringstream in(read_file_text(path));
  std::vector<double> theta;
  std::string line;
  int row = 0;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty()) continue;
    double v = kNaN;
    try {
      std::size_t used = 0;
      v = std::stod(line, &used);
      if (used != line.size()) throw std::invalid_argument(line);
    } catch (const std::exception&) {
      throw Error(fmt::format("{} line {}: '{}' is not a number", path.string(), row, line));
    }
    theta.push_back(v);
  }
  if (theta.empty())
    throw Error(path.string() + " holds no value (a policy file has one per line)");
  return theta;
}

}  // namespace drops::experiment
