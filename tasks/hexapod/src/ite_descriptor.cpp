// The hexapod's duty-factor descriptor for IT&E (Cully et al. 2015; baselines.md §3b).
#include "drops/hexapod/ite_descriptor.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::hexapod {

bool DutyFactorOptions::IsValid(std::string* why) const {
  if (!(contact_height >= 0) || !std::isfinite(contact_height)) {
    if (why) *why = "contact_height: expected >= 0 m, got " + std::to_string(contact_height);
    return false;
  }
  return true;
}

VectorXd duty_factor(const rollout::Trajectory& trajectory, SimulatorPool& pool,
                     const DutyFactorOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("duty_factor: " + why);
  check_size("duty_factor: state dimension", kStateDim, trajectory.states.cols());
  const Eigen::Index horizon = trajectory.states.rows() - 1;
  if (horizon < 1) throw InvalidArgument("duty_factor: expected an episode of >= 1 step");
  VectorXd b = VectorXd::Zero(kNumLegs);
  auto sim = pool.acquire();
  for (Eigen::Index t = 1; t <= horizon; ++t) {
    const VectorXd x = trajectory.states.row(t).transpose();
    if (!x.allFinite()) return VectorXd::Constant(kNumLegs, std::numeric_limits<double>::quiet_NaN());
    sim->set_state(x);
    const auto heights = sim->foot_heights();
    for (int k = 0; k < kNumLegs; ++k)
      if (heights[static_cast<std::size_t>(k)] <= options.contact_height) b[k] += 1;  // NaN: no
  }
  return b / static_cast<double>(horizon);
}

bool stayed_upright(const rollout::Trajectory& trajectory, double tilt_limit) {
  check_size("stayed_upright: state dimension", kStateDim, trajectory.states.cols());
  for (Eigen::Index t = 1; t < trajectory.states.rows(); ++t)
    if (!(body_tilt(trajectory.states(t, kBodyRpy), trajectory.states(t, kBodyRpy + 1)) <
          tilt_limit))
      return false;
  return true;
}

}  // namespace drops::hexapod
