// iRprop- maximisation of the GP log marginal likelihood (Igel & Huesken 2000, "Improving the Rprop
// learning algorithm", Fig. 3 "iRprop-"; settings.md §3).
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/gp/gp.hpp"
#include "rprop_loop.hpp"

namespace drops::gp {
namespace {

// Box kept on the log hyper-parameters during the search (documented in gp.hpp).
constexpr double kLogMin = -10.0;
constexpr double kLogMax = 10.0;
const double kLogNoiseStdMin = std::log(1e-5);

bool fail(std::string* why, const std::string& msg) {
  if (why != nullptr) *why = msg;
  return false;
}

// PILCO's soft walls (RpropOptions::penalty): value and gradient with respect to h.
class SoftWalls {
 public:
  SoftWalls(const RpropOptions& o, const Eigen::MatrixXd& X)
      : enabled_(o.penalty), power_(o.power), log_ratio_(std::log(o.max_length_scale_ratio)),
        log_snr_(std::log(o.max_snr)) {
    if (!enabled_) return;
    const Eigen::Index D = X.cols();
    log_std_.resize(D);
    active_.assign(static_cast<std::size_t>(D), false);
    const double n = static_cast<double>(X.rows());
    for (Eigen::Index d = 0; d < D; ++d) {
      const double mean = X.col(d).mean();
      const double var = n > 1 ? (X.col(d).array() - mean).square().sum() / (n - 1) : 0.0;
      const double s = std::sqrt(var);
      active_[static_cast<std::size_t>(d)] = s >= 1e-12;
      log_std_[d] = active_[static_cast<std::size_t>(d)] ? std::log(s) : 0.0;
    }
  }
  // Penalty at h (dim D + 2); adds its gradient to *grad (if not null).
  double operator()(const Eigen::VectorXd& h, Eigen::VectorXd* grad) const {
    if (!enabled_) return 0.0;
    const Eigen::Index D = log_std_.size();
    double value = 0.0;
    auto wall = [&](double z, double scale, double* dz) {
      const double zp = std::pow(z / scale, power_ - 1);
      *dz = power_ * zp / scale;
      return zp * z / scale;
    };
    double dz = 0.0;
    for (Eigen::Index d = 0; d < D; ++d) {
      if (!active_[static_cast<std::size_t>(d)]) continue;
      value += wall(h[d] - log_std_[d], log_ratio_, &dz);
      if (grad != nullptr) (*grad)[d] += dz;
    }
    value += wall(h[D] - h[D + 1], log_snr_, &dz);
    if (grad != nullptr) {
      (*grad)[D] += dz;
      (*grad)[D + 1] -= dz;
    }
    return value;
  }

