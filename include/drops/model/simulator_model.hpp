#pragma once
/// \file The simulator prior alone as a deterministic dynamics model: the planning model of the
/// first episode (paper Algorithm 1, line 1) and, with phi identified by the one-step mean squared
/// error, Black-DROPS with MI (paper §V-A; settings.md §4).

#include <memory>
#include <vector>

#include "drops/model/dynamics_model.hpp"

namespace drops::model {

/// M(x, u; phi) with variance 0. With `identify`, learn() sets phi to the minimiser of
/// sum_n ||M(x_n, u_n; phi) - dx_n||^2 over the tunable parameters (Subplex, options.mi); without,
/// phi stays parameters.values. Thread-safe for const calls after learn().
class SimulatorModel final : public DynamicsModel {
 public:
  /// Throws InvalidArgument when prior is null, parameters are invalid or options.mi is invalid.
  SimulatorModel(const ModelOptions& options, std::shared_ptr<const MeanFunction> prior,
                 const PriorParameters& parameters, bool identify);
  /// The built-in variant this model is (options.type).
  ModelType type() const { return options_.type; }
  VectorXd phi() const override { return phi_; }
  ModelState state() const override { return ModelState{phi_, {}}; }
  void restore(const ModelState& state) override;
  ModelSummary learn(const std::vector<Transition>& data,
                     const ModelProgress& progress = nullptr) override;
  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override;
  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override;

 private:
  ModelOptions options_;
  std::shared_ptr<const MeanFunction> prior_;
  PriorParameters params_;
  bool identify_;
  VectorXd phi_;
};

}  // namespace drops::model
