// Exhaustive search over discrete coordinates x Subplex over continuous ones (NLopt LN_SBPLX).
#include "drops/opt/subplex.hpp"

#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "drops/core/errors.hpp"

namespace drops::opt {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The Cartesian product of the discrete coordinates' choices, the first coordinate slowest: per
/// combination, (coordinate, value) for every discrete coordinate.
std::vector<std::vector<std::pair<int, double>>> combinations(const MixedBox& box) {
  std::vector<std::vector<std::pair<int, double>>> combos{{}};
  for (std::size_t k = 0; k < box.choices.size(); ++k) {
    if (box.choices[k].empty()) continue;
    std::vector<std::vector<std::pair<int, double>>> next;
    for (const auto& c : combos)
      for (double v : box.choices[k]) {
        auto e = c;
        e.emplace_back(static_cast<int>(k), v);
        next.push_back(std::move(e));
      }
    combos = std::move(next);
  }
  return combos;
}

}  // namespace

bool MixedBox::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  const auto n = static_cast<std::size_t>(lower.size());
  if (static_cast<std::size_t>(upper.size()) != n || choices.size() != n)
    return fail("lower, upper and choices must have the same size (got " +
                std::to_string(lower.size()) + ", " + std::to_string(upper.size()) + ", " +
                std::to_string(choices.size()) + ")");
  for (std::size_t i = 0; i < n; ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    if (choices[i].empty() && !(lower[k] <= upper[k]))
      return fail("coordinate " + std::to_string(i) + ": lower > upper or not a number");
    for (double v : choices[i])
      if (!std::isfinite(v)) return fail("coordinate " + std::to_string(i) + ": non-finite choice");
  }
  return true;
}

bool SubplexOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_evaluations < 1) return fail("max_evaluations must be >= 1");
  if (!(xtol_rel >= 0)) return fail("xtol_rel must be >= 0");
  if (!(ftol_rel >= 0)) return fail("ftol_rel must be >= 0");
  if (!(initial_step > 0)) return fail("initial_step must be > 0");
  return true;
}

SubplexSummary maximize_mixed(const MixedObjective& f, const Eigen::VectorXd& x0,
                              const MixedBox& box, const SubplexOptions& options) {
  std::string why;
  if (!box.IsValid(&why)) throw InvalidArgument("maximize_mixed: box: " + why);
  if (!options.IsValid(&why)) throw InvalidArgument("maximize_mixed: options: " + why);
  check_size("maximize_mixed: x0 vs box", box.lower.size(), x0.size());

  std::vector<int> cont;  // continuous coordinates
  for (std::size_t k = 0; k < box.choices.size(); ++k)
    if (box.choices[k].empty()) cont.push_back(static_cast<int>(k));

  SubplexSummary s;
  s.best_x = x0;
  s.best_value = -kInf;
  auto scored = [&](const Eigen::VectorXd& x) {
    double v;
    try {
      v = f(x);
    } catch (const InvalidArgument&) {
      v = -kInf;
    }
    ++s.evaluations;
    if (!std::isfinite(v)) v = -kInf;
    if (v > s.best_value) {
      s.best_value = v;
      s.best_x = x;
    }
    return v;
  };

  for (const auto& combo : combinations(box)) {
    ++s.combinations;
    Eigen::VectorXd start = x0;
    for (const auto& [k, v] : combo) start[k] = v;
    if (cont.empty()) {
      scored(start);
      continue;
    }
    const auto n = static_cast<unsigned>(cont.size());
    nlopt::opt opt(nlopt::LN_SBPLX, n);
    std::vector<double> lb(n), ub(n), x(n), step(n);
    for (unsigned j = 0; j < n; ++j) {
      const int k = cont[j];
      lb[j] = box.lower[k];
      ub[j] = box.upper[k];
      x[j] = std::clamp(start[k], lb[j], ub[j]);
      step[j] = std::max(1e-6, options.initial_step * (ub[j] - lb[j]));
    }
    opt.set_lower_bounds(lb);
    opt.set_upper_bounds(ub);
    opt.set_initial_step(step);
    opt.set_maxeval(options.max_evaluations);
    opt.set_xtol_rel(options.xtol_rel);
    opt.set_ftol_rel(options.ftol_rel);
    struct Context {
      const std::function<double(const Eigen::VectorXd&)>* scored;
      const std::vector<int>* cont;
      const Eigen::VectorXd* start;
    };
    const std::function<double(const Eigen::VectorXd&)> to_nlopt = [&](const Eigen::VectorXd& p) {
      const double v = scored(p);
      return std::isfinite(v) ? v : -1e300;  // Subplex needs a finite value
    };
    Context ctx{&to_nlopt, &cont, &start};
    opt.set_max_objective(
        [](const std::vector<double>& xv, std::vector<double>& /*grad*/, void* data) -> double {
          const auto* c = static_cast<const Context*>(data);
          Eigen::VectorXd p = *c->start;
          for (std::size_t j = 0; j < xv.size(); ++j) p[(*c->cont)[j]] = xv[j];
          return (*c->scored)(p);
        },
        &ctx);
    double value = 0;
    try {
      opt.optimize(x, value);
    } catch (const std::exception&) {
      // Subplex stopped on round-off or a forced stop: the best point is tracked in `scored`.
    }
  }
  return s;
}

}  // namespace drops::opt
