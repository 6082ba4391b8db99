// The hexapod prior simulator (simulator.hpp). DART translation unit: no -march=native.

#include "drops/hexapod/simulator.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/DegreeOfFreedom.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/Joint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <sstream>

#include "drops/core/errors.hpp"
#include "rigid_step.hpp"
#include "robot_dart.hpp"

namespace drops::hexapod {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

const char* block_name(int i) {
  if (i < kJointVel) return "joint angle";
  if (i < kBodyPos) return "joint velocity";
  if (i < kBodyRpy) return "body position";
  if (i < kBodyLinVel) return "body roll/pitch/yaw";
  if (i < kBodyAngVel) return "body linear velocity";
  return "body angular velocity";
}

}  // namespace

Eigen::Matrix3d rpy_to_rotation(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d rotation_to_rpy(const Eigen::Matrix3d& r) {
  const double pitch = std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0)));
  const double roll = std::atan2(r(2, 1), r(2, 2));
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  return {roll, pitch, yaw};
}

double unwrap_near(double angle, double reference) {
  return angle + 2.0 * kPi * std::round((reference - angle) / (2.0 * kPi));
}

bool check_state(const Eigen::VectorXd& x, const HexapodSpec& spec, std::string* why,
                 const StateBounds& bounds) {
  auto fail = [&](int i, double bound) {
    if (why != nullptr) {
      *why = "hexapod state: x[" + std::to_string(i) + "] (" + block_name(i) + ") = " + str(x[i]) +
             " is outside [-" + str(bound) + ", " + str(bound) + "]";
    }
    return false;
  };
  if (x.size() != kStateDim) {
    if (why != nullptr) *why = "hexapod state: expected size 48, got " + std::to_string(x.size());
    return false;
  }
  for (int i = 0; i < kStateDim; ++i) {
    if (!std::isfinite(x[i])) {
      if (why != nullptr) {
        *why =
            "hexapod state: x[" + std::to_string(i) + "] (" + block_name(i) + ") is " + str(x[i]);
      }
      return false;
    }
  }
  for (int j = 0; j < kNumJoints; ++j) {
    const double lim = spec.joint_limit(j % kJointsPerLeg) + bounds.joint_angle_margin;
    if (std::abs(x[kJointPos + j]) > lim) return fail(kJointPos + j, lim);
    if (std::abs(x[kJointVel + j]) > bounds.max_joint_velocity) {
      return fail(kJointVel + j, bounds.max_joint_velocity);
    }
  }
  for (int i = 0; i < 3; ++i) {
    if (std::abs(x[kBodyPos + i]) > bounds.max_position)
      return fail(kBodyPos + i, bounds.max_position);
    if (i < 2 && std::abs(x[kBodyRpy + i]) > bounds.max_roll_pitch) {
      return fail(kBodyRpy + i, bounds.max_roll_pitch);
    }
    if (std::abs(x[kBodyLinVel + i]) > bounds.max_linear_velocity) {
      return fail(kBodyLinVel + i, bounds.max_linear_velocity);
    }
    if (std::abs(x[kBodyAngVel + i]) > bounds.max_angular_velocity) {
      return fail(kBodyAngVel + i, bounds.max_angular_velocity);
    }
  }
  return true;
}

bool ServoOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto nonneg = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!positive(kp)) return fail("ServoOptions.kp must be > 0, got " + str(kp));
  if (!nonneg(kd)) return fail("ServoOptions.kd must be >= 0, got " + str(kd));
  if (!positive(stall_torque))
    return fail("ServoOptions.stall_torque must be > 0, got " + str(stall_torque));
  if (!positive(no_load_speed))
    return fail("ServoOptions.no_load_speed must be > 0, got " + str(no_load_speed));
  if (!nonneg(viscous_friction)) {
    return fail("ServoOptions.viscous_friction must be >= 0, got " + str(viscous_friction));
  }
  if (!nonneg(coulomb_friction)) {
    return fail("ServoOptions.coulomb_friction must be >= 0, got " + str(coulomb_friction));
  }
  return true;
}

