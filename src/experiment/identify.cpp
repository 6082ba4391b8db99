#include "drops/experiment/identify.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/model/dataset.hpp"

namespace drops::experiment {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

class FeatureTask final : public Task {
 public:
  FeatureTask(int E, int U, double dt, InputFeatures f) : E_(E), U_(U), dt_(dt), f_(std::move(f)) {}
  std::string name() const override { return "features"; }
  int state_dim() const override { return E_; }
  int action_dim() const override { return U_; }
  int observation_dim() const override { return f_.dim > 0 ? f_.dim : E_; }
  int horizon() const override { return 1; }
  double dt() const override { return dt_; }
  VectorXd initial_state() const override { return VectorXd::Zero(E_); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override {
    if (f_.dim > 0)
      f_.observe(x, obs);
    else
      obs = x;
  }
  double reward(const VectorXd&) const override { return 0; }
  bool solved(const Trajectory&) const override { return false; }

 private:
  int E_, U_;
  double dt_;
  InputFeatures f_;
};

/// Linear-interpolation percentile (numpy's default) of v (sorted in place); q in [0, 1].
double percentile(std::vector<double>& v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  const double a = v[lo], b = v[hi];
  if (a == kInf || b == kInf) return pos == static_cast<double>(lo) ? a : kInf;
  return a + (pos - static_cast<double>(lo)) * (b - a);
}

int steps_of(double seconds, double dt) {
  return std::max(1, static_cast<int>(std::lround(seconds / dt)));
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::shared_ptr<const Task> feature_task(int state_dim, int action_dim, double dt,
                                         InputFeatures features) {
  if (state_dim < 1 || action_dim < 1)
    throw InvalidArgument(fmt::format("feature_task: state_dim {} and action_dim {} must be >= 1",
                                      state_dim, action_dim));
  if (!(dt > 0) || !std::isfinite(dt))
    throw InvalidArgument(fmt::format("feature_task: dt = {} must be > 0", dt));
  if (features.dim < 0 || (features.dim > 0 && !features.observe))
    throw InvalidArgument(fmt::format(
        "feature_task: features.dim = {} needs an observe function (dim 0: the raw state)",
        features.dim));
  return std::make_shared<FeatureTask>(state_dim, action_dim, dt, std::move(features));
}

bool IdentifyOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (logs.empty()) return fail("identify: no fit log (identify.logs is empty)");
  std::string w;
  if (!log.IsValid(&w)) return fail(w);
  if (!columns.IsValid(&w)) return fail(w);
  if (horizons.empty()) return fail("identify.horizons: at least one horizon");
  int last = 0;
  for (double h : horizons) {
    if (!std::isfinite(h) || h < log.dt * (1 - 1e-9))
      return fail(fmt::format("identify.horizons: {} s is shorter than dt = {} s", h, log.dt));
    const int n = steps_of(h, log.dt);
    if (n <= last)
      return fail(fmt::format("identify.horizons: {} s is not longer than the one before it "
                              "(in steps of dt = {} s)",
                              h, log.dt));
    last = n;
  }
  if (!std::isfinite(start_spacing) || start_spacing < log.dt * (1 - 1e-9))
    return fail(fmt::format("identify.start_spacing: {} s is shorter than dt = {} s",
                            start_spacing, log.dt));
  if (max_points < 0) return fail(fmt::format("identify.max_points: {} < 0", max_points));
  if (threads < 0) return fail(fmt::format("threads: {} < 0", threads));
  return true;
}

MatrixXd open_loop_rollout(const model::DynamicsModel& model, const VectorXd& x0,
                           const MatrixXd& actions) {
  MatrixXd out(actions.rows() + 1, x0.size());
  out.row(0) = x0.transpose();
  Prediction p;
  VectorXd x = x0;
  for (Eigen::Index k = 0; k < actions.rows(); ++k) {
    const VectorXd u = actions.row(k).transpose();
    model.predict(x, u, p);
    if (p.mean.size() != x.size())
      throw InvalidArgument(fmt::format("open_loop_rollout: the model predicts dim {}, the state "
                                        "has dim {}",
                                        p.mean.size(), x.size()));
    x += p.mean;
    out.row(k + 1) = x.transpose();
  }
  return out;
}

std::vector<PredictionErrors> prediction_errors(const model::DynamicsModel& model,
                                                const RecordedLog& log, const std::string& file,
                                                const std::vector<double>& horizons,
                                                double start_spacing) {
  const double dt = log.dt;
  if (!(start_spacing >= dt * (1 - 1e-9)))
    throw InvalidArgument(fmt::format("prediction_errors: start spacing {} s < dt {} s",
                                      start_spacing, dt));
  const int E = static_cast<int>(log.state_names.size());
  // Horizons in steps, the one-step errors first (start spacing: one step).
  std::vector<int> steps = {1};
  std::vector<double> seconds = {dt};
  std::vector<int> spacing = {1};
  for (double h : horizons) {
    if (!(h >= dt * (1 - 1e-9)))
      throw InvalidArgument(fmt::format("prediction_errors: horizon {} s < dt {} s", h, dt));
    steps.push_back(steps_of(h, dt));
    seconds.push_back(h);
    spacing.push_back(steps_of(start_spacing, dt));
  }
  // errs[h][i]: the errors of state i at horizon h over every start.
  std::vector<std::vector<std::vector<double>>> errs(
      steps.size(), std::vector<std::vector<double>>(static_cast<std::size_t>(E)));
  for (const LogSegment& seg : log.segments) {
    const int K = seg.transitions();
    for (std::size_t h = 0; h < steps.size(); ++h) {
      const int n = steps[h];
      std::vector<int> starts;
      for (int k = 0; k + n <= K; k += spacing[h]) starts.push_back(k);
      if (starts.empty()) continue;
      const auto B = static_cast<Eigen::Index>(starts.size());
      MatrixXd X(B, E), U(B, seg.u.cols()), mean, var;
      for (Eigen::Index b = 0; b < B; ++b) X.row(b) = seg.x.row(starts[static_cast<std::size_t>(b)]);
      for (int j = 0; j < n; ++j) {
        for (Eigen::Index b = 0; b < B; ++b)
          U.row(b) = seg.u.row(starts[static_cast<std::size_t>(b)] + j);
        model.predict_batch(X, U, mean, var);
        X += mean;
      }
      for (Eigen::Index b = 0; b < B; ++b)
        for (int i = 0; i < E; ++i) {
          const double e =
              std::abs(X(b, i) - seg.x(starts[static_cast<std::size_t>(b)] + n, i));
          errs[h][static_cast<std::size_t>(i)].push_back(std::isfinite(e) ? e : kInf);
        }
    }
  }
  std::vector<PredictionErrors> out;
  for (std::size_t h = 0; h < steps.size(); ++h)
    for (int i = 0; i < E; ++i) {
      auto& v = errs[h][static_cast<std::size_t>(i)];
      PredictionErrors r;
      r.file = file;
      r.horizon = seconds[h];
      r.steps = steps[h];
      r.dim = i;
      r.state = log.state_names[static_cast<std::size_t>(i)];
      r.n = static_cast<int>(v.size());
      r.p90 = percentile(v, 0.9);
      r.median = percentile(v, 0.5);
      out.push_back(r);
    }
  return out;
}

IdentifyResult identify(const IdentifyModel& what, const std::vector<RecordedLog>& fit,
                        const std::vector<RecordedLog>& validation,
                        const IdentifyOptions& options, const IdentifyMessage& message,
                        const model::ModelProgress& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument(why);
  if (fit.empty()) throw InvalidArgument("identify: no fit log");
  auto say = [&](const std::string& s) {
    if (message) message(s);
  };
  ThreadLimit limit(options.threads);
  const double dt = options.log.dt;
  const RecordedLog& first = fit.front();
  const int E = static_cast<int>(first.state_names.size());
  const int U = static_cast<int>(first.action_names.size());
  auto check_log = [&](const RecordedLog& l) {
    if (l.state_names != first.state_names || l.action_names != first.action_names)
      throw InvalidArgument("identify: log " + l.report.source +
                            " has other state or action columns than " + first.report.source);
    if (std::abs(l.dt - dt) > 1e-12 * dt)
      throw InvalidArgument(fmt::format("identify: log {} was resampled to dt = {} s, not {} s",
                                        l.report.source, l.dt, dt));
  };
  for (const auto& l : fit) check_log(l);
  for (const auto& l : validation) check_log(l);
  // The model's pieces against the logs.
  if (!what.task) throw InvalidArgument("identify: no task (the model's input features)");
  if (what.task->state_dim() != E || what.task->action_dim() != U)
    throw InvalidArgument(fmt::format(
        "identify: the task '{}' has state dim {} and action dim {}, the logs {} ({}) and {} ({})",
        what.task->name(), what.task->state_dim(), what.task->action_dim(), E,
        fmt::join(first.state_names, ", "), U, fmt::join(first.action_names, ", ")));
  if (std::abs(what.task->dt() - dt) > 1e-9 * dt)
    throw InvalidArgument(fmt::format("identify: the task's dt is {} s, the logs are resampled "
                                      "to {} s (identify.dt / the log options' dt)",
                                      what.task->dt(), dt));
  const bool uses_prior = what.factory ? what.uses_prior : model::uses_prior(what.options.type);
  if (uses_prior) {
    if (!what.prior)
      throw InvalidArgument("identify: model.type " + what.type + " needs a prior; none given");
    if (what.prior->state_dim() != E || what.prior->action_dim() != U)
      throw InvalidArgument(fmt::format(
          "identify: the prior has state dim {} and action dim {}, the logs {} and {}",
          what.prior->state_dim(), what.prior->action_dim(), E, U));
    if (what.prior_dt > 0 && std::abs(what.prior_dt - dt) > 1e-9 * dt)
      throw InvalidArgument(fmt::format("identify: the prior integrates over dt = {} s, the logs "
                                        "are resampled to {} s: set the same control period",
                                        what.prior_dt, dt));
    what.parameters.check();
  }

  IdentifyResult res;
  IdentifySummary& s = res.summary;
  s.model_type = what.type;
  s.state_names = first.state_names;
  s.action_names = first.action_names;
  s.dt = dt;
  std::vector<Transition> all;
  for (const auto& l : fit) {
    s.fit_reports.push_back(l.report);
    const auto t = l.transitions();
    all.insert(all.end(), t.begin(), t.end());
  }
  for (const auto& l : validation) s.validation_reports.push_back(l.report);
  s.transitions = static_cast<int>(all.size());
  if (all.empty()) throw InvalidArgument("identify: the fit logs hold no transition");
  for (int i : model::subsample(s.transitions, options.max_points))
    res.data.push_back(all[static_cast<std::size_t>(i)]);
  s.points = static_cast<int>(res.data.size());

  // Learn.
  auto t0 = std::chrono::steady_clock::now();
  model::ModelOptions mo = what.options;
  std::shared_ptr<const model::MeanFunction> prior = uses_prior ? what.prior : nullptr;
  const model::PriorParameters params = uses_prior ? what.parameters : model::PriorParameters{};
  res.model = what.factory ? what.factory(mo, what.task, prior, params)
                           : model::make_model(mo, what.task, prior, params);
  if (!res.model) throw InvalidArgument("identify: the model factory of " + what.type + " gave none");
  say(fmt::format("learning {} on {} of {} transitions ({} fit log{})", what.type, s.points,
                  s.transitions, fit.size(), fit.size() == 1 ? "" : "s"));
  s.model = res.model->learn(res.data, progress);
  s.learn_seconds = seconds_since(t0);
  say(s.model.BriefReport());

  // phi and its intervals.
  if (uses_prior) {
    const auto P = what.parameters.values.size();
    s.phi_names = what.parameters.names;
    s.phi_start = what.parameters.values;
    s.phi = res.model->phi().size() == P ? res.model->phi() : what.parameters.values;
    s.phi_lower95 = s.phi_upper95 = VectorXd::Constant(P, kNaN);
    s.phi_tunable.assign(static_cast<std::size_t>(P), false);
    for (int i : what.parameters.tunable) s.phi_tunable[static_cast<std::size_t>(i)] = true;
    const model::PhiPosterior& post = s.model.phi_posterior;
    if (!post.empty()) {
      const VectorXd sd = post.stddev();
      for (std::size_t k = 0; k < post.names.size(); ++k) {
        const auto it = std::find(s.phi_names.begin(), s.phi_names.end(), post.names[k]);
        if (it == s.phi_names.end()) continue;
        const auto i = it - s.phi_names.begin();
        const auto kk = static_cast<Eigen::Index>(k);
        s.phi_lower95[i] = post.mean[kk] - 1.96 * sd[kk];
        s.phi_upper95[i] = post.mean[kk] + 1.96 * sd[kk];
      }
    }
  }

  // Validate.
  t0 = std::chrono::steady_clock::now();
  std::unique_ptr<model::DynamicsModel> prior_model;
  if (uses_prior) prior_model = model::make_prior_only_model(what.prior, what.parameters);
  for (const auto& l : validation) {
    say("validating on " + l.report.source);
    auto e = prediction_errors(*res.model, l, l.report.source, options.horizons,
                               options.start_spacing);
    s.errors.insert(s.errors.end(), e.begin(), e.end());
    if (prior_model) {
      e = prediction_errors(*prior_model, l, l.report.source, options.horizons,
                            options.start_spacing);
      s.prior_errors.insert(s.prior_errors.end(), e.begin(), e.end());
    }
  }
  s.validation_seconds = seconds_since(t0);
  res.fit = fit;
  res.validation = validation;
  return res;
}

IdentifyResult identify(const IdentifyModel& what, const IdentifyOptions& options,
                        const IdentifyMessage& message, const model::ModelProgress& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument(why);
  std::vector<RecordedLog> fit, validation;
  for (const auto& p : options.logs) {
    if (message) message("reading " + p.string());
    fit.push_back(read_log(p, options.columns, options.log));
    fit.back().report.source = p.string();
  }
  for (const auto& p : options.validation) {
    if (message) message("reading " + p.string());
    validation.push_back(read_log(p, options.columns, options.log));
    validation.back().report.source = p.string();
  }
  return identify(what, fit, validation, options, message, progress);
}

std::string IdentifySummary::BriefReport() const {
  std::ostringstream o;
  o << fmt::format("{}: {} of {} transitions (dt {} s) from {} fit log(s); learning {:.1f} s, "
                   "validation {:.1f} s\n",
                   model_type, points, transitions, dt, fit_reports.size(), learn_seconds,
                   validation_seconds);
  for (Eigen::Index i = 0; i < phi.size(); ++i) {
    if (!phi_tunable[static_cast<std::size_t>(i)]) continue;
    o << fmt::format("  {} = {:.6g} (start {:.6g}", phi_names[static_cast<std::size_t>(i)],
                     phi[i], phi_start[i]);
    if (std::isfinite(phi_lower95[i]))
      o << fmt::format(", 95% [{:.6g}, {:.6g}]", phi_lower95[i], phi_upper95[i]);
    o << ")\n";
  }
  if (!errors.empty()) {
    const double h = errors.back().horizon;
    for (std::size_t k = 0; k < errors.size(); ++k) {
      const auto& e = errors[k];
      if (e.horizon != h) continue;
      o << fmt::format("  {} {} at {} s: median {:.4g}, p90 {:.4g} (n {})", e.file, e.state, h,
                       e.median, e.p90, e.n);
      if (k < prior_errors.size())
        o << fmt::format("; prior: median {:.4g}", prior_errors[k].median);
      o << "\n";
    }
  }
  return o.str();
}

}  // namespace drops::experiment
