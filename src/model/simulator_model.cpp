#include "drops/model/simulator_model.hpp"

#include <chrono>
#include <limits>

#include "drops/core/errors.hpp"
#include "drops/model/dataset.hpp"
#include "drops/opt/subplex.hpp"

namespace drops::model {

SimulatorModel::SimulatorModel(const ModelOptions& options,
                               std::shared_ptr<const MeanFunction> prior,
                               const PriorParameters& parameters, bool identify)
    : options_(options), prior_(std::move(prior)), params_(parameters), identify_(identify) {
  if (!prior_) throw InvalidArgument("model '" + to_string(options.type) + "' needs a prior");
  std::string why;
  if (!options_.mi.IsValid(&why)) throw InvalidArgument("SimulatorModel: " + why);
  params_.check();
  prior_->check_phi(params_.values);
  phi_ = params_.values;
}

void SimulatorModel::restore(const ModelState& st) {
  check_size("restored phi", phi_.size(), st.phi.size());
  if (!st.h_params.empty())
    throw InvalidArgument("restored state has GP kernels; model is '" +
                          to_string(options_.type) + "'");
  if (!st.phi.allFinite()) throw InvalidArgument("restored phi is not finite");
  prior_->check_phi(st.phi);
  phi_ = st.phi;
}

ModelSummary SimulatorModel::learn(const std::vector<Transition>& data,
                                   const ModelProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  ModelSummary s;
  const Dataset d = make_dataset(data, nullptr, prior_->state_dim(), prior_->action_dim());
  s.points = d.size();
  if (identify_ && d.size() > 0 && !params_.tunable.empty()) {
    // MI: phi minimising the one-step mean squared error of the simulator (settings.md §4).
    int evals = 0;
    auto neg_mse = [&](const VectorXd& tuned) {
      const int k = evals++;
      VectorXd phi = params_.with_tuned(tuned);
      prior_->check_phi(phi);  // InvalidArgument: -inf
      long bad = 0;
      const MatrixXd m = prior_outputs(*prior_, d.x, d.u, phi, &bad);
      s.nonfinite_prior_outputs += bad;
      if (bad) return -std::numeric_limits<double>::infinity();
      const double mse = (m - d.dx).squaredNorm() / d.size();
      if (progress && k % 100 == 0) progress("mi", k, mse);
      return -mse;
    };
    PriorParameters p = params_;
    p.values = phi_;
    opt::SubplexOptions so;
    so.max_evaluations = options_.mi.max_evaluations;
    so.xtol_rel = options_.mi.xtol_rel;
    so.ftol_rel = options_.mi.ftol_rel;
    const auto r =
        opt::maximize_mixed(neg_mse, p.tuned(), opt::MixedBox{p.lower, p.upper, p.choices}, so);
    s.phi_evaluations = r.evaluations;
    if (std::isfinite(r.best_value)) {
      phi_ = p.with_tuned(r.best_x);
      s.score = -r.best_value;
    }
  }
  s.phi = phi_;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

void SimulatorModel::predict(const VectorXd& x, const VectorXd& u, Prediction& out) const {
  out.mean.resize(prior_->state_dim());
  prior_->evaluate(x, u, phi_, out.mean);
  out.var = VectorXd::Zero(prior_->state_dim());
}

void SimulatorModel::predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                                   MatrixXd& var) const {
  prior_->evaluate_batch(X, U, phi_, mean);
  var = MatrixXd::Zero(X.rows(), prior_->state_dim());
}

}  // namespace drops::model
