// IT&E's archive generation: MAP-Elites on a task's prior exactly as `drops run algorithm=ite`
// builds it (experiment::ite_options, algo::prior_evaluation), timed, with the archive's coverage
// after every `every` evaluations. A plain program, not a Google Benchmark: what it measures is a
// curve (coverage against evaluations) and a rate (evaluations per second).
//
//   build/bench/ite_archive TASK EVALUATIONS EVERY [--save-at=N1,N2,... --save-dir=DIR] [--cache-file]
//                          [key=value ...]
//   build/bench/ite_archive pendubot 200000 10000 threads=2
//   build/bench/ite_archive hexapod 40000 2000 threads=2
//   build/bench/ite_archive hexapod 800000 50000 --save-at=12600,50200,200200 --save-dir=a seed=1
//
// Prints one CSV row per report: evaluations, seconds (wall clock since the start),
// evaluations_per_s (over the last interval), filled, coverage, best_fitness; then a summary line
// on stderr. docs/benchmarks.md ("IT&E archive generation") holds the measured tables.
// --save-at writes the archive as it stands once it has at least N evaluations, as
// DIR/archive-M.csv, M its evaluations (the first batch boundary at or after N; the archive file
// of docs/ite.md, usable as `ite.archive`): MAP-Elites is an anytime algorithm, so one run gives
// the archives of every smaller budget M (the same archive as a run with budget M, tested). --cache-file prints, instead, the file in which ite.archive_cache
// keeps the archive of these settings (experiment::ite_archive_cache_file) and exits: the place
// to put such an archive so that `drops run` and `drops campaign` adapt with it.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "drops/algo/ite.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/archive_file.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"
#ifdef DROPS_WITH_HEXAPOD
#include "drops/hexapod/plugin.hpp"
#endif

using namespace drops;

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: ite_archive TASK EVALUATIONS EVERY [--save-at=N1,N2,... --save-dir=DIR] "
                 "[--cache-file] [key=value ...]\n";
    return 2;
  }
  use_single_threaded_blas();
  experiment::Registry registry;
  experiment::register_builtin_algorithms(registry);
  pendubot::register_task(registry);
#ifdef DROPS_WITH_HEXAPOD
  hexapod::register_task(registry);
#endif
  const long evaluations = std::atol(argv[2]);
  const long every = std::atol(argv[3]);
  std::vector<std::string> overrides = {std::string("task=") + argv[1], "algorithm=ite",
                                        "ite.evaluations=" + std::to_string(evaluations)};
  std::vector<long> save_at;
  bool print_cache_file = false;
  std::filesystem::path save_dir = ".";
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--save-at=", 0) == 0) {
      std::stringstream list(a.substr(10));
      for (std::string item; std::getline(list, item, ',');)
        save_at.push_back(std::atol(item.c_str()));
      std::sort(save_at.begin(), save_at.end());
    } else if (a == "--cache-file") {
      print_cache_file = true;
    } else if (a.rfind("--save-dir=", 0) == 0) {
      save_dir = a.substr(11);
    } else {
      overrides.emplace_back(a);
    }
  }
  if (!save_at.empty()) std::filesystem::create_directories(save_dir);
  const auto e =
      experiment::make_experiment(registry, experiment::load_settings(registry, "", overrides));
  if (print_cache_file) {
    std::cout << experiment::ite_archive_cache_file(e.settings, e.setup).string() << "\n";
    return 0;
  }
  ThreadLimit limit(e.threads);
  const algo::IteOptions o = experiment::ite_options(e.settings, e.setup);
  const algo::Problem problem = e.setup.problem();
  const int n = problem.policy->param_dim();
  ite::Archive archive(o.bins.empty() ? o.behaviour.bins : o.bins, n);
  ite::MapElitesOptions mo = o.map_elites;
  mo.seed = derive_seed(o.seed, {algo::kIteArchiveStream});  // as algo::Ite does
  const auto t0 = std::chrono::steady_clock::now();
  auto last_t = t0;
  long last_e = 0, next = every;
  std::cout << "evaluations,seconds,evaluations_per_s,filled,coverage,best_fitness\n";
  const experiment::ArchiveFileInfo file_info = experiment::archive_file_info(e.task, e.setup);
  std::size_t next_save = 0;
  auto save = [&](const ite::MapElitesProgress& p, const ite::Archive& a) {
    while (next_save < save_at.size() && p.cursor.evaluations >= save_at[next_save]) {
      experiment::ArchiveFileInfo info = file_info;
      info.complete = true;
      info.cursor = p.cursor;
      const auto file = save_dir / fmt::format("archive-{}.csv", p.cursor.evaluations);
      experiment::write_archive_file(file, a, info);
      std::cerr << fmt::format("wrote {} ({} evaluations)\n", file.string(), p.cursor.evaluations);
      ++next_save;
    }
  };
  auto report = [&](const ite::MapElitesProgress& p, const ite::Archive& a, bool force) {
    save(p, a);
    if (p.cursor.evaluations < next && !force) return;
    next = (p.cursor.evaluations / every + 1) * every;
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - t0).count();
    const double ds = std::chrono::duration<double>(now - last_t).count();
    std::cout << fmt::format("{},{:.2f},{:.1f},{},{:.6f},{:.6g}\n", p.cursor.evaluations, s,
                             (p.cursor.evaluations - last_e) / ds, a.size(), a.coverage(),
                             p.best_fitness)
              << std::flush;
    last_t = now;
    last_e = p.cursor.evaluations;
  };
  const auto summary = ite::run_map_elites(
      algo::prior_evaluation(problem, o.behaviour), VectorXd::Constant(n, -o.theta_bound),
      VectorXd::Constant(n, o.theta_bound), mo, archive,
      [&](const ite::MapElitesProgress& p, const ite::Archive& a) {
        report(p, a, p.cursor.evaluations >= evaluations);
        return true;
      });
  std::cerr << fmt::format("{} on {} (prior {}), {} threads: {:.1f} evaluations/s\n",
                           summary.BriefReport(), e.task, e.setup.prior_label,
                           e.threads ? e.threads : hardware_threads(),
                           summary.evaluations / summary.seconds);
  return 0;
}
