#pragma once
/// \file The RealAIGym swing-up as a drops task plugin (task name "realaigym_pendubot"): its
/// configuration keys (realaigym.*, policy.hidden_units), the experiment it builds (the
/// leaderboard's plant as the "real" system, the network policy, the plant's equations with another
/// design's parameters as the simulator prior) and the leaderboard's criteria as episode metrics.

#include "drops/experiment/registry.hpp"

namespace drops::realaigym {

/// Registers the task "realaigym_pendubot" in `registry` (drops::experiment::Registry::add_task).
/// Throws InvalidArgument when a task of that name is registered already.
void register_task(experiment::Registry& registry);

}  // namespace drops::realaigym
