// The hexapod description (robot.hpp) and its DART skeleton and world (robot_dart.hpp).
// Compiled without -march=native (DART translation unit).

#include "drops/hexapod/robot.hpp"

#include <cmath>
#include <memory>
#include <dart/collision/dart/DARTCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/SphereShape.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <sstream>

#include "drops/core/errors.hpp"
#include "contact_solver.hpp"
#include "robot_dart.hpp"

namespace drops::hexapod {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool positive(double v) { return std::isfinite(v) && v > 0.0; }

std::string str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void check_leg_joint(int leg, int joint) {
  if (leg < 0 || leg >= kNumLegs || joint < 0 || joint >= kJointsPerLeg) {
    throw InvalidArgument("hexapod: leg must be in 0..5 and joint in 0..2, got leg " +
                          std::to_string(leg) + ", joint " + std::to_string(joint));
  }
}

using dart::dynamics::BodyNode;
using dart::dynamics::BoxShape;
using dart::dynamics::CollisionAspect;
using dart::dynamics::DynamicsAspect;
using dart::dynamics::ShapeNode;
using dart::dynamics::SphereShape;
using dart::dynamics::VisualAspect;

// Attaches `shape` to `body` at `offset` with visual, collision and dynamics aspects.
ShapeNode* add_shape(BodyNode* body, const dart::dynamics::ShapePtr& shape,
                     const Eigen::Vector3d& offset, const std::string& name, double friction) {
  ShapeNode* node =
      body->createShapeNodeWith<VisualAspect, CollisionAspect, DynamicsAspect>(shape, name);
  Eigen::Isometry3d tf = Eigen::Isometry3d::Identity();
  tf.translation() = offset;
  node->setRelativeTransform(tf);
  node->getDynamicsAspect()->setFrictionCoeff(friction);
  return node;
}

// Mass and inertia of a solid box of size `size` centred at `com`.
void set_box_inertia(BodyNode* body, double mass, const Eigen::Vector3d& size,
                     const Eigen::Vector3d& com) {
  dart::dynamics::Inertia inertia;
  inertia.setMass(mass);
  inertia.setLocalCOM(com);
  inertia.setMoment(BoxShape::computeInertia(size, mass));
  body->setInertia(inertia);
}

BodyNode* add_revolute(const dart::dynamics::SkeletonPtr& skel, BodyNode* parent,
                       const std::string& joint, const std::string& body,
                       const Eigen::Isometry3d& parent_to_joint, const Eigen::Vector3d& axis,
                       double limit, const HexapodSpec& spec, double initial) {
  dart::dynamics::RevoluteJoint::Properties jp;
  jp.mName = joint;
  jp.mAxis = axis;
  jp.mT_ParentBodyToJoint = parent_to_joint;
  jp.mT_ChildBodyToJoint = Eigen::Isometry3d::Identity();
  jp.mPositionLowerLimits[0] = -limit;
  jp.mPositionUpperLimits[0] = limit;
  jp.mVelocityLowerLimits[0] = -spec.max_velocity;
  jp.mVelocityUpperLimits[0] = spec.max_velocity;
  jp.mForceLowerLimits[0] = -spec.max_torque;
  jp.mForceUpperLimits[0] = spec.max_torque;
  jp.mInitialPositions[0] = initial;
  jp.mIsPositionLimitEnforced = true;
  BodyNode::Properties bp;
  bp.mName = body;
  auto pair = skel->createJointAndBodyNodePair<dart::dynamics::RevoluteJoint>(parent, jp, bp);
  pair.first->setPosition(0, initial);
  return pair.second;
}

}  // namespace

HexapodSpec HexapodSpec::intact() { return HexapodSpec{}; }

HexapodSpec HexapodSpec::with_leg_removed(int leg) {
  if (leg < -1 || leg >= kNumLegs) {
    throw InvalidArgument("hexapod: removed leg must be -1 (intact) or 0..5, got " +
                          std::to_string(leg));
  }
  HexapodSpec spec;
  if (leg >= 0) spec.legs[leg].removed = true;
  return spec;
}

int HexapodSpec::num_present_legs() const {
  int n = 0;
  for (const LegOptions& l : legs) n += l.removed ? 0 : 1;
  return n;
}

