// `drops report CAMPAIGN_DIR` and `drops plot RUN_DIR`: run directories read back, a campaign
// aggregated into tables (CSV, Markdown), figures drawn by python/drops_plot.py (matplotlib).
#include "command.hpp"
#include "drops/experiment/report.hpp"
#include "figures.hpp"

#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>

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

#include "drops/core/errors.hpp"
#include "drops/experiment/archive_file.hpp"

extern char** environ;

namespace drops::app {
namespace fs = std::filesystem;
using namespace drops::experiment;

namespace {

// ---------- running python/drops_plot.py ----------

/// DROPS_PYTHON_DIR, else the installed share/drops/python next to the program, else the
/// sources' python/ folder (a build tree).
fs::path python_dir() {
  const char* env = std::getenv("DROPS_PYTHON_DIR");
  if (env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / DROPS_INSTALL_DATADIR / "drops" /
                               "python";
    if (fs::exists(installed / "drops_plot.py", ec)) return installed;
  }
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


}  // namespace

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
  // The task's metric (e.g. a walking speed) in its own table and figure.
  ReportMetric metric;
  for (const auto& g : report.groups)
    if (g.has_metric() && metric.name.empty()) metric = g.report.metric;
  const std::string stem = metric.file.empty() ? metric.name : metric.file;
  const bool with_metric =
      !metric.name.empty() && write_metric_csv(report, out_dir / (stem + ".csv"));
  if (with_metric) files.push_back(out_dir / (stem + ".csv"));
  const bool with_calibration = write_calibration_csv(report, out_dir / "calibration.csv");
  if (with_calibration) files.push_back(out_dir / "calibration.csv");
  if (figures) {
    try {
      run_plot_script({"report", (out_dir / "returns.csv").string(),
                       (out_dir / "returns.png").string(), "--ylabel", "return"},
                      "drops report");
      files.push_back(out_dir / "returns.png");
      if (with_metric) {
        run_plot_script({"report", (out_dir / (stem + ".csv")).string(),
                         (out_dir / (stem + ".png")).string(), "--ylabel",
                         (metric.label.empty() ? metric.name : metric.label) +
                             (metric.unit.empty() ? "" : " (" + metric.unit + ")")},
                        "drops report");
        files.push_back(out_dir / (stem + ".png"));
      }
      if (with_calibration) {
        run_plot_script({"calibration", (out_dir / "calibration.csv").string(),
                         (out_dir / "calibration.png").string()},
                        "drops report");
        files.push_back(out_dir / "calibration.png");
      }
    } catch (const Error& e) {
      throw Error(fmt::format("{} (the tables are written in {})", e.what(), out_dir.string()));
    }
  }
  return files;
}

std::vector<fs::path> plot_identify(const fs::path& dir) {
  run_plot_script({"identify", dir.string()}, "drops identify");
  std::vector<fs::path> drawn;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".png") drawn.push_back(e.path());
  std::sort(drawn.begin(), drawn.end());
  return drawn;
}

void plot_archive(const fs::path& archive_csv, const fs::path& output_png) {
  experiment::read_archive_file(archive_csv);  // a clear error for a file that is not one
  if (!output_png.parent_path().empty()) create_output_dir(output_png.parent_path());
  run_plot_script({"archive", archive_csv.string(), output_png.string()}, "drops plot");
}

std::vector<fs::path> plot_run(const Registry& registry, const fs::path& run_dir,
                               const std::string& episodes_text, const fs::path& out_dir) {
  if (!fs::is_directory(run_dir))
    throw ConfigError("run directory '" + run_dir.string() + "' does not exist");
  const RunResult run = read_run(run_dir, &registry);
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
    if (!fs::exists(real))
      throw Error("missing " + real.string() +
                  " (a direct search keeps the trajectories of its improvements only)");
  }
  create_output_dir(out_dir);
  const fs::path data = out_dir / "plot-data.json";
  write_plot_data(run, episodes, data);
  run_plot_script({"run", data.string(), out_dir.string()}, "drops plot");
  if (fs::exists(run_dir / "archive.csv"))  // an IT&E run's MAP-Elites archive
    plot_archive(run_dir / "archive.csv", out_dir / "archive.png");
  std::vector<fs::path> files = {data};
  for (const auto& e : fs::directory_iterator(out_dir))
    if (e.path().extension() == ".png") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

