#include "drops/model/dynamics_model.hpp"

#include <nlopt.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"

namespace drops::model {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Training set in the form the models need. Xin: GP inputs (N x (O + U)); X, U raw; DX targets.
struct Dataset {
  MatrixXd x, u, dx, gp_in;
  int size() const { return static_cast<int>(x.rows()); }
};

Dataset make_dataset(const std::vector<Transition>& data, const rollout::Task* task, int E, int U) {
  Dataset d;
  const int N = static_cast<int>(data.size());
  d.x.resize(N, E);
  d.u.resize(N, U);
  d.dx.resize(N, E);
  const int O = task ? task->observation_dim() : 0;
  if (task) d.gp_in.resize(N, O + U);
  VectorXd obs(O);
  for (int n = 0; n < N; ++n) {
    const Transition& t = data[static_cast<std::size_t>(n)];
    check_size("transition x", E, t.x.size());
    check_size("transition u", U, t.u.size());
    check_size("transition dx", E, t.dx.size());
    if (!t.x.allFinite() || !t.u.allFinite() || !t.dx.allFinite())
      throw InvalidArgument("transition " + std::to_string(n) + " has non-finite values");
    d.x.row(n) = t.x.transpose();
    d.u.row(n) = t.u.transpose();
    d.dx.row(n) = t.dx.transpose();
    if (task) {
      task->observe(t.x, obs);
      d.gp_in.row(n).head(O) = obs.transpose();
      d.gp_in.row(n).tail(U) = t.u.transpose();
    }
  }
  return d;
}

/// Evenly spaced subset of at most max_points rows (all when max_points <= 0 or N is smaller).
std::vector<int> subsample(int N, int max_points) {
  std::vector<int> idx;
  if (max_points <= 0 || N <= max_points) {
    for (int i = 0; i < N; ++i) idx.push_back(i);
    return idx;
  }
  for (int k = 0; k < max_points; ++k)
    idx.push_back(static_cast<int>(std::floor(static_cast<double>(k) * N / max_points)));
  return idx;
}

MatrixXd rows(const MatrixXd& m, const std::vector<int>& idx) {
  MatrixXd out(static_cast<Eigen::Index>(idx.size()), m.cols());
  for (std::size_t k = 0; k < idx.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = m.row(idx[k]);
  return out;
}

/// Simulator predictions for every row at phi, in parallel; counts non-finite outputs.
MatrixXd prior_outputs(const MeanFunction& prior, const MatrixXd& X, const MatrixXd& U,
                       const VectorXd& phi, long* nonfinite) {
  const int N = static_cast<int>(X.rows()), E = prior.state_dim();
  MatrixXd out(N, E);
  constexpr int kChunk = 64;
  const int chunks = (N + kChunk - 1) / kChunk;
  std::vector<long> bad(static_cast<std::size_t>(chunks), 0);
  parallel_for(static_cast<std::size_t>(chunks), [&](std::size_t c) {
    VectorXd x(X.cols()), u(U.cols()), dx(E);
    const int end = std::min(N, static_cast<int>(c + 1) * kChunk);
    for (int n = static_cast<int>(c) * kChunk; n < end; ++n) {
      x = X.row(n).transpose();
      u = U.row(n).transpose();
      prior.evaluate(x, u, phi, dx);
      if (!dx.allFinite()) ++bad[c];
      out.row(n) = dx.transpose();
    }
  });
  long total = 0;
  for (long b : bad) total += b;
  if (nonfinite) *nonfinite += total;
  return out;
}

/// Enumerates the Cartesian product of the discrete choices of the tunable parameters.
/// Returns, per combination, the values of the discrete entries (indices into tunable).
std::vector<std::vector<std::pair<int, double>>> discrete_combinations(const PriorParameters& p) {
  std::vector<std::vector<std::pair<int, double>>> combos{{}};
  for (std::size_t k = 0; k < p.tunable.size(); ++k) {
    if (p.choices[k].empty()) continue;
    std::vector<std::vector<std::pair<int, double>>> next;
    for (const auto& c : combos)
      for (double v : p.choices[k]) {
        auto e = c;
        e.emplace_back(static_cast<int>(k), v);
        next.push_back(std::move(e));
      }
    combos = std::move(next);
  }
  return combos;
}

/// Maximises f over the continuous tunable parameters of p (discrete ones exhaustively), starting
/// from p.values, with Subplex. f receives a full phi and returns a score (-inf = invalid).
/// Returns the best full phi and its score; *evaluations counts calls of f.
std::pair<VectorXd, double> search_phi(const PriorParameters& p, const MeanFunction& prior,
                                       int max_evaluations, double xtol_rel, double ftol_rel,
                                       const std::function<double(const VectorXd&)>& f,
                                       int* evaluations) {
  std::vector<int> cont;  // indices into tunable of continuous parameters
  for (std::size_t k = 0; k < p.tunable.size(); ++k)
    if (p.choices[k].empty()) cont.push_back(static_cast<int>(k));
  VectorXd best_phi = p.values;
  double best = -kInf;
  auto scored = [&](const VectorXd& phi) {
    double s;
    try {
      prior.check_phi(phi);
      s = f(phi);
    } catch (const InvalidArgument&) {
      s = -kInf;
    }
    ++*evaluations;
    if (!std::isfinite(s)) s = -kInf;
    if (s > best) {
      best = s;
      best_phi = phi;
    }
    return s;
  };
  for (const auto& combo : discrete_combinations(p)) {
    VectorXd phi0 = p.values;
    for (const auto& [k, v] : combo) phi0[p.tunable[static_cast<std::size_t>(k)]] = v;
    if (cont.empty()) {
      scored(phi0);
      continue;
    }
    const unsigned n = static_cast<unsigned>(cont.size());
    nlopt::opt opt(nlopt::LN_SBPLX, n);
    std::vector<double> lb(n), ub(n), x(n), step(n);
    for (unsigned j = 0; j < n; ++j) {
      const int k = cont[j];
      lb[j] = p.lower[k];
      ub[j] = p.upper[k];
      x[j] = std::clamp(phi0[p.tunable[static_cast<std::size_t>(k)]], lb[j], ub[j]);
      step[j] = std::max(1e-6, 0.1 * (ub[j] - lb[j]));
    }
    opt.set_lower_bounds(lb);
    opt.set_upper_bounds(ub);
    opt.set_initial_step(step);
    opt.set_maxeval(max_evaluations);
    opt.set_xtol_rel(xtol_rel);
    opt.set_ftol_rel(ftol_rel);
    struct Context {
      const std::function<double(const VectorXd&)>* scored;
      const PriorParameters* p;
      const std::vector<int>* cont;
      const VectorXd* phi0;
    };
    const std::function<double(const VectorXd&)> to_nlopt = [&](const VectorXd& phi) {
      const double s = scored(phi);
      return std::isfinite(s) ? s : -1e300;  // Subplex needs a finite value
    };
    Context ctx{&to_nlopt, &p, &cont, &phi0};
    opt.set_max_objective(
        [](const std::vector<double>& xv, std::vector<double>& /*grad*/, void* data) -> double {
          const auto* c = static_cast<const Context*>(data);
          VectorXd phi = *c->phi0;
          for (std::size_t j = 0; j < xv.size(); ++j)
            phi[c->p->tunable[static_cast<std::size_t>((*c->cont)[j])]] = xv[j];
          return (*c->scored)(phi);
        },
        &ctx);
    double fval = 0;
    try {
      opt.optimize(x, fval);
    } catch (const std::exception&) {
      // Subplex stopped on round-off or a forced stop: the best point is tracked in `scored`.
    }
  }
  return {best_phi, best};
}

// ---------------------------------------------------------------------------------------------
/// The GP model of the gp, gp_prior and gp_mi variants.
class GpModel final : public DynamicsModel {
 public:
  GpModel(const ModelOptions& options, std::shared_ptr<const rollout::Task> task,
          std::shared_ptr<const MeanFunction> prior, const PriorParameters& parameters)
      : options_(options), task_(std::move(task)), prior_(std::move(prior)), params_(parameters) {
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

  ModelType type() const override { return options_.type; }
  VectorXd phi() const override { return phi_; }

  ModelState state() const override {
    ModelState st;
    st.phi = phi_;
    for (const auto& g : gps_) st.h_params.push_back(g.h_params());
    return st;
  }

  void restore(const ModelState& st) override {
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

  ModelSummary learn(const std::vector<Transition>& data, const ModelProgress& progress) override {
    const auto t0 = Clock::now();
    ModelSummary s;
    Dataset d = make_dataset(data, task_.get(), E_, U_);
    s.points = d.size();
    if (d.size() == 0) throw InvalidArgument("learn: no transitions");

    if (options_.type == ModelType::kGpMi && !params_.tunable.empty()) {
      // A purely discrete phi is searched nested: with kernels fitted to one candidate's
      // residuals (alternating search), every other candidate is scored against them and the
      // search stays where it started (measured on the hexapod's 7 priors).
      const bool all_discrete = std::all_of(params_.choices.begin(), params_.choices.end(),
                                            [](const auto& c) { return !c.empty(); });
      if (options_.gp_mi.search == GpMiSearch::kAlternating && !all_discrete)
        learn_alternating(d, s, progress);
      else
        learn_nested(d, s, progress);
      params_.values = phi_;  // warm start of the next episode
    }
    // Final fit: all data, phi fixed, full Rprop budget (warm-started).
    if (progress) progress("kernels", s.phi_evaluations, s.score);
    MatrixXd targets = d.dx;
    if (prior_) targets -= prior_outputs(*prior_, d.x, d.u, phi_, &s.nonfinite_prior_outputs);
    if (!targets.allFinite())
      throw NumericalError("the simulator prior returned non-finite values at phi = [" +
                           format_phi() + "] on the recorded data");
    s.log_likelihoods = fit_kernels(d.gp_in, targets, options_.rprop, &s.rprop_iterations);
    s.score = gp_mi_score(s.log_likelihoods, options_.gp_mi.score);
    s.phi = phi_;
    s.seconds = seconds_since(t0);
    return s;
  }

  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
    MatrixXd X = x.transpose(), U = u.transpose(), mean, var;
    predict_batch(X, U, mean, var);
    out.mean = mean.row(0).transpose();
    out.var = var.row(0).transpose();
  }

  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override {
    const Eigen::Index B = X.rows();
    // Called at every step of every rollout: per-thread buffers, resized (not reallocated) when
    // the batch shape repeats.
    thread_local MatrixXd in;
    thread_local VectorXd x, u, obs, dx, m, v;
    in.resize(B, O_ + U_);
    x.resize(E_);
    u.resize(U_);
    obs.resize(O_);
    dx.resize(E_);
    mean.resize(B, E_);
    var.resize(B, E_);
    for (Eigen::Index b = 0; b < B; ++b) {
      x = X.row(b).transpose();
      u = U.row(b).transpose();
      task_->observe(x, obs);
      in.row(b).head(O_) = obs.transpose();
      in.row(b).tail(U_) = u.transpose();
      if (prior_) {
        prior_->evaluate(x, u, phi_, dx);
        mean.row(b) = dx.transpose();
      } else {
        mean.row(b).setZero();
      }
    }
    for (int i = 0; i < E_; ++i) {
      gps_[static_cast<std::size_t>(i)].predict_batch(in, m, v);
      mean.col(i) += m;
      var.col(i) = v;
    }
  }

 private:
  /// Fits every output GP on (in, targets) with Rprop in parallel over outputs; returns the
  /// per-output log-likelihoods.
  VectorXd fit_kernels(const MatrixXd& in, const MatrixXd& targets, const gp::RpropOptions& ro,
                       long* iterations) {
    VectorXd ll(E_);
    std::vector<int> its(static_cast<std::size_t>(E_), 0);
    parallel_for(static_cast<std::size_t>(E_), [&](std::size_t i) {
      auto& g = gps_[i];
      g.compute(in, targets.col(static_cast<Eigen::Index>(i)));
      const auto r = g.optimize_h_params(ro);
      its[i] = r.iterations;
      ll[static_cast<Eigen::Index>(i)] = g.log_marginal_likelihood();
    });
    for (int k : its) *iterations += k;
    return ll;
  }

  void learn_alternating(const Dataset& full, ModelSummary& s, const ModelProgress& progress) {
    const auto idx = subsample(full.size(), options_.gp_mi.max_points);
    const MatrixXd X = rows(full.x, idx), U = rows(full.u, idx), DX = rows(full.dx, idx),
                   IN = rows(full.gp_in, idx);
    gp::RpropOptions inner = options_.rprop;
    inner.max_iterations = options_.gp_mi.inner_rprop_iterations;
    const VectorXd lower = params_.lower, upper = params_.upper;
    for (int round = 0; round < options_.gp_mi.rounds; ++round) {
      // (a) kernels at the current phi.
      MatrixXd targets = DX - prior_outputs(*prior_, X, U, phi_, &s.nonfinite_prior_outputs);
      if (!targets.allFinite()) break;  // keep phi; the final fit reports the error
      fit_kernels(IN, targets, inner, &s.rprop_iterations);
      // (b) phi with the kernels fixed: each evaluation re-solves with the factorisations kept.
      PriorParameters p = params_;
      p.values = phi_;
      int evals = 0;
      auto score = [&](const VectorXd& phi) {
        long bad = 0;
        const MatrixXd t = DX - prior_outputs(*prior_, X, U, phi, &bad);
        s.nonfinite_prior_outputs += bad;
        if (bad) return -kInf;
        VectorXd ll(E_);
        for (int i = 0; i < E_; ++i) {
          auto& g = gps_[static_cast<std::size_t>(i)];
          g.set_targets(t.col(i));
          ll[i] = g.log_marginal_likelihood();
        }
        const double sc = gp_mi_score(ll, options_.gp_mi.score);
        if (progress && (evals % 50 == 0)) progress("gp-mi", s.phi_evaluations + evals, sc);
        return sc;
      };
      const auto [phi_new, best] = search_phi(p, *prior_, options_.gp_mi.max_evaluations,
                                              options_.gp_mi.xtol_rel, options_.gp_mi.ftol_rel,
                                              score, &evals);
      s.phi_evaluations += evals;
      s.rounds = round + 1;
      double move = 0;
      for (std::size_t k = 0; k < params_.tunable.size(); ++k) {
        const int i = params_.tunable[k];
        const double width = std::max(1e-12, upper[static_cast<Eigen::Index>(k)] -
                                                 lower[static_cast<Eigen::Index>(k)]);
        move = std::max(move, std::abs(phi_new[i] - phi_[i]) / width);
      }
      if (std::isfinite(best)) phi_ = phi_new;
      if (move < 1e-3) break;
    }
  }

  void learn_nested(const Dataset& full, ModelSummary& s, const ModelProgress& progress) {
    const auto idx = subsample(full.size(), options_.gp_mi.max_points);
    const MatrixXd X = rows(full.x, idx), U = rows(full.u, idx), DX = rows(full.dx, idx),
                   IN = rows(full.gp_in, idx);
    gp::RpropOptions inner = options_.rprop;
    inner.max_iterations = options_.gp_mi.inner_rprop_iterations;
    std::vector<VectorXd> best_h(static_cast<std::size_t>(E_));
    for (int i = 0; i < E_; ++i) best_h[static_cast<std::size_t>(i)] = gps_[static_cast<std::size_t>(i)].h_params();
    double best_score = -kInf;
    int evals = 0;
    std::atomic<long> rprop_its{0};
    auto score = [&](const VectorXd& phi) {
      long bad = 0;
      const MatrixXd t = DX - prior_outputs(*prior_, X, U, phi, &bad);
      s.nonfinite_prior_outputs += bad;
      if (bad) return -kInf;
      VectorXd ll(E_);
      std::vector<VectorXd> h(static_cast<std::size_t>(E_));
      parallel_for(static_cast<std::size_t>(E_), [&](std::size_t i) {
        gp::Gp g(O_ + U_);
        g.set_h_params(best_h[i]);  // warm start from the best kernels so far
        try {
          g.compute(IN, t.col(static_cast<Eigen::Index>(i)));
          rprop_its += g.optimize_h_params(inner).iterations;
          ll[static_cast<Eigen::Index>(i)] = g.log_marginal_likelihood();
          h[i] = g.h_params();
        } catch (const NumericalError&) {
          ll[static_cast<Eigen::Index>(i)] = -kInf;
        }
      });
      const double sc = gp_mi_score(ll, options_.gp_mi.score);
      if (sc > best_score) {
        best_score = sc;
        for (int i = 0; i < E_; ++i)
          if (h[static_cast<std::size_t>(i)].size()) best_h[static_cast<std::size_t>(i)] = h[static_cast<std::size_t>(i)];
      }
      if (progress && (evals % 10 == 0)) progress("gp-mi", evals, best_score);
      return sc;
    };
    PriorParameters p = params_;
    p.values = phi_;
    const auto [phi_new, best] = search_phi(p, *prior_, options_.gp_mi.max_evaluations,
                                            options_.gp_mi.xtol_rel, options_.gp_mi.ftol_rel,
                                            score, &evals);
    s.phi_evaluations += evals;
    s.rprop_iterations += rprop_its;
    if (std::isfinite(best)) {
      phi_ = phi_new;
      for (int i = 0; i < E_; ++i) gps_[static_cast<std::size_t>(i)].set_h_params(best_h[static_cast<std::size_t>(i)]);
    }
  }

  std::string format_phi() const {
    std::ostringstream o;
    for (Eigen::Index i = 0; i < phi_.size(); ++i) o << (i ? ", " : "") << phi_[i];
    return o.str();
  }

  ModelOptions options_;
  std::shared_ptr<const rollout::Task> task_;
  std::shared_ptr<const MeanFunction> prior_;
  PriorParameters params_;
  int E_ = 0, U_ = 0, O_ = 0;
  VectorXd phi_;
  std::vector<gp::Gp> gps_;
};

// ---------------------------------------------------------------------------------------------
/// The simulator alone (deterministic), optionally identified by one-step MSE (the mi variant).
class SimulatorModel final : public DynamicsModel {
 public:
  SimulatorModel(const ModelOptions& options, std::shared_ptr<const MeanFunction> prior,
                 const PriorParameters& parameters, bool identify)
      : options_(options), prior_(std::move(prior)), params_(parameters), identify_(identify) {
    if (!prior_) throw InvalidArgument("model '" + to_string(options.type) + "' needs a prior");
    params_.check();
    prior_->check_phi(params_.values);
    phi_ = params_.values;
  }
  ModelType type() const override { return options_.type; }
  VectorXd phi() const override { return phi_; }

  ModelState state() const override { return ModelState{phi_, {}}; }

  void restore(const ModelState& st) override {
    check_size("restored phi", phi_.size(), st.phi.size());
    if (!st.h_params.empty()) throw InvalidArgument("restored state has GP kernels; model is '" +
                                                    to_string(options_.type) + "'");
    if (!st.phi.allFinite()) throw InvalidArgument("restored phi is not finite");
    prior_->check_phi(st.phi);
    phi_ = st.phi;
  }

  ModelSummary learn(const std::vector<Transition>& data, const ModelProgress& progress) override {
    const auto t0 = Clock::now();
    ModelSummary s;
    const int E = prior_->state_dim(), U = prior_->action_dim();
    Dataset d = make_dataset(data, nullptr, E, U);
    s.points = d.size();
    if (identify_ && d.size() > 0 && !params_.tunable.empty()) {
      int evals = 0;
      auto neg_mse = [&](const VectorXd& phi) {
        long bad = 0;
        const MatrixXd m = prior_outputs(*prior_, d.x, d.u, phi, &bad);
        s.nonfinite_prior_outputs += bad;
        if (bad) return -kInf;
        const double mse = (m - d.dx).squaredNorm() / d.size();
        if (progress && evals % 100 == 0) progress("mi", evals, mse);
        return -mse;
      };
      PriorParameters p = params_;
      p.values = phi_;
      const auto [phi_new, best] = search_phi(p, *prior_, options_.mi.max_evaluations,
                                              options_.mi.xtol_rel, options_.mi.ftol_rel, neg_mse,
                                              &evals);
      s.phi_evaluations = evals;
      if (std::isfinite(best)) {
        phi_ = phi_new;
        s.score = -best;
      }
    }
    s.phi = phi_;
    s.seconds = seconds_since(t0);
    return s;
  }

  void predict(const VectorXd& x, const VectorXd& u, Prediction& out) const override {
    out.mean.resize(prior_->state_dim());
    prior_->evaluate(x, u, phi_, out.mean);
    out.var = VectorXd::Zero(prior_->state_dim());
  }

  void predict_batch(const MatrixXd& X, const MatrixXd& U, MatrixXd& mean,
                     MatrixXd& var) const override {
    const int E = prior_->state_dim();
    mean.resize(X.rows(), E);
    var = MatrixXd::Zero(X.rows(), E);
    VectorXd x(X.cols()), u(U.cols()), dx(E);
    for (Eigen::Index b = 0; b < X.rows(); ++b) {
      x = X.row(b).transpose();
      u = U.row(b).transpose();
      prior_->evaluate(x, u, phi_, dx);
      mean.row(b) = dx.transpose();
    }
  }

 private:
  ModelOptions options_;
  std::shared_ptr<const MeanFunction> prior_;
  PriorParameters params_;
  bool identify_;
  VectorXd phi_;
};

}  // namespace

ModelType parse_model_type(const std::string& name) {
  if (name == "gp") return ModelType::kGp;
  if (name == "gp_prior") return ModelType::kGpPrior;
  if (name == "gp_mi") return ModelType::kGpMi;
  if (name == "mi") return ModelType::kMi;
  throw InvalidArgument("unknown model type '" + name + "' (allowed: gp, gp_prior, gp_mi, mi)");
}

std::string to_string(ModelType type) {
  switch (type) {
    case ModelType::kGp: return "gp";
    case ModelType::kGpPrior: return "gp_prior";
    case ModelType::kGpMi: return "gp_mi";
    case ModelType::kMi: return "mi";
  }
  return "?";
}

double gp_mi_score(const VectorXd& ll, GpMiScore score) {
  if (score == GpMiScore::kSumOfLikelihoods) return log_sum_exp(ll);
  if ((ll.array() == -std::numeric_limits<double>::infinity()).any())
    return -std::numeric_limits<double>::infinity();
  return ll.sum();
}

double log_sum_exp(const VectorXd& v) {
  if (v.size() == 0) return -kInf;
  const double m = v.maxCoeff();
  if (!std::isfinite(m)) return m;
  return m + std::log((v.array() - m).exp().sum());
}

std::string ModelSummary::BriefReport() const {
  std::ostringstream o;
  o << "model: " << points << " points";
  if (phi.size()) {
    o << ", phi = [";
    for (Eigen::Index i = 0; i < phi.size(); ++i) o << (i ? ", " : "") << phi[i];
    o << "]";
  }
  if (phi_evaluations) o << ", " << phi_evaluations << " phi evaluations";
  if (log_likelihoods.size()) o << ", score " << score;
  o << ", " << rprop_iterations << " Rprop iterations, " << seconds << " s";
  if (nonfinite_prior_outputs) o << ", " << nonfinite_prior_outputs << " non-finite prior outputs";
  return o.str();
}

std::unique_ptr<DynamicsModel> make_model(const ModelOptions& options,
                                          std::shared_ptr<const rollout::Task> task,
                                          std::shared_ptr<const MeanFunction> prior,
                                          const PriorParameters& parameters) {
  if (!task) throw InvalidArgument("make_model: task is null");
  switch (options.type) {
    case ModelType::kGp:
      return std::make_unique<GpModel>(options, std::move(task), nullptr, PriorParameters{});
    case ModelType::kGpPrior:
    case ModelType::kGpMi:
      if (!prior)
        throw InvalidArgument("model '" + to_string(options.type) + "' needs a simulator prior");
      return std::make_unique<GpModel>(options, std::move(task), std::move(prior), parameters);
    case ModelType::kMi:
      return std::make_unique<SimulatorModel>(options, std::move(prior), parameters, true);
  }
  throw InvalidArgument("make_model: unknown type");
}

std::unique_ptr<DynamicsModel> make_prior_only_model(std::shared_ptr<const MeanFunction> prior,
                                                     const PriorParameters& parameters) {
  ModelOptions o;
  o.type = ModelType::kGpPrior;
  return std::make_unique<SimulatorModel>(o, std::move(prior), parameters, false);
}

}  // namespace drops::model
