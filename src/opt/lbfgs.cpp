#include "drops/opt/lbfgs.hpp"

#include <fmt/format.h>
#include <nlopt.h>

#include <chrono>
#include <cmath>
#include <exception>
#include <memory>

#include "drops/core/errors.hpp"

namespace drops::opt {

bool LbfgsOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_evaluations < 1) return fail("max_evaluations must be >= 1");
  if (!(ftol_rel >= 0)) return fail("ftol_rel must be >= 0");
  if (!(ftol_abs >= 0)) return fail("ftol_abs must be >= 0");
  if (!(xtol_rel >= 0)) return fail("xtol_rel must be >= 0");
  if (memory < 0) return fail("memory must be >= 0");
  if (max_restarts < 0) return fail("max_restarts must be >= 0");
  if (lower.size() != upper.size()) return fail("lower and upper must have the same size");
  for (Eigen::Index i = 0; i < lower.size(); ++i)
    if (std::isnan(lower[i]) || std::isnan(upper[i]) || lower[i] > upper[i])
      return fail(fmt::format("bounds: expected lower <= upper, got [{}, {}] at {}", lower[i],
                              upper[i], i));
  return true;
}

const char* to_string(LbfgsTermination t) {
  switch (t) {
    case LbfgsTermination::kConverged:
      return "converged";
    case LbfgsTermination::kMaxEvaluations:
      return "max_evaluations";
    case LbfgsTermination::kStopped:
      return "stopped";
    case LbfgsTermination::kRoundoffLimited:
      return "roundoff_limited";
    case LbfgsTermination::kFailure:
      return "failure";
    case LbfgsTermination::kNonFinite:
      return "non_finite";
  }
  return "unknown";
}

std::string LbfgsSummary::BriefReport() const {
  return fmt::format("L-BFGS: {:.6g} -> {:.6g} in {} evaluations, {} restarts ({}), {:.1f} s",
                     initial_value, value, evaluations, restarts, to_string(termination), seconds);
}

namespace {

/// What the NLopt callback needs; NLopt must never see a C++ exception (it is C code), so every
/// exception is caught here, kept, and the search is stopped (nlopt_force_stop).
struct Context {
  const GradientObjective* f = nullptr;
  const std::function<bool(const LbfgsProgress&)>* on_evaluation = nullptr;
  nlopt_opt opt = nullptr;
  Eigen::Index n = 0;
  LbfgsSummary* summary = nullptr;
  std::exception_ptr error;
  bool stopped = false;
  bool nonfinite = false;
  bool budget = false;  // max_evaluations reached (NLopt's own check comes only between iterations)
  int max_evaluations = 0;
  double scale = 1.0;       // NLopt sees f / scale (LbfgsOptions::scale_first_step)
  Eigen::VectorXd best_g;   // the gradient at the best point
  bool serve_best = false;  // the next call at exactly summary->x is answered from memory
  Eigen::VectorXd x, g;
  bool halted() const { return error || stopped || nonfinite || budget; }
};

/// One evaluation of f at c.x (value returned, gradient in c.g): counted, the best point kept,
/// the progress reported, the stopping rules applied. Exceptions propagate.
double evaluate(Context& c) {
  c.g.resize(0);
  const double v = (*c.f)(c.x, &c.g);
  if (c.g.size() != c.n)
    throw InvalidArgument(fmt::format(
        "lbfgs_minimize: the objective's gradient: expected size {}, got {}", c.n, c.g.size()));
  LbfgsSummary& s = *c.summary;
  ++s.evaluations;
  if (s.evaluations == 1) s.initial_value = v;
  if (!std::isfinite(v) || !c.g.allFinite()) {
    c.nonfinite = true;
    return v;
  }
  if (v < s.value) {
    s.value = v;
    s.x = c.x;
    c.best_g = c.g;
  }
  if (*c.on_evaluation && !(*c.on_evaluation)(LbfgsProgress{s.evaluations, v, s.value}))
    c.stopped = true;
  else if (s.evaluations >= c.max_evaluations)
    c.budget = true;
  return v;
}

double trampoline(unsigned n, const double* x, double* grad, void* data) {
  auto* c = static_cast<Context*>(data);
  auto zero = [&] {
    if (grad != nullptr)
      for (unsigned i = 0; i < n; ++i) grad[i] = 0.0;
  };
  // NLopt's L-BFGS notices a forced stop only between its own steps: later calls cost nothing.
  if (c->halted()) {
    zero();
    return c->summary->value / c->scale;
  }
  try {
    c->x = Eigen::Map<const Eigen::VectorXd>(x, n);
    double v;
    if (c->serve_best && c->x == c->summary->x) {
      // A run's first call at the point whose value and gradient are known already.
      v = c->summary->value;
      c->g = c->best_g;
    } else {
      v = evaluate(*c);
    }
    c->serve_best = false;
    if (c->halted()) nlopt_force_stop(c->opt);
    if (grad != nullptr) Eigen::Map<Eigen::VectorXd>(grad, n) = c->g / c->scale;
    return v / c->scale;
  } catch (...) {
    c->error = std::current_exception();
    nlopt_force_stop(c->opt);
    zero();
    return 0.0;
  }
}

struct OptDeleter {
  void operator()(nlopt_opt o) const { nlopt_destroy(o); }
};

}  // namespace

