// The IT&E algorithm plugin (algorithm=ite): its ite.* keys, the options they give, the archive
// read from a file (ite.archive) or shared between runs (ite.archive_cache).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "drops/algo/ite.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/archive_file.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run_directory.hpp"
#include "experiment_plugins.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;
namespace {

/// The values of the ite.* keys: IT&E's options and what the plugin does with the others.
struct IteKeys {
  algo::IteOptions ite;       ///< (episodes, seed, theta_bound, behaviour and bins set elsewhere)
  std::string archive;        ///< ite.archive: an archive file to adapt with ("" = build one)
  std::string archive_cache;  ///< ite.archive_cache: a directory of archives ("" = none)
  int bins = 0;               ///< ite.bins: cells per descriptor dimension (0 = the task's grid)
  double checkpoint_minutes = ite.checkpoint_seconds / 60;  ///< ite.checkpoint_minutes
};

/// The ite.* keys that decide the archive MAP-Elites builds (the others only the adaptation, or
/// where the archive comes from).
KeyTable<IteKeys> make_archive_key_table() {
  KeyTable<IteKeys> t;
  const auto me = [](auto& k) -> auto& { return k.ite.map_elites; };
  t.add("ite.evaluations", [=](auto& k) -> auto& { return me(k).max_evaluations; })
      .range(1, 1e10)
      .help("algorithm ite: MAP-Elites' budget of prior episodes");
  t.add("ite.batch", [=](auto& k) -> auto& { return me(k).batch_size; })
      .range(2, 1e6)
      .help("algorithm ite: MAP-Elites' offspring per generation (batch_size / 2 pairs of "
            "parents), evaluated in parallel");
  t.add("ite.initial_population", [=](auto& k) -> auto& { return me(k).initial_population; })
      .range(1, 1e7)
      .help("algorithm ite: random individuals evaluated first");
  t.add("ite.bins", &IteKeys::bins)
      .optional()
      .range(1, 1000)
      .help("algorithm ite: cells per descriptor dimension (empty = the task's grid)");
  t.add("ite.mutation", [=](auto& k) -> auto& { return me(k).mutation; })
      .values({{"polynomial", ite::Mutation::kPolynomial},
               {"gaussian", ite::Mutation::kGaussian},
               {"resample", ite::Mutation::kResample}})
      .help("algorithm ite: MAP-Elites' mutation: polynomial (Deb's bounded), gaussian, or "
            "resample (genes on a grid of ite.grid_levels values, a mutated gene re-drawn, as the "
            "reference archive of Cully et al. 2015)");
  t.add("ite.mutation_rate", [=](auto& k) -> auto& { return me(k).mutation_rate; })
      .range(0, 1)
      .help("algorithm ite: probability that each gene of an offspring mutates");
  t.add("ite.polynomial_eta", [=](auto& k) -> auto& { return me(k).polynomial_eta; })
      .range(1e-3, 1e6)
      .help("algorithm ite: distribution index of the polynomial mutation (larger = smaller "
            "steps)");
  t.add("ite.gaussian_sigma", [=](auto& k) -> auto& { return me(k).gaussian_sigma; })
      .range(1e-6, 10)
      .help("algorithm ite: standard deviation of the gaussian mutation, as a fraction of the "
            "box");
  t.add("ite.grid_levels", [=](auto& k) -> auto& { return me(k).grid_levels; })
      .range(2, 1e6)
      .help("algorithm ite: values per gene of the resample mutation");
  t.add("ite.crossover_rate", [=](auto& k) -> auto& { return me(k).crossover_rate; })
      .range(0, 1)
      .help("algorithm ite: probability that a pair of parents is crossed (SBX) before mutation");
  t.add("ite.insertion", [=](auto& k) -> auto& { return me(k).insertion; })
      .values({{"strict", ite::InsertionRule::kStrict}, {"epsilon", ite::InsertionRule::kEpsilon}})
      .help("algorithm ite: an offspring replaces a cell's elite when strictly fitter, or by the "
            "reference's epsilon rule (ite.epsilon)");
  t.add("ite.epsilon", [=](auto& k) -> auto& { return me(k).epsilon; })
      .range(0, 1e9)
      .unit("return")
      .help("algorithm ite: epsilon of the insertion rule epsilon, in units of the return");
  return t;
}

/// Every ite.* key, each declared with the field of IteKeys it sets, in documentation order.
KeyTable<IteKeys> make_ite_key_table() {
  KeyTable<IteKeys> t;
  t.add("ite.archive", &IteKeys::archive)
      .help("algorithm ite: an archive file to adapt with (e.g. a run's archive.csv) instead of "
            "building one with MAP-Elites; its grid replaces ite.bins");
  t.add("ite.archive_cache", &IteKeys::archive_cache)
      .help("algorithm ite: a directory of archives shared by runs whose settings differ only in "
            "keys that do not change the archive (seed, task keys of the real system such as a "
            "damage, the adaptation's keys): a run loads the archive it would build when one is "
            "there, and puts the one it built there (empty = none)");
  t.include(make_archive_key_table(), [](auto& k) -> auto& { return k; });
  const auto mb = [](auto& k) -> auto& { return k.ite.mboa; };
  t.add("ite.length_scale", [=](auto& k) -> auto& { return mb(k).length_scale; })
      .range(1e-6, 100)
      .help("algorithm ite: M-BOA's Matern 5/2 length scale l in descriptor units ([0, 1] per "
            "dimension)");
  t.add("ite.signal_variance", [=](auto& k) -> auto& { return mb(k).signal_variance; })
      .range(1e-12, 1e12)
      .help("algorithm ite: M-BOA's kernel signal variance sigma_f^2, on the scaled performance");
  t.add("ite.noise_variance", [=](auto& k) -> auto& { return mb(k).noise_variance; })
      .range(1e-14, 1e12)
      .help("algorithm ite: M-BOA's observation-noise variance sigma_n^2, on the scaled "
            "performance");
  t.add("ite.kappa", [=](auto& k) -> auto& { return mb(k).kappa; })
      .range(0, 1e6)
      .help("algorithm ite: M-BOA's UCB exploration weight kappa (UCB = mu + kappa sigma)");
  t.add("ite.stop_ratio", [=](auto& k) -> auto& { return mb(k).stop_ratio; })
      .range(0, 1)
      .help("algorithm ite: stop when the best trial >= stop_ratio x the highest predicted mean "
            "(0 = only the trial budget, `episodes`)");
  t.add("ite.cell_points", [=](auto& k) -> auto& { return mb(k).use_cell_centres; })
      .values({{"descriptor", false}, {"centre", true}})
      .help("algorithm ite: where M-BOA's kernel places each cell: its elite's descriptor (the "
            "reference) or the cell centre");
  t.add("ite.performance_scale", [](auto& k) -> auto& { return k.ite.performance_scale; })
      .range(1e-9, 1e9)
      .unit("1/return")
      .help("algorithm ite: M-BOA works on performance = scale x return (prior mean: scale x "
            "archive fitness), so that the kernel and kappa keep the reference's scale");
  t.add("ite.observation_floor", [](auto& k) -> auto& { return k.ite.observation_floor; })
      .optional()
      .range(-1e12, 1e12)
      .unit("performance")
      .help("algorithm ite: M-BOA observes max(floor, performance) of each trial, as the "
            "reference (Cully et al. 2015) sets negative covered distances to 0 (empty = no "
            "floor; the recorded returns are not changed)");
  t.add("ite.after_stop", [](auto& k) -> auto& { return k.ite.after_stop; })
      .values({{"repeat_best", algo::IteAfterStop::kRepeatBest}, {"end", algo::IteAfterStop::kEnd}})
      .help("algorithm ite: once the stopping rule fired, run the best tested policy in each "
            "remaining episode (repeat_best: every run has `episodes` episodes), or end the run");
  t.add("ite.checkpoint_minutes", &IteKeys::checkpoint_minutes)
      .range(0, 1e6)
      .unit("min")
      .help("algorithm ite: the archive in progress is saved (archive.csv, checkpoint.json) at "
            "most this often during MAP-Elites, so that an interrupted generation resumes");
  return t;
}

const KeyTable<IteKeys>& ite_key_table() {
  static const KeyTable<IteKeys> t = make_ite_key_table();
  return t;
}

/// FNV-1a, 64 bits: the archive cache's key of a settings text (not for security).
std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

/// The file of the archive cache that holds the archive of these settings: every setting that can
/// change the archive (task, seed, policy.bound, MAP-Elites' ite.* keys, the task's keys but
/// those of its real system) goes into the hash.
fs::path cache_file(const Settings& s, const TaskSetup& setup) {
  std::set<std::string> ignored(setup.real_system_keys.begin(), setup.real_system_keys.end());
  for (const auto& k : base_keys())
    if (k.key != "task" && k.key != "seed" && k.key != "policy.bound") ignored.insert(k.key);
  static const std::vector<KeySpec> archive_keys = make_archive_key_table().specs();
  for (const auto& k : ite_key_table().specs())
    if (std::none_of(archive_keys.begin(), archive_keys.end(),
                     [&](const KeySpec& a) { return a.key == k.key; }))
      ignored.insert(k.key);
  std::string text;
  for (const auto& [k, v] : s)
    if (!ignored.count(k)) text += k + "=" + v + "\n";
  std::string prior = setup.prior_label;
  for (char& c : prior)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return fs::path(ite_key_table().read(s).archive_cache) /
         fmt::format("{}-{}-seed{}-{:016x}.csv", s.at("task"), prior, s.at("seed"), fnv1a(text));
}

/// IT&E that also puts the archive it completes into the archive cache (the experiment layer's
/// file I/O around the core algorithm).
class CachingIte final : public algo::Algorithm {
 public:
  CachingIte(const algo::IteOptions& options, fs::path file, ArchiveFileInfo info)
      : ite_(options), file_(std::move(file)), info_(std::move(info)) {}
  std::string name() const override { return ite_.name(); }
  int episodes() const override { return ite_.episodes(); }
  algo::RunSummary run(const algo::Problem& problem, const algo::Callbacks& callbacks,
                       const algo::RunState* resume) const override {
    algo::Callbacks c = callbacks;
    c.on_state = [&](const algo::RunState& st) {
      const algo::ArchiveState* a = algo::archive_state(st);
      if (a && a->complete && !fs::exists(file_)) {
        std::error_code ec;
        fs::create_directories(file_.parent_path(), ec);
        ArchiveFileInfo info = info_;
        info.cursor = a->cursor;
        write_archive_file(file_, *a->archive, info);  // atomic: a concurrent writer is harmless
      }
      if (callbacks.on_state) callbacks.on_state(st);
    };
    return ite_.run(problem, c, resume);
  }

