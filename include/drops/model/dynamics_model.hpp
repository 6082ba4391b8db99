#pragma once
/// \file Learned dynamics models: the four variants of the paper (§IV, §V-A) behind one interface.
///   gp       Black-DROPS: E independent GPs on dx, zero mean;
///   gp_prior Black-DROPS with priors: GP mean = simulator at fixed phi (paper eq. 4);
///   gp_mi    Black-DROPS with GP-MI: phi tuned by maximising the sum of the GP likelihoods
///            (paper Algorithm 2), kernels refit at phi*;
///   mi       Black-DROPS with MI: phi by one-step mean squared error, deterministic simulator.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"
#include "drops/gp/gp.hpp"
#include "drops/model/gp_mi.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::model {

/// The built-in model variants that make_model builds (the experiment layer registers them as the
/// model.type values gp, gp_prior, gp_mi and mi, beside any model of one's own).
enum class ModelType { kGp, kGpPrior, kGpMi, kMi };
/// "gp" | "gp_prior" | "gp_mi" | "mi". Thread-safe.
std::string to_string(ModelType type);
/// True for the variants that use a simulator prior (all but gp).
inline bool uses_prior(ModelType t) { return t != ModelType::kGp; }

/// Options of MI (settings.md §4): phi minimising sum_n ||M(x_n, u_n; phi) - dx_n||^2.
struct MiOptions {
  int max_evaluations = 2000;  ///< Subplex evaluations, >= 1
  double xtol_rel = 1e-6;      ///< Subplex relative tolerance on phi, >= 0
  double ftol_rel = 1e-6;      ///< Subplex relative tolerance on the error, >= 0
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Options of every model variant.
struct ModelOptions {
  /// The built-in variant make_model builds. The experiment layer selects a model by its
  /// registered factory instead (BlackDropsOptions::model_factory, of model.type) and leaves this
  /// at its default.
  ModelType type = ModelType::kGpMi;
  gp::RpropOptions rprop;  ///< final kernel fit of each output GP (warm-started across episodes)
  GpMiOptions gp_mi;
  MiOptions mi;
  /// Output GPs (gp, gp_prior, gp_mi): once learn() has more than m = variance_points
  /// transitions, predictive variances from a subset of at most m of them, the subset of data
  /// approximation (gp::Gp::set_variance_points; the model puts the subset last in its GPs'
  /// rows). The subset is chosen greedily on the fitted kernels (gp::greedy_variance_subset):
  /// each transition added is the one the subset so far explains least, so a transition
  /// recorded again (a policy replayed on a deterministic robot) is not chosen twice. Never
  /// below the exact variance, O(m^2) instead of O(N^2) per prediction; learn() pays O(E N m^2)
  /// to choose and O(E N^3 / 3) to refactorise the GPs on the new row order. Means use every
  /// transition. 0 = every transition (exact). >= 0.
  int variance_points = 0;
  /// Output GPs (gp, gp_prior, gp_mi): once learn() has more than m = inducing_points GP points
  /// (recorded transitions, and their reflections with reflect_transitions), each output GP is
  /// a sparse GP with at most m inducing inputs (gp::SparseGp: the variational bound of Titsias
  /// 2009, inputs chosen among the transitions by greedy conditional variance for the kernel,
  /// again after its fit), fitted in O(N m^2) per Rprop iteration instead of O(N^3); predictions
  /// cost O(m^2) (variance_points is then not used). GP-MI's phi search uses sparse GPs too when
  /// the transitions it scores (gp_mi.max_points of them, or all) exceed m. The state carried
  /// between learn() calls is the same hyper-parameters as the exact GPs' (the inducing inputs
  /// are chosen again from the data at each learn()), so a resumed run is exact. 0 = exact GPs
  /// whatever N. >= 0; not with gp_mi.rollout_phi = posterior.
  int inducing_points = 0;
  /// Output GPs (gp, gp_prior, gp_mi): learn() also learns each recorded transition reflected by
  /// the task's symmetry (Task::reflection; data augmentation), so the model knows the mirror
  /// image of every state the robot visited: 2N transitions for N recorded, and the GP-MI search
  /// and kernel fits cost up to 8 times as much. With a prior that shares the symmetry (or none),
  /// the model's mean and variance are then equivariant: predict(R(x), R_u(u)) =
  /// (sign .* mean, var). The constructor throws
  /// InvalidArgument when the task declares no reflection.
  bool reflect_transitions = false;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// What DynamicsModel::draw_phi_samples did.
struct PhiSampling {
  int samples = 0;   ///< phi samples the rollouts use (0: every rollout uses phi())
  int clamped = 0;   ///< draws with an entry outside its search interval, clamped onto it
  int rejected = 0;  ///< draws the prior rejected (MeanFunction::check_phi), replaced by phi()
};

/// What learn() did.
struct ModelSummary {
  /// recorded transitions used (with ModelOptions::reflect_transitions the GPs learn 2 points)
  int points = 0;
  VectorXd phi;                  ///< full prior parameters after learning (empty for gp)
  VectorXd log_likelihoods;      ///< per output GP, at the final fit (empty for mi)
  double score = 0;              ///< GP-MI score log sum_i exp(loglik_i) (or MI's mean squared error)
  int phi_evaluations = 0;       ///< evaluations of the phi objective (GP-MI / MI)
  int rounds = 0;                ///< alternating GP-MI rounds performed
  long rprop_iterations = 0;     ///< Rprop iterations over all fits
  long nonfinite_prior_outputs = 0;  ///< simulator outputs that were NaN/inf (phi rejected there)
  int phi_screened_out = 0;  ///< GP-MI candidates left out by the screen (GpMiOptions)
  /// gp_mi with continuous tunable parameters: how sure the model is of them (phi_posterior, at
  /// the final fit); empty otherwise.
  PhiPosterior phi_posterior;
  /// The phi samples of the rollouts (GpMiOptions::rollout_phi); set by the algorithm from
  /// draw_phi_samples after learn().
  PhiSampling phi_sampling;
  double seconds = 0;            ///< wall-clock time of learn()
  std::string BriefReport() const;
};

/// What a model carries from one learn() to the next (warm starts): enough to continue a run
/// exactly (drops run --resume). Doubles must be stored exactly (17 significant digits).
struct ModelState {
  VectorXd phi;                       ///< current prior parameters (dim P; empty for gp)
  std::vector<VectorXd> h_params;     ///< per output GP, log-space kernel hyper-parameters (empty for mi)
};

/// A learned one-step model of dx = x_{t+1} - x_t. learn() is not thread-safe; after it, predict()
/// and predict_batch() are const and thread-safe.
class DynamicsModel {
 public:
  virtual ~DynamicsModel() = default;
  /// Learns from every transition recorded so far (x raw state dim E, u dim U, dx dim E),
  /// warm-starting from the previous call. Throws InvalidArgument on inconsistent sizes.
  virtual ModelSummary learn(const std::vector<Transition>& data,
                             const ModelProgress& progress = nullptr) = 0;
  /// Predictive distribution of dx at raw state x (dim E) and action u (dim U).
  virtual void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const = 0;
  /// Batched predict. X: B x E raw states, U: B x U actions; mean, var resized to B x E.
  virtual void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                             MatrixXd& var) const = 0;
  /// Draws the phi samples that rollouts use when the model's options ask for them
  /// (GpMiOptions::rollout_phi = kPosterior, a model with a posterior over phi after learn()):
  /// `count` (>= 1) draws from one random stream seeded by seed. A model without samples (the
  /// default implementation, every variant but gp_mi with a continuous tunable phi, or
  /// rollout_phi = kPoint) draws none and returns samples = 0. Call after learn(); the next
  /// learn() or restore() discards them. Throws InvalidArgument when count < 1. Not thread-safe.
  virtual PhiSampling draw_phi_samples(int count, std::uint64_t seed);
  /// Samples drawn by the last draw_phi_samples (0: none; rollouts then use predict_batch).
  virtual int phi_samples() const { return 0; }
  /// predict_batch with row b under phi sample sample[b] (in [0, phi_samples())). The default
  /// (no samples) is predict_batch. Throws InvalidArgument when sample has not one entry per row
  /// or an entry is out of range. Thread-safe after draw_phi_samples.
  virtual void predict_batch_sampled(const MatrixXd& X, const MatrixXd& U,
                                     const std::vector<int>& sample, MatrixXd& mean,
                                     MatrixXd& var) const;
  /// Current full prior parameters phi (dim P; empty for gp).
  virtual VectorXd phi() const = 0;
  /// The warm-start state (see ModelState). Not thread-safe with learn().
  virtual ModelState state() const = 0;
  /// Restores a state() of a model of the same type and dimensions, as if learn() had been called
  /// up to that point (the next learn() starts from it). Throws InvalidArgument on mismatched sizes
  /// or non-finite values. Not thread-safe.
  virtual void restore(const ModelState& state) = 0;

 protected:
  /// predict_batch_sampled's argument check: sample has one entry per row (rows) and each is in
  /// [0, max(1, phi_samples())). Throws InvalidArgument otherwise.
  void check_samples(Eigen::Index rows, const std::vector<int>& sample) const;
};

/// Builds the model of options.type. task gives the GP input (observe(x) concatenated with u);
/// prior and parameters are required for every type but gp (parameters.values is the starting
/// phi). Throws InvalidArgument when a prior is required but missing, or parameters are invalid.
std::unique_ptr<DynamicsModel> make_model(const ModelOptions& options,
                                          std::shared_ptr<const Task> task,
                                          std::shared_ptr<const MeanFunction> prior,
                                          const PriorParameters& parameters);

/// The simulator alone at the starting phi, deterministic (variance 0): the model on which the
/// first policy is optimised when a prior exists (paper Algorithm 1, line 1).
std::unique_ptr<DynamicsModel> make_prior_only_model(std::shared_ptr<const MeanFunction> prior,
                                                     const PriorParameters& parameters);

}  // namespace drops::model
