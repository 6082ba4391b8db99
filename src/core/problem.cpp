#include "drops/core/problem.hpp"

#include <cmath>
#include <numbers>

#include <string>

#include "drops/core/errors.hpp"

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

Transition Reflection::apply(const Transition& t) const {
  if (state_sign.size() != state_offset.size() || t.x.size() != state_sign.size() ||
      t.dx.size() != state_sign.size() || t.u.size() != action_sign.size())
    throw InvalidArgument("Reflection::apply: sizes differ (state_sign " +
                          std::to_string(state_sign.size()) + ", state_offset " +
                          std::to_string(state_offset.size()) + ", action_sign " +
                          std::to_string(action_sign.size()) + "; transition x " +
                          std::to_string(t.x.size()) + ", u " + std::to_string(t.u.size()) +
                          ", dx " + std::to_string(t.dx.size()) + ")");
  Transition r;
  r.x = state_offset + state_sign.cwiseProduct(t.x);
  r.u = action_sign.cwiseProduct(t.u);
  r.dx = state_sign.cwiseProduct(t.dx);
  return r;
}

VectorXd Goal::error(const VectorXd& x) const {
  check_size("Goal::error: x vs goal state", state.size(), x.size());
  VectorXd e = x - state;
  for (int i : angles) {
    if (i < 0 || i >= e.size()) continue;  // check() reports it
    e[i] = e[i] - 2 * std::numbers::pi * std::floor((e[i] + std::numbers::pi) /
                                                    (2 * std::numbers::pi));
  }
  return e;
}

void Goal::check(int E, int U) const {
  check_size("goal state vs task state_dim", E, state.size());
  check_size("goal action vs task action_dim", U, action.size());
  check_size("goal action_limit vs task action_dim", U, action_limit.size());
  if (!state.allFinite() || !action.allFinite() || !action_limit.allFinite())
    throw InvalidArgument("goal: the state, action and action_limit must be finite");
  if ((action_limit.array() <= 0).any())
    throw InvalidArgument("goal: every action_limit must be > 0");
  for (int i : angles)
    if (i < 0 || i >= E)
      throw InvalidArgument("goal: angle index " + std::to_string(i) + " outside [0, " +
                            std::to_string(E) + ")");
}

}  // namespace drops
