#pragma once
/// \file Model learning from recorded logs, without a policy search (issue 68, `drops identify`):
/// the logs read and resampled (recorded_log.hpp), one of the model variants (model.type: gp,
/// gp_prior, gp_mi, mi, or one's own) learned on the fit logs, then measured on the validation
/// logs by one-step and open-loop multi-step prediction errors. The C++ API under the command
/// line's `drops identify` and Python's drops.identify; docs/identify.md says the same for users.
///
/// The method (identify()):
///  1. The fit logs are resampled to options.log.dt; their transitions, in file and time order,
///     are the data. With options.max_points > 0 and N > max_points transitions, the model
///     learns from the evenly spaced subset model::subsample(N, max_points) (rows floor(k N /
///     max_points)): both GP-MI's search of phi (which subsamples further to
///     model.gp_mi.max_points) and the final kernel fits see only that subset, so the final
///     fit's cost is bounded (O(E m^3) per Rprop iteration for m = max_points).
///  2. The model learns once (DynamicsModel::learn), reporting its phases through `progress`.
///  3. Validation, per validation file: start points every options.start_spacing s from each
///     segment's first state (k_j = j round(start_spacing / dt)); from each, the recorded
///     actions are replayed open-loop through the model's mean (x^_{k+1} = x^_k + mean(x^_k,
///     u_k), open_loop_rollout) for each horizon h (round(h / dt) steps, >= 1); a start whose
///     horizon runs past its segment's end is not counted. The error of state dim i is
///     |x^_{k+n,i} - x_{k+n,i}| (the state's units), summarised over the start points by its
///     median and 90th percentile (linear interpolation between order statistics, numpy's
///     default). One-step errors: the same with one step from every state (PredictionErrors::
///     horizon = dt, every transition a start). A prediction that is not finite counts as an
///     infinite error.
///  4. The same errors of the prior alone at the starting phi (when the model uses a prior): the
///     baseline the learned model is to beat.
///
/// Threads: ThreadLimit(options.threads) while identify() runs. Every step is deterministic
/// (Rprop, Subplex and the subsample draw no random numbers), so the result does not depend on
/// options.seed or on the thread count; the seed is recorded for a model of one's own that draws.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/recorded_log.hpp"
#include "drops/model/dynamics_model.hpp"

