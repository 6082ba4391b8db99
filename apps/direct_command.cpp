// `drops direct`: the policy optimized directly on the "real" system by BIPOP-CMA-ES, each
// evaluation one real episode, no model. Not the paper's method: with a large budget it gives the
// ceiling of what the policy family achieves on the robot (issue 4: the hexapod's best walking
// speed), and with a small one a model-free baseline.
//
// <output>/<name>/
//   config.yaml    resolved configuration (every key; the model keys are unused)
//   progress.csv   a row per CMA-ES generation, appended and flushed (evaluations, restarts,
//                  best return so far, sigma, lambda, seconds)
//   summary.json   status, budget, best return, the task's trajectory metrics of the best
//                  episode (hexapod: walking_speed_m_s), its theta (rewritten atomically)
//   best.csv       the best policy's episode re-run with its random stream (real.csv format)

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <mutex>
#include <optional>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/io/config.hpp"
#include "drops/opt/cmaes.hpp"
#include "drops/rollout/rollout.hpp"
#include "run_directory.hpp"
#include "task_setup.hpp"

namespace drops::app {
namespace {

namespace fs = std::filesystem;

/// Random-stream tags of drops direct (derive_seed(seed, {tag})).
constexpr std::uint64_t kDirectSearch = 0xD12EC7;

struct DirectArgs {
  std::vector<std::string> args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::optional<long> evaluations;
  std::string output, name, start;
  bool quiet = false;
};

/// theta0 from a file of one value per line (the format of a run's episodes/NNN/policy.csv).
/// Throws ConfigError naming the file when it cannot be read, a line is not a finite number, the
/// count is not n or a value lies outside [-bound, bound].
VectorXd read_start(const std::string& path, int n, double bound) {
  std::ifstream in(path);
  if (!in) throw ConfigError("--start: cannot open " + path);
  std::vector<double> v;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(line, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || !std::isfinite(x))
      throw ConfigError(fmt::format("--start: {} line {}: '{}' is not a finite number", path,
                                    v.size() + 1, line));
    if (std::abs(x) > bound)
      throw ConfigError(fmt::format("--start: {} line {}: {} is outside the policy box [-{}, {}] "
                                    "(policy.bound)", path, v.size() + 1, x, bound, bound));
    v.push_back(x);
  }
  if (static_cast<int>(v.size()) != n)
    throw ConfigError(fmt::format("--start: {} holds {} values; the policy has {} parameters",
                                  path, v.size(), n));
  return Eigen::Map<VectorXd>(v.data(), n);
}

/// One real episode of theta with the random stream `stream` (measurement noise).
rollout::Trajectory real_episode(const TaskSetup& setup, const VectorXd& theta,
                                 std::uint64_t stream) {
  std::unique_ptr<policy::Policy> p = setup.policy->clone();
  p->set_params(theta);
  Rng rng(stream);
  return rollout::run_episode(*setup.task, *setup.real, *p, rng);
}

int direct_main(const DirectArgs& a) {
  std::vector<std::string> overrides;
  std::string file;
  split_args(a.args, file, overrides);
  if (a.seed) overrides.push_back("seed=" + std::to_string(*a.seed));
  if (a.threads) overrides.push_back("threads=" + std::to_string(*a.threads));
  if (a.evaluations) overrides.push_back("optimizer.max_evaluations=" + std::to_string(*a.evaluations));
  if (!a.output.empty()) overrides.push_back("output=" + a.output);
  if (!a.name.empty()) overrides.push_back("name=" + a.name);
  const io::Settings settings = settings_from(file, overrides);
  const io::Experiment e = io::make_experiment(settings);
  ThreadLimit threads(e.threads);
  const TaskSetup setup = make_task_setup(e);
  const int n = setup.policy->param_dim();
  const double b = e.algo.theta_bound;
  // Start: the centre of the box, or --start (evaluated too, and kept when it beats the search).
  const VectorXd x0 = a.start.empty() ? VectorXd::Zero(n) : read_start(a.start, n, b);

  std::string name = e.name;
  if (name.empty()) name = fmt::format("direct-{}-seed{}-{}", e.task, e.seed, local_timestamp());
  const fs::path dir = fs::path(e.output) / name;
  if (fs::exists(dir / "progress.csv"))
    throw Error("directory " + dir.string() + " already holds a direct search; choose another "
                "name= or remove it");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create " + dir.string() + ": " + ec.message());
  write_file_atomically(dir / "config.yaml", io::to_yaml(settings));
  std::ofstream progress(dir / "progress.csv", std::ios::trunc);
  if (!progress) throw Error("cannot write " + (dir / "progress.csv").string());
  progress << "evaluations,restarts,generation,best_return,sigma,lambda,seconds\n" << std::flush;

  opt::CmaesOptions co = e.algo.cmaes;
  co.seed = derive_seed(e.seed, {kDirectSearch});
  if (co.sigma0 <= 0) co.sigma0 = b;  // as the policy search on the model (settings.md §5)
  co.parallel = e.threads != 1;
  // The start (--start) is evaluated first, within the budget, and kept unless beaten. The
  // selection is the best episode seen: re-evaluating a short list would cost real episodes.
  co.evaluate_start = !a.start.empty();
  const VectorXd lower = VectorXd::Constant(n, -b), upper = VectorXd::Constant(n, b);

  nlohmann::json summary = {{"task", e.task},
                            {"seed", e.seed},
                            {"max_evaluations", e.algo.cmaes.max_evaluations},
                            {"started", now_iso()}};
  auto write_summary = [&](const std::string& status) {
    summary["status"] = status;
    write_file_atomically(dir / "summary.json", summary.dump(2) + "\n");
  };
  write_summary("running");

  const bool live = !a.quiet && isatty(STDERR_FILENO);
  std::cerr << fmt::format("drops direct: {} (no model), {} real episodes at most, seed {}, {} threads\n",
                           e.task, e.algo.cmaes.max_evaluations, e.seed, e.threads ? e.threads : hardware_threads());
  std::cerr << "directory: " << dir.string() << "\n";

  install_interrupt_handler();
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  // The best episode's stream, so that best.csv is that very episode (ties: the smaller stream,
  // whatever the evaluation order).
  std::mutex best_mutex;
  double best_value = std::numeric_limits<double>::infinity();
  std::uint64_t best_stream = 0;
  auto objective = [&](const VectorXd& theta, std::uint64_t stream) {
    const double v = -real_episode(setup, theta, stream).total_return();
    const std::lock_guard<std::mutex> lock(best_mutex);
    if (v < best_value || (v == best_value && stream < best_stream)) {
      best_value = v;
      best_stream = stream;
    }
    return v;
  };
  auto on_generation = [&](const opt::CmaesProgress& p) {
    progress << fmt::format("{},{},{},{:.10g},{:.6g},{},{:.3f}\n", p.evaluations, p.restarts,
                            p.generation, -p.best_value, p.sigma, p.lambda, seconds())
             << std::flush;
    if (live)
      std::cerr << fmt::format("\r\033[K[direct] {}/{} episodes, best return {:.3f}, restart {}",
                               p.evaluations, e.algo.cmaes.max_evaluations, -p.best_value, p.restarts)
                << std::flush;
    return !interrupt_requested();
  };
  opt::CmaesSummary s;
  try {
    s = opt::cmaes_minimize(objective, x0, lower, upper, co, on_generation);
    if (!a.start.empty()) summary["start_return"] = -s.start_value;
  } catch (const std::exception& ex) {
    if (live) std::cerr << "\r\033[K";
    summary["error"] = ex.what();
    summary["finished"] = now_iso();
    write_summary("failed");
    throw;
  }
  if (live) std::cerr << "\r\033[K";
  const bool interrupted = interrupt_requested();

  // The best episode again, with the stream it was evaluated with (the same episode: run_episode
  // is deterministic given theta and the stream), for its metrics and best.csv.
  const rollout::Trajectory best = real_episode(setup, s.best_x, best_stream);
  write_file_atomically(dir / "best.csv", trajectory_csv(best, setup));
  summary["evaluations"] = s.evaluations;
  summary["restarts"] = s.restarts;
  summary["stop_reasons"] = s.run_stop_reasons;
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& r : s.runs)
    runs.push_back({{"lambda", r.lambda}, {"sigma0", r.sigma0},
                    {"from", r.from_start ? "start" : "random"},
                    {"regime", r.small ? "small" : "large"}, {"evaluations", r.evaluations},
                    {"generations", r.generations}, {"best_return", -r.best_value},
                    {"stop", r.stop_reason}});
  summary["runs"] = runs;
  summary["best_return"] = -s.best_value;
  summary["solved"] = setup.task->solved(best);
  if (setup.trajectory_metrics) {
    const std::vector<double> m = setup.trajectory_metrics(best);
    for (std::size_t i = 0; i < m.size(); ++i) summary[setup.trajectory_metric_names[i]] = m[i];
  }
  summary["theta"] = std::vector<double>(s.best_x.data(), s.best_x.data() + s.best_x.size());
  summary["seconds"] = seconds();
  summary["finished"] = now_iso();
  write_summary(interrupted ? "interrupted" : "complete");

