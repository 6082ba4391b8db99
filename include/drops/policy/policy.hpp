#pragma once
/// \file Parametrised policies u = pi(obs | theta) (paper eq. 3).

#include <memory>
#include <string>

#include "drops/core/types.hpp"

namespace drops::policy {

/// A deterministic policy with a flat parameter vector theta. After set_params, act() is const and
/// thread-safe; use clone() for a per-thread copy with other parameters.
class Policy {
 public:
  virtual ~Policy() = default;
  virtual int observation_dim() const = 0;  ///< O
  virtual int action_dim() const = 0;       ///< U
  virtual int param_dim() const = 0;        ///< dim theta
  /// Sets theta (dim param_dim()). Throws InvalidArgument on wrong size or non-finite entries.
  virtual void set_params(const VectorXd& theta) = 0;
  virtual const VectorXd& params() const = 0;
  /// u = pi(obs, t | theta); obs: dim O, u: dim U. t: time since the start of the episode in s
  /// (step index * task dt; run_episode and evaluate_policies pass it), for open-loop policies
  /// such as a periodic gait; feedback policies ignore it.
  virtual void act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const = 0;
  virtual std::unique_ptr<Policy> clone() const = 0;
};

/// Options of NeuralNetPolicy (settings.md §2).
struct NeuralNetPolicyOptions {
  int observation_dim = 6;   ///< O, >= 1
  int hidden_units = 10;     ///< >= 1
  int action_dim = 1;        ///< U, >= 1
  /// Element-wise divisor of the observation (dim O, non-zero); empty means all ones.
  VectorXd input_scale;
  double hidden_gain = 5.0;  ///< h = tanh(hidden_gain * W1 [obs/scale; 1])
  double output_gain = 5.0;  ///< u = max_action * tanh(output_gain * W2 [h; 1])
  double max_action = 3.5;   ///< |u| <= max_action (> 0), in the action's unit
  bool IsValid(std::string* why) const;
};

/// One-hidden-layer tanh network (Black-DROPS' policy of the paper's swing-up task):
///   h = tanh(g_h W1 [obs ./ scale; 1]),  u = u_max tanh(g_o W2 [h; 1]).
/// theta = [W1 row-major (hidden x (O+1)); W2 row-major (U x (hidden+1))]:
/// (O+1)*hidden + (hidden+1)*U parameters (81 for O = 6, 10 hidden units, U = 1).
class NeuralNetPolicy final : public Policy {
 public:
  /// Throws InvalidArgument when options are invalid. Parameters start at zero.
  explicit NeuralNetPolicy(const NeuralNetPolicyOptions& options = {});
  int observation_dim() const override { return options_.observation_dim; }
  int action_dim() const override { return options_.action_dim; }
  int param_dim() const override;
  void set_params(const VectorXd& theta) override;
  const VectorXd& params() const override { return theta_; }
  /// Ignores t (a feedback policy).
  void act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const override;
  std::unique_ptr<Policy> clone() const override;

 private:
  NeuralNetPolicyOptions options_;
  VectorXd inv_scale_;
  VectorXd theta_;
  MatrixXd w1_;  // hidden x (O + 1)
  MatrixXd w2_;  // U x (hidden + 1)
};

}  // namespace drops::policy
