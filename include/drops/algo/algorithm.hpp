#pragma once
/// \file What every episodic learning algorithm of drops shares: the problem it is given, the
/// record of each real episode, the state that continues an interrupted run, the callbacks through
/// which a caller observes and steers it, and the Algorithm interface itself. Black-DROPS and its
/// variants (black_drops.hpp) and the direct search (direct_search.hpp) implement it; drops's
/// experiment layer writes every algorithm's episodes in one run-directory format.

#include <any>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/opt/cmaes.hpp"
#include "drops/policy/policy.hpp"
#include "drops/rollout/rollout.hpp"

namespace drops::algo {

/// What an algorithm learns on: the task, the real system, the policy family and, when the
/// algorithm uses one, the simulator prior with its parameters. Pointers are borrowed for the
/// duration of Algorithm::run.
struct Problem {
  std::shared_ptr<const rollout::Task> task;         ///< required
  const rollout::System* real = nullptr;             ///< required: the "real" system
  const policy::Policy* policy = nullptr;            ///< required: the prototype (parameters unset)
  std::shared_ptr<const model::MeanFunction> prior;  ///< may be null when the algorithm needs none
  model::PriorParameters prior_parameters;           ///< starting phi, tunable set and bounds
  /// Throws InvalidArgument when a required member is missing or the dimensions disagree.
  void check() const;
};

/// Facts an algorithm records beyond the common fields of an episode or a phase, as named numbers
/// and texts (summary.json "details"), e.g. PILCO's optimizer counts and the GP's size.
struct Details {
  std::map<std::string, double> numbers;
  std::map<std::string, std::string> texts;
  bool empty() const { return numbers.empty() && texts.empty(); }
};

/// A part of a run that is not a real episode and costs no interaction time, e.g. PILCO with
/// priors' simulation phase (PILCO run on the simulator before the first real episode). Reported
/// through Callbacks::on_phase once it ends, and a long phase also after each of its episodes
/// (complete = false, the episodes so far); summary.json keeps the last report under
/// "phases".<name>.
struct PhaseRecord {
  std::string name;               ///< e.g. "simulation"
  Details summary;                ///< about the whole phase (so far, when not complete)
  std::vector<Details> episodes;  ///< one entry per episode of the phase, in order
  bool complete = true;           ///< false while the phase runs
};

/// Everything recorded about one real episode. Complete when the on_episode callback receives it.
struct EpisodeRecord {
  int episode = 0;                  ///< 1-based
  double interaction_time = 0;      ///< cumulated real interaction time at the end of it, s
  rollout::Trajectory real;         ///< on the system
  rollout::Trajectory predicted;    ///< mean-propagated rollout on the model that chose the policy (empty without a model)
  VectorXd theta;                   ///< policy parameters run (dim param_dim)
  double real_return = 0;
  double predicted_return = 0;      ///< mean over predicted_rollouts MC rollouts (NaN without a model)
  /// Each of those Monte-Carlo rollouts' return, in rollout order (dim predicted_rollouts; empty
  /// without a model): the model's predictive distribution of the policy's return.
  VectorXd predicted_returns;
  /// theta is a policy already run on the system (the best so far, kept): its real return
  /// tests the model on data it has seen. Set for Black-DROPS.
  bool replay = false;
  bool solved = false;
  bool random_policy = false;       ///< episode 1 without a prior: random theta
  /// False when the caller need not keep this episode's trajectories and policy (e.g. a direct
  /// search's evaluations that did not improve on the best): its row is still recorded.
  bool keep_trajectories = true;
  VectorXd phi;                     ///< prior parameters of the model that chose the policy
  model::ModelSummary model;        ///< the learning that preceded this episode (empty for ep. 1)
  opt::CmaesSummary policy_search;  ///< the optimization that chose theta (empty if none)
  /// Where theta came from: "start" (the start policy was kept), "best_seen" (a best single
  /// evaluation), "run_mean" (a CMA-ES run's final mean), "random" (episode 1 without a prior),
  /// "candidate" (a direct search's candidate).
  std::string selected;
  /// The chosen policy's mean return over a re-evaluation (NaN when there was none).
  double reevaluated_return = std::numeric_limits<double>::quiet_NaN();
  int reevaluated_candidates = 0;   ///< size of the re-evaluated short list (0 if none)
  double model_seconds = 0;         ///< model learning time before this episode, s
  double policy_seconds = 0;        ///< policy optimization time, s
  long evaluations = 0;             ///< policy evaluations that chose theta (model rollouts / rollouts per eval; 1 for a direct search)
  long nonfinite_model_steps = 0;   ///< rollout steps stopped by non-finite model predictions
  /// Algorithm-specific facts of this episode (e.g. IT&E's cell and the mean M-BOA predicted for
  /// it, PILCO's optimizer counts); the run directory writes them in summary.json. May be empty.
  Details details;
};

/// Where an episode's real return falls in the model's predictive distribution of the policy's
/// return (its Monte-Carlo rollouts on the model that chose it): is the model calibrated?
struct Calibration {
  /// Mid-rank quantile of the real return among the predicted returns: (number below + half the
  /// number equal) / count, in [0, 1]; 0.5 when the model is right on average.
  double quantile = 0;
  /// The predicted returns' 5 % quantile, at the plotting position 0.05 (n + 1) between order
  /// statistics (Hyndman & Fan 1996, definition 6): a real return drawn from the model's
  /// predictive distribution falls inside [band_low, band_high] with probability about 0.90 for
  /// n >= 19 rollouts (definition 7, R's default, would give 0.9 (n - 1) / (n + 1): 81 % for
  /// n = 20).
  double band_low = 0;
  double band_high = 0;   ///< their 95 % quantile, at 0.95 (n + 1)
  bool inside_band = false;  ///< band_low <= real return <= band_high
  double gap = 0;         ///< predicted_return - real_return (> 0: the model was optimistic)
};

/// The calibration of an episode with predicted returns (rec.predicted_returns not empty), or
/// nullopt without them (no model predicted the episode). Thread-safe.
std::optional<Calibration> calibration(const EpisodeRecord& rec);

/// Named vectors: the form in which an algorithm's own state travels in a RunState and is stored
/// (checkpoint.json "extra", doubles exact). Each algorithm writes and reads its own entries
/// through a typed struct of its own (BlackDropsOwnState, IteTrials, PILCO's in pilco.cpp); no
/// other code reads them.
using StateVectors = std::map<std::string, VectorXd>;

/// An algorithm between two episodes: everything the next episodes depend on. episodes_done may be
/// 0 for an algorithm with work before its first episode (PILCO with priors saves its simulation
/// phase's results). Every random stream
/// is derived from (seed, episode, ...), so a run continued from the state saved after episode k
/// produces exactly the episodes k+1.. of an uninterrupted run (drops run --resume).
struct RunState {
  int episodes_done = 0;             ///< completed real episodes (>= 0)
  std::vector<Transition> data;      ///< every real transition so far, in order
  VectorXd best_theta;               ///< policy of the best real episode (empty before episode 1)
  double best_return = -std::numeric_limits<double>::infinity();  ///< its real return
  int first_solved_episode = 0;      ///< 0 when never solved
  model::ModelState model;           ///< the model's warm starts after the last learn()
  /// The algorithm's own state, serialised by its own struct (see StateVectors).
  StateVectors extra;
  /// The algorithm's own state that is kept in files of its own beside checkpoint.json rather
  /// than in it (large, or in a format users read), of a type the algorithm defines: IT&E's
  /// archive (algo::ArchiveState in ite.hpp, archive.csv). Empty for the other algorithms. The
  /// experiment layer's plugin of the algorithm saves and reads it (experiment::StateFiles); no
  /// other code looks inside. An algorithm may hand out a state with episodes_done = 0 and a side
  /// state (IT&E during and after its archive generation), so that a long generation is
  /// resumable too.
  std::any side_state;
};

/// Live status for progress displays.
struct Status {
  int episode = 0;                  ///< episode being prepared (1-based)
  /// "model", "policy", "archive" (MAP-Elites), "episode", "simulation" (PILCO with priors' policy
  /// search on the simulator) or "simulation episode" (once per simulated episode when it ends:
  /// `episode` is its number, `best` its return, `evaluations` its policy search's, `budget` the
  /// phase's episode count).
  std::string phase;
  long evaluations = 0;             ///< evaluations in this phase so far
  /// Best score in this phase (model score / predicted return / best fitness in the archive).
  double best = 0;
  long budget = 0;                  ///< the phase's budget of evaluations when known (0: unknown)
  /// Phase "archive": the filled fraction of the archive's cells, in [0, 1] (NaN otherwise).
  double coverage = std::numeric_limits<double>::quiet_NaN();
};

/// Hooks through which the caller observes and steers a run. All are called on the caller's thread.
struct Callbacks {
  /// After each real episode, with its full record. Persist it here.
  std::function<void(const EpisodeRecord&)> on_episode;
  /// Frequently during model learning and policy search.
  std::function<void(const Status&)> on_status;
  /// Polled often; returning true interrupts the run after the current step (nothing recorded
  /// is lost: on_episode has already been called for every finished episode).
  std::function<bool()> should_stop;
  /// After on_episode, with the state needed to continue the run from there. Persist it to
  /// make the run resumable.
  std::function<void(const RunState&)> on_state;
  /// When a phase that is not a real episode ends (PhaseRecord), before the next real episode.
  std::function<void(const PhaseRecord&)> on_phase;
};

/// Result of Algorithm::run.
struct RunSummary {
  int episodes_done = 0;
  bool interrupted = false;
  int first_solved_episode = 0;   ///< 0 when never solved
  double best_real_return = 0;
  double seconds = 0;             ///< wall-clock time of this call, s
  /// The whole-run search of an algorithm that has one (the direct search); empty otherwise.
  opt::CmaesSummary search;
  /// Algorithm-specific results (e.g. IT&E's archive coverage and trial count); the run
  /// directory writes them in summary.json. May be empty.
  Details details;
  /// One line: "12 episodes, best return 19.81, first solved at episode 4, 83.2 s".
  std::string BriefReport() const;
};

/// An episodic learning algorithm: it runs policies on the real system episode by episode and
/// reports each through the callbacks. Implementations are configured at construction (an
/// Options struct) and are immutable; run() is not reentrant (it uses drops::parallel_for).
class Algorithm {
 public:
  virtual ~Algorithm() = default;
  /// Short name, e.g. "black_drops", "direct".
  virtual std::string name() const = 0;
  /// Episodes the run is configured for (its budget of real episodes).
  virtual int episodes() const = 0;
  /// Whether run() accepts a resume state.
  virtual bool resumable() const { return true; }
  /// Runs on `problem`; with `resume` (a state from on_state of a run with the same options), it
  /// continues after resume->episodes_done. Throws InvalidArgument on a problem that does not fit
  /// or a resume state that does not fit (or is given to an algorithm that is not resumable);
  /// exceptions from callbacks propagate.
  virtual RunSummary run(const Problem& problem, const Callbacks& callbacks,
                         const RunState* resume = nullptr) const = 0;
};

}  // namespace drops::algo
