// Running an experiment into its run directory (run.hpp): the run loop of `drops run` and of the
// Python module, with the progress lines formatted here and printed by the caller.

#include "drops/experiment/run.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/run_directory.hpp"
#include "run_hints.hpp"

namespace drops::experiment {
namespace {

std::string phi_brief(const VectorXd& phi, const model::PriorParameters& p) {
  std::string s;
  for (int i : p.tunable)
    if (i >= 0 && i < phi.size() && static_cast<std::size_t>(i) < p.names.size())
      s += fmt::format("{}{}={:.4g}", s.empty() ? "" : " ", p.names[static_cast<std::size_t>(i)],
                       phi[i]);
  return s.empty() ? "none" : s;  // no prior (the gp variant, a direct search), hence no phi
}

}  // namespace

std::string policy_cost_hint(int episode, double seconds, double previous_seconds,
                             long transitions, long variance_points, long max_evaluations,
                             long inducing_points) {
  if (!(seconds >= 30 && previous_seconds > 0 && seconds >= 1.5 * previous_seconds)) return "";
  const std::string head = fmt::format(
      "hint: episode {}'s policy search took {:.0f} s ({:.0f} s the episode before), with the "
      "model on N = {} recorded transitions. ",
      episode, seconds, previous_seconds, transitions);
  if (inducing_points > 0 && transitions > inducing_points)
    return head + fmt::format(
        "The model's sparse GPs predict from at most m = {} inducing inputs "
        "(model.inducing_points; fewer while fewer explain the data): a prediction's mean costs "
        "at most O(m) and its variance O(m^2), whatever N. Each of optimizer.max_evaluations = {} "
        "evaluations costs the horizon's steps times that; fewer evaluations or a smaller "
        "model.inducing_points trade it; docs/python.md, \"What a run costs\"",
        inducing_points, max_evaluations);
  const bool capped = variance_points > 0 && transitions > variance_points;
  return head + fmt::format(
      "Its cost grows with N: every prediction's mean costs "
      "O(N) and its variance O({}){}, for each of optimizer.max_evaluations = {} evaluations "
      "times the horizon's steps. Fewer evaluations, model.variance_points (a cap m on the "
      "variance's points) or fewer episodes trade it; docs/python.md, \"What a run costs\"",
      capped ? "m^2" : "N^2",
      variance_points > 0 ? fmt::format(" (model.variance_points = {})", variance_points)
                          : std::string(" (model.variance_points = 0: every transition)"),
      max_evaluations);
}

Experiment make_experiment(const Registry& registry, const Settings& settings,
                           const std::string& source) {
  try {
    return make_experiment(registry, settings);
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    if (source.empty() || what.rfind(source + ":", 0) == 0) throw;
    throw ConfigError(source + ": " + what);
  }
}

Settings resume_settings(const Registry& registry, const std::filesystem::path& dir,
                         const std::vector<std::string>& overrides) {
  if (dir.empty())
    throw ConfigError("--resume needs the run directory to continue, got an empty path");
  for (const auto& o : overrides) {
    const std::string key = o.substr(0, o.find('='));
    if (key != "episodes" && key != "threads")
      throw ConfigError("--resume can only change episodes= and threads=, not '" + key + "'");
  }
  if (!std::filesystem::is_directory(dir))
    throw Error(dir.string() + " is not a run directory (no such directory)");
  if (!std::filesystem::exists(dir / "config.yaml"))
    throw Error(dir.string() + " is not a run directory (no config.yaml)");
  // Another format version is named before its config.yaml, whose keys may differ, is read.
  check_run_directory_format(dir);
  return load_settings_file(registry, (dir / "config.yaml").string(), overrides);
}

RunOutcome run_experiment(const Registry& registry, const Settings& settings,
                          const std::string& source, const std::string& resume_dir,
                          const RunOutput& out) {
  if (!out.line) throw InvalidArgument("run_experiment: RunOutput::line is required");
  const bool quiet = out.quiet;
  const bool live = out.live && !quiet;
  const auto clear = [&] {
    if (live && out.clear_status) out.clear_status();
  };
  const auto status_line = [&](const std::string& text) {
    if (live && out.status) out.status(text);
  };

  const Experiment e = make_experiment(registry, settings, source);
  ThreadLimit threads(e.threads);
  const bool resuming = !resume_dir.empty();
  std::unique_ptr<RunDirectory> dir;
  algo::RunState state;
  const std::string config_yaml = to_yaml(registry, e.settings);
  if (resuming) {
    dir = RunDirectory::reopen(resume_dir, e, config_yaml, &state);
  } else if (e.name.empty()) {
    // A default name holds the time to the second: a run started in the same second by another
    // process gets "-2", "-3", ... appended.
    dir = RunDirectory::create_unique(e.output, e.default_run_name(local_timestamp()), config_yaml,
                                      e);
  } else {
    dir = std::make_unique<RunDirectory>(std::filesystem::path(e.output) / e.name, config_yaml, e);
  }
  RunOutcome outcome;
  outcome.directory = dir->path();
  const int episodes = e.runner->episodes();
  // quiet: only the final line (done, interrupted or nothing to do; an error is its own line).
  if (!quiet) {
    out.line(fmt::format("drops run: {} with {}{}, {} episodes, seed {}, {} threads", e.task,
                         e.variant,
                         e.uses_prior ? fmt::format(" (prior {})", e.setup.prior_label) : "",
                         episodes, e.seed, e.threads ? e.threads : hardware_threads()));
    out.line("run directory: " + dir->path().string());
    if (!e.setup.recorded_data.empty())
      out.line(fmt::format(
          "recorded data: {} log(s), {} transitions (data.logs); {}",
          e.setup.declaration.at("data.logs"), e.setup.recorded_data.size(),
          e.setup.keep_first_episode
              ? "episode 1 runs without them, the model learns from them from episode 2 on"
              : "episode 1 learns the model on them"));
  }
  if (resuming) {
    if (!quiet) {
      for (const auto& r : dir->repairs()) out.line("resume: " + r);
      if (dir->has_checkpoint())
        out.line(fmt::format("resuming after episode {} of {}", state.episodes_done, episodes));
    }
    if (state.episodes_done >= episodes) {
      algo::RunSummary& done = outcome.summary;
      done.episodes_done = state.episodes_done;
      done.first_solved_episode = state.first_solved_episode;
      done.best_real_return = state.best_return;
      dir->finish(done, "complete");
      outcome.status = "complete";
      outcome.nothing_to_do = true;
      out.line("nothing to do: the run already has its " + std::to_string(episodes) +
               " episodes");
      return outcome;
    }
  }

  auto last = std::chrono::steady_clock::now();
  auto last_line = last;
  algo::Callbacks cb;
  cb.should_stop = [&] { return out.should_stop && out.should_stop(); };
  cb.on_status = [&](const algo::Status& s) {
    dir->record_status(s);  // the side state's progress files (IT&E: archive_progress.csv)
    const auto now = std::chrono::steady_clock::now();
    if (s.phase == "simulation episode") {  // PILCO with priors: one line per simulated episode
      clear();
      if (!quiet)
        out.line(fmt::format("simulation episode {:>2}/{}  return {:6.2f}  {} evals  [{}]",
                             s.episode, s.budget, s.best, s.evaluations, now_iso()));
      return;
    }
    if (s.phase == "archive" && !live && !quiet) {
      // Without a terminal (a campaign's log), a line a minute while an archive is built.
      if (now - last_line < std::chrono::seconds(60)) return;
      last_line = now;
      out.line(fmt::format("[{}] MAP-Elites on the prior: {}/{} evaluations, {} of the cells "
                           "filled, best return {:.3f}",
                           now_iso(), s.evaluations, s.budget,
                           fmt::format("{:.1f} %", 100 * s.coverage), s.best));
      return;
    }
    if (!live) return;
    if (now - last < std::chrono::milliseconds(100)) return;
    last = now;
    if (s.phase == "simulation") {  // PILCO with priors, before the real episodes
      status_line(fmt::format("[simulation phase, episode {}] policy search: {} evaluations, "
                              "predicted return {:.2f}",
                              s.episode, s.evaluations, s.best));
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
    status_line(fmt::format("[episode {}/{}] {}", s.episode, episodes, what));
  };
  // The cost hint (policy_cost_hint): the transitions recorded in this session, the last search.
  long transitions = 0;
  double previous_policy_seconds = 0;
  bool hinted = false;
  // Base keys: every validated experiment has them.
  const long variance_points = static_cast<long>(get_int(e.settings, "model.variance_points"));
  const long max_evaluations = static_cast<long>(get_int(e.settings, "optimizer.max_evaluations"));
  const long inducing_points = static_cast<long>(get_int(e.settings, "model.inducing_points"));
  cb.on_episode = [&](const algo::EpisodeRecord& r) {
    dir->record(r);
    clear();
    if (!hinted && e.uses_model && r.keep_trajectories) {
      const std::string hint =
          policy_cost_hint(r.episode, r.policy_seconds, previous_policy_seconds, transitions,
                           variance_points, max_evaluations, inducing_points);
      if (!hint.empty() && !quiet) {
        out.line(hint);
        hinted = true;
      }
    }
    if (r.keep_trajectories) {
      transitions += static_cast<long>(r.real.actions.rows());
      previous_policy_seconds = r.policy_seconds;
    }
    // Said even when quiet: a real system that breaks down is something to act on.
    if (r.real.nonfinite_step >= 0)
      out.line(fmt::format(
          "episode {}: the real system returned a non-finite state at step {} of {}: the episode "
          "ended there (reward 0 for the rest, not solved) and only its {} finite transitions "
          "join the data (summary.json: nonfinite_real_step)",
          r.episode, r.real.nonfinite_step + 1, r.real.actions.rows(), r.real.nonfinite_step));
    // A direct search reports the episodes that improved on the best (every other is recorded).
    if (quiet || !r.keep_trajectories) return;
    out.line(fmt::format(
        "episode {:>2}/{}  t={:5.1f} s  return {:6.2f}  predicted {:>6}  solved {}  phi [{}]  "
        "model {:.1f} s  policy {:.1f} s  {} evals{}",
        r.episode, episodes, r.interaction_time, r.real_return,
        // No model predicted the episode (a random first policy, a direct search).
        std::isfinite(r.predicted_return) ? fmt::format("{:.2f}", r.predicted_return) : "none",
        r.solved ? "yes" : "no ", phi_brief(r.phi, e.setup.prior_parameters), r.model_seconds,
        r.policy_seconds, r.evaluations,
        r.selected == "start" ? std::string("  (best policy kept)")
        : r.details.numbers.count("cell")
            ? fmt::format("  ({} cell {})", r.selected == "trial" ? "trial of" : "best tested",
                          static_cast<long long>(r.details.numbers.at("cell")))
            : std::string()));
  };
  cb.on_state = [&](const algo::RunState& st) { dir->save_state(st); };
  cb.on_phase = [&](const algo::PhaseRecord& p) {
    dir->record_phase(p);
    if (!p.complete) return;  // the phase so far: its episodes have their own progress lines
    clear();
    if (quiet) return;
    const auto number = [&](const char* k) {
      const auto it = p.summary.numbers.find(k);
      return it == p.summary.numbers.end() ? std::nan("") : it->second;
    };
    out.line(fmt::format("{} phase: {} episodes, last return {:.2f} (predicted {:.2f}), {:.1f} s",
                         p.name, p.episodes.size(), number("last_return"),
                         number("last_predicted_return"), number("seconds")));
  };

  algo::RunSummary& summary = outcome.summary;
  try {
    // A directory reopened without a checkpoint (no episode had finished) starts from the
    // beginning.
    const bool continuing = resuming && dir->has_checkpoint();
    summary = e.runner->run(e.setup.problem(), cb, continuing ? &state : nullptr);
  } catch (const std::exception& ex) {
    clear();
    dir->finish(summary, "failed", ex.what());
    throw;
  }
  clear();
  outcome.status = summary.interrupted ? "interrupted" : "complete";
  dir->finish(summary, outcome.status);
  if (summary.interrupted) {  // what to do with an interrupted run
    const std::string resume = "drops run --resume " + dir->path().string();
    if (e.runner->resumable() && dir->has_checkpoint())
      outcome.hint = "continue it with: " + resume;
    else if (e.runner->resumable())  // a resume starts it from its beginning, in place
      outcome.hint = "no episode finished, so nothing was recorded: start it again with: " +
                     resume;
    else
      outcome.hint = "algorithm '" + e.algorithm + "' cannot be resumed: start it again (its " +
                     std::to_string(summary.episodes_done) + " recorded episodes stay in " +
                     dir->path().string() + ")";
  }
  const std::string final_line =
      fmt::format("{}: {}; results in {}", summary.interrupted ? "interrupted" : "done",
                  summary.BriefReport(), dir->path().string());
  // When quiet, the hint goes on the final line, the only one.
  if (outcome.hint.empty()) {
    out.line(final_line);
  } else if (quiet) {
    out.line(final_line + "; " + outcome.hint);
  } else {
    out.line(final_line);
    out.line(outcome.hint);
  }
  return outcome;
}

}  // namespace drops::experiment
