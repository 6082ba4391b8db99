// The "real" hexapod (real_robot.hpp). No DART include here: the physics is PriorSimulator's.

#include "drops/hexapod/real_robot.hpp"

#include <cmath>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::hexapod {

double MeasurementNoise::sigma(int i) const {
  if (i < 0 || i >= kStateDim) {
    throw InvalidArgument("MeasurementNoise::sigma: index must be in 0..47, got " +
                          std::to_string(i));
  }
  if (i < kJointVel) return joint_angle;
  if (i < kBodyPos) return joint_velocity;
  if (i < kBodyRpy) return body_position;
  if (i < kBodyLinVel) return body_orientation;
  if (i < kBodyAngVel) return linear_velocity;
  return angular_velocity;
}

PriorOptions real_simulator_defaults() {
  PriorOptions o;
  o.physics_dt = 0.001;
  o.control_dt = 0.1;
  o.ground_friction = 0.4;
  o.actuation = Actuation::kServo;
  return o;
}

bool RealRobotOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (!spec.IsValid(why)) return false;
  if (!simulator.IsValid(why)) return false;
  if (simulator.actuation == Actuation::kServo && simulator.servo.stall_torque > spec.max_torque) {
    std::ostringstream s;
    s << "RealRobotOptions: simulator.servo.stall_torque (" << simulator.servo.stall_torque
      << ") exceeds spec.max_torque (" << spec.max_torque << ")";
    return fail(s.str());
  }
  for (int i = 0; i < kStateDim; ++i) {
    const double s = noise.sigma(i);
    if (!(std::isfinite(s) && s >= 0.0)) {
      std::ostringstream m;
      m << "RealRobotOptions.noise: sigma of state entry " << i << " must be >= 0, got " << s;
      return fail(m.str());
    }
  }
  return true;
}

namespace {

class RealEpisode final : public rollout::EpisodeSession {
 public:
  RealEpisode(const RealRobotOptions& options, const VectorXd& x0)
      : noise_(options.noise), sim_(options.spec, options.simulator), x_(kStateDim) {
    sim_.set_state(x0);
  }
  VectorXd step(const VectorXd& u, Rng& rng) override {
    sim_.step(u);
    sim_.state(x_);
    VectorXd measured = x_;
    for (int i = 0; i < kStateDim; ++i) {
      const double s = noise_.sigma(i);
      const double z = rng.normal();  // drawn even when s = 0: the stream does not depend on sigma
      measured[i] += s * z;
    }
    return measured;
  }

 private:
  MeasurementNoise noise_;
  PriorSimulator sim_;
  VectorXd x_;  // the true state
};

}  // namespace

HexapodRealSystem::HexapodRealSystem(const RealRobotOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument(why);
}

std::unique_ptr<rollout::EpisodeSession> HexapodRealSystem::begin_episode(
    const VectorXd& x0) const {
  check_size("HexapodRealSystem::begin_episode x0", kStateDim, x0.size());
  return std::make_unique<RealEpisode>(options_, x0);
}

VectorXd HexapodRealSystem::step(const VectorXd& x, const VectorXd& u, Rng& rng) const {
  check_size("HexapodRealSystem::step u", kNumJoints, u.size());
  return begin_episode(x)->step(u, rng);
}

}  // namespace drops::hexapod
