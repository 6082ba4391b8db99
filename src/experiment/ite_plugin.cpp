// The IT&E algorithm plugin (algorithm=ite): its ite.* keys, the options they give, the archive
// read from a file (ite.archive) or shared between runs (ite.archive_cache).
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <set>

#include "drops/algo/ite.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/archive_file.hpp"
#include "drops/experiment/experiment.hpp"
#include "experiment_plugins.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;
namespace {

std::string num(double v) { return fmt::format("{}", v); }

/// The ite.* keys that decide the archive MAP-Elites builds (the rest only the adaptation).
const std::vector<std::string> kArchiveKeys = {
    "ite.evaluations", "ite.batch",     "ite.initial_population", "ite.bins",
    "ite.mutation",    "ite.mutation_rate", "ite.polynomial_eta", "ite.gaussian_sigma",
    "ite.grid_levels", "ite.crossover_rate", "ite.insertion",     "ite.epsilon"};

std::vector<KeySpec> ite_keys() {
  const ite::MapElitesOptions me;
  const ite::MboaOptions mb;
  const algo::IteOptions io;
  std::vector<KeySpec> s;
  auto add = [&](KeySpec k) { s.push_back(std::move(k)); };
  add({"ite.archive", "string", "", 0, 0, {}, "-",
       "algorithm ite: an archive file to adapt with (e.g. a run's archive.csv) instead of "
       "building one with MAP-Elites; its grid replaces ite.bins"});
  add({"ite.archive_cache", "string", "", 0, 0, {}, "-",
       "algorithm ite: a directory of archives shared by runs whose settings differ only in keys "
       "that do not change the archive (seed, task keys of the real system such as a damage, the "
       "adaptation's keys): a run loads the archive it would build when one is there, and puts "
       "the one it built there (empty = none)"});
  add({"ite.evaluations", "int", "", 1, 1e10, {}, "-",
       "algorithm ite: MAP-Elites' budget of prior episodes (empty = the task's value, else " +
           num(static_cast<double>(me.max_evaluations)) + ")"});
  add({"ite.batch", "int", num(me.batch_size), 2, 1e6, {}, "-",
       "algorithm ite: MAP-Elites' offspring per generation (batch_size / 2 pairs of parents), "
       "evaluated in parallel"});
  add({"ite.initial_population", "int", num(me.initial_population), 1, 1e7, {}, "-",
       "algorithm ite: random individuals evaluated first"});
  add({"ite.bins", "int", "", 1, 1000, {}, "-",
       "algorithm ite: cells per descriptor dimension (empty = the task's grid)"});
  add({"ite.mutation", "enum", "", 0, 0, {"polynomial", "gaussian", "resample"}, "-",
       "algorithm ite: MAP-Elites' mutation: polynomial (Deb's bounded), gaussian, or resample "
       "(genes on a grid of ite.grid_levels values, a mutated gene re-drawn, as the reference "
       "archive of Cully et al. 2015) (empty = the task's, else polynomial)"});
  add({"ite.mutation_rate", "double", "", 0, 1, {}, "-",
       "algorithm ite: probability that each gene of an offspring mutates (empty = the task's, "
       "else " + num(me.mutation_rate) + ")"});
  add({"ite.polynomial_eta", "double", num(me.polynomial_eta), 1e-3, 1e6, {}, "-",
       "algorithm ite: distribution index of the polynomial mutation (larger = smaller steps)"});
  add({"ite.gaussian_sigma", "double", num(me.gaussian_sigma), 1e-6, 10, {}, "-",
       "algorithm ite: standard deviation of the gaussian mutation, as a fraction of the box"});
  add({"ite.grid_levels", "int", num(me.grid_levels), 2, 1e6, {}, "-",
       "algorithm ite: values per gene of the resample mutation"});
  add({"ite.crossover_rate", "double", num(me.crossover_rate), 0, 1, {}, "-",
       "algorithm ite: probability that a pair of parents is crossed (SBX) before mutation"});
  add({"ite.insertion", "enum", "strict", 0, 0, {"strict", "epsilon"}, "-",
       "algorithm ite: an offspring replaces a cell's elite when strictly fitter, or by the "
       "reference's epsilon rule (ite.epsilon)"});
  add({"ite.epsilon", "double", num(me.epsilon), 0, 1e9, {}, "return",
       "algorithm ite: epsilon of the insertion rule epsilon, in units of the return"});
  add({"ite.length_scale", "double", num(mb.length_scale), 1e-6, 100, {}, "-",
       "algorithm ite: M-BOA's Matern 5/2 length scale l in descriptor units ([0, 1] per "
       "dimension)"});
  add({"ite.signal_variance", "double", num(mb.signal_variance), 1e-12, 1e12, {}, "-",
       "algorithm ite: M-BOA's kernel signal variance sigma_f^2, on the scaled performance"});
  add({"ite.noise_variance", "double", num(mb.noise_variance), 1e-14, 1e12, {}, "-",
       "algorithm ite: M-BOA's observation-noise variance sigma_n^2, on the scaled performance"});
  add({"ite.kappa", "double", num(mb.kappa), 0, 1e6, {}, "-",
       "algorithm ite: M-BOA's UCB exploration weight kappa (UCB = mu + kappa sigma)"});
  add({"ite.stop_ratio", "double", num(mb.stop_ratio), 0, 1, {}, "-",
       "algorithm ite: stop when the best trial >= stop_ratio x the highest predicted mean "
       "(0 = only the trial budget, `episodes`)"});
  add({"ite.cell_points", "enum", "descriptor", 0, 0, {"descriptor", "centre"}, "-",
       "algorithm ite: where M-BOA's kernel places each cell: its elite's descriptor (the "
       "reference) or the cell centre"});
  add({"ite.performance_scale", "double", "", 1e-9, 1e9, {}, "1/return",
       "algorithm ite: M-BOA works on performance = scale x return (prior mean: scale x archive "
       "fitness), so that the kernel and kappa keep the reference's scale (empty = the task's, "
       "else " + num(io.performance_scale) + ")"});
  add({"ite.observation_floor", "double", "", -1e12, 1e12, {}, "performance",
       "algorithm ite: M-BOA observes max(floor, performance) of each trial, as the reference "
       "(Cully et al. 2015) sets negative covered distances to 0 (empty = the task's, else no floor; the "
       "recorded returns are not changed)"});
  add({"ite.after_stop", "enum", "repeat_best", 0, 0, {"repeat_best", "end"}, "-",
       "algorithm ite: once the stopping rule fired, run the best tested policy in each "
       "remaining episode (repeat_best: every run has `episodes` episodes), or end the run"});
  add({"ite.checkpoint_minutes", "double", num(io.checkpoint_seconds / 60), 0, 1e6, {}, "min",
       "algorithm ite: the archive in progress is saved (archive.csv, checkpoint.json) at most "
       "this often during MAP-Elites, so that an interrupted generation resumes"});
  return s;
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
  for (const auto& k : ite_keys())
    if (std::find(kArchiveKeys.begin(), kArchiveKeys.end(), k.key) == kArchiveKeys.end())
      ignored.insert(k.key);
  std::string text;
  for (const auto& [k, v] : s)
    if (!ignored.count(k)) text += k + "=" + v + "\n";
  std::string prior = setup.prior_label;
  for (char& c : prior)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return fs::path(s.at("ite.archive_cache")) /
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
      const auto& a = st.archive;
      if (a.archive && a.complete && !fs::exists(file_)) {
        std::error_code ec;
        fs::create_directories(file_.parent_path(), ec);
        ArchiveFileInfo info = info_;
        info.cursor = a.cursor;
        write_archive_file(file_, *a.archive, info);  // atomic: a concurrent writer is harmless
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

class ItePlugin final : public AlgorithmPlugin {
 public:
  std::string name() const override { return "ite"; }
  std::string description() const override {
    return "IT&E (Cully et al., Nature 2015): a MAP-Elites archive of policies built on the "
           "task's simulator prior at its starting parameters (or read from ite.archive), then "
           "M-BOA on the real system, one episode per trial, until its stopping rule or "
           "`episodes` trials (docs/ite.md). Needs a task with a behaviour descriptor";
  }
  std::vector<KeySpec> keys() const override { return ite_keys(); }
  std::string variant(const Settings&) const override { return "ite"; }
  VariantStyle variant_style(const Settings&) const override { return {"IT&E", 4, "#9467bd"}; }
  bool uses_prior(const Settings&) const override { return true; }
  std::unique_ptr<algo::Algorithm> make(const Settings& s, const TaskSetup& setup) const override {
    algo::IteOptions o = ite_options(s, setup);
    const std::string cache = s.at("ite.archive_cache");
    if (cache.empty() || o.archive) return std::make_unique<algo::Ite>(o);
    const fs::path file = cache_file(s, setup);
    if (fs::exists(file)) {
      const ArchiveFile f = read_archive_file(file);
      if (f.info.complete) {
        o.archive = f.archive;
        return std::make_unique<algo::Ite>(o);
      }
    }
    return std::make_unique<CachingIte>(o, file, archive_file_info(s.at("task"), setup));
  }
};

}  // namespace

algo::IteOptions ite_options(const Settings& s, const TaskSetup& setup) {
  const std::string task = s.at("task");
  if (!setup.behaviour.available())
    throw ConfigError("config key 'algorithm' = 'ite': the task '" + task +
                      "' has no behaviour descriptor for IT&E's archive; choose another "
                      "algorithm or give the task one (TaskSetup::behaviour)");
  algo::IteOptions o;
  o.episodes = static_cast<int>(get_int(s, "episodes"));
  o.seed = static_cast<std::uint64_t>(get_int(s, "seed"));
  o.theta_bound = get_double(s, "policy.bound");
  o.behaviour = setup.behaviour;
  try {
    o.behaviour.check();
  } catch (const InvalidArgument& e) {
    throw ConfigError("task '" + task + "': " + e.what());
  }
  auto& me = o.map_elites;
  if (!s.at("ite.evaluations").empty()) me.max_evaluations = get_int(s, "ite.evaluations");
  me.batch_size = static_cast<int>(get_int(s, "ite.batch"));
  me.initial_population = static_cast<int>(get_int(s, "ite.initial_population"));
  if (!s.at("ite.bins").empty())
    o.bins.assign(setup.behaviour.bins.size(), static_cast<int>(get_int(s, "ite.bins")));
  const std::string mutation = s.at("ite.mutation");
  me.mutation = mutation == "gaussian"   ? ite::Mutation::kGaussian
                : mutation == "resample" ? ite::Mutation::kResample
                                         : ite::Mutation::kPolynomial;
  if (!s.at("ite.mutation_rate").empty()) me.mutation_rate = get_double(s, "ite.mutation_rate");
  me.polynomial_eta = get_double(s, "ite.polynomial_eta");
  me.gaussian_sigma = get_double(s, "ite.gaussian_sigma");
  me.grid_levels = static_cast<int>(get_int(s, "ite.grid_levels"));
  me.crossover_rate = get_double(s, "ite.crossover_rate");
  me.insertion = s.at("ite.insertion") == "epsilon" ? ite::InsertionRule::kEpsilon
                                                    : ite::InsertionRule::kStrict;
  me.epsilon = get_double(s, "ite.epsilon");
  auto& mb = o.mboa;
  mb.length_scale = get_double(s, "ite.length_scale");
  mb.signal_variance = get_double(s, "ite.signal_variance");
  mb.noise_variance = get_double(s, "ite.noise_variance");
  mb.kappa = get_double(s, "ite.kappa");
  mb.stop_ratio = get_double(s, "ite.stop_ratio");
  mb.use_cell_centres = s.at("ite.cell_points") == "centre";
  if (!s.at("ite.performance_scale").empty())
    o.performance_scale = get_double(s, "ite.performance_scale");
  if (!s.at("ite.observation_floor").empty())
    o.observation_floor = get_double(s, "ite.observation_floor");
  o.after_stop = s.at("ite.after_stop") == "end" ? algo::IteAfterStop::kEnd
                                                 : algo::IteAfterStop::kRepeatBest;
  o.checkpoint_seconds = 60 * get_double(s, "ite.checkpoint_minutes");

  const std::string path = s.at("ite.archive");
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
    const auto k = static_cast<int>(setup.behaviour.bins.size());
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
    if (!s.at("ite.bins").empty() && f.archive->bins() != o.bins)
      throw ConfigError(key + "its grid differs from ite.bins = " + s.at("ite.bins") +
                        "; leave ite.bins empty (the archive's grid is used)");
    if (f.archive->empty()) throw ConfigError(key + "the archive holds no elite");
    o.archive = f.archive;
  }
  std::string why;
  if (!o.IsValid(&why)) throw ConfigError("config: ite: " + why);
  return o;
}

std::unique_ptr<AlgorithmPlugin> make_ite_plugin() { return std::make_unique<ItePlugin>(); }

}  // namespace drops::experiment
