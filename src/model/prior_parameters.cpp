#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::model {

void PriorParameters::check() const {
  check_size("PriorParameters names vs values", static_cast<long>(names.size()), values.size());
  const long T = static_cast<long>(tunable.size());
  check_size("PriorParameters lower bounds", T, lower.size());
  check_size("PriorParameters upper bounds", T, upper.size());
  check_size("PriorParameters choices", T, static_cast<long>(choices.size()));
  for (long k = 0; k < T; ++k) {
    const int i = tunable[k];
    if (i < 0 || i >= values.size())
      throw InvalidArgument("PriorParameters: tunable index " + std::to_string(i) +
                            " out of range [0, " + std::to_string(values.size()) + ")");
    const std::string& n = names[i];
    if (!(lower[k] <= upper[k]) || !std::isfinite(lower[k]) || !std::isfinite(upper[k]))
      throw InvalidArgument("prior parameter " + n + ": bounds [" + std::to_string(lower[k]) +
                            ", " + std::to_string(upper[k]) + "] must be finite with lower <= upper");
    if (choices[k].empty() && !(values[i] >= lower[k] && values[i] <= upper[k]))
      throw InvalidArgument("prior parameter " + n + " = " + std::to_string(values[i]) +
                            " lies outside its bounds [" + std::to_string(lower[k]) + ", " +
                            std::to_string(upper[k]) + "]");
  }
}

VectorXd PriorParameters::with_tuned(const VectorXd& tuned) const {
  check_size("tuned prior parameters", static_cast<long>(tunable.size()), tuned.size());
  VectorXd phi = values;
  for (std::size_t k = 0; k < tunable.size(); ++k) phi[tunable[k]] = tuned[static_cast<long>(k)];
  return phi;
}

VectorXd PriorParameters::tuned() const {
  VectorXd t(static_cast<long>(tunable.size()));
  for (std::size_t k = 0; k < tunable.size(); ++k) t[static_cast<long>(k)] = values[tunable[k]];
  return t;
}

}  // namespace drops::model
