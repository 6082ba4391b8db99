// make_task_setup: the pendubot and (with DART) the hexapod, built from an io::Experiment.

#include "task_setup.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "drops/core/errors.hpp"
#include "pendubot/pendubot.hpp"

#ifdef DROPS_WITH_HEXAPOD
#include "hexapod/policy.hpp"
#include "hexapod/prior.hpp"
#include "hexapod/real_robot.hpp"
#include "hexapod/simulator.hpp"
#include "hexapod/task.hpp"
#endif

namespace drops::app {
namespace {

TaskSetup pendubot_setup(const io::Experiment& e) {
  TaskSetup s;
  s.task = std::make_shared<pendubot::SwingUpTask>(e.task_options);
  s.real = std::make_unique<pendubot::PendubotSystem>(e.actual, e.task_options);
  s.policy = std::make_unique<policy::NeuralNetPolicy>(e.policy);
  s.prior = std::make_shared<pendubot::PendubotPrior>(e.task_options);
  s.state_names = {"dtheta1", "dtheta2", "theta1", "theta2"};
  s.action_names = {"u"};
  return s;
}

#ifdef DROPS_WITH_HEXAPOD
}  // namespace

hexapod::HexapodSpec real_robot_spec(const io::Experiment& e) {
  using hexapod::HexapodSpec;
  const io::HexapodSettings& h = e.hexapod;
  HexapodSpec spec = HexapodSpec::with_leg_removed(h.removed_leg);
  if (h.shortened_leg >= 0)
    spec.legs[static_cast<std::size_t>(h.shortened_leg)].tibia_length_factor = h.tibia_factor;
  if (h.blocked_leg >= 0) {
    auto& leg = spec.legs[static_cast<std::size_t>(h.blocked_leg)];
    leg.blocked_joint = h.blocked_joint;
    leg.blocked_angle = h.blocked_angle;
  }
  return spec;
}

namespace {

TaskSetup hexapod_setup(const io::Experiment& e) {
  using namespace drops::hexapod;
  const io::HexapodSettings& h = e.hexapod;
  TaskSetup s;

  HexapodTaskOptions to;
  to.horizon = h.horizon;
  auto task = std::make_shared<HexapodTask>(to);
  s.task = task;

  RealRobotOptions ro;
  ro.spec = real_robot_spec(e);
  if (!h.noise) ro.noise = MeasurementNoise{0, 0, 0, 0, 0, 0};
  std::string why;
  if (!ro.IsValid(&why)) throw ConfigError("config: hexapod.damage: " + why);
  s.real = std::make_unique<HexapodRealSystem>(ro);

  HexapodGaitPolicyOptions po;
  po.observation_dim = kObservationDim;
  po.theta_bound = e.algo.theta_bound;
  s.policy = std::make_unique<HexapodGaitPolicy>(po);

  HexapodPriorOptions mo;
  mo.guard.policy = h.guard_clamp ? StateGuardPolicy::kClamp : StateGuardPolicy::kStop;
  mo.pool_capacity = e.threads;  // 0: hardware threads
  auto prior = std::make_shared<HexapodPrior>(mo);
  s.prior = prior;

  for (const char* block : {"q", "dq"})
    for (int k = 0; k < kNumLegs; ++k)
      for (int j = 0; j < kJointsPerLeg; ++j) s.state_names.push_back(std::string(block) + "_" + joint_name(k, j));
  for (const char* n : {"x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "wx", "wy", "wz"})
    s.state_names.emplace_back(n);
  for (int k = 0; k < kNumLegs; ++k)
    for (int j = 0; j < kJointsPerLeg; ++j) s.action_names.push_back("u_" + joint_name(k, j));

  // Per episode: the walking speed on the robot and on the model's predicted trajectory, and the
  // state guard's events since the previous episode (policy search and model learning).
  s.metric_names = {"walking_speed_m_s", "predicted_speed_m_s", "guard_evaluations",
                    "guard_stopped", "guard_clamped"};
  auto last = std::make_shared<StateGuardCounts>();
  s.metrics = [task, prior, last](const algo::EpisodeRecord& r) {
    const StateGuardCounts c = prior->guard_counts();
    const double predicted = r.predicted.states.rows() > 1
                                 ? task->walking_speed(r.predicted)
                                 : std::numeric_limits<double>::quiet_NaN();
    std::vector<double> v = {task->walking_speed(r.real), predicted,
                             static_cast<double>(c.evaluations - last->evaluations),
                             static_cast<double>(c.stopped - last->stopped),
                             static_cast<double>(c.clamped - last->clamped)};
    *last = c;
    return v;
  };

  s.trajectory_metric_names = {"walking_speed_m_s"};
  s.trajectory_metrics = [task](const rollout::Trajectory& t) {
    return std::vector<double>{task->walking_speed(t)};
  };

  // Foot heights of the real robot's body for the gait diagram (drops plot).
  for (int k = 0; k < kNumLegs; ++k) s.state_extra_names.push_back(fmt::format("foot{}_height", k));
  PriorOptions fk = ro.simulator;
  fk.actuation = Actuation::kVelocity;
  auto sim = std::make_shared<PriorSimulator>(ro.spec, fk);
  s.state_extras = [sim](const VectorXd& x) {
    std::vector<double> v(kNumLegs, std::numeric_limits<double>::quiet_NaN());
    if (!x.allFinite()) return v;
    sim->set_state(x);
    const auto f = sim->foot_heights();
    v.assign(f.begin(), f.end());
    return v;
  };
  return s;
}
#endif

}  // namespace

bool hexapod_available() {
#ifdef DROPS_WITH_HEXAPOD
  return true;
#else
  return false;
#endif
}

TaskSetup make_task_setup(const io::Experiment& e) {
  if (e.task == "pendubot") return pendubot_setup(e);
  if (e.task == "hexapod") {
#ifdef DROPS_WITH_HEXAPOD
    return hexapod_setup(e);
#else
    throw ConfigError(
        "config key 'task' = 'hexapod': this drops was built without the hexapod task (DART 6 "
        "was not found). Run scripts/install-deps, then scripts/build again.");
#endif
  }
  throw ConfigError("config key 'task' = '" + e.task + "': unknown task");
}

}  // namespace drops::app
