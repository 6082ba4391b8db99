#pragma once
/// \file Learned dynamics models: the four variants of the paper (§IV, §V-A) behind one interface.
///   gp       Black-DROPS: E independent GPs on dx, zero mean;
///   gp_prior Black-DROPS with priors: GP mean = simulator at fixed phi (paper eq. 4);
///   gp_mi    Black-DROPS with GP-MI: phi tuned by maximising the sum of the GP likelihoods
///            (paper Algorithm 2), kernels refit at phi*;
///   mi       Black-DROPS with MI: phi by one-step mean squared error, deterministic simulator.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/types.hpp"
#include "drops/gp/gp.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/rollout/task.hpp"

namespace drops::model {

/// Model variant, chosen in the config as model.type.
enum class ModelType { kGp, kGpPrior, kGpMi, kMi };
/// "gp" | "gp_prior" | "gp_mi" | "mi"; throws InvalidArgument listing the allowed names.
ModelType parse_model_type(const std::string& name);
std::string to_string(ModelType type);
/// True for the variants that use a simulator prior (all but gp).
inline bool uses_prior(ModelType t) { return t != ModelType::kGp; }

/// How GP-MI searches phi (paper Algorithm 2). Both maximise the same score
///   S(phi) = max_{h_1..h_E} log sum_i exp(log p(dx_i | X, h_i, phi)).
enum class GpMiSearch {
  /// Paper's nested loops: every Subplex evaluation of phi refits all E kernels with Rprop
  /// (warm-started from the best kernels so far, inner_rprop_iterations iterations).
  kNested,
  /// Block-coordinate ascent on the same score: Subplex over phi with the kernels fixed (each
  /// evaluation costs N simulator calls and E O(N^2) solves), then refit the kernels at the new
  /// phi, for up to `rounds` rounds or until phi stops moving. Much cheaper; same fixed points.
  /// When every tunable parameter is discrete, GP-MI uses kNested instead: with the kernels fitted
  /// to the starting candidate's residuals, the others are scored against them and the search
  /// stays at its start (measured on the hexapod's 7 priors).
  kAlternating,
};

/// Options of GP-MI (settings.md §4).
/// How GP-MI combines the E output GPs' log marginal likelihoods l_i into its score.
enum class GpMiScore {
  /// log sum_i exp(l_i): the paper's "sum of the likelihoods" (settings.md §4). Dominated by the
  /// single best-fitting output, so with many outputs that every prior predicts alike (the
  /// hexapod's 36 joint outputs) it can ignore the outputs that tell the priors apart.
  kSumOfLikelihoods,
  /// sum_i l_i: the joint log likelihood of the independent output GPs (the product of the
  /// likelihoods), which every output informs.
  kSumOfLogLikelihoods,
};

struct GpMiOptions {
  GpMiSearch search = GpMiSearch::kAlternating;
  GpMiScore score = GpMiScore::kSumOfLikelihoods;  ///< how the per-output likelihoods combine
  int max_evaluations = 1000;   ///< Subplex evaluations per search (per discrete combination), >= 1
  double xtol_rel = 1e-4;       ///< Subplex relative tolerance on phi, >= 0
  double ftol_rel = 1e-4;       ///< Subplex relative tolerance on the score, >= 0
  int rounds = 5;               ///< alternating search: maximum rounds, >= 1
  int inner_rprop_iterations = 50;  ///< Rprop iterations of the kernel refits inside the search
  /// Use at most this many transitions (evenly spaced) inside the phi search; 0 = all. The final
  /// kernel fit always uses all data.
  int max_points = 0;
};

/// Options of MI (settings.md §4): phi minimising sum_n ||M(x_n, u_n; phi) - dx_n||^2.
struct MiOptions {
  int max_evaluations = 2000;  ///< Subplex evaluations, >= 1
  double xtol_rel = 1e-6;
  double ftol_rel = 1e-6;
};

/// Options of every model variant.
struct ModelOptions {
  ModelType type = ModelType::kGpMi;
  gp::RpropOptions rprop;  ///< final kernel fit of each output GP (warm-started across episodes)
  GpMiOptions gp_mi;
  MiOptions mi;
};

/// What learn() did.
struct ModelSummary {
  int points = 0;                ///< transitions used
  VectorXd phi;                  ///< full prior parameters after learning (empty for gp)
  VectorXd log_likelihoods;      ///< per output GP, at the final fit (empty for mi)
  double score = 0;              ///< GP-MI score log sum_i exp(loglik_i) (or MI's mean squared error)
  int phi_evaluations = 0;       ///< evaluations of the phi objective (GP-MI / MI)
  int rounds = 0;                ///< alternating GP-MI rounds performed
  long rprop_iterations = 0;     ///< Rprop iterations over all fits
  long nonfinite_prior_outputs = 0;  ///< simulator outputs that were NaN/inf (phi rejected there)
  double seconds = 0;            ///< wall-clock time of learn()
  std::string BriefReport() const;
};

/// What a model carries from one learn() to the next (warm starts): enough to continue a run
/// exactly (drops run --resume). Doubles must be stored exactly (17 significant digits).
struct ModelState {
  VectorXd phi;                       ///< current prior parameters (dim P; empty for gp)
  std::vector<VectorXd> h_params;     ///< per output GP, log-space kernel hyper-parameters (empty for mi)
};

/// Progress during learn(): phase ("gp-mi", "kernels", "mi"), evaluations so far, best score.
using ModelProgress = std::function<void(const std::string& phase, int evaluations, double best)>;

/// A learned one-step model of dx = x_{t+1} - x_t. learn() is not thread-safe; after it, predict()
/// and predict_batch() are const and thread-safe.
class DynamicsModel {
 public:
  virtual ~DynamicsModel() = default;
  virtual ModelType type() const = 0;
  /// Learns from every transition recorded so far (x raw state dim E, u dim U, dx dim E),
  /// warm-starting from the previous call. Throws InvalidArgument on inconsistent sizes.
  virtual ModelSummary learn(const std::vector<Transition>& data,
                             const ModelProgress& progress = nullptr) = 0;
  /// Predictive distribution of dx at raw state x (dim E) and action u (dim U).
  virtual void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const = 0;
  /// Batched predict. X: B x E raw states, U: B x U actions; mean, var resized to B x E.
  virtual void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                             MatrixXd& var) const = 0;
  /// Current full prior parameters phi (dim P; empty for gp).
  virtual VectorXd phi() const = 0;
  /// The warm-start state (see ModelState). Not thread-safe with learn().
  virtual ModelState state() const = 0;
  /// Restores a state() of a model of the same type and dimensions, as if learn() had been called
  /// up to that point (the next learn() starts from it). Throws InvalidArgument on mismatched sizes
  /// or non-finite values. Not thread-safe.
  virtual void restore(const ModelState& state) = 0;
};

/// Builds the model of options.type. task gives the GP input (observe(x) concatenated with u);
/// prior and parameters are required for every type but gp (parameters.values is the starting
/// phi). Throws InvalidArgument when a prior is required but missing, or parameters are invalid.
std::unique_ptr<DynamicsModel> make_model(const ModelOptions& options,
                                          std::shared_ptr<const rollout::Task> task,
                                          std::shared_ptr<const MeanFunction> prior,
                                          const PriorParameters& parameters);

/// The simulator alone at the starting phi, deterministic (variance 0): the model on which the
/// first policy is optimised when a prior exists (paper Algorithm 1, line 1).
std::unique_ptr<DynamicsModel> make_prior_only_model(std::shared_ptr<const MeanFunction> prior,
                                                     const PriorParameters& parameters);

/// log sum_i exp(v_i), computed stably (max shift). Returns -inf for an empty or all -inf vector.
double log_sum_exp(const VectorXd& v);

/// GP-MI's score of per-output log likelihoods ll (dim E) under `score` (see GpMiScore); -inf
/// when any entry is -inf under kSumOfLogLikelihoods. Thread-safe.
double gp_mi_score(const VectorXd& ll, GpMiScore score);

}  // namespace drops::model