 private:
  algo::Ite ite_;
  fs::path file_;
  ArchiveFileInfo info_;
};

/// IT&E's side state in the run directory: its archive (algo::ArchiveState) as archive.csv,
/// written before each checkpoint that carries another archive or the same one now complete, with
/// its MAP-Elites cursor; and archive_progress.csv, one row per MAP-Elites generation (status
/// phase "archive"): evaluations, seconds of the run, coverage, best fitness, UTC time
/// (docs/ite.md, "The run directory").
class IteStateFiles final : public StateFiles {
 public:
  explicit IteStateFiles(ArchiveFileInfo info) : info_(std::move(info)) {}

  std::vector<std::string> file_names() const override {
    return {"archive.csv", "archive_progress.csv"};
  }

  bool save(const std::any& side, const fs::path& dir, nlohmann::json* summary) override {
    const auto* a = std::any_cast<algo::ArchiveState>(&side);
    if (!a || !a->archive || (a->archive == written_ && a->complete == written_complete_))
      return false;
    ArchiveFileInfo info = info_;
    info.complete = a->complete;
    info.cursor = a->cursor;
    write_archive_file(dir / "archive.csv", *a->archive, info);
    written_ = a->archive;  // held, so that its address is not reused
    written_complete_ = a->complete;
    const auto number = [](double v) {
      return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
    };
    (*summary)["archive"] = {
        {"file", "archive.csv"},
        {"complete", a->complete},
        {"cells", a->archive->size()},
        {"total_cells", a->archive->total_cells()},
        {"coverage", a->archive->coverage()},
        {"best_fitness", a->archive->empty() ? nlohmann::json(nullptr)
                                             : number(a->archive->best().fitness)},
        {"evaluations", a->cursor.evaluations}};
    return true;
  }

