#include "drops/algo/algorithm.hpp"

#include <cstdio>

#include "drops/core/errors.hpp"

namespace drops::algo {

void Problem::check() const {
  if (!task) throw InvalidArgument("Problem: task is null");
  if (!real) throw InvalidArgument("Problem: real system is null");
  if (!policy) throw InvalidArgument("Problem: policy is null");
  check_size("Problem: policy observation_dim vs task observation_dim", task->observation_dim(),
             policy->observation_dim());
  check_size("Problem: policy action_dim vs task action_dim", task->action_dim(),
             policy->action_dim());
  if (prior) {
    check_size("Problem: prior state_dim vs task state_dim", task->state_dim(), prior->state_dim());
    check_size("Problem: prior action_dim vs task action_dim", task->action_dim(),
               prior->action_dim());
  }
}

std::string RunSummary::BriefReport() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%d episodes, best return %.2f, ", episodes_done,
                best_real_return);
  std::string s = buf;
  s += first_solved_episode ? "first solved at episode " + std::to_string(first_solved_episode)
                            : std::string("never solved");
  std::snprintf(buf, sizeof buf, ", %.1f s", seconds);
  s += buf;
  if (interrupted) s += " (interrupted)";
  return s;
}

}  // namespace drops::algo
