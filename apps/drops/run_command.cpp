// `drops run` (an algorithm on a configured experiment, or --resume of an interrupted run) and
// `drops config` (the resolved configuration, or the schema as Markdown).

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "command.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::app {
namespace {

std::string phi_brief(const VectorXd& phi, const model::PriorParameters& p) {
  std::string s;
  for (int i : p.tunable)
    if (i >= 0 && i < phi.size() && static_cast<std::size_t>(i) < p.names.size())
      s += fmt::format("{}{}={:.3f}", s.empty() ? "" : " ", p.names[static_cast<std::size_t>(i)],
                       phi[i]);
  return s.empty() ? "none" : s;  // no prior (the gp variant, a direct search), hence no phi
}

struct RunArgs {
  std::vector<std::string> args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::string output, name;
  std::optional<std::string> resume;  ///< --resume DIR (given, even empty: an error)
  bool quiet = false;
};

}  // namespace

/// Runs the experiment of `settings` (read from the configuration file `source`, empty: none), or
/// continues the run in `resume_dir`, with the progress display of `drops run`. Shared by
/// `drops run` and `drops direct`.
int run_experiment(const experiment::Registry& registry, const experiment::Settings& settings,
                   const std::string& source, const std::string& resume_dir, bool quiet) {
  const experiment::Experiment e = make_experiment_from(registry, settings, source);
  ThreadLimit threads(e.threads);
  const bool resuming = !resume_dir.empty();
  std::unique_ptr<experiment::RunDirectory> dir;
  algo::RunState state;
  const std::string config_yaml = experiment::to_yaml(registry, e.settings);
  try {
    if (resuming) {
      dir = experiment::RunDirectory::reopen(resume_dir, e, config_yaml, &state);
    } else if (e.name.empty()) {
      // A default name holds the time to the second: a run started in the same second by another
      // process gets "-2", "-3", ... appended.
      dir = experiment::RunDirectory::create_unique(
          e.output, e.default_run_name(experiment::local_timestamp()), config_yaml, e);
    } else {
      dir = std::make_unique<experiment::RunDirectory>(std::filesystem::path(e.output) / e.name,
                                                       config_yaml, e);
    }
  } catch (const experiment::RunDirectoryBusy& ex) {
    std::cerr << "drops: " << ex.what() << "\n";
    return 3;
  }
  const int episodes = e.runner->episodes();
  const bool live = !quiet && isatty(STDERR_FILENO);
  // -q: only the final line (done, interrupted or nothing to do; an error is its own line).
  if (!quiet) {
    std::cerr << fmt::format("drops run: {} with {}{}, {} episodes, seed {}, {} threads\n",
                             e.task, e.variant,
                             e.uses_prior ? fmt::format(" (prior {})", e.setup.prior_label) : "",
                             episodes, e.seed, e.threads ? e.threads : hardware_threads());
    std::cerr << "run directory: " << dir->path().string() << "\n";
  }
  if (resuming) {
    if (!quiet) {
      for (const auto& r : dir->repairs()) std::cerr << "resume: " << r << "\n";
      if (dir->has_checkpoint())
        std::cerr << fmt::format("resuming after episode {} of {}\n", state.episodes_done,
                                 episodes);
    }
    if (state.episodes_done >= episodes) {
      algo::RunSummary done;
      done.episodes_done = state.episodes_done;
      done.first_solved_episode = state.first_solved_episode;
      done.best_real_return = state.best_return;
      dir->finish(done, "complete");
      std::cerr << "nothing to do: the run already has its " << episodes << " episodes\n";
      return 0;
    }
  }

  install_interrupt_handler();
  auto last = std::chrono::steady_clock::now();
  auto last_line = last;
  algo::Callbacks cb;
  cb.should_stop = [] { return interrupt_requested(); };
  cb.on_status = [&](const algo::Status& s) {
    dir->record_archive_progress(s);  // IT&E's archive: coverage against evaluations and time
    const auto now = std::chrono::steady_clock::now();
    if (s.phase == "simulation episode") {  // PILCO with priors: one line per simulated episode
      if (live) std::cerr << "\r\033[K";
      if (!quiet)
        std::cerr << fmt::format("simulation episode {:>2}/{}  return {:6.2f}  {} evals  [{}]\n",
                                 s.episode, s.budget, s.best, s.evaluations,
                                 experiment::now_iso());
      return;
    }
    if (s.phase == "archive" && !live && !quiet) {
      // Without a terminal (a campaign's log), a line a minute while an archive is built.
      if (now - last_line < std::chrono::seconds(60)) return;
      last_line = now;
      std::cerr << fmt::format("[{}] MAP-Elites on the prior: {}/{} evaluations, {} of the cells "
                               "filled, best return {:.3f}\n",
                               experiment::now_iso(), s.evaluations, s.budget,
                               fmt::format("{:.1f} %", 100 * s.coverage), s.best);
      return;
    }
    if (!live) return;
    if (now - last < std::chrono::milliseconds(100)) return;
    last = now;
    if (s.phase == "simulation") {  // PILCO with priors, before the real episodes
      std::cerr << fmt::format("\r\033[K[simulation phase, episode {}] policy search: {} "
                               "evaluations, predicted return {:.2f}",
                               s.episode, s.evaluations, s.best)
                << std::flush;
      return;
    }
    const std::string what =
        s.phase == "model"
            ? fmt::format("learning model: {} phi evaluations, score {:.2f}", s.evaluations, s.best)
        : s.phase == "policy"
            ? fmt::format("policy search: {} evaluations, best return {:.2f}", s.evaluations,
                          s.best)
        : s.phase == "archive"
            ? fmt::format("MAP-Elites on the prior: {}/{} evaluations, {:.1f} % of the cells "
                          "filled, best return {:.3f}",
                          s.evaluations, s.budget, 100 * s.coverage, s.best)
            : std::string("running the episode");
    std::cerr << fmt::format("\r\033[K[episode {}/{}] {}", s.episode, episodes, what)
              << std::flush;
  };
  cb.on_episode = [&](const algo::EpisodeRecord& r) {
    dir->record(r);
    if (live) std::cerr << "\r\033[K";
    // Said even with -q: a real system that breaks down is something to act on.
    if (r.real.nonfinite_step >= 0)
      std::cerr << fmt::format(
          "episode {}: the real system returned a non-finite state at step {} of {}: the episode "
          "ended there (reward 0 for the rest, not solved) and only its {} finite transitions "
          "join the data (summary.json: nonfinite_real_step)\n",
          r.episode, r.real.nonfinite_step + 1, r.real.actions.rows(), r.real.nonfinite_step);
    // A direct search reports the episodes that improved on the best (every other is recorded).
    if (quiet || !r.keep_trajectories) return;
    std::cerr << fmt::format(
        "episode {:>2}/{}  t={:5.1f} s  return {:6.2f}  predicted {:6.2f}  solved {}  phi [{}]  "
        "model {:.1f} s  policy {:.1f} s  {} evals{}\n",
        r.episode, episodes, r.interaction_time, r.real_return, r.predicted_return,
        r.solved ? "yes" : "no ", phi_brief(r.phi, e.setup.prior_parameters), r.model_seconds,
        r.policy_seconds, r.evaluations,
        r.selected == "start" ? std::string("  (best policy kept)")
        : r.details.numbers.count("cell")
            ? fmt::format("  ({} cell {})", r.selected == "trial" ? "trial of" : "best tested",
                          static_cast<long long>(r.details.numbers.at("cell")))
            : std::string());
  };
  cb.on_state = [&](const algo::RunState& st) { dir->save_state(st); };
  cb.on_phase = [&](const algo::PhaseRecord& p) {
    dir->record_phase(p);
    if (!p.complete) return;  // the phase so far: its episodes have their own progress lines
    if (live) std::cerr << "\r\033[K";
    if (quiet) return;
    const auto number = [&](const char* k) {
      const auto it = p.summary.numbers.find(k);
      return it == p.summary.numbers.end() ? std::nan("") : it->second;
    };
    std::cerr << fmt::format("{} phase: {} episodes, last return {:.2f} (predicted {:.2f}), {:.1f} s\n",
                             p.name, p.episodes.size(), number("last_return"),
                             number("last_predicted_return"), number("seconds"));
  };

  algo::RunSummary summary;
  try {
    // A directory reopened without a checkpoint (no episode had finished) starts from the
    // beginning.
    const bool continuing = resuming && dir->has_checkpoint();
    summary = e.runner->run(e.setup.problem(), cb, continuing ? &state : nullptr);
  } catch (const std::exception& ex) {
    if (live) std::cerr << "\r\033[K";
    dir->finish(summary, "failed", ex.what());
    throw;
  }
  if (live) std::cerr << "\r\033[K";
  dir->finish(summary, summary.interrupted ? "interrupted" : "complete");
  std::string hint;  // what to do with an interrupted run
  if (summary.interrupted) {
    if (e.runner->resumable() && dir->has_checkpoint())
      hint = "continue it with: drops run --resume " + dir->path().string();
    else if (e.runner->resumable())  // --resume starts it from its beginning, in place
      hint = "no episode finished, so nothing was recorded: start it again with: drops run "
             "--resume " + dir->path().string();
    else
      hint = "algorithm '" + e.algorithm + "' cannot be resumed: start it again (its " +
             std::to_string(summary.episodes_done) + " recorded episodes stay in " +
             dir->path().string() + ")";
  }
  std::cerr << fmt::format("{}: {}; results in {}", summary.interrupted ? "interrupted" : "done",
                           summary.BriefReport(), dir->path().string());
  // With -q the hint goes on the final line, the only one.
  std::cerr << (hint.empty() ? "" : quiet ? "; " + hint : "\n" + hint) << "\n";
  return summary.interrupted ? 130 : 0;
}

