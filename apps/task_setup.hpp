#pragma once
// The objects of one experiment's task, built from its io::Experiment: the task, the "real"
// system, the policy, the simulator prior and the names the run directory writes. One place that
// knows every task (pendubot; hexapod when drops was built with DART), so that `drops run`,
// resume and plotting stay task-agnostic.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "drops/io/config.hpp"

namespace drops::hexapod {
struct HexapodSpec;  // hexapod/robot.hpp
}  // namespace drops::hexapod

namespace drops::app {

/// Everything run_black_drops needs for one experiment, plus what the run directory records.
struct TaskSetup {
  std::shared_ptr<const rollout::Task> task;
  std::unique_ptr<rollout::System> real;     ///< the "real" system
  std::unique_ptr<policy::Policy> policy;    ///< the policy family (parameters set by Algorithm 1)
  std::shared_ptr<const model::MeanFunction> prior;  ///< the simulator prior M(x, u; phi)
  /// Column names of the trajectory files: state (dim E) and action (dim U).
  std::vector<std::string> state_names, action_names;
  /// Names of the task's per-episode metrics, appended to episodes.csv and summary.json (may be
  /// empty). metrics(record) returns one value per name; it is called once per episode, in order,
  /// from the thread that runs Algorithm 1.
  std::vector<std::string> metric_names;
  std::function<std::vector<double>(const algo::EpisodeRecord&)> metrics;
  /// The subset of the metrics that a real trajectory alone determines (no model involved), for
  /// `drops direct`: names and a function of the trajectory returning one value per name; thread-
  /// safe. May be empty (pendubot).
  std::vector<std::string> trajectory_metric_names;
  std::function<std::vector<double>(const rollout::Trajectory&)> trajectory_metrics;
  /// Extra columns of the trajectory files computed from each state (e.g. the hexapod's foot
  /// heights for the gait diagram); names and a function of the state (dim E) returning one value
  /// per name. May be empty.
  std::vector<std::string> state_extra_names;
  std::function<std::vector<double>(const VectorXd&)> state_extras;
};

/// Builds the task of e.task. Throws ConfigError when the task is not available in this build
/// (hexapod without DART) or when the settings describe an impossible robot (the message names
/// the config key).
TaskSetup make_task_setup(const io::Experiment& e);

/// True when this build includes the hexapod task (DART found at configure time).
bool hexapod_available();

#ifdef DROPS_WITH_HEXAPOD
/// The hexapod "real" robot of e (its hexapod.damage.* keys, already range-checked by
/// io::make_experiment) as a HexapodSpec (hexapod/robot.hpp): the leg removed, the tibia
/// shortened, the joint blocked. Does not throw; a damage combination the robot cannot have is
/// reported where the spec is used (make_task_setup: ConfigError; PriorSimulator:
/// InvalidArgument). Thread-safe.
hexapod::HexapodSpec real_robot_spec(const io::Experiment& e);
#endif

}  // namespace drops::app
