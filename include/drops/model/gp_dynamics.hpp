#pragma once
/// \file The GP dynamics model of Black-DROPS and its prior variants (paper §IV-A, eq. 3-4): E
/// independent GPs on the state differences dx, each with the simulator prior M(x, u; phi) as
/// mean (gp_prior, gp_mi) or a zero mean (gp); gp_mi identifies phi first (Algorithm 2, gp_mi.hpp).

#include <memory>
#include <optional>
#include <vector>

#include "drops/gp/gp.hpp"
#include "drops/model/dynamics_model.hpp"

namespace drops::model {

/// The model of the types gp, gp_prior and gp_mi. learn() is not thread-safe; predict() and
/// predict_batch() are const and thread-safe after it.
class GpDynamicsModel final : public DynamicsModel {
 public:
  /// task: gives the GP input [task.observe(x), u] (dim O + U). prior and parameters: required
  /// for gp_prior and gp_mi (parameters.values is the starting phi), ignored (pass null and {})
  /// for gp. Throws InvalidArgument when options are invalid, the prior is missing or does not
  /// fit the task, the parameters are invalid, or gp_mi is asked for rollouts over phi's
  /// posterior (GpMiOptions::rollout_phi) without a continuous tunable parameter.
  GpDynamicsModel(const ModelOptions& options, std::shared_ptr<const Task> task,
                  std::shared_ptr<const MeanFunction> prior, const PriorParameters& parameters);

  /// The built-in variant this model is (options.type).
  ModelType type() const { return options_.type; }
  VectorXd phi() const override { return phi_; }
  ModelState state() const override;
  void restore(const ModelState& state) override;
  /// gp_mi: phi by identify_phi (warm-started from the previous phi and kernels), then every
  /// output GP refit on all data at phi with options.rprop; the others: the refit only. With
  /// ModelOptions::reflect_transitions, "the data" are the transitions and their reflections
  /// (2 data.size() rows; ModelSummary::points counts the recorded ones).
  ModelSummary learn(const std::vector<Transition>& data,
                     const ModelProgress& progress = nullptr) override;
  /// The output GPs conditioned on `data` at the current phi() and kernels (those of restore())
  /// without any search: what learn() does after its phi search and kernel fits (the residual
  /// targets, the variance subset, the reflections), so that a saved model (state() and its
  /// data) predicts again exactly (experiment::load_identified_model). No phi posterior (the
  /// summary's is empty). Throws as learn(). Not thread-safe.
  ModelSummary condition(const std::vector<Transition>& data);
  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override;
  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override;
  /// gp_mi with GpMiOptions::rollout_phi = kPosterior and a posterior over phi from the last
  /// learn() (finite covariance): `count` draws phi_s = phi* + C z, z ~ N(0, I) from the stream
  /// Rng(seed), C C^T the posterior covariance (symmetric square root, negative eigenvalues at
  /// 0), each entry clamped onto its search interval (counted), a draw check_phi rejects or on
  /// which the simulator gives a non-finite output on the data replaced by phi* (counted); then
  /// per draw and output the GP weights K^-1 (dx - M(X; phi_s)) on the same factorisation.
  /// Otherwise none (samples = 0). Cost: count x (N simulator calls + E O(N^2) solves).
  PhiSampling draw_phi_samples(int count, std::uint64_t seed) override;
  int phi_samples() const override { return static_cast<int>(sample_phi_.size()); }
  /// Row b: the simulator at sample sample[b]'s phi (one evaluate_batch per sample present)
  /// plus the output GPs with that sample's weights (gp::Gp::predict_batch with weights);
  /// variances as predict_batch. A sample equal to phi* predicts what predict_batch does.
  /// Throws InvalidArgument as DynamicsModel::predict_batch_sampled. Thread-safe after
  /// draw_phi_samples (per-thread buffers).
  void predict_batch_sampled(const MatrixXd& X, const MatrixXd& U, const std::vector<int>& sample,
                             MatrixXd& mean, MatrixXd& var) const override;
  /// The phi of each sample drawn (full phi, dim P each).
  const std::vector<VectorXd>& sample_phis() const { return sample_phi_; }
  /// The E output GPs (after learn(): fitted to the residuals at phi()), when the model is exact
  /// (sparse() false); without data otherwise.
  const std::vector<gp::Gp>& output_gps() const { return gps_; }
  /// True when the last learn() fitted sparse output GPs (ModelOptions::inducing_points).
  bool sparse() const { return sparse_active_; }
  /// The E sparse output GPs, fitted by the last learn() when sparse(); without data otherwise.
  const std::vector<gp::SparseGp>& sparse_output_gps() const { return sparse_; }

 private:
  ModelOptions options_;
  std::shared_ptr<const Task> task_;
  std::shared_ptr<const MeanFunction> prior_;
  PriorParameters params_;
  int E_ = 0, U_ = 0, O_ = 0;
  VectorXd phi_;
  std::optional<Reflection> reflection_;  // set when options_.reflect_transitions
  std::vector<gp::Gp> gps_;
  // ModelOptions::inducing_points: the sparse output GPs, and which of the two sets holds the
  // fitted GPs (the other holds the same hyper-parameters, without data: the warm start).
  std::vector<gp::SparseGp> sparse_;
  bool sparse_active_ = false;
  // Makes the exact (false) or sparse (true) set the active one, carrying the hyper-parameters.
  void activate(bool sparse);
  // The last learn()'s data and posterior (draw_phi_samples), and the samples drawn.
  MatrixXd data_x_, data_u_, data_dx_;
  PhiPosterior posterior_;
  std::vector<VectorXd> sample_phi_;           // S full phi
  std::vector<MatrixXd> sample_weights_;       // per output: N x S, K^-1 (dx - M(X; phi_s))
  bool condition_only_ = false;  // condition(): learn() without the phi search and the fits
  void clear_samples();
};

}  // namespace drops::model
