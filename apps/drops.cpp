// The drops command line: `drops run` (Algorithm 1 on a configured experiment) and `drops config`.

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <iostream>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/io/config.hpp"
#include "run_directory.hpp"

namespace {

std::atomic<int> g_interrupts{0};

extern "C" void on_sigint(int) {
  if (g_interrupts.fetch_add(1) >= 1) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
}

std::string phi_brief(const drops::VectorXd& phi, const std::vector<std::string>& names,
                      const std::vector<int>& tunable) {
  std::string s;
  for (int i : tunable) s += fmt::format("{}{}={:.3f}", s.empty() ? "" : " ", names[static_cast<std::size_t>(i)], phi[i]);
  return s;
}

std::string default_name(const drops::io::Experiment& e) {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  return fmt::format("{}-{}-{}-seed{}-{}", e.task, drops::model::to_string(e.algo.model.type),
                     e.prior_preset, e.seed, buf);
}

/// Splits positional arguments into an optional config file and key=value overrides.
void split_args(const std::vector<std::string>& args, std::string& file,
                std::vector<std::string>& overrides) {
  for (const auto& a : args) {
    if (a.find('=') != std::string::npos) {
      overrides.push_back(a);
    } else if (file.empty()) {
      file = a;
    } else {
      throw drops::ConfigError("more than one config file given ('" + file + "' and '" + a +
                               "'); overrides are written key=value");
    }
  }
}

drops::io::Settings settings_from(const std::string& file, const std::vector<std::string>& ov) {
  return file.empty() ? drops::io::load_settings("", ov) : drops::io::load_settings_file(file, ov);
}

int run_command(const std::string& file, std::vector<std::string> overrides, bool quiet) {
  using namespace drops;
  const io::Settings settings = settings_from(file, overrides);
  const io::Experiment e = io::make_experiment(settings);
  ThreadLimit threads(e.threads);

  auto task = std::make_shared<pendubot::SwingUpTask>(e.task_options);
  pendubot::PendubotSystem real(e.actual, e.task_options);
  auto prior = std::make_shared<pendubot::PendubotPrior>(e.task_options);
  policy::NeuralNetPolicy policy(e.policy);

  const std::string name = e.name.empty() ? default_name(e) : e.name;
  app::RunDirectory dir(std::filesystem::path(e.output) / name, settings, e);
  const bool live = !quiet && isatty(STDERR_FILENO);
  std::cerr << fmt::format("drops run: {} with {} (prior {}), {} episodes, seed {}, {} threads\n",
                           e.task, model::to_string(e.algo.model.type), e.prior_preset,
                           e.algo.episodes, e.seed, e.threads ? e.threads : hardware_threads());
  std::cerr << "run directory: " << dir.path().string() << "\n";

  std::signal(SIGINT, on_sigint);
  auto last = std::chrono::steady_clock::now();
  algo::BlackDropsCallbacks cb;
  cb.should_stop = [] { return g_interrupts.load() > 0; };
  cb.on_status = [&](const algo::Status& s) {
    if (!live) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last < std::chrono::milliseconds(100)) return;
    last = now;
    std::string what = s.phase == "model"    ? fmt::format("learning model: {} phi evaluations, score {:.2f}", s.evaluations, s.best)
                       : s.phase == "policy" ? fmt::format("policy search: {} evaluations, best predicted return {:.2f}", s.evaluations, s.best)
                                             : std::string("running the episode");
    std::cerr << fmt::format("\r\033[K[episode {}/{}] {}", s.episode, e.algo.episodes, what) << std::flush;
  };
  cb.on_episode = [&](const algo::EpisodeRecord& r) {
    dir.record(r);
    if (live) std::cerr << "\r\033[K";
    if (quiet) return;
    std::cerr << fmt::format(
        "episode {:>2}/{}  t={:5.1f} s  return {:6.2f}  predicted {:6.2f}  solved {}  phi [{}]  "
        "model {:.1f} s  policy {:.1f} s  {} evals\n",
        r.episode, e.algo.episodes, r.interaction_time, r.real_return, r.predicted_return,
        r.solved ? "yes" : "no ", phi_brief(r.phi, e.prior.names, e.prior.tunable),
        r.model_seconds, r.policy_seconds, r.evaluations);
  };

  algo::BlackDropsSummary summary;
  try {
    summary = algo::run_black_drops(task, real, policy, prior, e.prior, e.algo, cb);
  } catch (const std::exception& ex) {
    if (live) std::cerr << "\r\033[K";
    dir.finish(summary, "failed", ex.what());
    throw;
  }
  if (live) std::cerr << "\r\033[K";
  dir.finish(summary, summary.interrupted ? "interrupted" : "complete");
  std::cerr << fmt::format("{}: {} episodes, best return {:.2f}, {} in {:.1f} s; results in {}\n",
                           summary.interrupted ? "interrupted" : "done", summary.episodes_done,
                           summary.best_real_return,
                           summary.first_solved_episode
                               ? fmt::format("first solved at episode {}", summary.first_solved_episode)
                               : std::string("never solved"),
                           summary.seconds, dir.path().string());
  return summary.interrupted ? 130 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "drops: data-efficient robot learning with black-box simulator priors\n"
      "(Black-DROPS with GP-MI, Chatzilygeroudis & Mouret, ICRA 2018)"};
  app.set_version_flag("--version", "drops 0.1.0");
  app.require_subcommand(1);

  auto* run = app.add_subcommand(
      "run",
      "Run Algorithm 1 on an experiment. Without arguments: the default experiment (pendubot, "
      "gp_mi, prior tunable-useful, 10 episodes, seed 1).");
  std::vector<std::string> run_args;
  std::optional<std::uint64_t> seed;
  std::optional<int> threads;
  std::string output, name;
  bool quiet = false;
  run->add_option("args", run_args, "[CONFIG.yaml] [key=value ...] (see 'drops config --markdown')");
  run->add_option("--seed", seed, "seed of the run (same as seed=N)");
  run->add_option("--threads", threads, "worker threads, 0 = all (same as threads=N)");
  run->add_option("--output", output, "parent directory of the run directory (default runs)");
  run->add_option("--name", name, "name of the run directory");
  run->add_flag("-q,--quiet", quiet, "only the final line on stderr");

  auto* config = app.add_subcommand(
      "config", "Print the resolved configuration (defaults, a config file and overrides applied)");
  std::vector<std::string> config_args;
  bool markdown = false;
  config->add_option("args", config_args, "[CONFIG.yaml] [key=value ...]");
  config->add_flag("--markdown", markdown, "print every key as a Markdown table instead");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*run) {
      std::string file;
      std::vector<std::string> overrides;
      split_args(run_args, file, overrides);
      if (seed) overrides.push_back("seed=" + std::to_string(*seed));
      if (threads) overrides.push_back("threads=" + std::to_string(*threads));
      if (!output.empty()) overrides.push_back("output=" + output);
      if (!name.empty()) overrides.push_back("name=" + name);
      return run_command(file, overrides, quiet);
    }
    if (*config) {
      if (markdown) {
        std::cout << drops::io::schema_markdown();
        return 0;
      }
      std::string file;
      std::vector<std::string> overrides;
      split_args(config_args, file, overrides);
      const auto s = settings_from(file, overrides);
      drops::io::make_experiment(s);  // full validation
      std::cout << drops::io::to_yaml(s);
      return 0;
    }
  } catch (const drops::ConfigError& e) {
    std::cerr << "drops: configuration error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "drops: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