  // archive.csv is not among the checkpoint's checksums: it is written before checkpoint.json and
  // carries its own MAP-Elites cursor, so one newer than the checkpoint (a crash between the two
  // writes) is continued from, not refused; its reader checks every line.
  bool load(const fs::path& dir, std::any* side, std::vector<std::string>* repairs) override {
    if (!fs::exists(dir / "archive.csv")) return false;
    ArchiveFile file;
    try {
      file = read_archive_file(dir / "archive.csv");
    } catch (const std::exception& ex) {
      throw RunDirectoryDamaged(std::string(ex.what()) +
                                ": restore the file or start the run again");
    }
    *side = algo::ArchiveState{file.archive, file.info.complete, file.info.cursor};
    written_ = file.archive;
    written_complete_ = file.info.complete;
    // archive_progress.csv may run past the archive's cursor (rows of generations the resumed
    // run evaluates again): keep its rows up to the cursor.
    const fs::path progress = dir / "archive_progress.csv";
    if (!fs::exists(progress)) return true;
    std::istringstream in(read_file_text(progress));
    std::string line, kept;
    std::size_t dropped = 0;
    for (bool header = true; std::getline(in, line); header = false) {
      // A whole row has 5 fields and ends with the time (a crash may have cut the last one).
      const bool whole = std::count(line.begin(), line.end(), ',') == 4 && line.back() == 'Z';
      if (header || (whole && std::atol(line.c_str()) <= file.info.cursor.evaluations))
        kept += line + "\n";
      else
        ++dropped;
    }
    if (dropped > 0) {
      write_file_atomically(progress, kept);
      repairs->push_back(fmt::format("removed {} row{} of archive_progress.csv past the archive's "
                                     "{} evaluations",
                                     dropped, dropped == 1 ? "" : "s",
                                     file.info.cursor.evaluations));
    }
    return true;
  }

