// `drops run` (Algorithm 1 on a configured experiment, or --resume of an interrupted run) and
// `drops config` (the resolved configuration, or the schema as Markdown).

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/io/config.hpp"
#include "run_directory.hpp"
#include "task_setup.hpp"

namespace drops::app {
namespace {

std::string phi_brief(const VectorXd& phi, const std::vector<std::string>& names,
                      const std::vector<int>& tunable) {
  std::string s;
  for (int i : tunable)
    if (i >= 0 && i < phi.size() && static_cast<std::size_t>(i) < names.size())
      s += fmt::format("{}{}={:.3f}", s.empty() ? "" : " ", names[static_cast<std::size_t>(i)],
                       phi[i]);
  return s.empty() ? "none" : s;  // the gp variant has no prior, hence no phi
}

std::string default_name(const io::Experiment& e) {
  return fmt::format("{}-{}-{}-seed{}-{}", e.task, model::to_string(e.algo.model.type),
                     e.prior_preset, e.seed, local_timestamp());
}

struct RunArgs {
  std::vector<std::string> args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::string output, name, resume;
  bool quiet = false;
};

int run_main(const RunArgs& a) {
  std::string file;
  std::vector<std::string> overrides;
  split_args(a.args, file, overrides);
  if (a.threads) overrides.push_back("threads=" + std::to_string(*a.threads));

  io::Settings settings;
  std::unique_ptr<RunDirectory> dir;
  algo::BlackDropsState state;
  const bool resuming = !a.resume.empty();
  if (resuming) {
    if (!file.empty())
      throw ConfigError("--resume takes the run directory's own config.yaml; drop '" + file + "'");
    if (a.seed || !a.output.empty() || !a.name.empty())
      throw ConfigError("--resume continues a run as configured; --seed, --output and --name "
                        "cannot be changed");
    for (const auto& o : overrides) {
      const std::string key = o.substr(0, o.find('='));
      if (key != "episodes" && key != "threads")
        throw ConfigError("--resume can only change episodes= and threads=, not '" + key + "'");
    }
    const std::filesystem::path d(a.resume);
    if (!std::filesystem::exists(d / "config.yaml"))
      throw Error(d.string() + " is not a run directory (no config.yaml)");
    settings = io::load_run_settings_file((d / "config.yaml").string(), overrides);
  } else {
    if (a.seed) overrides.push_back("seed=" + std::to_string(*a.seed));
    if (!a.output.empty()) overrides.push_back("output=" + a.output);
    if (!a.name.empty()) overrides.push_back("name=" + a.name);
    settings = settings_from(file, overrides);
  }
  const io::Experiment e = io::make_experiment(settings);
  ThreadLimit threads(e.threads);

  const TaskSetup setup = make_task_setup(e);

  try {
    if (resuming) {
      dir = RunDirectory::reopen(a.resume, e, setup, &state);
    } else {
      const std::string name = e.name.empty() ? default_name(e) : e.name;
      dir = std::make_unique<RunDirectory>(std::filesystem::path(e.output) / name, settings, e,
                                           setup);
    }
  } catch (const RunDirectoryBusy& ex) {
    std::cerr << "drops: " << ex.what() << "\n";
    return 3;
  }
  const bool live = !a.quiet && isatty(STDERR_FILENO);
  std::cerr << fmt::format("drops run: {} with {} (prior {}), {} episodes, seed {}, {} threads\n",
                           e.task, model::to_string(e.algo.model.type), e.prior_preset,
                           e.algo.episodes, e.seed, e.threads ? e.threads : hardware_threads());
  std::cerr << "run directory: " << dir->path().string() << "\n";
  if (resuming) {
    std::cerr << fmt::format("resuming after episode {} of {}\n", state.episodes_done,
                             e.algo.episodes);
    if (state.episodes_done >= e.algo.episodes) {
      algo::BlackDropsSummary done;
      done.episodes_done = state.episodes_done;
      done.first_solved_episode = state.first_solved_episode;
      done.best_real_return = state.best_return;
      dir->finish(done, "complete");
      std::cerr << "nothing to do: the run already has its " << e.algo.episodes << " episodes\n";
      return 0;
    }
  }

  install_interrupt_handler();
  auto last = std::chrono::steady_clock::now();
  algo::BlackDropsCallbacks cb;
  cb.should_stop = [] { return interrupt_requested(); };
  cb.on_status = [&](const algo::Status& s) {
    if (!live) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last < std::chrono::milliseconds(100)) return;
    last = now;
    std::string what =
        s.phase == "model"    ? fmt::format("learning model: {} phi evaluations, score {:.2f}", s.evaluations, s.best)
        : s.phase == "policy" ? fmt::format("policy search: {} evaluations, best predicted return {:.2f}", s.evaluations, s.best)
                              : std::string("running the episode");
    std::cerr << fmt::format("\r\033[K[episode {}/{}] {}", s.episode, e.algo.episodes, what) << std::flush;
  };
  cb.on_episode = [&](const algo::EpisodeRecord& r) {
    dir->record(r);
    if (live) std::cerr << "\r\033[K";
    if (a.quiet) return;
    std::cerr << fmt::format(
        "episode {:>2}/{}  t={:5.1f} s  return {:6.2f}  predicted {:6.2f}  solved {}  phi [{}]  "
        "model {:.1f} s  policy {:.1f} s  {} evals{}\n",
        r.episode, e.algo.episodes, r.interaction_time, r.real_return, r.predicted_return,
        r.solved ? "yes" : "no ", phi_brief(r.phi, e.prior.names, e.prior.tunable),
        r.model_seconds, r.policy_seconds, r.evaluations,
        r.selected == "start" ? "  (best policy kept)" : "");
  };
  cb.on_state = [&](const algo::BlackDropsState& st) { dir->save_state(st); };

