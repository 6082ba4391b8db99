#pragma once
// What the tests share: a registry with the built-in algorithms and the pendubot (the task that
// most tests learn on), and the pendubot experiment of some overrides.
#include <memory>
#include <string>
#include <vector>

#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"

namespace drops::fixtures {

/// The built-in algorithms and the pendubot.
inline const experiment::Registry& registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    pendubot::register_task(*reg);
    return reg;
  }();
  return *r;
}

/// The settings of a YAML text and overrides (experiment::load_settings).
inline experiment::Settings settings(const std::string& yaml,
                                     const std::vector<std::string>& overrides = {}) {
  return experiment::load_settings(registry(), yaml, overrides);
}

/// The pendubot experiment of `overrides` (the drops command line's defaults otherwise).
inline experiment::Experiment experiment(const std::vector<std::string>& overrides = {},
                                         const std::string& yaml = "") {
  return experiment::make_experiment(registry(), settings(yaml, overrides));
}

/// A model of one's own for the tests of model factories and registered variants: another model
/// behind a wrapper that counts its learn() calls in *learns.
class CountingModel final : public model::DynamicsModel {
 public:
  CountingModel(std::unique_ptr<model::DynamicsModel> m, int* learns)
      : m_(std::move(m)), learns_(learns) {}
  model::ModelSummary learn(const std::vector<Transition>& d,
                            const model::ModelProgress& p) override {
    ++*learns_;
    return m_->learn(d, p);
  }
  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
    m_->predict(x, u, out);
  }
  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override {
    m_->predict_batch(X, U, mean, var);
  }
  VectorXd phi() const override { return m_->phi(); }
  model::ModelState state() const override { return m_->state(); }
  void restore(const model::ModelState& s) override { m_->restore(s); }

 private:
  std::unique_ptr<model::DynamicsModel> m_;
  int* learns_;
};

}  // namespace drops::fixtures