namespace {

struct ReportArgs {
  std::string campaign_dir;
  std::string output;
  bool no_figures = false;
};

int report_main(const Registry& registry, const ReportArgs& args) {
  const CampaignReport report = aggregate_campaign(registry, args.campaign_dir);
  for (const auto& r : report.runs)
    if (r.status == "unreadable")
      fmt::print(stderr, "drops report: warning: {} is unreadable ({}); left out\n", r.dir.string(),
                 r.error);
  for (const auto& key : report.split_settings)
    fmt::print(stderr,
               "drops report: note: runs of one panel and variant differ in {0}: their groups are "
               "split by its value (variants \"<variant> {0}=<value>\")\n",
               key);
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

int plot_main(const Registry& registry, const PlotArgs& args) {
  if (fs::is_regular_file(args.run_dir)) {  // an archive file (IT&E)
    const fs::path png = args.output.empty() ? fs::path(args.run_dir).replace_extension(".png")
                                             : fs::path(args.output);
    plot_archive(args.run_dir, png);
    fmt::print("drops plot: {}\n  {}\n", args.run_dir, png.string());
    return 0;
  }
  const fs::path out =
      args.output.empty() ? fs::path(args.run_dir) / "plots" : fs::path(args.output);
  const std::vector<fs::path> files = plot_run(registry, args.run_dir, args.episodes, out);
  fmt::print("drops plot: {}\n", args.run_dir);
  for (const auto& f : files) fmt::print("  {}\n", f.string());
  return 0;
}

}  // namespace

void add_report_command(CLI::App& app, Action& action, const Registry& registry) {
  auto args = std::make_shared<ReportArgs>();
  auto* sub = app.add_subcommand(
      "report",
      "Aggregate a campaign: summary.csv, returns.csv, phi.csv, report.md and returns.png "
      "(median return with the 25-75 % band per panel and variant; see docs/reports.md)");
  sub->add_option("CAMPAIGN_DIR", args->campaign_dir,
                  "campaign directory written by drops campaign (holds runs/), or a folder of run "
                  "directories")
      ->required();
  sub->add_option("--output,-o", args->output, "where to write (default CAMPAIGN_DIR/report)");
  sub->add_flag("--no-figures", args->no_figures, "tables only: do not run python/matplotlib");
  sub->callback([&action, &registry, args] {
    action = [&registry, args] { return report_main(registry, *args); };
  });
}

void add_plot_command(CLI::App& app, Action& action, const Registry& registry) {
  auto args = std::make_shared<PlotArgs>();
  auto* sub = app.add_subcommand(
      "plot",
      "Figures of one run: returns.png, phi.png, trajectories-NNN.png (real vs predicted) and "
      "the task's metric (e.g. a walking speed), a body path and a gait diagram when the "
      "trajectories hold body positions and foot heights, and archive.png for an IT&E run; "
      "given an archive file (e.g. a run's archive.csv), only its figure");
  sub->add_option("RUN_DIR", args->run_dir,
                  "run directory written by drops run, or an IT&E archive file")
      ->required();
  sub->add_option("--episodes", args->episodes,
                  "episodes whose trajectories to draw, e.g. 1,5,10 (default: the first solved "
                  "and the last)");
  sub->add_option("--output,-o", args->output,
                  "where to write (default RUN_DIR/plots; for an archive file, the PNG file, "
                  "default the archive's name with .png)");
  sub->callback([&action, &registry, args] {
    action = [&registry, args] { return plot_main(registry, *args); };
  });
}

}  // namespace drops::app
