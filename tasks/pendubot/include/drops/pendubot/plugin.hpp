#pragma once
/// \file The pendubot as a drops task plugin: its configuration keys (system.*, prior.*,
/// pendubot.*, policy.hidden_units), the experiment it builds (the swing-up task, the "real"
/// pendubot, the 81-parameter network policy, the simulator prior with Table I's presets) and its
/// report labels (one panel per prior, A-D).

#include "drops/experiment/registry.hpp"

namespace drops::pendubot {

/// Registers the task "pendubot" in `registry` (drops::experiment::Registry::add_task). Throws
/// InvalidArgument when a task of that name or one of its keys is registered already.
void register_task(experiment::Registry& registry);

}  // namespace drops::pendubot