  void on_status(const algo::Status& status, double seconds, const fs::path& dir) override {
    if (status.phase != "archive") return;
    const fs::path path = dir / "archive_progress.csv";
    // Also a file left empty by a crash before its header was written.
    const bool fresh = !fs::exists(path) || fs::file_size(path) == 0;
    std::ofstream out(path, std::ios::app);
    if (fresh) out << "evaluations,seconds,coverage,best_fitness,utc\n";
    // A non-finite number (no elite yet) is an empty field, which CSV readers take as missing.
    const auto field = [](double v) { return std::isfinite(v) ? fmt::format("{:.10g}", v) : ""; };
    out << fmt::format("{},{:.3f},{},{},{}\n", status.evaluations, seconds,
                       field(status.coverage), field(status.best), now_iso());
    out.flush();
    if (!out) throw Error("cannot write " + path.string());
  }

 private:
  ArchiveFileInfo info_;
  std::shared_ptr<const ite::Archive> written_;  ///< last written to or read from archive.csv
  bool written_complete_ = false;                ///< whether it was complete then
};

class ItePlugin final : public AlgorithmPlugin {
 public:
  std::string name() const override { return "ite"; }
  std::string description() const override {
    return "IT&E (Cully et al., Nature 2015): a MAP-Elites archive of policies built on the "
           "task's simulator prior at its starting parameters (or read from ite.archive), then "
           "M-BOA on the real system, one episode per trial, until its stopping rule or "
           "`episodes` trials (docs/ite.md). Needs a task with a behaviour descriptor";
  }
  std::vector<KeySpec> keys() const override { return ite_key_table().specs(); }
  std::string variant(const Settings&) const override { return "ite"; }
  VariantStyle variant_style(const Settings&) const override { return {"IT&E", 4, "#9467bd"}; }
  bool uses_prior(const Settings&) const override { return true; }
  std::unique_ptr<algo::Algorithm> make(const Settings& s, const TaskSetup& setup) const override {
    algo::IteOptions o = ite_options(s, setup);
    const std::string cache = ite_key_table().read(s).archive_cache;
    if (cache.empty() || o.archive) return std::make_unique<algo::Ite>(o);
    const fs::path file = cache_file(s, setup);
    if (fs::exists(file)) {
      const ArchiveFile f = read_archive_file(file);
      if (f.info.complete) {
        o.archive = f.archive;
        o.archive_cursor = f.info.cursor;
        return std::make_unique<algo::Ite>(o);
      }
    }
    return std::make_unique<CachingIte>(o, file, archive_file_info(s.at("task"), setup));
  }
  StateFilesFactory state_files(const Settings& s, const TaskSetup& setup) const override {
    return [info = archive_file_info(s.at("task"), setup)] {
      return std::make_unique<IteStateFiles>(info);
    };
  }
};

}  // namespace

