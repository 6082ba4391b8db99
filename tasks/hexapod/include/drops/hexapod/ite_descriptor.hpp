#pragma once
/// \file The hexapod's IT&E behaviour descriptor: the 6-D duty factor (Cully et al. 2015;
/// baselines.md §3b), the fraction of an episode each foot touches the ground, computed from the
/// episode's states through the prior simulator's foot heights. No DART in this header.

#include <array>

#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/simulator.hpp"

namespace drops::hexapod {

/// Options of duty_factor.
struct DutyFactorOptions {
  /// A foot touches the ground when its lowest point is at most this high above the ground
  /// plane, m (>= 0). docs/ite.md gives the measured foot heights this was chosen from.
  double contact_height = 0.005;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why = nullptr) const;
};

/// The duty factor of an episode, b in [0, 1]^6 in leg order (robot.hpp): b_k = the fraction of
/// the states x_1..x_H (one per 0.1 s control step; x_0, the reset state, is the same for every
/// policy and is left out) at which foot k is at most options.contact_height above the ground
/// (PriorSimulator::foot_heights after set_state(x_t) on a simulator leased from `pool`). A leg
/// the pool's robot lacks (a removed leg) has b_k = 0, as in the reference. A non-finite state
/// gives NaN entries (MAP-Elites counts the episode as invalid).
/// Sampling, compared with the reference (every 2 physics steps of 0.015 s over 5 s): H = 40
/// samples per 4 s episode, so b_k is a multiple of 1/40; the gait's period (1 s) is 10 control
/// steps, so the samples see 10 phases of the gait, each 4 times (docs/ite.md).
/// trajectory.states: (H + 1) x 48. Throws InvalidArgument on a state dimension other than 48,
/// H < 1 or invalid options. Thread-safe (a lease per call).
VectorXd duty_factor(const rollout::Trajectory& trajectory, SimulatorPool& pool,
                     const DutyFactorOptions& options = {});

/// Whether MAP-Elites keeps an episode: false when the body tilted by tilt_limit (rad) or more at
/// some state x_1..x_H (the robot turned over: the reference's TurnOver "dead" individuals).
/// Throws InvalidArgument on a state dimension other than 48. Thread-safe (pure).
bool stayed_upright(const rollout::Trajectory& trajectory, double tilt_limit);

}  // namespace drops::hexapod
