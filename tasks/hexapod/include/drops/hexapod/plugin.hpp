#pragma once
/// \file The hexapod as a drops task plugin (paper §V-B): its configuration keys (hexapod.*), the
/// experiment it builds (the walking task, the "real" robot with its damage, servos and noise, the
/// 36-parameter gait policy, the DART prior family with the 7 leg-removal priors) and its report
/// labels (one panel per damage of the real robot, the walking speed as metric). No DART here.

#include "drops/experiment/registry.hpp"
#include "drops/hexapod/robot.hpp"

namespace drops::hexapod {

/// Registers the task "hexapod" in `registry`. Throws InvalidArgument when a task of that name or
/// one of its keys is registered already.
void register_task(experiment::Registry& registry);

/// The "real" robot of validated hexapod settings (hexapod.damage.*): the leg removed, the tibia
/// shortened, the joint blocked. Does not throw; a damage combination the robot cannot have is
/// reported where the spec is used (the plugin's make: ConfigError; PriorSimulator:
/// InvalidArgument). Thread-safe.
HexapodSpec real_robot_spec(const experiment::Settings& settings);

}  // namespace drops::hexapod