bool HexapodSpec::IsValid(std::string* why) const {
  const std::pair<const char*, double> sizes[] = {
      {"body_length", body_length},       {"body_width", body_width},
      {"body_height", body_height},       {"body_mass", body_mass},
      {"hip_length", hip_length},         {"femur_length", femur_length},
      {"tibia_length", tibia_length},     {"foot_radius", foot_radius},
      {"link_thickness", link_thickness}, {"hip_mass", hip_mass},
      {"femur_mass", femur_mass},         {"tibia_mass", tibia_mass},
      {"hip_limit", hip_limit},           {"knee_limit", knee_limit},
      {"max_velocity", max_velocity},     {"max_torque", max_torque}};
  for (const auto& [name, value] : sizes) {
    if (!positive(value)) {
      return fail(why, std::string("HexapodSpec.") + name + " must be positive and finite, got " +
                           str(value));
    }
  }
  for (int k = 0; k < kNumLegs; ++k) {
    if (!std::isfinite(attach_x[k]) || !std::isfinite(attach_y[k])) {
      return fail(why, "HexapodSpec.attach_x/attach_y[" + std::to_string(k) + "] must be finite");
    }
    const LegOptions& l = legs[k];
    const std::string leg = "HexapodSpec.legs[" + std::to_string(k) + "].";
    if (!(std::isfinite(l.tibia_length_factor) && l.tibia_length_factor > 0.0 &&
          l.tibia_length_factor <= 1.0)) {
      return fail(why,
                  leg + "tibia_length_factor must be in (0, 1], got " + str(l.tibia_length_factor));
    }
    if (l.blocked_joint < -1 || l.blocked_joint >= kJointsPerLeg) {
      return fail(why, leg + "blocked_joint must be -1 (none) or 0..2, got " +
                           std::to_string(l.blocked_joint));
    }
    if (l.blocked_joint >= 0) {
      const double lim = joint_limit(l.blocked_joint);
      if (!std::isfinite(l.blocked_angle) || std::abs(l.blocked_angle) > lim) {
        return fail(why, leg + "blocked_angle must be in [-" + str(lim) + ", " + str(lim) +
                             "] rad, got " + str(l.blocked_angle));
      }
    }
  }
  return true;
}

void HexapodSpec::check() const {
  std::string why;
  if (!IsValid(&why)) throw InvalidArgument(why);
}

std::string joint_name(int leg, int joint) {
  check_leg_joint(leg, joint);
  static const char* const kParts[kJointsPerLeg] = {"hip", "femur", "tibia"};
  return "leg" + std::to_string(leg) + "_" + kParts[joint];
}

std::string body_name(int leg, int joint) { return joint_name(leg, joint) + "_link"; }

std::string foot_name(int leg) {
  check_leg_joint(leg, 0);
  return "leg" + std::to_string(leg) + "_foot";
}

bool WorldOptions::IsValid(std::string* why) const {
  if (!positive(time_step))
    return fail(why, "WorldOptions.time_step must be > 0, got " + str(time_step));
  if (!(std::isfinite(gravity) && gravity >= 0.0)) {
    return fail(why, "WorldOptions.gravity must be >= 0, got " + str(gravity));
  }
  if (!positive(ground_friction)) {
    return fail(why, "WorldOptions.ground_friction must be > 0, got " + str(ground_friction));
  }
  if (!positive(ground_size))
    return fail(why, "WorldOptions.ground_size must be > 0, got " + str(ground_size));
  if (!positive(ground_thickness)) {
    return fail(why, "WorldOptions.ground_thickness must be > 0, got " + str(ground_thickness));
  }
  return true;
}

