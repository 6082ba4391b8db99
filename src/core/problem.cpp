#include "drops/core/problem.hpp"

namespace drops {

std::vector<Transition> Trajectory::transitions() const {
  std::vector<Transition> out;
  const Eigen::Index steps = nonfinite_step >= 0 ? nonfinite_step : actions.rows();
  out.reserve(static_cast<std::size_t>(steps));
  for (Eigen::Index t = 0; t < steps; ++t) {
    Transition tr;
    tr.x = states.row(t).transpose();
    tr.u = actions.row(t).transpose();
    tr.dx = (states.row(t + 1) - states.row(t)).transpose();
    out.push_back(std::move(tr));
  }
  return out;
}

}  // namespace drops
