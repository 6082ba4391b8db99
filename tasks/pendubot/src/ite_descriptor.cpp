// The pendubot's IT&E behaviour descriptor (paper §V-A; baselines.md §3b).
#include "drops/pendubot/ite_descriptor.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/pendubot/pendubot.hpp"

namespace drops::pendubot {

std::array<int, 3> tip_descriptor_steps(int horizon) {
  if (horizon < 3) {
    throw InvalidArgument("pendubot tip_descriptor: expected a horizon >= 3 steps, got " +
                          std::to_string(horizon));
  }
  std::array<int, 3> steps{};
  for (int k = 1; k <= 3; ++k) steps[k - 1] = static_cast<int>(std::lround(k * horizon / 3.0));
  return steps;
}

VectorXd tip_descriptor(const rollout::Trajectory& trajectory, double l1, double l2) {
  check_size("pendubot tip_descriptor: state dimension", 4, trajectory.states.cols());
  if (!(l1 > 0.0) || !(l2 > 0.0)) {
    throw InvalidArgument("pendubot tip_descriptor: expected link lengths > 0, got l1 = " +
                          std::to_string(l1) + ", l2 = " + std::to_string(l2));
  }
  const auto steps = tip_descriptor_steps(static_cast<int>(trajectory.states.rows()) - 1);
  const double reach = l1 + l2;
  // Keeps NaN as NaN (std::clamp would too, but only by accident of its comparisons).
  auto normalise = [reach](double v) {
    const double b = (v + reach) / (2.0 * reach);
    return std::isfinite(b) ? std::clamp(b, 0.0, 1.0) : b;
  };
  VectorXd b(6);
  for (int k = 0; k < 3; ++k) {
    const VectorXd x = trajectory.states.row(steps[k]).transpose();
    const auto tip = tip_position(x, l1, l2);
    b[2 * k] = normalise(tip[0]);
    b[2 * k + 1] = normalise(tip[1]);
  }
  return b;
}

}  // namespace drops::pendubot