dart::dynamics::SkeletonPtr build_skeleton(const HexapodSpec& spec, double friction) {
  spec.check();
  if (!positive(friction)) {
    throw InvalidArgument("build_skeleton: friction must be positive and finite, got " +
                          str(friction));
  }
  auto skel = dart::dynamics::Skeleton::create(kSkeletonName);

  dart::dynamics::FreeJoint::Properties root_props;
  root_props.mName = kRootJointName;
  BodyNode::Properties body_props;
  body_props.mName = kBodyName;
  BodyNode* body =
      skel->createJointAndBodyNodePair<dart::dynamics::FreeJoint>(nullptr, root_props, body_props)
          .second;
  const Eigen::Vector3d body_size(spec.body_length, spec.body_width, spec.body_height);
  set_box_inertia(body, spec.body_mass, body_size, Eigen::Vector3d::Zero());
  add_shape(body, std::make_shared<BoxShape>(body_size), Eigen::Vector3d::Zero(),
            std::string(kBodyName) + "_shape", friction);

  const double t = spec.link_thickness;
  for (int k = 0; k < kNumLegs; ++k) {
    const LegOptions& leg = spec.legs[k];
    if (leg.removed) continue;
    const bool left = k < 3;
    auto initial = [&](int j) { return leg.blocked_joint == j ? leg.blocked_angle : 0.0; };

    // Hip: leg frame with local x pointing outwards; positive angle swings the foot forward.
    Eigen::Isometry3d hip_tf = Eigen::Isometry3d::Identity();
    hip_tf.translation() = Eigen::Vector3d(spec.attach_x[k], spec.attach_y[k], 0.0);
    hip_tf.linear() =
        Eigen::AngleAxisd(left ? kPi / 2 : -kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d hip_axis(0.0, 0.0, left ? -1.0 : 1.0);
    BodyNode* hip = add_revolute(skel, body, joint_name(k, 0), body_name(k, 0), hip_tf, hip_axis,
                                 spec.hip_limit, spec, initial(0));
    const Eigen::Vector3d hip_size(spec.hip_length, t, t);
    const Eigen::Vector3d hip_com(spec.hip_length / 2, 0.0, 0.0);
    set_box_inertia(hip, spec.hip_mass, hip_size, hip_com);
    add_shape(hip, std::make_shared<BoxShape>(hip_size), hip_com, body_name(k, 0) + "_shape",
              friction);

    // Femur and tibia turn about -y of the leg frame: a positive angle lifts the outer part.
    const Eigen::Vector3d lift_axis(0.0, -1.0, 0.0);
    Eigen::Isometry3d femur_tf = Eigen::Isometry3d::Identity();
    femur_tf.translation() = Eigen::Vector3d(spec.hip_length, 0.0, 0.0);
    BodyNode* femur = add_revolute(skel, hip, joint_name(k, 1), body_name(k, 1), femur_tf,
                                   lift_axis, spec.knee_limit, spec, initial(1));
    const Eigen::Vector3d femur_size(spec.femur_length, t, t);
    const Eigen::Vector3d femur_com(spec.femur_length / 2, 0.0, 0.0);
    set_box_inertia(femur, spec.femur_mass, femur_size, femur_com);
    add_shape(femur, std::make_shared<BoxShape>(femur_size), femur_com, body_name(k, 1) + "_shape",
              friction);

    Eigen::Isometry3d tibia_tf = Eigen::Isometry3d::Identity();
    tibia_tf.translation() = Eigen::Vector3d(spec.femur_length, 0.0, 0.0);
    BodyNode* tibia = add_revolute(skel, femur, joint_name(k, 2), body_name(k, 2), tibia_tf,
                                   lift_axis, spec.knee_limit, spec, initial(2));
    const double tibia_len = spec.tibia_length * leg.tibia_length_factor;
    const Eigen::Vector3d tibia_size(t, t, tibia_len);
    const Eigen::Vector3d tibia_com(0.0, 0.0, -tibia_len / 2);
    set_box_inertia(tibia, spec.tibia_mass, tibia_size, tibia_com);
    add_shape(tibia, std::make_shared<BoxShape>(tibia_size), tibia_com, body_name(k, 2) + "_shape",
              friction);
    add_shape(tibia, std::make_shared<SphereShape>(spec.foot_radius),
              Eigen::Vector3d(0.0, 0.0, -tibia_len), foot_name(k), friction);
  }
  return skel;
}

dart::simulation::WorldPtr make_world(const dart::dynamics::SkeletonPtr& robot,
                                      const WorldOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument(why);
  if (!robot) throw InvalidArgument("make_world: robot skeleton is null");

  auto ground = dart::dynamics::Skeleton::create(kGroundName);
  dart::dynamics::WeldJoint::Properties wp;
  wp.mName = std::string(kGroundName) + "_weld";
  wp.mT_ParentBodyToJoint.translation() = Eigen::Vector3d(0.0, 0.0, -options.ground_thickness / 2);
  BodyNode::Properties gp;
  gp.mName = kGroundName;
  BodyNode* ground_body =
      ground->createJointAndBodyNodePair<dart::dynamics::WeldJoint>(nullptr, wp, gp).second;
  const ShapeNode* ground_shape = add_shape(
      ground_body,
      std::make_shared<BoxShape>(
          Eigen::Vector3d(options.ground_size, options.ground_size, options.ground_thickness)),
      Eigen::Vector3d::Zero(), std::string(kGroundName) + "_shape", options.ground_friction);
  ground->setMobile(false);

  auto world = dart::simulation::World::create("hexapod_world");
  // Before anything is added: World::setConstraintSolver hands the skeletons over but not the
  // collision detector or its options.
  world->setConstraintSolver(std::make_unique<RigidRobotContactSolver>());
  world->setGravity(Eigen::Vector3d(0.0, 0.0, -options.gravity));
  world->setTimeStep(options.time_step);
  dart::constraint::ConstraintSolver* solver = world->getConstraintSolver();
  solver->setCollisionDetector(dart::collision::DARTCollisionDetector::create());
  solver->getCollisionOption().collisionFilter =
      std::make_shared<GroundContactFilter>(ground_shape, *robot, 0.0);
  world->addSkeleton(ground);
  world->addSkeleton(robot);
  return world;
}

}  // namespace drops::hexapod