namespace {

int run_main(const experiment::Registry& registry, const RunArgs& a) {
  std::string file;
  std::vector<std::string> overrides;
  split_args(a.args, file, overrides);
  if (a.threads) overrides.push_back("threads=" + std::to_string(*a.threads));

  experiment::Settings settings;
  std::string source = file;
  const bool resuming = a.resume.has_value();
  if (resuming) {
    if (a.resume->empty())
      throw ConfigError("--resume needs the run directory to continue, got an empty path");
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
    const std::filesystem::path d(*a.resume);
    if (!std::filesystem::is_directory(d))
      throw Error(d.string() + " is not a run directory (no such directory)");
    if (!std::filesystem::exists(d / "config.yaml"))
      throw Error(d.string() + " is not a run directory (no config.yaml)");
    // Another format version is named before its config.yaml, whose keys may differ, is read.
    experiment::check_run_directory_format(d);
    source = (d / "config.yaml").string();
    settings = experiment::load_settings_file(registry, source, overrides);
  } else {
    if (a.seed) overrides.push_back("seed=" + std::to_string(*a.seed));
    if (!a.output.empty()) overrides.push_back("output=" + a.output);
    if (!a.name.empty()) overrides.push_back("name=" + a.name);
    settings = settings_from(registry, file, overrides);
  }
  return run_experiment(registry, settings, source, a.resume.value_or(""), a.quiet);
}

}  // namespace