 private:
  bool enabled_;
  int power_;
  double log_ratio_;
  double log_snr_;
  Eigen::VectorXd log_std_;
  std::vector<bool> active_;
};

}  // namespace

bool RpropOptions::IsValid(std::string* why) const {
  std::ostringstream os;
  if (max_iterations < 1) {
    os << "max_iterations: expected >= 1, got " << max_iterations;
    return fail(why, os.str());
  }
  if (!(std::isfinite(delta0) && delta0 > 0.0)) {
    os << "delta0: expected a finite value > 0, got " << delta0;
    return fail(why, os.str());
  }
  if (!(std::isfinite(delta_min) && delta_min > 0.0 && delta_min <= delta0)) {
    os << "delta_min: expected a finite value in (0, delta0 = " << delta0 << "], got " << delta_min;
    return fail(why, os.str());
  }
  if (!(std::isfinite(delta_max) && delta_max >= delta0)) {
    os << "delta_max: expected a finite value >= delta0 = " << delta0 << ", got " << delta_max;
    return fail(why, os.str());
  }
  if (!(eta_minus > 0.0 && eta_minus < 1.0)) {
    os << "eta_minus: expected a value in (0, 1), got " << eta_minus;
    return fail(why, os.str());
  }
  if (!(std::isfinite(eta_plus) && eta_plus > 1.0)) {
    os << "eta_plus: expected a finite value > 1, got " << eta_plus;
    return fail(why, os.str());
  }
  if (!(std::isfinite(tolerance) && tolerance >= 0.0)) {
    os << "tolerance: expected a finite value >= 0, got " << tolerance;
    return fail(why, os.str());
  }
  if (patience < 1) {
    os << "patience: expected >= 1, got " << patience;
    return fail(why, os.str());
  }
  if (!(std::isfinite(max_length_scale_ratio) && max_length_scale_ratio > 1.0)) {
    os << "max_length_scale_ratio: expected a finite value > 1, got " << max_length_scale_ratio;
    return fail(why, os.str());
  }
  if (!(std::isfinite(max_snr) && max_snr > 1.0)) {
    os << "max_snr: expected a finite value > 1, got " << max_snr;
    return fail(why, os.str());
  }
  if (power < 2 || power % 2 != 0) {
    os << "power: expected an even integer >= 2, got " << power;
    return fail(why, os.str());
  }
  if (why != nullptr) why->clear();
  return true;
}

namespace detail {

RpropSummary run_irprop(const RpropOptions& options, const Eigen::MatrixXd& X,
                        const Eigen::VectorXd& h0, RpropState* state, const RpropTarget& target) {
  const Eigen::Index P = h0.size();
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(P, kLogMin);
  Eigen::VectorXd hi = Eigen::VectorXd::Constant(P, kLogMax);
  lo[P - 1] = kLogNoiseStdMin;

  RpropSummary summary;
  // The objective f = log p(y | X, h) - walls(h), walls = 0 without options.penalty.
  const SoftWalls walls(options, X);
  auto objective = [&](const Eigen::VectorXd& at, Eigen::VectorXd& grad) {
    const double ll = target.evaluate(grad);
    Eigen::VectorXd wall_grad = Eigen::VectorXd::Zero(P);
    const double value = ll - walls(at, &wall_grad);
    grad -= wall_grad;
    return value;
  };
  Eigen::VectorXd h, g, best_h, best_g, delta, g_prev;
  double best_f = 0.0;
  std::vector<double> best_history;
  bool finished = false;
  bool pending = false;  // h was stepped to and not evaluated yet (a continued search)
  if (state != nullptr && state->started) {
    summary.iterations = state->iterations;
    summary.initial_log_likelihood = state->initial_log_likelihood;
    summary.cholesky_failures = state->cholesky_failures;
    h = state->h;
    g = state->g;
    g_prev = state->g_prev;
    delta = state->delta;
    best_h = state->best_h;
    best_g = state->best_g;
    best_f = state->best_f;
    best_history = state->best_history;
    finished = state->finished;
    pending = true;
  } else {
    // Warm start: the current h is already factorised.
    h = h0;
    double f = objective(h, g);
    summary.iterations = 1;
    summary.initial_log_likelihood = target.value();
    best_h = h;
    best_g = g;
    best_f = std::isfinite(f) && g.allFinite() ? f : -std::numeric_limits<double>::infinity();
    if (!(std::isfinite(f) && g.allFinite())) g.setZero();
    delta = Eigen::VectorXd::Constant(P, options.delta0);
    g_prev = Eigen::VectorXd::Zero(P);
    best_history.push_back(best_f);
  }
  const auto patience = static_cast<std::size_t>(options.patience);

  while (!finished) {
    if (!pending) {
      // iRprop- step (ascent on f).
      for (Eigen::Index i = 0; i < P; ++i) {
        const double s = g_prev[i] * g[i];
        if (s > 0.0) {
          delta[i] = std::min(delta[i] * options.eta_plus, options.delta_max);
        } else if (s < 0.0) {
          delta[i] = std::max(delta[i] * options.eta_minus, options.delta_min);
          g[i] = 0.0;
        }
        const double step = g[i] > 0.0 ? delta[i] : (g[i] < 0.0 ? -delta[i] : 0.0);
        const double to = h[i] + step;
        h[i] = std::clamp(to, lo[i], hi[i]);
        // A parameter pinned at the box keeps a moderate step, so that it can come back quickly
        // and does not jump across the box when its gradient changes sign.
        if (h[i] != to) delta[i] = std::min(delta[i], options.delta0);
        g_prev[i] = g[i];
      }
      if (delta.maxCoeff() <= options.delta_min) {  // every step at the floor: converged
        finished = true;
        break;
      }
    }
    if (summary.iterations >= options.max_iterations) {
      pending = true;  // the step is taken; a continued search evaluates it first
      break;
    }
    pending = false;

    ++summary.iterations;
    double f = 0.0;
    bool ok = true;
    try {
      target.apply(h);
      f = objective(h, g);
      ok = std::isfinite(f) && g.allFinite();
    } catch (const NumericalError&) {
      ok = false;
    }
    if (!ok) {
      // Treat the iterate as f = -inf: back to the best point with smaller steps.
      ++summary.cholesky_failures;
      delta = (delta * options.eta_minus).cwiseMax(options.delta_min);
      h = best_h;
      g = best_g;
      g_prev.setZero();
    } else if (f > best_f) {
      best_f = f;
      best_h = h;
      best_g = g;
    }
    best_history.push_back(best_f);
    if (options.tolerance > 0.0 && best_history.size() > patience &&
        best_f - best_history[best_history.size() - 1 - patience] < options.tolerance) {
      finished = true;
      break;
    }
  }

  if (state != nullptr) {
    state->started = true;
    state->finished = finished;
    state->iterations = summary.iterations;
    state->cholesky_failures = summary.cholesky_failures;
    state->initial_log_likelihood = summary.initial_log_likelihood;
    state->h = h;
    state->g = g;
    state->g_prev = g_prev;
    state->delta = delta;
    state->best_h = best_h;
    state->best_g = best_g;
    state->best_f = best_f;
    state->best_history = best_history;
  }
  target.keep(best_h);
  summary.final_log_likelihood = target.value();
  summary.final_penalty = walls(best_h, nullptr);
  return summary;
}

}  // namespace detail

RpropSummary Gp::optimize_h_params(const RpropOptions& options, RpropState* state) {
  std::string why;
  if (!options.IsValid(&why)) {
    throw InvalidArgument("Gp::optimize_h_params: invalid RpropOptions: " + why);
  }
  if (size() == 0) {
    throw InvalidArgument(
        "Gp::optimize_h_params: training points: expected N >= 1 (call compute first), got 0");
  }
  if (options.penalty && !se_) {
    throw InvalidArgument("Gp::optimize_h_params: the soft walls (penalty) need the SE-ARD kernel, "
                          "this GP has '" + kernel_->name() + "'");
  }
  const Eigen::Index P = h_.size();
  if (state != nullptr && state->started && state->h.size() != P) {
    throw InvalidArgument("Gp::optimize_h_params: state: expected " + std::to_string(P) +
                          " hyper-parameters, got " + std::to_string(state->h.size()));
  }
  detail::RpropTarget target;
  target.apply = [this](const Eigen::VectorXd& h) {
    apply_h(h, /*subset=*/false);  // the subset's factor once, for the iterate kept
  };
  target.evaluate = [this](Eigen::VectorXd& grad) {
    grad = log_marginal_likelihood_gradient();
    return log_marginal_likelihood();
  };
  target.value = [this] { return log_marginal_likelihood(); };
  // Keep the best iterate (it factorised before, so this succeeds; so does its variance subset's
  // factor, a principal block of the same positive definite matrix, barring round-off).
  target.keep = [this](const Eigen::VectorXd& h) { apply_h(h); };
  return detail::run_irprop(options, X_, h_params(), state, target);
}

}  // namespace drops::gp
