#pragma once
/// \file The pendubot's IT&E behaviour descriptor (paper §V-A: "the end-effector positions at 3
/// equally spaced times"; baselines.md §3b), for a MAP-Elites archive (drops/ite/map_elites.hpp).

#include <array>

#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"

namespace drops::pendubot {

/// The state indices t_k = round(k H / 3), k = 1, 2, 3, of an episode of H steps (H >= 3) at which
/// tip_descriptor samples the tip: for H = 50 (2.5 s at dt = 0.05 s), steps 17, 33 and 50, i.e.
/// 0.85 s, 1.65 s and 2.5 s. The start x_0 is left out: it is the same for every policy, so it
/// carries no behaviour. Throws InvalidArgument when H < 3. Thread-safe (pure).
std::array<int, 3> tip_descriptor_steps(int horizon);

/// The 6-D behaviour descriptor of a pendubot episode: the tip position (pendubot::tip_position)
/// at the steps of tip_descriptor_steps(H), H = trajectory.states.rows() - 1, each coordinate
/// normalised by the reachable square of the disc of radius L = l1 + l2:
///   b = [(x_1 + L) / 2L, (y_1 + L) / 2L, (x_2 + L) / 2L, (y_2 + L) / 2L, (x_3 + L) / 2L, ...]
/// in [0, 1]^6. The tip is computed from the recorded angles with l1, l2, so it lies in the disc;
/// values are clamped to [0, 1] against round-off only. Non-finite states give non-finite values,
/// which MAP-Elites counts as invalid. l1, l2: link lengths in m (> 0), e.g. the prior's for an
/// archive built on the prior. trajectory.states: (H + 1) x 4 raw states [dth1, dth2, th1, th2].
/// Throws InvalidArgument on a state dimension other than 4, H < 3 or non-positive lengths.
/// Thread-safe (pure).
VectorXd tip_descriptor(const rollout::Trajectory& trajectory, double l1, double l2);

}  // namespace drops::pendubot
