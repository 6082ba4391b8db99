#pragma once
/// \file IT&E (Intelligent Trial and Error; Cully, Clune, Tarapore & Mouret, Nature 2015) as a drops
/// algorithm, read top-down in Ite::run(): a MAP-Elites archive of policies built on the task's
/// simulator prior (or given), then M-BOA on the real system, one recorded real episode per trial
/// (baselines.md §3; docs/ite.md).

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/algorithm.hpp"
#include "drops/ite/archive.hpp"
#include "drops/ite/behaviour.hpp"
#include "drops/ite/map_elites.hpp"
#include "drops/ite/mboa.hpp"

namespace drops::algo {

/// What IT&E does with the episodes left once M-BOA's stopping rule has fired.
enum class IteAfterStop {
  /// Run the best tested policy again in each remaining episode (the robot keeps the behaviour it
  /// adapted to; every run then has `episodes` episodes, so reports compare it episode by episode
  /// with the other algorithms).
  kRepeatBest,
  /// End the run: it has as many episodes as M-BOA's trials.
  kEnd,
};

/// Options of Ite. Defaults: MAP-Elites' and M-BOA's own (map_elites.hpp, mboa.hpp: the reference
/// settings of Cully et al. 2015), which the command line sets per task from the ite.* keys.
struct IteOptions {
  /// Real episodes in all (>= 1): M-BOA's trial budget, then repeats of the best tested policy
  /// (after_stop).
  int episodes = 10;
  /// The run's seed: MAP-Elites draws from derive_seed(seed, {kIteArchiveStream}), real episode e
  /// from derive_seed(seed, {e, kIteRealEpisodeStream}).
  std::uint64_t seed = 1;
  /// MAP-Elites searches theta in the box [-b, b]^n (n = the policy's parameters), b > 0.
  double theta_bound = 5.0;
  /// The task's behaviour space (required: IT&E needs a descriptor).
  ite::BehaviourDescriptor behaviour;
  /// Cells per descriptor dimension (dim k, each >= 1); empty: behaviour.bins.
  std::vector<int> bins;
  /// MAP-Elites' settings (budget max_evaluations, batch, mutation, insertion...); seed and
  /// parallel are set by the run (evaluations always run in parallel).
  ite::MapElitesOptions map_elites;
  /// A given archive (e.g. read from a file): no MAP-Elites. Its grid replaces `bins`; its
  /// descriptor dimension must be the behaviour's and its param_dim the policy's. Null: build one.
  std::shared_ptr<const ite::Archive> archive;
  /// Where the MAP-Elites run that built the given archive stood (its file's cursor; empty when
  /// unknown): recorded with the archive (ArchiveState::cursor, summary.json), not used.
  ite::MapElitesCursor archive_cursor;
  /// M-BOA's settings (length scale, signal and noise variance, kappa, stop ratio, cell points);
  /// max_trials is set to `episodes`. Its variances and kappa apply to the scaled performance.
  ite::MboaOptions mboa;
  /// M-BOA works on performance = performance_scale * return (> 0): its prior mean is the scaled
  /// archive fitness and its observations the scaled real returns, so that a task whose returns
  /// are not in the reference's metres ([0, 2.5]) can keep the reference's kernel and kappa
  /// (baselines.md §3c).
  double performance_scale = 1.0;
  /// M-BOA observes max(observation_floor, performance_scale * return) (not NaN; -inf: no floor).
  /// The reference (Cully et al. 2015) observes the covered distance and sets negative values to
  /// 0 (baselines.md §3b), so a fall counts as no progress; without a floor a task whose return
  /// penalises falls heavily (e.g. -10 per tipped step) lets one fall pull the
  /// predicted performance of every cell far below the archive's range (docs/ite.md). The
  /// recorded real returns are not changed.
  double observation_floor = -std::numeric_limits<double>::infinity();
  /// What happens once the stopping rule fired.
  IteAfterStop after_stop = IteAfterStop::kRepeatBest;
  /// During MAP-Elites, on_state receives the archive so far at most every checkpoint_seconds
  /// (wall clock; >= 0; 0: after every batch), and once more when the run is stopped, so that an
  /// interrupted generation resumes where it stopped. The results do not depend on it.
  double checkpoint_seconds = 300;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Stream tags of Ite (derive_seed paths).
inline constexpr std::uint64_t kIteArchiveStream = 0x17E0A;      ///< {tag}: MAP-Elites' seed
inline constexpr std::uint64_t kIteRealEpisodeStream = 0x17E0E;  ///< {episode, tag}

/// IT&E's MAP-Elites archive, built, being built or given, with where its generation stands: Ite's
/// side state (RunState::side_state), which the run directory saves beside the checkpoint as
/// archive.csv (experiment/archive_file.hpp), not inside checkpoint.json.
struct ArchiveState {
  std::shared_ptr<const ite::Archive> archive;  ///< never null in a state Ite hands out
  /// True once the archive is final (MAP-Elites used its budget, or the archive was given).
  bool complete = false;
  /// Where the MAP-Elites run that builds it stands: with `archive`, what continues it exactly.
  ite::MapElitesCursor cursor;
};

/// The archive a state carries (its side_state), or null when it carries none. Throws
/// drops::Error when its side state is of another algorithm's type. Thread-safe.
const ArchiveState* archive_state(const RunState& state);

/// IT&E's adaptation so far, its own part of a RunState (in RunState::extra; the archive travels
/// as its side state, ArchiveState): every trial in order. Written and read only by Ite.
struct IteTrials {
  std::vector<std::int64_t> cells;  ///< linear cell index of each trial (Archive::cell_from_linear)
  std::vector<double> returns;      ///< its real return
  /// Its entries of RunState::extra.
  StateVectors save() const;
  /// Reads it back from RunState::extra. Throws InvalidArgument when an entry is missing, the two
  /// differ in length or a cell index is not a non-negative integer. Thread-safe.
  static IteTrials load(const StateVectors& extra);
};

/// IT&E behind the Algorithm interface:
///   1. the archive: the resumed one, the given one (options.archive), or MAP-Elites on the prior
///      at the starting phi, each evaluation one deterministic episode of the prior
///      (prior_evaluation): fitness = its return, descriptor and alive from the task;
///   2. the adaptation: M-BOA over the archive's cells, each trial a real episode of the cell's
///      elite (recorded through on_episode like any episode), until the stopping rule or
///      `episodes` trials; then after_stop.
/// on_state receives the archive (ArchiveState, the state's side_state) during its generation,
/// once it is complete (episodes_done = 0), and after each episode with the trials so far
/// (RunState::extra), so that the run resumes exactly. Progress of the generation goes to on_status (phase "archive").
/// The same seed gives the same archive and the same trials whatever the thread count.
class Ite final : public Algorithm {
 public:
  /// Throws InvalidArgument when options are invalid (the reason from IsValid).
  explicit Ite(const IteOptions& options);
  std::string name() const override { return "ite"; }
  int episodes() const override { return options_.episodes; }
  /// Throws InvalidArgument when the problem has no prior and no archive is given, the behaviour
  /// space or a given archive does not fit the policy, or the resume state does not fit.
  RunSummary run(const Problem& problem, const Callbacks& callbacks,
                 const RunState* resume = nullptr) const override;
  const IteOptions& options() const { return options_; }

 private:
  IteOptions options_;
};

/// The evaluation function MAP-Elites runs on the prior: theta -> one episode of the policy with
/// parameters theta on the prior alone at problem.prior_parameters.values, wrapped as a
/// deterministic rollout::System (mean propagation; the stream is not used), with fitness = the
/// episode's return, descriptor = behaviour.describe(trajectory), alive = behaviour.alive (when
/// set). An episode the prior could not finish (a non-finite state) gets a NaN fitness and
/// descriptor, which MAP-Elites counts as invalid. The returned function is thread-safe and keeps
/// `problem`'s objects by pointer: they must outlive it. Throws InvalidArgument when the problem
/// has no prior or the behaviour space is invalid.
ite::EvaluationFunction prior_evaluation(const Problem& problem,
                                         const ite::BehaviourDescriptor& behaviour);

/// The episode of `theta` (dim param_dim) on the prior alone at the starting phi (as in
/// prior_evaluation). Throws InvalidArgument on a size mismatch or a problem without a prior.
rollout::Trajectory prior_episode(const Problem& problem, const VectorXd& theta);

}  // namespace drops::algo