fs::path ite_archive_cache_file(const Settings& settings, const TaskSetup& setup) {
  if (ite_key_table().read(settings).archive_cache.empty())
    throw ConfigError("config key 'ite.archive_cache' is empty: no archive cache to name a file in");
  return cache_file(settings, setup);
}

const ite::BehaviourDescriptor* task_behaviour(const TaskSetup& setup) {
  return setup.algorithm_data.find<ite::BehaviourDescriptor>("ite");
}

algo::IteOptions ite_options(const Settings& s, const TaskSetup& setup) {
  const std::string task = s.at("task");
  const ite::BehaviourDescriptor* behaviour = task_behaviour(setup);
  if (!behaviour)
    throw ConfigError("config key 'algorithm' = 'ite': the task '" + task +
                      "' has no behaviour descriptor for IT&E's archive; choose another "
                      "algorithm or give the task one (an ite::BehaviourDescriptor under "
                      "\"ite\" in TaskSetup::algorithm_data)");
  const IteKeys keys = ite_key_table().read(s);
  const algo::BlackDropsOptions base = base_options(s).black_drops;
  algo::IteOptions o = keys.ite;
  o.episodes = base.episodes;
  o.seed = base.seed;
  o.theta_bound = base.search.theta_bound;
  o.behaviour = *behaviour;
  try {
    o.behaviour.check();
  } catch (const InvalidArgument& e) {
    throw ConfigError("task '" + task + "': " + e.what());
  }
  if (keys.bins > 0) o.bins.assign(behaviour->bins.size(), keys.bins);
  o.checkpoint_seconds = 60 * keys.checkpoint_minutes;

  const std::string& path = keys.archive;
  if (!path.empty()) {
    const std::string key = "config key 'ite.archive' = '" + path + "': ";
    ArchiveFile f;
    try {
      f = read_archive_file(path);
    } catch (const Error& e) {
      throw ConfigError(key + e.what());
    }
    if (!f.info.complete)
      throw ConfigError(key + "a snapshot of a MAP-Elites run in progress (" +
                        std::to_string(f.info.cursor.evaluations) +
                        " evaluations), not a finished archive; resume that run first");
    const auto k = static_cast<int>(behaviour->bins.size());
    if (f.archive->descriptor_dim() != k)
      throw ConfigError(key + fmt::format("the archive has {} descriptor dimensions; the task "
                                          "'{}' has {}",
                                          f.archive->descriptor_dim(), task, k));
    if (f.archive->param_dim() != setup.policy->param_dim())
      throw ConfigError(key + fmt::format("the archive's policies have {} parameters; the task's "
                                          "policy has {}",
                                          f.archive->param_dim(), setup.policy->param_dim()));
    if (!f.info.task.empty() && f.info.task != task)
      throw ConfigError(key + "the archive was built for the task '" + f.info.task +
                        "', not '" + task + "'");
    if (keys.bins > 0 && f.archive->bins() != o.bins)
      throw ConfigError(key + "its grid differs from ite.bins = " + s.at("ite.bins") +
                        "; leave ite.bins empty (the archive's grid is used)");
    if (f.archive->empty()) throw ConfigError(key + "the archive holds no elite");
    o.archive = f.archive;
    o.archive_cursor = f.info.cursor;
  }
  std::string why;
  if (!o.IsValid(&why)) throw ConfigError("config: ite: " + why);
  return o;
}

std::unique_ptr<AlgorithmPlugin> make_ite_plugin() { return std::make_unique<ItePlugin>(); }

}  // namespace drops::experiment
