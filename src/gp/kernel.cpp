// Squared-exponential ARD kernel (Rasmussen & Williams 2006, eq. 5.1).
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

}  // namespace drops::gp