  std::string metrics;
  for (const auto& m : setup.trajectory_metric_names)
    metrics += fmt::format(", {} {:.3f}", m, summary[m].get<double>());
  std::cerr << fmt::format("{}: {} episodes, best return {:.3f}{} in {:.1f} s; results in {}\n",
                           interrupted ? "interrupted" : "done", s.evaluations, -s.best_value,
                           metrics, seconds(), dir.string());
  return interrupted ? 130 : 0;
}

}  // namespace

void add_direct_command(CLI::App& app, Action& action) {
  auto* cmd = app.add_subcommand(
      "direct",
      "Optimize the policy directly on the \"real\" system with BIPOP-CMA-ES, one real episode "
      "per evaluation and no model (a model-free baseline; with a large budget, the ceiling of "
      "the policy family). Uses the config's task, damage, policy and optimizer keys. Exit codes: "
      "0 done, 1 error, 2 configuration error, 130 interrupted (the best so far is written).");
  auto args = std::make_shared<DirectArgs>();
  cmd->add_option("args", args->args,
                  "[CONFIG.yaml] [key=value ...] (see 'drops config --markdown')");
  cmd->add_option("--evaluations", args->evaluations,
                  "real episodes at most (same as optimizer.max_evaluations=N)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--start", args->start,
                  "start point: a file of policy parameters, one per line (e.g. a run's "
                  "episodes/NNN/policy.csv); evaluated too and kept if the search does not beat it "
                  "(default: the centre of the box)");
  cmd->add_option("--seed", args->seed, "seed of the search (same as seed=N)");
  cmd->add_option("--threads", args->threads, "worker threads, 0 = all (same as threads=N)");
  cmd->add_option("--output", args->output, "parent directory of the result directory (default runs)");
  cmd->add_option("--name", args->name, "name of the result directory (default direct-<task>-seed<seed>-<time>)");
  cmd->add_flag("-q,--quiet", args->quiet, "only the final line on stderr");
  cmd->callback([&action, args] { action = [args] { return direct_main(*args); }; });
}

}  // namespace drops::app