void add_run_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* run = app.add_subcommand(
      "run",
      "Run an algorithm on an experiment. Without arguments: the default experiment (the "
      "first task, Black-DROPS with GP-MI, 10 episodes, seed 1). Exit codes: 0 done, 1 error, "
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
                  "(same results as an uninterrupted run; episodes=N may extend it); a run with "
                  "no finished episode starts from its beginning there");
  run->add_flag("-q,--quiet", args->quiet, "only the final line on stderr");
  run->callback([&action, &registry, args] {
    action = [&registry, args] { return run_main(registry, *args); };
  });
}

void add_config_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* config = app.add_subcommand(
      "config", "Print the resolved configuration (defaults, a config file and overrides applied)");
  auto args = std::make_shared<std::vector<std::string>>();
  auto markdown = std::make_shared<bool>(false);
  config->add_option("args", *args, "[CONFIG.yaml] [key=value ...]");
  config->add_flag("--markdown", *markdown, "print every key of every task as Markdown tables");
  config->callback([&action, &registry, args, markdown] {
    action = [&registry, args, markdown] {
      if (*markdown) {
        // The schema is the same whatever the configuration: a file or key=value given with it
        // would be silently ignored.
        if (!args->empty()) {
          std::string given;
          for (const auto& a : *args) given += (given.empty() ? "'" : " '") + a + "'";
          throw ConfigError("--markdown prints the schema of every task and takes no config file "
                            "or key=value; drop " + given);
        }
        std::cout << experiment::schema_markdown(registry);
        return 0;
      }
      std::string file;
      std::vector<std::string> overrides;
      split_args(*args, file, overrides);
      const auto s = settings_from(registry, file, overrides);
      make_experiment_from(registry, s, file);  // full validation
      std::cout << experiment::to_yaml(registry, s);
      return 0;
    };
  });
}

}  // namespace drops::app
