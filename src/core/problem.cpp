#include "drops/core/problem.hpp"

namespace drops {

std::vector<Transition> Trajectory::transitions() const {
  std::vector<Transition> out;
  out.reserve(static_cast<std::size_t>(actions.rows()));
  for (Eigen::Index t = 0; t < actions.rows(); ++t) {
    Transition tr;
    tr.x = states.row(t).transpose();
    tr.u = actions.row(t).transpose();
    tr.dx = (states.row(t + 1) - states.row(t)).transpose();
    out.push_back(std::move(tr));
  }
  return out;
}

}  // namespace drops