  algo::BlackDropsSummary summary;
  try {
    summary = algo::run_black_drops(setup.task, *setup.real, *setup.policy, setup.prior, e.prior,
                                    e.algo, cb, resuming ? &state : nullptr);
  } catch (const std::exception& ex) {
    if (live) std::cerr << "\r\033[K";
    dir->finish(summary, "failed", ex.what());
    throw;
  }
  if (live) std::cerr << "\r\033[K";
  dir->finish(summary, summary.interrupted ? "interrupted" : "complete");
  std::cerr << fmt::format("{}: {} episodes, best return {:.2f}, {} in {:.1f} s; results in {}\n",
                           summary.interrupted ? "interrupted" : "done", summary.episodes_done,
                           summary.best_real_return,
                           summary.first_solved_episode
                               ? fmt::format("first solved at episode {}", summary.first_solved_episode)
                               : std::string("never solved"),
                           summary.seconds, dir->path().string());
  if (summary.interrupted)
    std::cerr << "continue it with: drops run --resume " << dir->path().string() << "\n";
  return summary.interrupted ? 130 : 0;
}

}  // namespace

void add_run_command(CLI::App& app, Action& action) {
  auto* run = app.add_subcommand(
      "run",
      "Run Algorithm 1 on an experiment. Without arguments: the default experiment (pendubot, "
      "gp_mi, prior tunable-useful, 10 episodes, seed 1). Exit codes: 0 done, 1 error, "
      "2 configuration error, 3 run directory in use, 130 interrupted (resumable).");
  auto args = std::make_shared<RunArgs>();
  run->add_option("args", args->args,
                  "[CONFIG.yaml] [key=value ...] (see 'drops config --markdown')");
  run->add_option("--seed", args->seed, "seed of the run (same as seed=N)");
  run->add_option("--threads", args->threads, "worker threads, 0 = all (same as threads=N)");
  run->add_option("--output", args->output, "parent directory of the run directory (default runs)");
  run->add_option("--name", args->name, "name of the run directory");
  run->add_option("--resume", args->resume,
                  "continue the interrupted run in this directory from its last finished episode "
                  "(same results as an uninterrupted run; episodes=N may extend it)");
  run->add_flag("-q,--quiet", args->quiet, "only the final line on stderr");
  run->callback([&action, args] { action = [args] { return run_main(*args); }; });
}

void add_config_command(CLI::App& app, Action& action) {
  auto* config = app.add_subcommand(
      "config", "Print the resolved configuration (defaults, a config file and overrides applied)");
  auto args = std::make_shared<std::vector<std::string>>();
  auto markdown = std::make_shared<bool>(false);
  config->add_option("args", *args, "[CONFIG.yaml] [key=value ...]");
  config->add_flag("--markdown", *markdown, "print every key as a Markdown table instead");
  config->callback([&action, args, markdown] {
    action = [args, markdown] {
      if (*markdown) {
        std::cout << io::schema_markdown();
        return 0;
      }
      std::string file;
      std::vector<std::string> overrides;
      split_args(*args, file, overrides);
      const auto s = settings_from(file, overrides);
      io::make_experiment(s);  // full validation
      std::cout << io::to_yaml(s);
      return 0;
    };
  });
}

}  // namespace drops::app
