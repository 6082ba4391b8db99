#pragma once
/// \file What a task gives MAP-Elites (drops/ite/map_elites.hpp) about the behaviour of an
/// episode: the behaviour descriptor of a trajectory, the grid over it and which episodes count.
/// A task that offers IT&E sets one under "ite" in experiment::TaskSetup::algorithm_data;
/// docs/ite.md describes
/// the descriptors of the shipped tasks.

#include <functional>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"

namespace drops::ite {

/// A task's behaviour space. Empty (no `describe`) when the task offers none.
struct BehaviourDescriptor {
  /// One name per descriptor dimension (dim k >= 1), e.g. "tip_x_1" or "duty_leg0"; written in
  /// the archive file and used by its plots.
  std::vector<std::string> names;
  /// The default grid: cells per dimension (dim k, each >= 1).
  std::vector<int> bins;
  /// The descriptor of an episode (states (H + 1) x E, actions, rewards) in [0, 1]^k. A
  /// non-finite value marks an episode MAP-Elites cannot place (counted as invalid). Must be
  /// thread-safe: MAP-Elites calls it from several threads at once.
  std::function<VectorXd(const Trajectory&)> describe;
  /// Optional: false for an episode that MAP-Elites must discard (the reference's "dead"
  /// individuals, e.g. a robot that turned over). Empty: every episode counts. Thread-safe.
  std::function<bool(const Trajectory&)> alive;
  /// One line on how the descriptor is computed (the archive file's comment), e.g. "the fraction
  /// of the 40 control steps at which each foot is within 5 mm of the ground".
  std::string doc;

  /// Whether the task offers a descriptor.
  bool available() const { return static_cast<bool>(describe); }
  /// Throws InvalidArgument when there is no describe function, names and bins differ in size or
  /// are empty, or a bin count is < 1.
  void check() const;
};

}  // namespace drops::ite
