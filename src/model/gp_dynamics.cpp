#include "drops/model/gp_dynamics.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/model/dataset.hpp"
#include "drops/model/gp_mi.hpp"

namespace drops::model {
namespace {

/// The layout of a dataset of n transitions followed by their reflections (Dataset::pairs):
/// each GP input column must be the same or the opposite in every reflected row (the
/// reflection flips inputs in sign only, which leaves the SE-ARD kernel unchanged); otherwise
/// no layout (n = 0) and the fits run on all rows.
ReflectedPairs reflected_pairs(const Dataset& d, int n, const VectorXd& state_sign) {
  ReflectedPairs p;
  const Eigen::Index D = d.gp_in.cols();
  if (n < 1 || d.size() != 2 * n || D < 1) return p;
  VectorXd flip(D);
  for (Eigen::Index c = 0; c < D; ++c) {
    const auto a = d.gp_in.col(c).head(n), b = d.gp_in.col(c).tail(n);
    const double scale = 1e-12 * (1.0 + a.cwiseAbs().maxCoeff());
    if ((b - a).cwiseAbs().maxCoeff() <= scale)
      flip[c] = 1;
    else if ((b + a).cwiseAbs().maxCoeff() <= scale)
      flip[c] = -1;
    else
      return p;
  }
  p.n = n;
  p.flip = flip;
  p.sign = state_sign;
  return p;
}
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

GpDynamicsModel::GpDynamicsModel(const ModelOptions& options, std::shared_ptr<const Task> task,
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
  if (options_.reflect_transitions) {
    reflection_ = task_->reflection();
    if (!reflection_)
      throw InvalidArgument("model.reflect_transitions: task '" + task_->name() +
                            "' declares no reflection symmetry (Task::reflection); set it false");
    check_size("task reflection state_sign", E_, reflection_->state_sign.size());
    check_size("task reflection state_offset", E_, reflection_->state_offset.size());
    check_size("task reflection action_sign", U_, reflection_->action_sign.size());
    const auto signs = [](const VectorXd& v) { return (v.array().abs() == 1.0).all(); };
    if (!signs(reflection_->state_sign) || !signs(reflection_->action_sign) ||
        !reflection_->state_offset.allFinite())
      throw InvalidArgument("task '" + task_->name() +
                            "': its reflection's signs must be +1 or -1 and its offset finite");
  }
  if (prior_) {
    params_.check();
    check_size("prior state_dim vs task", E_, prior_->state_dim());
    check_size("prior action_dim vs task", U_, prior_->action_dim());
    prior_->check_phi(params_.values);
    phi_ = params_.values;
  }
  if (options_.type == ModelType::kGpMi && options_.gp_mi.rollout_phi == RolloutPhi::kPosterior &&
      std::all_of(params_.choices.begin(), params_.choices.end(),
                  [](const std::vector<double>& c) { return !c.empty(); })) {
    throw InvalidArgument(
        "model.gp_mi.rollout_phi: posterior draws phi from GP-MI's posterior over its continuous "
        "tunable parameters, and this prior tunes none (" +
        std::string(params_.tunable.empty() ? "nothing is tunable"
                                            : "every tunable entry is discrete") +
        "); use rollout_phi: point");
  }
  if (options_.inducing_points > 0 && options_.type == ModelType::kGpMi &&
      options_.gp_mi.rollout_phi == RolloutPhi::kPosterior)
    throw InvalidArgument(
        "model.inducing_points: the sparse output GPs do not draw rollouts over phi's posterior "
        "(model.gp_mi.rollout_phi: posterior); use rollout_phi: point or inducing_points: 0");
  gps_.assign(static_cast<std::size_t>(E_), gp::Gp(O_ + U_));
  for (auto& g : gps_) g.set_variance_points(options_.variance_points);
  if (options_.inducing_points > 0) {
    gp::SparseGpOptions so;
    so.inducing_points = options_.inducing_points;
    sparse_.assign(static_cast<std::size_t>(E_), gp::SparseGp(O_ + U_, so));
  }
}

void GpDynamicsModel::activate(bool sparse) {
  if (sparse == sparse_active_) return;
  for (std::size_t i = 0; i < gps_.size(); ++i) {
    if (sparse) {
      const VectorXd h = gps_[i].h_params();
      sparse_[i] = gp::SparseGp(O_ + U_, sparse_[i].options());
      sparse_[i].set_h_params(h);
    } else {
      const VectorXd h = sparse_[i].h_params();
      gps_[i] = gp::Gp(O_ + U_);
      gps_[i].set_h_params(h);  // (variance_points: set by learn() after its final fit)
    }
  }
  sparse_active_ = sparse;
}

ModelState GpDynamicsModel::state() const {
  ModelState st;
  st.phi = phi_;
  for (std::size_t i = 0; i < gps_.size(); ++i)
    st.h_params.push_back(sparse_active_ ? sparse_[i].h_params() : gps_[i].h_params());
  return st;
}

void GpDynamicsModel::restore(const ModelState& st) {
  check_size("restored phi", phi_.size(), st.phi.size());
  check_size("restored GP count", E_, static_cast<Eigen::Index>(st.h_params.size()));
  if (!st.phi.allFinite()) throw InvalidArgument("restored phi is not finite");
  if (prior_) prior_->check_phi(st.phi);
  // Both sets without data, at the state's hyper-parameters: the next learn() starts from them
  // whichever set it uses, as the run that saved the state did.
  std::vector<gp::Gp> gps(gps_.size(), gp::Gp(O_ + U_));
  for (std::size_t i = 0; i < gps.size(); ++i) {
    gps[i].set_h_params(st.h_params[i]);
    gps[i].set_variance_points(options_.variance_points);
  }
  std::vector<gp::SparseGp> sparse = sparse_;
  for (std::size_t i = 0; i < sparse.size(); ++i) {
    sparse[i] = gp::SparseGp(O_ + U_, sparse[i].options());
    sparse[i].set_h_params(st.h_params[i]);
  }
  gps_ = std::move(gps);
  sparse_ = std::move(sparse);
  sparse_active_ = false;
  phi_ = st.phi;
  clear_samples();
  posterior_ = PhiPosterior{};
  if (prior_) params_.values = phi_;
}

ModelSummary GpDynamicsModel::learn(const std::vector<Transition>& data,
                                    const ModelProgress& progress) {
  const auto t0 = Clock::now();
  ModelSummary s;
  // ModelOptions::reflect_transitions: the reflected copies follow the recorded transitions.
  std::vector<Transition> reflected;
  if (reflection_) {
    reflected.reserve(2 * data.size());
    reflected = data;
    for (const auto& t : data) reflected.push_back(reflection_->apply(t));
  }
  Dataset d = make_dataset(reflection_ ? reflected : data, task_.get(), E_, U_);
  s.points = reflection_ ? d.size() / 2 : d.size();  // recorded transitions
  if (d.size() == 0) throw InvalidArgument("learn: no transitions");
  if (reflection_) d.pairs = reflected_pairs(d, s.points, reflection_->state_sign);
  // The variance subset's factors (ModelOptions::variance_points) are made once, after the
  // final fit, for the rollouts; not at each of the many refits of the phi search.
  for (auto& g : gps_) g.set_variance_points(0);
  // ModelOptions::inducing_points: sparse GPs where the data exceed m (the search's and the
  // final fit's separately).
  const int M = options_.inducing_points;
  const int search_points =
      options_.gp_mi.max_points > 0 ? std::min(options_.gp_mi.max_points, d.size()) : d.size();
  // GP-MI (Algorithm 2): phi, warm-started from the previous episode's phi and kernels.
  if (options_.type == ModelType::kGpMi && !params_.tunable.empty() && !condition_only_) {
    activate(M > 0 && search_points > M);
    const GpMiSummary mi =
        sparse_active_
            ? identify_phi(*prior_, params_, d, options_.gp_mi, options_.rprop, sparse_, progress)
            : identify_phi(*prior_, params_, d, options_.gp_mi, options_.rprop, gps_, progress);
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
  activate(M > 0 && d.size() > M);
  if (sparse_active_ && condition_only_)
    throw InvalidArgument(
        "a model with sparse GPs (model.inducing_points below its " + std::to_string(d.size()) +
        " points) cannot be conditioned on saved data without a fit: only exact GPs can");
  if (sparse_active_) {
    s.log_likelihoods =
        fit_output_gps(sparse_, d.gp_in, targets, options_.rprop, &s.rprop_iterations);
    if (options_.type == ModelType::kGpMi && !params_.tunable.empty())
      s.phi_posterior = phi_posterior(*prior_, params_, d, sparse_);
    clear_samples();
    posterior_ = s.phi_posterior;
    s.score = gp_mi_score(s.log_likelihoods, options_.gp_mi.score);
    s.phi = phi_;
    s.seconds = seconds_since(t0);
    return s;
  }
  if (condition_only_) {
    s.log_likelihoods.resize(E_);
    for (int i = 0; i < E_; ++i) {
      auto& g = gps_[static_cast<std::size_t>(i)];
      g.compute(d.gp_in, targets.col(i));
      s.log_likelihoods[i] = g.log_marginal_likelihood();
    }
  } else {
    s.log_likelihoods =
        fit_output_gps(gps_, d.gp_in, targets, options_.rprop, &s.rprop_iterations, d.pairs);
  }
  if (options_.type == ModelType::kGpMi && !params_.tunable.empty() && !condition_only_)
    s.phi_posterior = phi_posterior(*prior_, params_, d, gps_);
  // Variances from a subset (ModelOptions::variance_points), chosen on the fitted kernels
  // (gp::greedy_variance_subset): its rows go last, in order, after the others in order, and the
  // GPs are refactorised on that order (the same kernels, the same posterior);
  // gp::Gp::set_variance_points conditions on the last rows. With the reflected transitions the
  // subset is chosen in mirror pairs (gp::greedy_variance_pairs: m / 2 recorded rows and their
  // images, the images last), which halves a variance's cost (gp::Gp::set_variance_pairs).
  const int m = options_.variance_points;
  int variance_rows = m;
  int variance_pairs = 0;
  if (m > 0 && d.size() > m) {
    const bool paired = d.pairs.n > 0 && d.size() == 2 * d.pairs.n && m >= 2;
    std::vector<int> subset;
    if (paired) {
      const std::vector<int> recorded = gp::greedy_variance_pairs(d.gp_in, gps_, m / 2);
      variance_pairs = static_cast<int>(recorded.size());
      subset = recorded;
      for (const int i : recorded) subset.push_back(d.pairs.n + i);
    } else {
      subset = gp::greedy_variance_subset(d.gp_in, gps_, m);
    }
    variance_rows = static_cast<int>(subset.size());
    std::vector<char> in_subset(static_cast<std::size_t>(d.size()), 0);
    for (const int i : subset) in_subset[static_cast<std::size_t>(i)] = 1;
    std::vector<int> order;
    order.reserve(static_cast<std::size_t>(d.size()));
    for (int n = 0; n < d.size(); ++n)
      if (!in_subset[static_cast<std::size_t>(n)]) order.push_back(n);
    order.insert(order.end(), subset.begin(), subset.end());
    d = d.rows(order);
    MatrixXd t(d.size(), targets.cols());
    for (int n = 0; n < d.size(); ++n) t.row(n) = targets.row(order[static_cast<std::size_t>(n)]);
    for (std::size_t i = 0; i < gps_.size(); ++i)
      gps_[i].compute(d.gp_in, t.col(static_cast<Eigen::Index>(i)));
  }
  // Every row in pairs (m = 0 or 2 n <= m): the exact variances, by blocks.
  if ((m == 0 || d.size() <= m) && d.pairs.n > 0 && d.size() == 2 * d.pairs.n)
    variance_pairs = d.pairs.n;
  for (auto& g : gps_) {
    if (variance_pairs > 0)
      g.set_variance_pairs(variance_pairs);
    else
      g.set_variance_points(variance_rows);
  }
  clear_samples();
  posterior_ = s.phi_posterior;
  if (options_.gp_mi.rollout_phi == RolloutPhi::kPosterior) {  // kept for draw_phi_samples
    data_x_ = d.x;
    data_u_ = d.u;
    data_dx_ = d.dx;
  }
  s.score = gp_mi_score(s.log_likelihoods, options_.gp_mi.score);
  s.phi = phi_;
  s.seconds = seconds_since(t0);
  return s;
}

ModelSummary GpDynamicsModel::condition(const std::vector<Transition>& data) {
  condition_only_ = true;
  try {
    ModelSummary s = learn(data);
    condition_only_ = false;
    return s;
  } catch (...) {
    condition_only_ = false;
    throw;
  }
}

void GpDynamicsModel::clear_samples() {
  sample_phi_.clear();
  sample_weights_.clear();
}

PhiSampling GpDynamicsModel::draw_phi_samples(int count, std::uint64_t seed) {
  if (count < 1)
    throw InvalidArgument("draw_phi_samples: count must be >= 1, got " + std::to_string(count));
  clear_samples();
  PhiSampling out;
  const auto K = static_cast<Eigen::Index>(posterior_.names.size());
  if (options_.type != ModelType::kGpMi || options_.gp_mi.rollout_phi != RolloutPhi::kPosterior ||
      K == 0 || !posterior_.covariance.allFinite() || data_x_.rows() != gps_.front().size())
    return out;
  // The continuous tunable entries, in the posterior's order (phi_posterior; an entry at its
  // bound is held there and not in the posterior).
  std::vector<Eigen::Index> at, bound;
  for (std::size_t k = 0; k < params_.tunable.size(); ++k) {
    if (!params_.choices[k].empty()) continue;
    const int i = params_.tunable[k];
    const std::string name = static_cast<std::size_t>(i) < params_.names.size()
                                 ? params_.names[static_cast<std::size_t>(i)]
                                 : "phi" + std::to_string(i);
    if (std::find(posterior_.names.begin(), posterior_.names.end(), name) ==
        posterior_.names.end())
      continue;
    at.push_back(i);
    bound.push_back(static_cast<Eigen::Index>(k));
  }
  check_size("draw_phi_samples: posterior dimension", static_cast<long>(at.size()), K);
  // Symmetric square root of the covariance (semi-definite: negative round-off set to 0).
  const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(posterior_.covariance);
  const MatrixXd C = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
                     eig.eigenvectors().transpose();
  Rng rng(seed);
  const Eigen::Index N = data_x_.rows();
  sample_weights_.assign(gps_.size(), MatrixXd(N, count));
  MatrixXd M;
  VectorXd z(K);
  for (int s = 0; s < count; ++s) {
    for (Eigen::Index k = 0; k < K; ++k) z[k] = rng.normal();
    const VectorXd draw = posterior_.mean + C * z;
    VectorXd phi = phi_;
    bool clamped = false;
    for (Eigen::Index k = 0; k < K; ++k) {
      const double lo = params_.lower[bound[static_cast<std::size_t>(k)]];
      const double hi = params_.upper[bound[static_cast<std::size_t>(k)]];
      const double v = std::clamp(draw[k], lo, hi);
      clamped = clamped || v != draw[k];
      phi[at[static_cast<std::size_t>(k)]] = v;
    }
    out.clamped += clamped ? 1 : 0;
    bool ok = true;
    try {
      prior_->check_phi(phi);
      prior_->evaluate_batch(data_x_, data_u_, phi, M);
      ok = M.allFinite();
    } catch (const InvalidArgument&) {
      ok = false;
    }
    if (!ok) {
      ++out.rejected;
      phi = phi_;
      prior_->evaluate_batch(data_x_, data_u_, phi, M);
    }
    for (std::size_t i = 0; i < gps_.size(); ++i) {
      const auto col = static_cast<Eigen::Index>(i);
      sample_weights_[i].col(s) = gps_[i].solve(data_dx_.col(col) - M.col(col));
    }
    sample_phi_.push_back(phi);
  }
  out.samples = count;
  return out;
}

void GpDynamicsModel::predict_batch_sampled(const MatrixXd& X, const MatrixXd& U,
                                            const std::vector<int>& sample, MatrixXd& mean,
                                            MatrixXd& var) const {
  if (sample_phi_.empty()) {
    DynamicsModel::predict_batch_sampled(X, U, sample, mean, var);
    return;
  }
  const Eigen::Index B = X.rows();
  check_samples(B, sample);
  thread_local MatrixXd in, obs, Xs, Us, Ms;
  thread_local VectorXd m, v;
  in.resize(B, O_ + U_);
  task_->observe_batch(X, obs);
  in.leftCols(O_) = obs;
  in.rightCols(U_) = U;
  // The simulator: one evaluate_batch per sample present, on its rows.
  mean.resize(B, E_);
  thread_local std::vector<char> done;
  thread_local std::vector<Eigen::Index> rows;
  done.assign(static_cast<std::size_t>(B), 0);
  for (Eigen::Index b = 0; b < B; ++b) {
    if (done[static_cast<std::size_t>(b)]) continue;
    const int s = sample[static_cast<std::size_t>(b)];
    rows.clear();
    for (Eigen::Index c = b; c < B; ++c) {
      if (sample[static_cast<std::size_t>(c)] != s) continue;
      rows.push_back(c);
      done[static_cast<std::size_t>(c)] = 1;
    }
    const auto R = static_cast<Eigen::Index>(rows.size());
    Xs.resize(R, X.cols());
    Us.resize(R, U.cols());
    for (Eigen::Index r = 0; r < R; ++r) {
      Xs.row(r) = X.row(rows[static_cast<std::size_t>(r)]);
      Us.row(r) = U.row(rows[static_cast<std::size_t>(r)]);
    }
    prior_->evaluate_batch(Xs, Us, sample_phi_[static_cast<std::size_t>(s)], Ms);
    for (Eigen::Index r = 0; r < R; ++r) mean.row(rows[static_cast<std::size_t>(r)]) = Ms.row(r);
  }
  var.resize(B, E_);
  for (int i = 0; i < E_; ++i) {
    gps_[static_cast<std::size_t>(i)].predict_batch(
        in, sample_weights_[static_cast<std::size_t>(i)], sample, m, v);
    mean.col(i) += m;
    var.col(i) = v;
  }
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
    if (sparse_active_)
      sparse_[static_cast<std::size_t>(i)].predict_batch(in, m, v);
    else
      gps_[static_cast<std::size_t>(i)].predict_batch(in, m, v);
    mean.col(i) += m;
    var.col(i) = v;
  }
}

}  // namespace drops::model