namespace drops::experiment {

/// The model's input features, without a whole Task: the GP input is [observe(x), u].
struct InputFeatures {
  /// O, the dimension of observe's output; 0: the raw state is the input (observe unused).
  int dim = 0;
  /// obs (dim O) of a raw state x (dim E). Must be thread-safe.
  std::function<void(const VectorXd& x, Eigen::Ref<VectorXd> obs)> observe;
};

/// A Task that carries only what a model reads (state_dim, action_dim, dt, observe): reward 0,
/// horizon 1, initial state 0, never solved. For learning a model (model::make_model, a
/// ModelFactory) from recorded data, where no reward or episode exists. Throws InvalidArgument
/// unless state_dim >= 1, action_dim >= 1, dt > 0 and features.dim >= 0 (with an observe
/// function when dim > 0). Thread-safe (immutable).
std::shared_ptr<const Task> feature_task(int state_dim, int action_dim, double dt,
                                         InputFeatures features = {});

/// What identify() learns: the model variant, its features, the prior and its parameters.
struct IdentifyModel {
  /// The variant's name (model.type), for reports and the saved model.
  std::string type = "gp_mi";
  /// Builds the model (a registered ModelVariant's factory); empty: model::make_model of
  /// options.type.
  algo::ModelFactory factory;
  /// Whether the model uses the prior (ModelVariant::uses_prior; without a factory,
  /// model::uses_prior(options.type)).
  bool uses_prior = true;
  model::ModelOptions options = algo::black_drops_model_defaults();
  /// The model's inputs (a task's observe, or feature_task). Its dt must equal the logs' dt and
  /// its dimensions the logs' (checked).
  std::shared_ptr<const Task> task;
  /// The simulator prior M(x, u; phi) (required when the model uses one) and its parameters.
  std::shared_ptr<const model::MeanFunction> prior;
  model::PriorParameters parameters;
  /// The prior's own control period (s) when it has one (a description-file prior's dt), 0 when
  /// unknown: identify() refuses a prior whose dt differs from the logs'.
  double prior_dt = 0;
};

/// The options of identify() (the keys identify.*, docs/configuration.md).
struct IdentifyOptions {
  std::vector<std::filesystem::path> logs;        ///< fit logs (CSV), >= 1
  std::vector<std::filesystem::path> validation;  ///< validation logs (CSV); may be empty
  LogColumns columns;                             ///< which columns are time, state, action
  LogOptions log;                                 ///< resampling (log.dt: the control period)
  /// Open-loop horizons (s), each >= dt and finite, ascending after rounding to steps.
  std::vector<double> horizons = {0.1, 0.5, 1.0};
  double start_spacing = 0.25;  ///< between open-loop start points (s), >= dt
  /// Most transitions the model learns from (the evenly spaced subset of step 1); 0: all. >= 0.
  int max_points = 0;
  std::uint64_t seed = 1;  ///< recorded (every built-in step is deterministic)
  int threads = 0;         ///< worker threads, 0 = all hardware threads; >= 0
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// One line of errors.csv: the prediction errors of one state dimension at one horizon on one
/// validation file.
struct PredictionErrors {
  std::string file;    ///< the validation log (its path as given)
  double horizon = 0;  ///< s; dt for the one-step errors
  int steps = 0;       ///< round(horizon / dt)
  int dim = 0;         ///< state dimension, 0-based
  std::string state;   ///< its name
  double median = 0;   ///< median of |x^ - x| over the start points (state's units)
  double p90 = 0;      ///< 90th percentile
  int n = 0;           ///< start points counted
};

/// What identify() did.
struct IdentifySummary {
  std::string model_type;
  std::vector<std::string> state_names, action_names;
  double dt = 0;
  std::vector<LogReport> fit_reports, validation_reports;
  int transitions = 0;  ///< transitions in the fit logs
  int points = 0;       ///< transitions the model learned from (max_points)
  model::ModelSummary model;
  /// phi (empty for a model without prior): names, start, the learned point (dim P each),
  /// the tunable flags and, per entry, the posterior's 95% interval (phi +- 1.96 sd; NaN where the
  /// model has no posterior or the entry is not a continuous tunable one).
  std::vector<std::string> phi_names;
  VectorXd phi_start, phi, phi_lower95, phi_upper95;
  std::vector<bool> phi_tunable;
  std::vector<PredictionErrors> errors;        ///< the model's, one-step rows first per file
  std::vector<PredictionErrors> prior_errors;  ///< the prior's at phi_start (empty without one)
  double learn_seconds = 0, validation_seconds = 0;
  /// A few lines: data, phi, the errors of the longest horizon.
  std::string BriefReport() const;
};

/// The result: the summary, the learned model (predict() is thread-safe) and the data.
struct IdentifyResult {
  IdentifySummary summary;
  std::unique_ptr<model::DynamicsModel> model;
  std::vector<Transition> data;              ///< the transitions the model learned from
  std::vector<RecordedLog> fit, validation;  ///< the logs as resampled
};

/// Progress lines ("reading a.csv", "learning gp_mi on 300 transitions", "validating b.csv"),
/// called from the thread that runs identify().
using IdentifyMessage = std::function<void(const std::string& line)>;

/// Mean open-loop rollout of recorded actions: x^_0 = x0 (dim E), x^_{k+1} = x^_k + mean of
/// model.predict at (x^_k, u_k) for the H rows of actions (H x U). Returns (H + 1) x E. Throws
/// InvalidArgument on a size mismatch. Thread-safe (const model).
MatrixXd open_loop_rollout(const model::DynamicsModel& model, const VectorXd& x0,
                           const MatrixXd& actions);

/// The errors of step 3 of the method on one resampled log (`file` names it in the rows):
/// one-step rows, then per horizon in order. Throws InvalidArgument for horizons or spacing
/// shorter than log.dt. Thread-safe (const model).
std::vector<PredictionErrors> prediction_errors(const model::DynamicsModel& model,
                                                const RecordedLog& log, const std::string& file,
                                                const std::vector<double>& horizons,
                                                double start_spacing);

/// The method above on logs already resampled (from files or Python's arrays): fit (>= 1 log)
/// and validation (may be empty) with the state and action of `what`. Throws InvalidArgument for
/// invalid options or a model description that does not fit the logs (dimensions, dt, a
/// missing prior; the message names the item), drops::Error from the model's learning.
IdentifyResult identify(const IdentifyModel& what, const std::vector<RecordedLog>& fit,
                        const std::vector<RecordedLog>& validation, const IdentifyOptions& options,
                        const IdentifyMessage& message = nullptr,
                        const model::ModelProgress& progress = nullptr);

/// The same reading options.logs and options.validation (read_log with options.columns and
/// options.log; a file's error names the file, the line and the column). Nothing is written.
IdentifyResult identify(const IdentifyModel& what, const IdentifyOptions& options,
                        const IdentifyMessage& message = nullptr,
                        const model::ModelProgress& progress = nullptr);

// ---------------------------------------------------------------------------------------------
// `drops identify`: its configuration keys and its output directory.

/// The keys identify.* (schema(): every task's schema has them; docs/configuration.md).
/// Thread-safe.
const std::vector<KeySpec>& identify_keys();

/// The `task` of a `drops identify` configuration without a built-in task: the prior is the
/// description file of prior.model (required), the state the angles and velocities of its joints
/// prior.joints ([q, qd], dim 2n), the action the torques of prior.actuated (dim m), the control
/// period identify.dt (required). Not a task of `drops run`.
inline constexpr const char* kNoTask = "none";

/// The keys of a configuration with task none beside the base, algorithm and identify.* keys:
/// the description-file prior's (description_prior_keys()) and prior.joints, prior.actuated
/// (lists of the file's joint names; [] = every joint that moves, in the file's order, and every
/// joint of prior.joints). Thread-safe.
const std::vector<KeySpec>& no_task_keys();

/// IdentifyOptions of validated settings: identify.* with dt = the task's control period, the
/// columns defaulting to the task's state and action names (a state entry "d/dt(COLUMN)" is the
/// smoothed derivative of COLUMN, named by the task's state name at its place), seed and threads.
/// state_names, action_names: the task's (dim E, U). Throws ConfigError naming the key when the
/// columns do not fit the task or the options are invalid.
IdentifyOptions identify_options(const Settings& settings, double dt,
                                 const std::vector<std::string>& state_names,
                                 const std::vector<std::string>& action_names);

/// The log declaration of identify.* alone (the columns and the resampling; identify_options
/// without identify.logs and the validation options), shared by `drops identify` and runs that
/// start from recorded data (data.logs). dt: the task's control period (s); state_names,
/// action_names: the task's. Throws ConfigError naming the key as identify_options does.
void log_declaration(const Settings& settings, double dt,
                     const std::vector<std::string>& state_names,
                     const std::vector<std::string>& action_names, LogColumns* columns,
                     LogOptions* options);

// ---------------------------------------------------------------------------------------------
// Runs that start from recorded data (the keys data.*; docs/logs.md).

/// The keys data.* (schema(): every task's schema has them; docs/configuration.md): data.logs
/// (a list of paths: CSV logs declared and resampled by identify.columns.* and the resampling
/// keys of identify.*) and data.keep_first_episode. Thread-safe.
const std::vector<KeySpec>& run_data_keys();

/// The recorded data of a run: the transitions of data.logs, in file and time order, and what
/// was read.
struct RunData {
  std::vector<Transition> transitions;  ///< every log's transitions, in order
  std::vector<LogReport> reports;       ///< one per log, in order
  bool keep_first_episode = false;      ///< data.keep_first_episode
  /// What the run records and compares on resume (TaskSetup::declaration): "data.logs" (the
  /// number of logs), per log i (1-based) "data.log.<i>" (its path as resolved),
  /// "data.log.<i>.sha256" (its bytes' digest), "data.log.<i>.rows", "data.log.<i>.dropped"
  /// (rows dropped and rows of short segments), "data.log.<i>.transitions", then
  /// "data.transitions" (the total) and "data.keep_first_episode". Empty without data.logs.
  std::map<std::string, std::string> declaration;
};

/// Fewest recorded transitions a run accepts from data.logs in total (the model's kernels are
/// fitted on them before any real episode).
constexpr int kMinRecordedTransitions = 10;

/// Reads data.logs (empty: an empty RunData, nothing read) for a task of control period dt (s)
/// and these state and action names (each log through parse_log_csv and resample_log with
/// log_declaration's columns and options, so that a log's digest is that of the bytes parsed).
/// Throws ConfigError naming the key or the file: a missing column (the file's columns listed),
/// a log that cannot be read; drops::Error naming the file, the line and the column for the
/// rest of read_log's errors (a log sampled more coarsely than dt among them), and when the logs
/// give fewer than kMinRecordedTransitions transitions. Nothing is written. Thread-safe.
RunData read_run_data(const Settings& settings, double dt,
                      const std::vector<std::string>& state_names,
                      const std::vector<std::string>& action_names);

/// Writes `<dir>` (created; files through write_file_atomically, so nothing is half-written):
/// config.yaml (config_yaml as given), summary.json (what IdentifySummary holds), phi.csv (name,
/// start, value, tunable, lower95, upper95), errors.csv (model, file, horizon, steps, dim, state,
/// median, p90, n; model "learned" and "prior"), model.json (the type, state and action names,
/// dt, phi and per output GP the log hyper-parameters: the model's ModelState) with data.csv (the
/// transitions it learned from: x, u, dx columns), validation-NN.csv (per validation file, the
/// recorded states and the open-loop predictions over the longest horizon from every start
/// point, for the figures) and report.md. Returns the files written. Throws drops::Error naming
/// the file that cannot be written.
std::vector<std::filesystem::path> write_identify_directory(const std::filesystem::path& dir,
                                                            const IdentifyResult& result,
                                                            const IdentifyOptions& options,
                                                            const std::string& config_yaml);

/// `drops identify`'s whole work, shared by the command line and Python's drops.identify: the
/// task of settings' `task` gives the prior, its parameters and the state and action names (with
/// task none, kNoTask: prior.model's file with prior.joints and prior.actuated, at identify.dt;
/// its state names, the defaults of identify.columns.state, are the joints' names then
/// `<joint>_vel`, its action names `<joint>_torque`),
/// model.* the variant, identify.* the logs (identify_options); identify() runs and the
/// directory <output>/<name>/ (default name identify-<task>-<model.type>; with task none
/// identify-<the file's stem>-<model.type>) is written (write_identify_directory). Throws
/// ConfigError for a bad key or value, or a log without a declared column (the message names the
/// file and the column); drops::Error for a log's other errors (file, line, column) and the model's
/// learning; nothing is written before the learning is done. Not thread-safe (one identify at a
/// time: the thread limit is process-wide).
struct IdentifyRun {
  IdentifyResult result;
  IdentifyOptions options;
  std::filesystem::path directory;           ///< <output>/<name>
  std::vector<std::filesystem::path> files;  ///< the files written
};
IdentifyRun identify_from_settings(const Registry& registry, const Settings& settings,
                                   const IdentifyMessage& message = nullptr,
                                   const model::ModelProgress& progress = nullptr);

/// A model saved by write_identify_directory, loaded again: model.json's type, names, dt, phi
/// and kernel hyper-parameters with data.csv's transitions. `what` describes the model as
/// identify() was given it (type, factory, options, task, prior, parameters: the same task and
/// prior); the model is conditioned on the saved data at the saved phi and kernels without any
/// search (model::GpDynamicsModel::condition; for mi, the prior at phi), so its predictions
/// equal the fitted model's (to rounding: the data are stored with 17 digits). Throws
/// drops::Error naming the file and the item for a file that cannot be read, another format, or
/// names, dimensions or dt that differ from `what`'s; InvalidArgument from the model. Not
/// thread-safe; the model's predict() is thread-safe after it returns.
std::unique_ptr<model::DynamicsModel> load_identified_model(const std::filesystem::path& dir,
                                                            const IdentifyModel& what);

}  // namespace drops::experiment