bool PriorOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (actuation != Actuation::kVelocity && actuation != Actuation::kServo)
    return fail("PriorOptions.actuation must be kVelocity or kServo");
  if (actuation == Actuation::kServo && !servo.IsValid(why)) return false;
  if (engine != PriorEngine::kDart && engine != PriorEngine::kRigid)
    return fail("PriorOptions.engine must be kDart or kRigid");
  if (engine == PriorEngine::kRigid && actuation != Actuation::kVelocity) {
    return fail("PriorOptions.engine = kRigid needs actuation = kVelocity (kinematic joints); "
                "the servo robot's joints are dynamic");
  }
  if (!positive(physics_dt))
    return fail("PriorOptions.physics_dt must be > 0, got " + str(physics_dt));
  if (!positive(control_dt))
    return fail("PriorOptions.control_dt must be > 0, got " + str(control_dt));
  const double ratio = control_dt / physics_dt;
  if (ratio < 0.5 || std::abs(ratio - std::round(ratio)) > 1e-6) {
    return fail("PriorOptions.control_dt (" + str(control_dt) +
                ") must be an integer multiple of physics_dt (" + str(physics_dt) + ")");
  }
  if (!positive(initial_height)) {
    return fail("PriorOptions.initial_height must be > 0, got " + str(initial_height));
  }
  if (!(std::isfinite(gravity) && gravity >= 0.0))
    return fail("PriorOptions.gravity must be >= 0, got " + str(gravity));
  if (!positive(ground_friction)) {
    return fail("PriorOptions.ground_friction must be > 0, got " + str(ground_friction));
  }
  if (!positive(robot_friction)) {
    return fail("PriorOptions.robot_friction must be > 0, got " + str(robot_friction));
  }
  if (!positive(velocity_gain_period)) {
    return fail("PriorOptions.velocity_gain_period must be > 0, got " + str(velocity_gain_period));
  }
  return true;
}

struct PriorSimulator::Impl {
  HexapodSpec spec;
  PriorOptions options;
  int substeps = 1;
  dart::simulation::WorldPtr world;
  dart::dynamics::SkeletonPtr robot;
  dart::dynamics::BodyNode* body = nullptr;
  dart::dynamics::FreeJoint* root = nullptr;
  // Per joint index 3 k + j: the DART degree of freedom, or null for a removed leg.
  std::array<dart::dynamics::DegreeOfFreedom*, kNumJoints> dofs{};
  // Index among the rigid step's leg dofs of joint 3 k + j (-1 for a removed leg).
  std::array<int, kNumJoints> leg_dof{};
  std::unique_ptr<RigidRobotStep> rigid;  // engine == kRigid
  std::array<double, kNumJoints> rigid_commands{};
  std::array<bool, kNumJoints> blocked{};
  std::array<double, kNumJoints> blocked_angle{};
  // Kinematic joints of removed legs (angle, velocity).
  std::array<double, kNumJoints> free_q{};
  std::array<double, kNumJoints> free_dq{};
  long steps_done = 0;   // physics steps since reset
  double roll_ref = 0.0;  // roll of the last state, for unwrapping
  double yaw_ref = 0.0;   // yaw of the last state, for unwrapping

  // The body's roll, pitch, yaw with roll and yaw unwrapped near roll_ref and yaw_ref.
  Eigen::Vector3d continuous_rpy() const {
    Eigen::Vector3d rpy = rotation_to_rpy(body->getWorldTransform().linear());
    rpy[0] = unwrap_near(rpy[0], roll_ref);
    rpy[2] = unwrap_near(rpy[2], yaw_ref);
    return rpy;
  }
};

PriorSimulator::PriorSimulator(const HexapodSpec& spec, const PriorOptions& options)
    : impl_(std::make_unique<Impl>()) {
  spec.check();
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument(why);
  const bool servo = options.actuation == Actuation::kServo;
  if (servo && options.servo.stall_torque > spec.max_torque) {
    throw InvalidArgument("PriorSimulator: servo.stall_torque (" + str(options.servo.stall_torque) +
                          ") exceeds spec.max_torque (" + str(spec.max_torque) + ")");
  }
  Impl& m = *impl_;
  m.spec = spec;
  m.options = options;
  m.substeps = static_cast<int>(std::lround(options.control_dt / options.physics_dt));
  m.robot = build_skeleton(spec, options.robot_friction);
  WorldOptions wo;
  wo.time_step = options.physics_dt;
  wo.gravity = options.gravity;
  wo.ground_friction = options.ground_friction;
  m.world = make_world(m.robot, wo);
  m.body = m.robot->getBodyNode(kBodyName);
  m.root = static_cast<dart::dynamics::FreeJoint*>(m.robot->getRootJoint());
  for (int k = 0; k < kNumLegs; ++k) {
    const LegOptions& leg = spec.legs[k];
    for (int j = 0; j < kJointsPerLeg; ++j) {
      const int idx = kJointsPerLeg * k + j;
      m.blocked[idx] = !leg.removed && leg.blocked_joint == j;
      m.blocked_angle[idx] = m.blocked[idx] ? leg.blocked_angle : 0.0;
      if (leg.removed) continue;
      dart::dynamics::Joint* joint = m.robot->getJoint(joint_name(k, j));
      joint->setActuatorType(m.blocked[idx] ? dart::dynamics::Joint::LOCKED
                             : servo        ? dart::dynamics::Joint::FORCE
                                            : dart::dynamics::Joint::VELOCITY);
      if (servo && !m.blocked[idx]) {
        joint->setDampingCoefficient(0, options.servo.viscous_friction);
        joint->setCoulombFriction(0, options.servo.coulomb_friction);
      }
      m.dofs[idx] = joint->getDof(0);
      m.leg_dof[idx] = static_cast<int>(m.dofs[idx]->getIndexInSkeleton()) - 6;
    }
  }
  if (options.engine == PriorEngine::kRigid)
    m.rigid = std::make_unique<RigidRobotStep>(m.world, m.robot);
  reset();
}

