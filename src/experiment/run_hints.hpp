#pragma once
// Hints the run loop prints once per run (run.cpp); internal to the library.

#include <string>

namespace drops::experiment {

/// The line printed once per run when a policy search grows costly: `seconds`, episode
/// `episode`'s policy search time (s), is at least 30 s and at least 1.5 times `previous_seconds`,
/// the search before it (> 0). It says the time, the number of recorded transitions the model
/// held (`transitions`), why the cost grows with them (each prediction's mean costs O(N), its
/// variance O(N^2) without a cap, `variance_points` 0, else O(m^2)) and which keys trade it
/// (optimizer.max_evaluations = `max_evaluations`, model.variance_points, episodes), pointing to
/// docs/python.md, "What a run costs". With sparse GPs in use (`inducing_points` > 0 and below
/// `transitions`: model.inducing_points) it says instead that a prediction costs at most O(m)
/// and O(m^2) whatever N (the greedy selection may choose fewer than m inputs while fewer explain
/// the data), and names optimizer.max_evaluations and model.inducing_points. Empty when
/// the rule does not hold. Thread-safe.
std::string policy_cost_hint(int episode, double seconds, double previous_seconds,
                             long transitions, long variance_points, long max_evaluations,
                             long inducing_points = 0);

}  // namespace drops::experiment
