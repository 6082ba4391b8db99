#include "drops/model/gp_dynamics.hpp"

#include <chrono>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/model/dataset.hpp"
#include "drops/model/gp_mi.hpp"

namespace drops::model {
namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
std::string format_phi(const VectorXd& phi) {
  std::ostringstream o;
  for (Eigen::Index i = 0; i < phi.size(); ++i) o << (i ? ", " : "") << phi[i];
  return o.str();
}
}  // namespace

GpDynamicsModel::GpDynamicsModel(const ModelOptions& options,
                                 std::shared_ptr<const Task> task,
                                 std::shared_ptr<const MeanFunction> prior,
                                 const PriorParameters& parameters)
    : options_(options), task_(std::move(task)), prior_(std::move(prior)), params_(parameters) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("GpDynamicsModel: " + why);
  if (!task_) throw InvalidArgument("GpDynamicsModel: task is null");
  if (options_.type == ModelType::kMi)
    throw InvalidArgument("GpDynamicsModel: model 'mi' has no GP (use SimulatorModel)");
  if (options_.type == ModelType::kGp) {
    prior_.reset();
    params_ = PriorParameters{};
  } else if (!prior_) {
    throw InvalidArgument("model '" + to_string(options_.type) + "' needs a simulator prior");
  }
  E_ = task_->state_dim();
  U_ = task_->action_dim();
  O_ = task_->observation_dim();
  if (prior_) {
    params_.check();
    check_size("prior state_dim vs task", E_, prior_->state_dim());
    check_size("prior action_dim vs task", U_, prior_->action_dim());
    prior_->check_phi(params_.values);
    phi_ = params_.values;
  }
  gps_.assign(static_cast<std::size_t>(E_), gp::Gp(O_ + U_));
}

ModelState GpDynamicsModel::state() const {
  ModelState st;
  st.phi = phi_;
  for (const auto& g : gps_) st.h_params.push_back(g.h_params());
  return st;
}

void GpDynamicsModel::restore(const ModelState& st) {
  check_size("restored phi", phi_.size(), st.phi.size());
  check_size("restored GP count", E_, static_cast<Eigen::Index>(st.h_params.size()));
  if (!st.phi.allFinite()) throw InvalidArgument("restored phi is not finite");
  if (prior_) prior_->check_phi(st.phi);
  std::vector<gp::Gp> gps = gps_;
  for (std::size_t i = 0; i < gps.size(); ++i) gps[i].set_h_params(st.h_params[i]);
  gps_ = std::move(gps);
  phi_ = st.phi;
  if (prior_) params_.values = phi_;
}

ModelSummary GpDynamicsModel::learn(const std::vector<Transition>& data,
                                    const ModelProgress& progress) {
  const auto t0 = Clock::now();
  ModelSummary s;
  const Dataset d = make_dataset(data, task_.get(), E_, U_);
  s.points = d.size();
  if (d.size() == 0) throw InvalidArgument("learn: no transitions");

  // GP-MI (Algorithm 2): phi, warm-started from the previous episode's phi and kernels.
  if (options_.type == ModelType::kGpMi && !params_.tunable.empty()) {
    const GpMiSummary mi = identify_phi(*prior_, params_, d, options_.gp_mi, options_.rprop, gps_,
                                        progress);
    phi_ = mi.phi;
    params_.values = phi_;  // warm start of the next episode
    s.phi_evaluations = mi.evaluations;
    s.rounds = mi.rounds;
    s.rprop_iterations = mi.rprop_iterations;
    s.nonfinite_prior_outputs = mi.nonfinite_prior_outputs;
    s.phi_screened_out = mi.screened_out;
  }
  // Final fit: all data, phi fixed, full Rprop budget (warm-started).
  if (progress) progress("kernels", s.phi_evaluations, s.score);
  MatrixXd targets = d.dx;
  if (prior_) targets -= prior_outputs(*prior_, d.x, d.u, phi_, &s.nonfinite_prior_outputs);
  if (!targets.allFinite())
    throw NumericalError("the simulator prior returned non-finite values at phi = [" +
                         format_phi(phi_) + "] on the recorded data");
  s.log_likelihoods = fit_output_gps(gps_, d.gp_in, targets, options_.rprop, &s.rprop_iterations);
  if (options_.type == ModelType::kGpMi && !params_.tunable.empty())
    s.phi_posterior = phi_posterior(*prior_, params_, d, gps_);
  s.score = gp_mi_score(s.log_likelihoods, options_.gp_mi.score);
  s.phi = phi_;
  s.seconds = seconds_since(t0);
  return s;
}

void GpDynamicsModel::predict(const VectorXd& x, const VectorXd& u, Prediction& out) const {
  MatrixXd X = x.transpose(), U = u.transpose(), mean, var;
  predict_batch(X, U, mean, var);
  out.mean = mean.row(0).transpose();
  out.var = var.row(0).transpose();
}

void GpDynamicsModel::predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                                    MatrixXd& var) const {
  const Eigen::Index B = X.rows();
  // Called at every step of every rollout: per-thread buffers, resized (not reallocated) when
  // the batch shape repeats.
  // One call each to the task's observation and the prior for the whole batch.
  thread_local MatrixXd in, obs;
  thread_local VectorXd m, v;
  in.resize(B, O_ + U_);
  task_->observe_batch(X, obs);
  in.leftCols(O_) = obs;
  in.rightCols(U_) = U;
  if (prior_)
    prior_->evaluate_batch(X, U, phi_, mean);
  else
    mean.setZero(B, E_);
  var.resize(B, E_);
  for (int i = 0; i < E_; ++i) {
    gps_[static_cast<std::size_t>(i)].predict_batch(in, m, v);
    mean.col(i) += m;
    var.col(i) = v;
  }
}

}  // namespace drops::model
