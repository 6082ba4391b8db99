#include "drops/opt/objective.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "drops/core/errors.hpp"

namespace drops::opt {

GradientCheck check_gradient(const GradientObjective& f, const Eigen::VectorXd& x, double step) {
  if (!(step > 0.0))
    throw InvalidArgument("check_gradient: step: expected > 0, got " + std::to_string(step));
  if (!x.allFinite()) throw InvalidArgument("check_gradient: x: expected finite entries");
  GradientCheck c;
  c.analytic.resize(x.size());
  f(x, &c.analytic);
  check_size("check_gradient: gradient returned by the objective", x.size(), c.analytic.size());
  c.numeric.resize(x.size());
  Eigen::VectorXd y = x;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double h = step * std::max(1.0, std::abs(x[i]));
    y[i] = x[i] + h;
    const double fp = f(y, nullptr);
    y[i] = x[i] - h;
    const double fm = f(y, nullptr);
    y[i] = x[i];
    c.numeric[i] = (fp - fm) / (2.0 * h);
  }
  if (x.size() == 0) return c;
  const Eigen::VectorXd diff = (c.analytic - c.numeric).cwiseAbs();
  diff.maxCoeff(&c.worst);
  c.relative_error = diff[c.worst] / std::max(c.numeric.cwiseAbs().maxCoeff(), 1e-12);
  return c;
}

}  // namespace drops::opt