PriorSimulator::~PriorSimulator() = default;
PriorSimulator::PriorSimulator(PriorSimulator&&) noexcept = default;
PriorSimulator& PriorSimulator::operator=(PriorSimulator&&) noexcept = default;

void PriorSimulator::reset() {
  Impl& m = *impl_;
  m.world->reset();
  m.robot->resetPositions();
  m.robot->resetVelocities();
  m.robot->resetAccelerations();
  m.robot->resetCommands();
  Eigen::Isometry3d tf = Eigen::Isometry3d::Identity();
  tf.translation() = Eigen::Vector3d(0.0, 0.0, m.options.initial_height);
  m.root->setPositions(dart::dynamics::FreeJoint::convertToPositions(tf));
  m.root->setVelocities(Eigen::Vector6d::Zero());
  for (int i = 0; i < kNumJoints; ++i) {
    if (m.dofs[i] != nullptr) {
      m.dofs[i]->setPosition(m.blocked_angle[i]);
      m.dofs[i]->setVelocity(0.0);
    }
    m.free_q[i] = 0.0;
    m.free_dq[i] = 0.0;
  }
  m.steps_done = 0;
  m.roll_ref = 0.0;
  m.yaw_ref = 0.0;
}

void PriorSimulator::step(const Eigen::VectorXd& q_target) {
  check_size("PriorSimulator::step q_target", kNumJoints, q_target.size());
  Impl& m = *impl_;
  std::array<double, kNumJoints> target{};
  for (int i = 0; i < kNumJoints; ++i) {
    if (!std::isfinite(q_target[i])) {
      throw InvalidArgument("PriorSimulator::step: q_target[" + std::to_string(i) + "] is " +
                            str(q_target[i]));
    }
    const double lim = m.spec.joint_limit(i % kJointsPerLeg);
    target[i] = std::clamp(q_target[i], -lim, lim);
  }
  const double dt = m.options.physics_dt;
  const double gain = 1.0 / (m.options.velocity_gain_period * dt);
  const double vmax = m.spec.max_velocity;
  auto command = [&](double error) {
    const double v = gain * error;
    return m.options.clip_velocity_command ? std::clamp(v, -vmax, vmax) : v;
  };
  const bool servo = m.options.actuation == Actuation::kServo;
  const ServoOptions& so = m.options.servo;
  auto torque = [&](double error, double dq) {
    const double tau = so.kp * error - so.kd * dq;
    const double hi = std::min(so.stall_torque, so.stall_torque * (1.0 - dq / so.no_load_speed));
    const double lo = std::max(-so.stall_torque, -so.stall_torque * (1.0 + dq / so.no_load_speed));
    return std::clamp(tau, std::min(lo, 0.0), std::max(hi, 0.0));
  };
  if (m.rigid) {
    m.rigid->load();
    for (int s = 0; s < m.substeps; ++s) {
      for (int i = 0; i < kNumJoints; ++i) {
        if (m.dofs[i] != nullptr) {
          if (m.blocked[i]) continue;
          const int d = m.leg_dof[i];
          m.rigid_commands[d] = command(target[i] - m.rigid->leg_position(d));
        } else {
          m.free_dq[i] = command(target[i] - m.free_q[i]);
          m.free_q[i] += dt * m.free_dq[i];
        }
      }
      m.rigid->step(m.rigid_commands.data());
      ++m.steps_done;
    }
    m.rigid->store();
  }
  for (int s = 0; s < (m.rigid ? 0 : m.substeps); ++s) {
    for (int i = 0; i < kNumJoints; ++i) {
      if (m.dofs[i] != nullptr) {
        if (m.blocked[i]) continue;
        const double error = target[i] - m.dofs[i]->getPosition();
        m.dofs[i]->setCommand(servo ? torque(error, m.dofs[i]->getVelocity()) : command(error));
      } else {
        // A removed leg's servo moves without load: the same command, reached instantly.
        m.free_dq[i] = command(target[i] - m.free_q[i]);
        m.free_q[i] += dt * m.free_dq[i];
      }
    }
    m.world->step();
    ++m.steps_done;
  }
  const Eigen::Vector3d rpy = m.continuous_rpy();
  m.roll_ref = rpy[0];
  m.yaw_ref = rpy[2];
}