LbfgsSummary lbfgs_minimize(const GradientObjective& f, const Eigen::VectorXd& x0,
                            const LbfgsOptions& options,
                            const std::function<bool(const LbfgsProgress&)>& on_evaluation) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("lbfgs_minimize: options: " + why);
  if (!f) throw InvalidArgument("lbfgs_minimize: the objective is empty");
  const Eigen::Index n = x0.size();
  if (n < 1) throw InvalidArgument("lbfgs_minimize: x0: expected size >= 1, got 0");
  if (!x0.allFinite()) throw InvalidArgument("lbfgs_minimize: x0: expected finite entries");
  const bool boxed = options.lower.size() > 0;
  if (boxed) {
    check_size("lbfgs_minimize: bounds vs x0", n, options.lower.size());
    if ((x0.array() < options.lower.array()).any() || (x0.array() > options.upper.array()).any())
      throw InvalidArgument("lbfgs_minimize: x0 lies outside the box [lower, upper]");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const auto un = static_cast<unsigned>(n);
  std::unique_ptr<nlopt_opt_s, OptDeleter> opt(nlopt_create(NLOPT_LD_LBFGS, un));
  if (!opt) throw NumericalError("lbfgs_minimize: NLopt could not create the optimizer");

  LbfgsSummary s;
  s.x = x0;
  Context c;
  c.f = &f;
  c.on_evaluation = &on_evaluation;
  c.opt = opt.get();
  c.n = n;
  c.summary = &s;
  c.max_evaluations = options.max_evaluations;
  auto check = [](nlopt_result r, const char* what) {
    if (r < 0) throw InvalidArgument(std::string("lbfgs_minimize: NLopt refused ") + what);
  };
  check(nlopt_set_min_objective(opt.get(), trampoline, &c), "the objective");
  check(nlopt_set_ftol_rel(opt.get(), options.ftol_rel), "ftol_rel");
  check(nlopt_set_xtol_rel(opt.get(), options.xtol_rel), "xtol_rel");
  if (options.memory > 0)
    check(nlopt_set_vector_storage(opt.get(), static_cast<unsigned>(options.memory)), "memory");
  if (boxed) {
    check(nlopt_set_lower_bounds(opt.get(), options.lower.data()), "the lower bounds");
    check(nlopt_set_upper_bounds(opt.get(), options.upper.data()), "the upper bounds");
  }
  // One L-BFGS run, then restarts from the best point after a failed line search (see
  // LbfgsOptions::max_restarts). The budget and the counts run over every run.
  if (options.scale_first_step) {  // the start's gradient sets the first run's scale
    c.x = x0;
    try {
      evaluate(c);
    } catch (...) {
      c.error = std::current_exception();
    }
    if (c.error) std::rethrow_exception(c.error);
  }
  nlopt_result r = NLOPT_FAILURE;
  while (!c.halted()) {
    const double before = s.value;
    Eigen::VectorXd x = s.x;
    double fx = 0.0;
    if (options.scale_first_step && s.evaluations > 0 && std::isfinite(s.value)) {
      c.scale = 1.0 + c.best_g.squaredNorm();
      c.serve_best = true;
    }
    check(nlopt_set_ftol_abs(opt.get(), options.ftol_abs / c.scale), "ftol_abs");
    check(nlopt_set_maxeval(opt.get(),
                            options.max_evaluations - s.evaluations + (c.serve_best ? 1 : 0)),
          "max_evaluations");
    r = nlopt_optimize(opt.get(), x.data(), &fx);
    if (c.error) std::rethrow_exception(c.error);
    const bool failed = r == NLOPT_FAILURE || r == NLOPT_ROUNDOFF_LIMITED;
    if (!failed || c.halted() || s.restarts >= options.max_restarts || !(s.value < before)) break;
    ++s.restarts;
  }
  s.nlopt_result = nlopt_result_to_string(r);
  if (c.stopped)
    s.termination = LbfgsTermination::kStopped;
  else if (c.nonfinite)
    s.termination = LbfgsTermination::kNonFinite;
  else if (c.budget || r == NLOPT_MAXEVAL_REACHED)
    s.termination = LbfgsTermination::kMaxEvaluations;
  else if (r == NLOPT_ROUNDOFF_LIMITED)
    s.termination = LbfgsTermination::kRoundoffLimited;
  else if (r > 0)
    s.termination = LbfgsTermination::kConverged;
  else
    s.termination = LbfgsTermination::kFailure;
  if (s.evaluations == 0)
    s.value = std::numeric_limits<double>::quiet_NaN();
  else if (!std::isfinite(s.value))
    s.value = s.initial_value;  // no finite value was seen
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace drops::opt
