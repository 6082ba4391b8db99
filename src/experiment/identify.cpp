#include "drops/experiment/identify.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/description_prior.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/dataset.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "drops/model/simulator_model.hpp"
#include "sha256.hpp"

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
      return fail(
          fmt::format("identify.horizons: {} s is not longer than the one before it "
                      "(in steps of dt = {} s)",
                      h, log.dt));
    last = n;
  }
  if (!std::isfinite(start_spacing) || start_spacing < log.dt * (1 - 1e-9))
    return fail(fmt::format("identify.start_spacing: {} s is shorter than dt = {} s", start_spacing,
                            log.dt));
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
      throw InvalidArgument(
          fmt::format("open_loop_rollout: the model predicts dim {}, the state "
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
    throw InvalidArgument(
        fmt::format("prediction_errors: start spacing {} s < dt {} s", start_spacing, dt));
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
      for (Eigen::Index b = 0; b < B; ++b)
        X.row(b) = seg.x.row(starts[static_cast<std::size_t>(b)]);
      for (int j = 0; j < n; ++j) {
        for (Eigen::Index b = 0; b < B; ++b)
          U.row(b) = seg.u.row(starts[static_cast<std::size_t>(b)] + j);
        model.predict_batch(X, U, mean, var);
        X += mean;
      }
      for (Eigen::Index b = 0; b < B; ++b)
        for (int i = 0; i < E; ++i) {
          const double e = std::abs(X(b, i) - seg.x(starts[static_cast<std::size_t>(b)] + n, i));
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
                        const std::vector<RecordedLog>& validation, const IdentifyOptions& options,
                        const IdentifyMessage& message, const model::ModelProgress& progress) {
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
    throw InvalidArgument(
        fmt::format("identify: the task's dt is {} s, the logs are resampled "
                    "to {} s (identify.dt / the log options' dt)",
                    what.task->dt(), dt));
  const bool uses_prior = what.factory ? what.uses_prior : model::uses_prior(what.options.type);
  if (uses_prior) {
    if (!what.prior)
      throw InvalidArgument("identify: model.type " + what.type + " needs a prior; none given");
    if (what.prior->state_dim() != E || what.prior->action_dim() != U)
      throw InvalidArgument(
          fmt::format("identify: the prior has state dim {} and action dim {}, the logs {} and {}",
                      what.prior->state_dim(), what.prior->action_dim(), E, U));
    if (what.prior_dt > 0 && std::abs(what.prior_dt - dt) > 1e-9 * dt)
      throw InvalidArgument(
          fmt::format("identify: the prior integrates over dt = {} s, the logs "
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
  if (!res.model)
    throw InvalidArgument("identify: the model factory of " + what.type + " gave none");
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
    auto e =
        prediction_errors(*res.model, l, l.report.source, options.horizons, options.start_spacing);
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
  o << fmt::format(
      "{}: {} of {} transitions (dt {} s) from {} fit log(s); learning {:.1f} s, "
      "validation {:.1f} s\n",
      model_type, points, transitions, dt, fit_reports.size(), learn_seconds, validation_seconds);
  for (Eigen::Index i = 0; i < phi.size(); ++i) {
    if (!phi_tunable[static_cast<std::size_t>(i)]) continue;
    o << fmt::format("  {} = {:.6g} (start {:.6g}", phi_names[static_cast<std::size_t>(i)], phi[i],
                     phi_start[i]);
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

// ---------------------------------------------------------------------------------------------

namespace {

KeySpec key(std::string name, std::string type, std::string def, std::string unit, std::string doc,
            double min = 0, double max = 0, std::vector<std::string> allowed = {}) {
  KeySpec k;
  k.key = std::move(name);
  k.type = std::move(type);
  k.default_value = std::move(def);
  k.unit = std::move(unit);
  k.doc = std::move(doc);
  k.min = min;
  k.max = max;
  k.allowed = std::move(allowed);
  return k;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "";
  return fmt::format("{}", v);
}

}  // namespace

const std::vector<KeySpec>& identify_keys() {
  static const std::vector<KeySpec> k = [] {
    const IdentifyOptions d;
    const LogOptions l;
    std::vector<KeySpec> v;
    v.push_back(key("identify.logs", "list", "[]", "-",
                    "drops identify: the logs (CSV files) the model learns from, relative to the "
                    "working directory"));
    v.push_back(key("identify.validation", "list", "[]", "-",
                    "drops identify: the logs the learned model is measured on (open-loop and "
                    "one-step errors); none: no errors"));
    v.push_back(key("identify.columns.time", "string", "time", "-",
                    "drops identify: the logs' time column (units: identify.time_scale s)"));
    v.push_back(key("identify.columns.state", "list", "[]", "-",
                    "drops identify: the column of each state, in the task's state order; "
                    "d/dt(COLUMN) is the smoothed derivative of COLUMN, VEL=d/dt(COLUMN) the "
                    "logged velocity VEL checked against it (degrees, sign; docs/logs.md); [] = "
                    "the task's state names"));
    v.push_back(key("identify.columns.angles", "list", "[]", "-",
                    "drops identify: the state columns that hold angles in rad (unwrapped, "
                    "checked for degrees)"));
    v.push_back(key("identify.columns.action", "list", "[]", "-",
                    "drops identify: the column of each action, in the task's order; [] = the "
                    "task's action names"));
    v.push_back(key("identify.time_scale", "double", num(l.time_scale), "s",
                    "drops identify: seconds per unit of the time column (1e-3 for ms)", 1e-12,
                    1e6));
    v.push_back(key("identify.bad_rows", "enum", "error", "-",
                    "drops identify: rows with a value that is not finite or a repeated time: "
                    "an error naming the file, line and column, or dropped and counted",
                    0, 0, {"error", "drop"}));
    v.push_back(key("identify.lowpass_hz", "double", num(l.lowpass_hz), "Hz",
                    "drops identify: zero-phase Butterworth low-pass of the states; 0 = off", 0,
                    1e6));
    v.push_back(key("identify.derivative_window", "double", num(l.derivative_window), "s",
                    "drops identify: window of the Savitzky-Golay derivative of d/dt states", 0,
                    1e3));
    v.push_back(key("identify.horizons", "numbers", "[0.1, 0.5, 1]", "s",
                    "drops identify: open-loop horizons of the validation errors, ascending", 1e-9,
                    1e6));
    v.push_back(key("identify.start_spacing", "double", num(d.start_spacing), "s",
                    "drops identify: time between open-loop start points", 1e-9, 1e6));
    v.push_back(key("identify.max_points", "int", "0", "-",
                    "drops identify: most transitions the model learns from (an evenly spaced "
                    "subset, for the phi search and the final kernel fit alike); 0 = all",
                    0, 1e9));
    v.push_back(key("identify.dt", "double", "0", "s",
                    "drops identify: the control period the logs are resampled to; 0 = the "
                    "task's dt (with task: none, required; a task's must equal it)",
                    0, 1e3));
    return v;
  }();
  return k;
}

const std::vector<KeySpec>& no_task_keys() {
  static const std::vector<KeySpec> k = [] {
    std::vector<KeySpec> v = description_prior_keys();
    v.push_back(key("prior.joints", "list", "[]", "-",
                    "with task: none (drops identify): the joints of the state, names as in "
                    "prior.model's file; the state is their angles then their velocities; [] = "
                    "every joint that moves, in the file's order"));
    v.push_back(key("prior.actuated", "list", "[]", "-",
                    "with task: none (drops identify): the joints the action drives (their "
                    "torques, in this order); [] = every joint of prior.joints"));
    return v;
  }();
  return k;
}

const std::vector<KeySpec>& run_data_keys() {
  static const std::vector<KeySpec> k = [] {
    std::vector<KeySpec> v;
    v.push_back(key("data.logs", "paths", "[]", "-",
                    "drops run: logs (CSV files) of the real system whose transitions join the "
                    "data before episode 1, declared and resampled to the task's dt as for drops "
                    "identify (identify.columns.*, identify.time_scale, identify.bad_rows, "
                    "identify.lowpass_hz, identify.derivative_window; docs/logs.md); relative: "
                    "beside the configuration file, else in the working directory; [] = none"));
    v.push_back(key("data.keep_first_episode", "bool", "false", "-",
                    "drops run with data.logs: true keeps episode 1 as without logs (a random "
                    "policy, or one planned on the prior alone) and learns from the logs from "
                    "episode 2 on; false: episode 1 learns the model on the logs and plans on "
                    "it"));
    return v;
  }();
  return k;
}

RunData read_run_data(const Settings& st, double dt, const std::vector<std::string>& state_names,
                      const std::vector<std::string>& action_names) {
  RunData d;
  const std::vector<std::string> files = get_names(st, "data.logs");
  d.keep_first_episode = st.at("data.keep_first_episode") == "true";
  if (files.empty()) return d;
  LogColumns columns;
  LogOptions options;
  log_declaration(st, dt, state_names, action_names, &columns, &options);
  d.declaration["data.logs"] = std::to_string(files.size());
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string& f = files[i];
    std::string text;
    try {
      text = read_file_text(f);
    } catch (const Error& e) {
      throw ConfigError("config key 'data.logs': " + std::string(e.what()));
    }
    RecordedLog log;
    try {
      log = resample_log(parse_log_csv(text, f, columns), columns, options);
    } catch (const ConfigError& e) {
      throw ConfigError("config key 'data.logs': " + std::string(e.what()));
    }
    const std::string n = "data.log." + std::to_string(i + 1);
    const LogReport& r = log.report;
    d.declaration[n] = f;
    d.declaration[n + ".sha256"] = sha256_hex(text);
    d.declaration[n + ".rows"] = std::to_string(r.rows);
    d.declaration[n + ".dropped"] =
        std::to_string(r.dropped_nonfinite + r.dropped_repeated_time + r.short_segment_rows);
    d.declaration[n + ".transitions"] = std::to_string(r.transitions);
    for (auto& t : log.transitions()) d.transitions.push_back(std::move(t));
    d.reports.push_back(r);
  }
  if (d.transitions.size() < static_cast<std::size_t>(kMinRecordedTransitions))
    throw Error(fmt::format(
        "config key 'data.logs': the {} log(s) give {} transitions at dt = {} s, fewer than "
        "the {} a run needs to learn a model from before its first episode (longer logs, or "
        "data.logs: [] for a run without them)",
        files.size(), d.transitions.size(), dt, kMinRecordedTransitions));
  d.declaration["data.transitions"] = std::to_string(d.transitions.size());
  d.declaration["data.keep_first_episode"] = d.keep_first_episode ? "true" : "false";
  return d;
}

IdentifyOptions identify_options(const Settings& st, double dt,
                                 const std::vector<std::string>& state_names,
                                 const std::vector<std::string>& action_names) {
  IdentifyOptions o;
  for (const auto& f : get_names(st, "identify.logs")) o.logs.emplace_back(f);
  for (const auto& f : get_names(st, "identify.validation")) o.validation.emplace_back(f);
  if (o.logs.empty())
    throw ConfigError("config key 'identify.logs' is empty: name the logs to learn from");
  log_declaration(st, dt, state_names, action_names, &o.columns, &o.log);
  o.horizons = get_numbers(st, "identify.horizons");
  o.start_spacing = get_double(st, "identify.start_spacing");
  o.max_points = static_cast<int>(get_int(st, "identify.max_points"));
  o.seed = static_cast<std::uint64_t>(get_int(st, "seed"));
  o.threads = static_cast<int>(get_int(st, "threads"));
  std::string why;
  if (!o.IsValid(&why)) throw ConfigError("config: " + why);
  return o;
}

void log_declaration(const Settings& st, double dt, const std::vector<std::string>& state_names,
                     const std::vector<std::string>& action_names, LogColumns* columns,
                     LogOptions* options) {
  LogOptions& l = *options;
  l = LogOptions{};
  l.dt = dt;
  l.time_scale = get_double(st, "identify.time_scale");
  l.bad_rows = st.at("identify.bad_rows") == "drop" ? BadRows::kDrop : BadRows::kError;
  l.lowpass_hz = get_double(st, "identify.lowpass_hz");
  l.derivative_window = get_double(st, "identify.derivative_window");
  IdentifyOptions o;
  o.columns.time = st.at("identify.columns.time");
  std::vector<std::string> state = get_names(st, "identify.columns.state");
  if (state.empty()) state = state_names;
  if (state.size() != state_names.size())
    throw ConfigError(fmt::format(
        "config key 'identify.columns.state' lists {} columns; the task has {} states ({})",
        state.size(), state_names.size(), fmt::join(state_names, ", ")));
  const std::vector<std::string> angles = get_names(st, "identify.columns.angles");
  for (std::size_t i = 0; i < state.size(); ++i) {
    LogState ls;
    const std::string& c = state[i];
    const std::size_t eq = c.find('=');
    const std::string rate = eq == std::string::npos ? c : c.substr(eq + 1);
    const bool is_rate = rate.rfind("d/dt(", 0) == 0 && rate.size() > 6 && rate.back() == ')';
    if (eq != std::string::npos && (!is_rate || eq == 0))
      throw ConfigError("config key 'identify.columns.state': '" + c +
                        "' is not COLUMN=d/dt(STATE) (a logged velocity checked against the "
                        "derivative of STATE)");
    if (is_rate) {
      ls.quantity = LogQuantity::kVelocity;
      ls.of = rate.substr(5, rate.size() - 6);
      if (eq == std::string::npos) {
        ls.name = state_names[i];  // derived: no column
      } else {
        ls.column = c.substr(0, eq);  // logged, its units checked against the derivative
      }
    } else {
      ls.column = c;
      ls.quantity = std::find(angles.begin(), angles.end(), c) != angles.end()
                        ? LogQuantity::kAngle
                        : LogQuantity::kOther;
    }
    o.columns.state.push_back(ls);
  }
  for (const auto& a : angles)
    if (std::find(state.begin(), state.end(), a) == state.end())
      throw ConfigError("config key 'identify.columns.angles' names '" + a +
                        "', which is no column of identify.columns.state");
  o.columns.action = get_names(st, "identify.columns.action");
  if (o.columns.action.empty()) o.columns.action = action_names;
  if (o.columns.action.size() != action_names.size())
    throw ConfigError(fmt::format(
        "config key 'identify.columns.action' lists {} columns; the task has {} actions ({})",
        o.columns.action.size(), action_names.size(), fmt::join(action_names, ", ")));
  std::string why;
  if (!l.IsValid(&why)) throw ConfigError("config: " + why);
  if (!o.columns.IsValid(&why)) throw ConfigError("config: " + why);
  *columns = o.columns;
}

std::vector<std::filesystem::path> write_identify_directory(const std::filesystem::path& dir,
                                                            const IdentifyResult& r,
                                                            const IdentifyOptions& options,
                                                            const std::string& config_yaml) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(file_error("output directory " + dir.string(), ec.message()));
  std::vector<fs::path> written;
  auto put = [&](const std::string& name, const std::string& text) {
    write_file_atomically(dir / name, text);
    written.push_back(dir / name);
  };
  const IdentifySummary& s = r.summary;
  put("config.yaml", config_yaml);
  // phi.csv
  {
    std::string t = "name,start,value,tunable,lower95,upper95\n";
    for (Eigen::Index i = 0; i < s.phi.size(); ++i)
      t += fmt::format("{},{},{},{},{},{}\n", s.phi_names[static_cast<std::size_t>(i)],
                       num(s.phi_start[i]), num(s.phi[i]),
                       s.phi_tunable[static_cast<std::size_t>(i)] ? 1 : 0, num(s.phi_lower95[i]),
                       num(s.phi_upper95[i]));
    put("phi.csv", t);
  }
  // errors.csv
  {
    std::string t = "model,file,horizon,steps,dim,state,median,p90,n\n";
    auto rows = [&](const char* m, const std::vector<PredictionErrors>& v) {
      for (const auto& e : v)
        t += fmt::format("{},{},{},{},{},{},{},{},{}\n", m, e.file, num(e.horizon), e.steps, e.dim,
                         e.state, e.median, e.p90, e.n);
    };
    rows("learned", s.errors);
    rows("prior", s.prior_errors);
    put("errors.csv", t);
  }
  // model.json + data.csv
  {
    const model::ModelState st = r.model->state();
    nlohmann::json j;
    j["format"] = "drops-identified-model-1";
    j["type"] = s.model_type;
    j["state_names"] = s.state_names;
    j["action_names"] = s.action_names;
    j["dt"] = s.dt;
    j["phi_names"] = s.phi_names;
    j["phi"] = std::vector<double>(st.phi.data(), st.phi.data() + st.phi.size());
    nlohmann::json h = nlohmann::json::array();
    for (const auto& v : st.h_params)
      h.push_back(std::vector<double>(v.data(), v.data() + v.size()));
    j["h_params"] = h;
    j["data"] = "data.csv";
    j["points"] = s.points;
    put("model.json", j.dump(2) + "\n");
    std::string t;
    for (const auto& n : s.state_names) t += n + ",";
    for (const auto& n : s.action_names) t += n + ",";
    for (std::size_t i = 0; i < s.state_names.size(); ++i)
      t += "d_" + s.state_names[i] + (i + 1 < s.state_names.size() ? "," : "\n");
    for (const auto& tr : r.data) {
      std::string line;
      auto add = [&](const VectorXd& v) {
        for (Eigen::Index i = 0; i < v.size(); ++i) {
          if (!line.empty()) line += ',';
          line += fmt::format("{:.17g}", v[i]);
        }
      };
      add(tr.x);
      add(tr.u);
      add(tr.dx);
      t += line + "\n";
    }
    put("data.csv", t);
  }
  // validation-NN.csv: recorded states and the open-loop prediction (longest horizon) from
  // every start point of the first segment.
  const int n_long = steps_of(options.horizons.back(), s.dt);
  const int spacing = steps_of(options.start_spacing, s.dt);
  for (std::size_t f = 0; f < r.validation.size(); ++f) {
    const RecordedLog& l = r.validation[f];
    if (l.segments.empty()) continue;
    const LogSegment& seg = l.segments.front();
    std::string t = "t";
    for (const auto& n : s.state_names) t += "," + n;
    t += ",start";
    for (const auto& n : s.state_names) t += ",pred_" + n;
    t += "\n";
    for (Eigen::Index k = 0; k < seg.x.rows(); ++k) {
      t += num(seg.t0 + static_cast<double>(k) * s.dt);
      for (Eigen::Index i = 0; i < seg.x.cols(); ++i) t += fmt::format(",{:.9g}", seg.x(k, i));
      t += ",,";
      for (Eigen::Index i = 1; i < seg.x.cols(); ++i) t += ",";
      t += "\n";
    }
    for (int k0 = 0; k0 < seg.transitions(); k0 += spacing) {
      const int n = std::min(n_long, seg.transitions() - k0);
      const MatrixXd x =
          open_loop_rollout(*r.model, seg.x.row(k0).transpose(), seg.u.middleRows(k0, n));
      for (Eigen::Index k = 0; k < x.rows(); ++k) {
        t += num(seg.t0 + static_cast<double>(k0 + k) * s.dt);
        for (Eigen::Index i = 0; i < x.cols(); ++i) t += ",";
        t += fmt::format(",{}", k0);
        for (Eigen::Index i = 0; i < x.cols(); ++i) t += fmt::format(",{:.9g}", x(k, i));
        t += "\n";
      }
    }
    put(fmt::format("validation-{:02d}.csv", f + 1), t);
  }
  // summary.json
  {
    nlohmann::json j;
    j["model_type"] = s.model_type;
    j["dt"] = s.dt;
    j["transitions"] = s.transitions;
    j["points"] = s.points;
    j["learn_seconds"] = s.learn_seconds;
    j["validation_seconds"] = s.validation_seconds;
    j["seed"] = options.seed;
    nlohmann::json logs = nlohmann::json::array();
    for (const auto& rep : s.fit_reports)
      logs.push_back({{"file", rep.source}, {"role", "fit"}, {"report", rep.BriefReport()}});
    for (const auto& rep : s.validation_reports)
      logs.push_back({{"file", rep.source}, {"role", "validation"}, {"report", rep.BriefReport()}});
    j["logs"] = logs;
    j["model"] = s.model.BriefReport();
    put("summary.json", j.dump(2) + "\n");
  }
  // report.md
  {
    std::ostringstream o;
    o << "# drops identify: " << s.model_type << "\n\n";
    o << fmt::format("{} of {} transitions at dt = {} s from {} fit log(s); learning {:.1f} s.\n\n",
                     s.points, s.transitions, s.dt, s.fit_reports.size(), s.learn_seconds);
    o << "## Logs\n\n";
    for (const auto& rep : s.fit_reports) o << "- fit: " << rep.BriefReport() << "\n";
    for (const auto& rep : s.validation_reports) o << "- validation: " << rep.BriefReport() << "\n";
    if (s.phi.size() > 0) {
      o << "\n## phi\n\n| name | start | learned | 95% interval |\n|---|---|---|---|\n";
      for (Eigen::Index i = 0; i < s.phi.size(); ++i) {
        if (!s.phi_tunable[static_cast<std::size_t>(i)]) continue;
        o << fmt::format("| {} | {:.6g} | {:.6g} | {} |\n",
                         s.phi_names[static_cast<std::size_t>(i)], s.phi_start[i], s.phi[i],
                         std::isfinite(s.phi_lower95[i])
                             ? fmt::format("[{:.6g}, {:.6g}]", s.phi_lower95[i], s.phi_upper95[i])
                             : std::string("- (at a bound, or no posterior)"));
      }
    }
    if (!s.errors.empty()) {
      o << "\n## Prediction errors (median / p90 of |predicted - recorded| over the start "
           "points; the first horizon, dt, is the one-step error from every state)\n\n";
      o << "| file | horizon (s) | state | learned | prior at its start | n |\n";
      o << "|---|---|---|---|---|---|\n";
      for (std::size_t k = 0; k < s.errors.size(); ++k) {
        const auto& e = s.errors[k];
        o << fmt::format(
            "| {} | {} | {} | {:.4g} / {:.4g} | {} | {} |\n", fs::path(e.file).filename().string(),
            e.horizon, e.state, e.median, e.p90,
            k < s.prior_errors.size()
                ? fmt::format("{:.4g} / {:.4g}", s.prior_errors[k].median, s.prior_errors[k].p90)
                : std::string("-"),
            e.n);
      }
    }
    o << "\n## Model\n\n" << s.model.BriefReport() << "\n";
    put("report.md", o.str());
  }
  return written;
}

}  // namespace drops::experiment

// ---------------------------------------------------------------------------------------------

namespace drops::experiment {

namespace {

// The prior, parameters, feature task and names of a configuration with task none: prior.model's
// joints prior.joints (state [q, qd]) and prior.actuated (torques) at identify.dt.
TaskSetup no_task_setup(const Registry& registry, const Settings& st, double dt) {
  if (!uses_description_prior(st))
    throw ConfigError(
        "config key 'task' = 'none': drops identify without a task needs prior.model (a URDF or "
        "MJCF file: its joints are the state, their torques the action)");
  if (!(dt > 0))
    throw ConfigError(
        "config key 'identify.dt' = 0: with task: none, set the control period (s) the logs are "
        "resampled to");
  const DescriptionPriorFactory& factory = registry.description_prior_factory();
  if (!factory)
    throw ConfigError("config key 'prior.model' = '" + st.at("prior.model") +
                      "': this build of drops has no description-file prior (MuJoCo)");
  const DescriptionPriorSpec spec = description_prior_spec(st);
  JointDeclaration joints;
  joints.joints = get_names(st, "prior.joints");
  joints.actuated = get_names(st, "prior.actuated");
  if (joints.joints.empty() || joints.actuated.empty()) {
    // The file's joints (every one that moves) or prior.joints' as the actuated ones.
    DescriptionPriorRequest r;
    r.file = spec.file;
    r.joints = joints.joints;
    r.actuated = joints.actuated;
    r.dt = dt;
    DescriptionPriorModel m;
    try {
      m = factory(r);
    } catch (const Error& e) {
      throw ConfigError(std::string("config key 'prior.model': ") + e.what());
    }
    if (m.joints.empty() || m.actuated.empty())
      throw ConfigError("config key 'prior.model' = '" + spec.file +
                        "': the prior does not name its joints: set prior.joints and "
                        "prior.actuated");
    joints.joints = m.joints;
    joints.actuated = m.actuated;
  }
  DescriptionPriorSetup d = make_description_prior(factory, spec, joints, dt);
  TaskSetup setup;
  const int n = static_cast<int>(joints.joints.size());
  setup.task = feature_task(2 * n, static_cast<int>(joints.actuated.size()), dt);
  setup.prior = std::move(d.prior);
  setup.prior_parameters = std::move(d.parameters);
  for (const auto& j : joints.joints) setup.state_names.push_back(j);
  for (const auto& j : joints.joints) setup.state_names.push_back(j + "_vel");
  for (const auto& j : joints.actuated) setup.action_names.push_back(j + "_torque");
  return setup;
}

}  // namespace

IdentifyRun identify_from_settings(const Registry& registry, const Settings& settings,
                                   const IdentifyMessage& message,
                                   const model::ModelProgress& progress) {
  const BaseOptions base = base_options(settings);
  const std::string task_name = settings.at("task");
  const double identify_dt = get_double(settings, "identify.dt");
  TaskSetup setup = task_name == kNoTask ? no_task_setup(registry, settings, identify_dt)
                                         : registry.task(task_name).make(settings);
  if (task_name != kNoTask && identify_dt > 0 &&
      std::abs(identify_dt - setup.task->dt()) > 1e-9 * identify_dt)
    throw ConfigError(fmt::format(
        "config key 'identify.dt' = {} s: task '{}' has dt = {} s (leave identify.dt at 0 for "
        "the task's)",
        identify_dt, task_name, setup.task->dt()));
  if (task_name != kNoTask && uses_description_prior(settings)) {
    // The task's prior replaced by the file's, as drops run does (TaskSetup::joints).
    if (!setup.joints)
      throw ConfigError("config key 'prior.model': task '" + task_name +
                        "' declares no joints, so it cannot use a description file as its prior");
    DescriptionPriorSetup d =
        make_description_prior(registry.description_prior_factory(),
                               description_prior_spec(settings), *setup.joints, setup.task->dt());
    setup.prior = std::move(d.prior);
    setup.prior_parameters = std::move(d.parameters);
  }
  const ModelVariant& variant = registry.model_variant(base.model_type);
  IdentifyModel what;
  what.type = variant.name;
  what.factory = variant.factory;
  what.uses_prior = variant.uses_prior;
  what.options = black_drops_options(registry, settings).model;
  what.task = setup.task;
  what.prior = setup.prior;
  what.parameters = setup.prior_parameters;
  std::vector<std::string> states = setup.state_names, actions = setup.action_names;
  for (int i = static_cast<int>(states.size()); i < setup.task->state_dim(); ++i)
    states.push_back("x_" + std::to_string(i + 1));
  for (int i = static_cast<int>(actions.size()); i < setup.task->action_dim(); ++i)
    actions.push_back("u_" + std::to_string(i + 1));
  IdentifyRun run;
  run.options = identify_options(settings, setup.task->dt(), states, actions);
  const std::string name =
      base.name.empty()
          ? fmt::format("identify-{}-{}",
                        task_name == kNoTask
                            ? std::filesystem::path(settings.at("prior.model")).stem().string()
                            : task_name,
                        variant.name)
          : base.name;
  if (!is_directory_name(name))
    throw ConfigError("config key 'name' = '" + name + "' is not a directory name");
  run.directory = std::filesystem::path(base.output) / name;
  if (message)
    message(fmt::format("task {}, model {}, dt {} s, {} fit and {} validation log(s)", task_name,
                        variant.name, setup.task->dt(), run.options.logs.size(),
                        run.options.validation.size()));
  run.result = identify(what, run.options, message, progress);
  run.files =
      write_identify_directory(run.directory, run.result, run.options, to_yaml(registry, settings));
  return run;
}

namespace {

std::vector<double> split_numbers(const std::string& line, const std::string& where) {
  std::vector<double> v;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    char* end = nullptr;
    const double x = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end == cell.c_str() || *end != '\0' || !std::isfinite(x))
      throw Error(where + ": '" + cell + "' is not a finite number");
    v.push_back(x);
  }
  return v;
}

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw Error(p.string() + ": cannot be read");
  std::ostringstream o;
  o << in.rdbuf();
  return o.str();
}

}  // namespace

std::unique_ptr<model::DynamicsModel> load_identified_model(const std::filesystem::path& dir,
                                                            const IdentifyModel& what) {
  const std::filesystem::path mj = dir / "model.json";
  const std::string src = mj.string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(mj));
  } catch (const nlohmann::json::exception& e) {
    throw Error(src + ": not JSON (" + e.what() + ")");
  }
  auto field = [&](const char* k) -> const nlohmann::json& {
    if (!j.contains(k)) throw Error(src + ": no '" + std::string(k) + "'");
    return j.at(k);
  };
  try {
    if (field("format").get<std::string>() != "drops-identified-model-1")
      throw Error(src + ": format '" + field("format").get<std::string>() +
                  "', expected 'drops-identified-model-1'");
    if (field("type").get<std::string>() != what.type)
      throw Error(src + ": a '" + field("type").get<std::string>() +
                  "' model; the model described is '" + what.type + "'");
    if (!what.task) throw InvalidArgument("load_identified_model: the model has no task");
    const auto states = field("state_names").get<std::vector<std::string>>();
    const auto actions = field("action_names").get<std::vector<std::string>>();
    const int E = what.task->state_dim(), U = what.task->action_dim();
    if (static_cast<int>(states.size()) != E || static_cast<int>(actions.size()) != U)
      throw Error(fmt::format("{}: {} states and {} actions; the task has {} and {}", src,
                              states.size(), actions.size(), E, U));
    const double dt = field("dt").get<double>();
    if (std::abs(dt - what.task->dt()) > 1e-12 * std::max(1.0, dt))
      throw Error(fmt::format("{}: dt = {} s; the task's is {} s", src, dt, what.task->dt()));
    model::ModelState st;
    const auto phi = field("phi").get<std::vector<double>>();
    st.phi = Eigen::Map<const VectorXd>(phi.data(), static_cast<Eigen::Index>(phi.size()));
    for (const auto& h : field("h_params")) {
      const auto v = h.get<std::vector<double>>();
      st.h_params.push_back(
          Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
    }
    // data.csv: x (E), u (U), dx (E) per row, after a header of those names.
    const std::filesystem::path dp = dir / field("data").get<std::string>();
    std::stringstream text(read_text(dp));
    std::string line;
    std::getline(text, line);
    std::vector<std::string> expected;
    for (const auto& n : states) expected.push_back(n);
    for (const auto& n : actions) expected.push_back(n);
    for (const auto& n : states) expected.push_back("d_" + n);
    if (line != fmt::format("{}", fmt::join(expected, ",")))
      throw Error(fmt::format("{}: line 1 is '{}', expected '{}'", dp.string(), line,
                              fmt::join(expected, ",")));
    std::vector<Transition> data;
    for (int row = 2; std::getline(text, line); ++row) {
      if (line.empty()) continue;
      const auto v = split_numbers(line, fmt::format("{}: line {}", dp.string(), row));
      if (static_cast<int>(v.size()) != 2 * E + U)
        throw Error(fmt::format("{}: line {} has {} values, expected {}", dp.string(), row,
                                v.size(), 2 * E + U));
      Transition t;
      t.x = Eigen::Map<const VectorXd>(v.data(), E);
      t.u = Eigen::Map<const VectorXd>(v.data() + E, U);
      t.dx = Eigen::Map<const VectorXd>(v.data() + E + U, E);
      data.push_back(std::move(t));
    }
    const bool uses_prior = what.factory ? what.uses_prior : model::uses_prior(what.options.type);
    std::shared_ptr<const model::MeanFunction> prior = uses_prior ? what.prior : nullptr;
    const model::PriorParameters params = uses_prior ? what.parameters : model::PriorParameters{};
    std::unique_ptr<model::DynamicsModel> m =
        what.factory ? what.factory(what.options, what.task, prior, params)
                     : model::make_model(what.options, what.task, prior, params);
    if (!m) throw InvalidArgument("load_identified_model: the model factory gave none");
    m->restore(st);
    if (auto* gp = dynamic_cast<model::GpDynamicsModel*>(m.get())) {
      if (data.empty()) throw Error(dp.string() + ": no transitions");
      gp->condition(data);
    } else if (!dynamic_cast<model::SimulatorModel*>(m.get())) {
      throw InvalidArgument("load_identified_model: a '" + what.type +
                            "' model is neither a GP model nor the prior alone; it cannot be "
                            "conditioned without learning");
    }
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw Error(src + ": " + e.what());
  }
}

}  // namespace drops::experiment
