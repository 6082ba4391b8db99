// Squared-exponential ARD kernel (Rasmussen & Williams 2006, eq. 5.1) and Matern 5/2 (eq. 4.17).
#include "drops/gp/kernel.hpp"

#include <cmath>

#include "drops/core/errors.hpp"

namespace drops::gp {

double SquaredExpArd::operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  check_size("SquaredExpArd: first input", length_scales.size(), a.size());
  check_size("SquaredExpArd: second input", length_scales.size(), b.size());
  double s = 0.0;
  for (Eigen::Index d = 0; d < a.size(); ++d) {
    const double t = (a[d] - b[d]) / length_scales[d];
    s += t * t;
  }
  return signal_variance * std::exp(-0.5 * s);
}

double Matern52::of_distance(double d) const {
  const double r = std::sqrt(5.0) * d / length_scale;
  return signal_variance * (1.0 + r + r * r / 3.0) * std::exp(-r);
}

double Matern52::operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  check_size("Matern52: second input", a.size(), b.size());
  return of_distance((a - b).norm());
}

}  // namespace drops::gp
