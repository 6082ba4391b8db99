#pragma once
/// \file Shared by test_hexapod_mi.cpp and test_hexapod_mi_slow.cpp: episodes of the "real" hexapod
/// with a leg removed, and GP-MI / MI models over the 7 removed-leg priors.

#include <chrono>
#include <cstdint>
#include <memory>
#include <vector>

#include "drops/core/rng.hpp"
#include "drops/core/types.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::hexapod::testing {

/// A gentle random gait: gait parameters p uniform in [0, 1]^36 drawn from rng, with the hip and
/// femur/tibia amplitudes (p[6 k], p[6 k + 3]) halved, so that the robot without a rear leg does
/// not turn over (the full-amplitude tripod of test_hexapod_real.cpp flips it onto its back).
/// Returns the gait parameters p (dim 36).
inline Eigen::VectorXd gentle_gait(Rng& rng) {
  Eigen::VectorXd p(36);
  for (int i = 0; i < 36; ++i) p[i] = rng.uniform();
  for (int k = 0; k < kNumLegs; ++k) {
    p[6 * k] *= 0.5;
    p[6 * k + 3] *= 0.5;
  }
  return p;
}

/// The real robot's options with leg `removed_leg` removed (-1: intact), otherwise `base`.
inline RealRobotOptions damaged(int removed_leg, RealRobotOptions base = {}) {
  base.spec = HexapodSpec::with_leg_removed(removed_leg);
  return base;
}

/// Transitions (x_t, u_t, dx_t) of `episodes` episodes (H = 40 each, so 40 * episodes rows) of
/// the real robot `options` running gentle_gait()s, through rollout::run_episode. Episode e uses
/// the stream derive_seed(2024, {removed_leg + 1, e}) (the leg of options.spec) for the gait and
/// the measurement noise (data_seed replaces 2024 for other data sets). *nonfinite (if not
/// null) counts episodes stopped early.
inline std::vector<Transition> real_data(const RealRobotOptions& options, int episodes,
                                         long* nonfinite = nullptr,
                                         std::uint64_t data_seed = 2024) {
  int leg = -1;
  for (int k = 0; k < kNumLegs; ++k)
    if (options.spec.legs[static_cast<std::size_t>(k)].removed) leg = k;
  const HexapodRealSystem real(options);
  const HexapodTask task;
  HexapodGaitPolicy policy;
  std::vector<Transition> data;
  for (int e = 0; e < episodes; ++e) {
    Rng rng(
        derive_seed(data_seed, {static_cast<std::uint64_t>(leg + 1), static_cast<std::uint64_t>(e)}));
    policy.set_params(policy.theta_of(gentle_gait(rng)));
    const rollout::Trajectory tr = rollout::run_episode(task, real, policy, rng, nonfinite);
    for (auto& t : tr.transitions()) data.push_back(t);
  }
  return data;
}

/// Wall-clock seconds since t0 (for the tests' [info] lines).
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A model of options.type on HexapodTask and a fresh HexapodPrior, over
/// HexapodPrior::prior_parameters() with the starting removed_leg `phi0` (-1..5).
inline std::unique_ptr<model::DynamicsModel> hexapod_model(const model::ModelOptions& options,
                                                           int phi0 = -1) {
  model::PriorParameters p = HexapodPrior::prior_parameters();
  p.values[0] = phi0;
  return model::make_model(options, std::make_shared<HexapodTask>(),
                           std::make_shared<HexapodPrior>(), p);
}

}  // namespace drops::hexapod::testing