void PriorSimulator::state(Eigen::Ref<Eigen::VectorXd> x) const {
  check_size("PriorSimulator::state x", kStateDim, x.size());
  const Impl& m = *impl_;
  for (int i = 0; i < kNumJoints; ++i) {
    if (m.dofs[i] != nullptr) {
      x[kJointPos + i] = m.dofs[i]->getPosition();
      x[kJointVel + i] = m.dofs[i]->getVelocity();
    } else {
      x[kJointPos + i] = m.free_q[i];
      x[kJointVel + i] = m.free_dq[i];
    }
  }
  const Eigen::Isometry3d& tf = m.body->getWorldTransform();
  x.segment<3>(kBodyPos) = tf.translation();
  x.segment<3>(kBodyRpy) = m.continuous_rpy();
  x.segment<3>(kBodyLinVel) = m.body->getLinearVelocity();
  x.segment<3>(kBodyAngVel) = m.body->getAngularVelocity();
}

Eigen::VectorXd PriorSimulator::state() const {
  Eigen::VectorXd x(kStateDim);
  state(x);
  return x;
}

void PriorSimulator::set_state(const Eigen::VectorXd& x) {
  check_size("PriorSimulator::set_state x", kStateDim, x.size());
  for (int i = 0; i < kStateDim; ++i) {
    if (!std::isfinite(x[i])) {
      throw InvalidArgument("PriorSimulator::set_state: x[" + std::to_string(i) + "] (" +
                            block_name(i) + ") is " + str(x[i]));
    }
  }
  Impl& m = *impl_;
  for (int i = 0; i < kNumJoints; ++i) {
    if (m.dofs[i] != nullptr) {
      m.dofs[i]->setPosition(m.blocked[i] ? m.blocked_angle[i] : x[kJointPos + i]);
      m.dofs[i]->setVelocity(m.blocked[i] ? 0.0 : x[kJointVel + i]);
    } else {
      m.free_q[i] = x[kJointPos + i];
      m.free_dq[i] = x[kJointVel + i];
    }
  }
  const Eigen::Vector3d rpy = x.segment<3>(kBodyRpy);
  Eigen::Isometry3d tf = Eigen::Isometry3d::Identity();
  tf.linear() = rpy_to_rotation(rpy);
  tf.translation() = x.segment<3>(kBodyPos);
  m.root->setPositions(dart::dynamics::FreeJoint::convertToPositions(tf));
  // FreeJoint velocities are the body's spatial velocity in its own frame: [R^T w; R^T v].
  Eigen::Vector6d v;
  v.head<3>() = tf.linear().transpose() * x.segment<3>(kBodyAngVel);
  v.tail<3>() = tf.linear().transpose() * x.segment<3>(kBodyLinVel);
  m.root->setVelocities(v);
  m.robot->resetAccelerations();
  m.roll_ref = rpy[0];
  m.yaw_ref = rpy[2];
}

double PriorSimulator::time() const {
  return static_cast<double>(impl_->steps_done) * impl_->options.physics_dt;
}
int PriorSimulator::substeps() const { return impl_->substeps; }
std::shared_ptr<dart::simulation::World> PriorSimulator::world() const { return impl_->world; }
const HexapodSpec& PriorSimulator::spec() const { return impl_->spec; }
const PriorOptions& PriorSimulator::options() const { return impl_->options; }

std::array<double, kNumLegs> PriorSimulator::foot_heights() const {
  std::array<double, kNumLegs> h{};
  for (int k = 0; k < kNumLegs; ++k) {
    const auto* foot = impl_->spec.legs[static_cast<std::size_t>(k)].removed
                           ? nullptr
                           : impl_->robot->getShapeNode(foot_name(k));
    h[static_cast<std::size_t>(k)] =
        foot ? foot->getWorldTransform().translation().z() - impl_->spec.foot_radius
             : std::numeric_limits<double>::quiet_NaN();
  }
  return h;
}

std::vector<std::string> PriorSimulator::body_names() const {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < impl_->robot->getNumBodyNodes(); ++i) {
    names.push_back(impl_->robot->getBodyNode(i)->getName());
  }
  return names;
}

std::vector<std::string> PriorSimulator::joint_names() const {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < impl_->robot->getNumJoints(); ++i) {
    names.push_back(impl_->robot->getJoint(i)->getName());
  }
  return names;
}

std::vector<std::string> PriorSimulator::shape_names() const {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < impl_->robot->getNumShapeNodes(); ++i) {
    names.push_back(impl_->robot->getShapeNode(i)->getName());
  }
  return names;
}

int PriorSimulator::num_dofs() const { return static_cast<int>(impl_->robot->getNumDofs()); }
double PriorSimulator::mass() const { return impl_->robot->getMass(); }

}  // namespace drops::hexapod
