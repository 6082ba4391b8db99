// RigidRobotStep (rigid_step.hpp). DART translation unit: no -march=native.
//
// Each part follows what DART 6.12 computes for the prior's world; the DART function it stands
// for is named in a comment (Skeleton::computeForwardDynamics, ContactConstraint, ...). The
// semantics were taken from DART's headers and public sources (see rigid_step.hpp) and checked
// numerically against a DART world step (test_hexapod_rigid_step).

#include "rigid_step.hpp"

#include <dart/external/odelcpsolver/common.h>

#include <algorithm>
#include <cmath>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/dart/DARTCollide.hpp>
#include <dart/collision/dart/DARTCollisionDetector.hpp>
#include <dart/constraint/ContactConstraint.hpp>
#include <dart/constraint/DantzigBoxedLcpSolver.hpp>
#include <dart/constraint/PgsBoxedLcpSolver.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/SphereShape.hpp>
#include <dart/math/Geometry.hpp>
#include <limits>

#include "drops/core/errors.hpp"

namespace drops::hexapod {

namespace {

using dart::dynamics::Joint;

// GroundContactFilter's margin (contact_solver.cpp): shapes whose bounding sphere stays this far
// above the ground are not tested, m.
constexpr double kHeightMargin = 1e-6;
// DART's detector drops a contact closer than this to an earlier one of the same step, m.
constexpr double kDuplicateTolerance = 3.0e-12;
// ContactConstraint's thresholds (DART 6.12).
constexpr double kRestitutionThreshold = 1e-3;
constexpr double kFrictionThreshold = 1e-3;
constexpr double kBouncingVelocityThreshold = 1e-1;
constexpr double kMaxBouncingVelocity = 1e+2;
constexpr double kTangentEpsilonSquared = 1e-12;
// DART's collideBoxSphere treats a sphere centre closer than this to the box as inside, m.
constexpr double kCollisionEpsilon = 1e-6;
// Initial capacity of the contact buffers (grown, with an allocation, when exceeded).
constexpr int kInitialContacts = 48;
constexpr double kPi = 3.14159265358979323846;

// ContactConstraint::getTangentBasisMatrixODE with the default first friction direction (+z):
// column 0 = the tangent turned a quarter turn about n, column 1 = the tangent.
Eigen::Matrix<double, 3, 2> tangent_basis(const Eigen::Vector3d& n) {
  Eigen::Vector3d tangent = n.cross(Eigen::Vector3d::UnitZ());
  if (tangent.squaredNorm() < kTangentEpsilonSquared) {
    tangent = n.cross(Eigen::Vector3d::UnitX());
    if (tangent.squaredNorm() < kTangentEpsilonSquared) {
      tangent = n.cross(Eigen::Vector3d::UnitY());
      if (tangent.squaredNorm() < kTangentEpsilonSquared)
        tangent = n.cross(Eigen::Vector3d::UnitZ());
    }
  }
  tangent.normalize();
  Eigen::Matrix<double, 3, 2> t;
  t.col(0) = Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * kPi, n)) * tangent;
  t.col(1) = tangent;
  return t;
}

// Cholesky factor L (lower) of a symmetric positive definite 6 x 6 matrix m = L L^T.
Eigen::Matrix6d cholesky6(const Eigen::Matrix6d& m) {
  Eigen::Matrix6d l = Eigen::Matrix6d::Zero();
  for (int j = 0; j < 6; ++j) {
    double d = m(j, j);
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    l(j, j) = std::sqrt(d);
    for (int i = j + 1; i < 6; ++i) {
      double v = m(i, j);
      for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
      l(i, j) = v / l(j, j);
    }
  }
  return l;
}

// y = L^-1 f (forward substitution).
Eigen::Vector6d forward6(const Eigen::Matrix6d& l, const Eigen::Vector6d& f) {
  Eigen::Vector6d y;
  for (int i = 0; i < 6; ++i) {
    double v = f[i];
    for (int k = 0; k < i; ++k) v -= l(i, k) * y[k];
    y[i] = v / l(i, i);
  }
  return y;
}

// x = (L L^T)^-1 f.
Eigen::Vector6d solve6(const Eigen::Matrix6d& l, const Eigen::Vector6d& f) {
  Eigen::Vector6d x = forward6(l, f);
  for (int i = 5; i >= 0; --i) {
    double v = x[i];
    for (int k = i + 1; k < 6; ++k) v -= l(k, i) * x[k];
    x[i] = v / l(i, i);
  }
  return x;
}

// Spatial algebra of DART's conventions (twists and wrenches as [angular; linear] in a body's
// frame), inlined: what dart::math::AdInvT, dAdInvT, ad and dad compute.
// The twist V of a parent frame seen from a child frame at pose t in it: [R^T w; R^T (v + w x p)].
inline Eigen::Vector6d ad_inv_t(const Eigen::Isometry3d& t, const Eigen::Vector6d& v) {
  Eigen::Vector6d out;
  const Eigen::Matrix3d& r = t.linear();
  const Eigen::Vector3d w = v.head<3>();
  const Eigen::Vector3d lin = v.tail<3>() + w.cross(t.translation());
  out.head<3>().noalias() = r.transpose() * w;
  out.tail<3>().noalias() = r.transpose() * lin;
  return out;
}

// The wrench F of a child frame at pose t, expressed in the parent frame: [R n + p x R f; R f].
inline Eigen::Vector6d dad_inv_t(const Eigen::Isometry3d& t, const Eigen::Vector6d& f) {
  Eigen::Vector6d out;
  const Eigen::Matrix3d& r = t.linear();
  out.tail<3>().noalias() = r * f.tail<3>();
  out.head<3>().noalias() = r * f.head<3>();
  out.head<3>() += t.translation().cross(out.tail<3>());
  return out;
}

// ad(V, W) = [w1 x w2; w1 x v2 + v1 x w2]: the velocity-product acceleration.
inline Eigen::Vector6d ad(const Eigen::Vector6d& a, const Eigen::Vector6d& b) {
  Eigen::Vector6d out;
  out.head<3>() = a.head<3>().cross(b.head<3>());
  out.tail<3>() = a.head<3>().cross(b.tail<3>()) + a.tail<3>().cross(b.head<3>());
  return out;
}

// dad(V, F) = ad(V)^T F = [n x w + f x v; f x w]: the dual (force) version.
inline Eigen::Vector6d dad(const Eigen::Vector6d& v, const Eigen::Vector6d& f) {
  Eigen::Vector6d out;
  out.head<3>() = f.head<3>().cross(v.head<3>()) + f.tail<3>().cross(v.tail<3>());
  out.tail<3>() = f.tail<3>().cross(v.head<3>());
  return out;
}

// a * b for rigid transforms, written out (Eigen's Isometry product goes through a generic 4 x 4
// block product): each entry summed in the same order, so the result has the same bits.
inline Eigen::Isometry3d compose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  Eigen::Isometry3d out;
  const Eigen::Matrix3d& ra = a.linear();
  const Eigen::Matrix3d& rb = b.linear();
  const Eigen::Vector3d& tb = b.translation();
  Eigen::Matrix4d& m = out.matrix();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      m(i, j) = ra(i, 0) * rb(0, j) + ra(i, 1) * rb(1, j) + ra(i, 2) * rb(2, j);
    m(i, 3) = (ra(i, 0) * tb[0] + ra(i, 1) * tb[1] + ra(i, 2) * tb[2]) + a.translation()[i];
  }
  m.row(3) << 0, 0, 0, 1;
  return out;
}

// A rigid body's (or a rigidly attached subtree's) spatial inertia about a frame's origin, in that
// frame: mass m, first moment h = m c (c the centre of mass) and rotational inertia about the
// origin; as a 6 x 6 matrix (DART's order: angular, linear) [[rot, s [h]x], [-s [h]x, m 1]] with
// s = +1 or -1 as DART's Inertia::getSpatialTensor has it (found at construction).
struct RigidInertia {
  double m = 0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rot = Eigen::Matrix3d::Zero();

  // Adds `child`, given in a frame whose pose in this frame is t (rotation r, translation p):
  // the parallel-axis theorem, rot += R rot_c R^T + m (|p|^2 1 - p p^T) + 2 (p.Rh) 1
  // - Rh p^T - p Rh^T, h += R h_c + m p. The same as dart::math::transformInertia of the 6 x 6
  // matrices, with a tenth of the arithmetic.
  void add(const RigidInertia& child, const Eigen::Isometry3d& t) {
    const Eigen::Matrix3d r = t.linear();
    const Eigen::Vector3d p = t.translation();
    const Eigen::Vector3d rh = r * child.h;
    const double mc = child.m;
    Eigen::Matrix3d rot_c;
    rot_c.noalias() = r * child.rot * r.transpose();
    const double diag = mc * p.squaredNorm() + 2.0 * p.dot(rh);
    rot_c.diagonal().array() += diag;
    rot_c.noalias() -= mc * p * p.transpose();
    rot_c.noalias() -= rh * p.transpose();
    rot_c.noalias() -= p * rh.transpose();
    rot += rot_c;
    h += rh + mc * p;
    m += mc;
  }

  // The 6 x 6 matrix times x = [w; v]: [rot w + s h x v; -s h x w + m v].
  Eigen::Vector6d apply(double s, const Eigen::Vector6d& x) const {
    Eigen::Vector6d out;
    const Eigen::Vector3d w = x.head<3>(), v = x.tail<3>();
    out.head<3>().noalias() = rot * w;
    out.head<3>() += s * h.cross(v);
    out.tail<3>() = m * v - s * h.cross(w);
    return out;
  }

  // The 6 x 6 matrix (sign s of the off-diagonal blocks: see the struct comment).
  Eigen::Matrix6d matrix(double s) const {
    Eigen::Matrix6d out;
    Eigen::Matrix3d hx;
    hx << 0, -h.z(), h.y(), h.z(), 0, -h.x(), -h.y(), h.x(), 0;
    out.topLeftCorner<3, 3>() = rot;
    out.topRightCorner<3, 3>() = s * hx;
    out.bottomLeftCorner<3, 3>() = -s * hx;
    out.bottomRightCorner<3, 3>() = m * Eigen::Matrix3d::Identity();
    return out;
  }
};

}  // namespace

struct RigidRobotStep::Body {
  int parent = -1;
  std::vector<int> children;
  bool locked = false;
  dart::dynamics::DegreeOfFreedom* dof = nullptr;  // null for the root
  Eigen::Isometry3d parent_to_joint = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  Eigen::Vector6d s = Eigen::Vector6d::Zero();        // joint's relative Jacobian [axis; 0]
  Eigen::Matrix6d inertia = Eigen::Matrix6d::Zero();  // spatial inertia in the body frame
  double q = 0, dq = 0, ddq = 0, command = 0;
  double velocity_lower = 0, velocity_upper = 0;  // GenericJoint::setCommand clips to these
  Eigen::Isometry3d t_rel = Eigen::Isometry3d::Identity(), t = Eigen::Isometry3d::Identity();
  Eigen::Vector6d v = Eigen::Vector6d::Zero(), partial_acc = Eigen::Vector6d::Zero();
  Eigen::Vector6d bias = Eigen::Vector6d::Zero();
  RigidInertia own, subtree;  // the body's, and its kinematic subtree's (BodyNode::mArtInertia)
};

struct RigidRobotStep::Shape {
  int body = 0;
  const dart::dynamics::ShapeNode* node = nullptr;
  Eigen::Isometry3d rel = Eigen::Isometry3d::Identity();
  bool sphere = false;
  double radius = 0;        // sphere
  Eigen::Vector3d size;     // box
  double bound = 0;         // bounding-sphere radius (GroundContactFilter's)
  double mu1 = 1, mu2 = 1;  // combined with the ground's (minimum)
  double restitution = 0;   // combined with the ground's (product)
};

namespace {
// A collision object for DART's box-box routine, which only stores it in the contacts it reports
// (and reads its shape frame when adding them to a result).
class ShapeObject final : public dart::collision::CollisionObject {
 public:
  ShapeObject(dart::collision::CollisionDetector* detector, const dart::dynamics::ShapeFrame* frame)
      : dart::collision::CollisionObject(detector, frame) {}

 protected:
  void updateEngineData() override {}
};
}  // namespace

struct RigidRobotStep::BoxObjects {
  // Owns nothing the objects use; DART asserts that a collision object has a detector.
  std::shared_ptr<dart::collision::DARTCollisionDetector> detector =
      dart::collision::DARTCollisionDetector::create();
  std::unique_ptr<ShapeObject> ground;
  std::vector<std::unique_ptr<ShapeObject>> shapes;
};

RigidRobotStep::RigidRobotStep(const dart::simulation::WorldPtr& world,
                               const dart::dynamics::SkeletonPtr& robot)
    : robot_(robot), box_objects_(std::make_unique<BoxObjects>()) {
  if (!world || !robot) throw InvalidArgument("RigidRobotStep: world and robot must not be null");
  dt_ = world->getTimeStep();
  gravity_ = world->getGravity();
  // The ground: the world's only other skeleton, static, with one box.
  const dart::dynamics::ShapeNode* ground = nullptr;
  int others = 0;
  for (std::size_t i = 0; i < world->getNumSkeletons(); ++i) {
    const auto skel = world->getSkeleton(i);
    if (skel == robot) continue;
    ++others;
    if (skel->isMobile() || skel->getNumShapeNodes() != 1) break;
    ground = skel->getShapeNode(0);
  }
  if (others != 1 || ground == nullptr ||
      ground->getShape()->getType() != dart::dynamics::BoxShape::getStaticType()) {
    throw InvalidArgument(
        "RigidRobotStep: the world must hold the robot and one static ground box");
  }
  ground_tf_ = ground->getWorldTransform();
  ground_size_ = static_cast<const dart::dynamics::BoxShape*>(ground->getShape().get())->getSize();
  ground_top_ = (ground_tf_ * Eigen::Vector3d(0, 0, 0.5 * ground_size_.z())).z();
  const auto* gd = ground->getDynamicsAspect();
  box_objects_->ground = std::make_unique<ShapeObject>(box_objects_->detector.get(), ground);

  // Bodies, in DART's order (a parent before its children).
  const std::size_t n = robot->getNumBodyNodes();
  bodies_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const dart::dynamics::BodyNode* bn = robot->getBodyNode(i);
    Body& b = bodies_[i];
    b.inertia = bn->getInertia().getSpatialTensor();
    // The body's inertia as (m, h, rot), and the sign of the off-diagonal blocks.
    const Eigen::Vector3d h = bn->getInertia().getMass() * bn->getInertia().getLocalCOM();
    b.own.m = bn->getInertia().getMass();
    b.own.h = h;
    b.own.rot = b.inertia.topLeftCorner<3, 3>();
    for (double sign : {1.0, -1.0}) {
      if ((b.own.matrix(sign) - b.inertia).cwiseAbs().maxCoeff() <=
          1e-12 * b.inertia.cwiseAbs().maxCoeff()) {
        inertia_sign_ = sign;
      }
    }
    const Joint* joint = bn->getParentJoint();
    if (i == 0) {
      if (joint->getType() != dart::dynamics::FreeJoint::getStaticType() ||
          !joint->getTransformFromParentBodyNode().isApprox(Eigen::Isometry3d::Identity(), 0) ||
          !joint->getTransformFromChildBodyNode().isApprox(Eigen::Isometry3d::Identity(), 0) ||
          joint->isKinematic()) {
        throw InvalidArgument(
            "RigidRobotStep: the root must be a dynamic FreeJoint with identity offsets");
      }
      continue;
    }
    const auto* rev = dynamic_cast<const dart::dynamics::RevoluteJoint*>(joint);
    if (rev == nullptr ||
        !joint->getTransformFromChildBodyNode().isApprox(Eigen::Isometry3d::Identity(), 0)) {
      throw InvalidArgument("RigidRobotStep: joint '" + joint->getName() +
                            "' must be a RevoluteJoint with an identity child offset");
    }
    const auto type = joint->getActuatorType();
    if (type != Joint::VELOCITY && type != Joint::LOCKED) {
      throw InvalidArgument("RigidRobotStep: joint '" + joint->getName() +
                            "' must be a VELOCITY or LOCKED actuator (kinematic)");
    }
    b.locked = type == Joint::LOCKED;
    b.parent = static_cast<int>(bn->getParentBodyNode()->getIndexInSkeleton());
    bodies_[static_cast<std::size_t>(b.parent)].children.push_back(static_cast<int>(i));
    b.dof = const_cast<dart::dynamics::DegreeOfFreedom*>(joint->getDof(0));
    b.parent_to_joint = joint->getTransformFromParentBodyNode();
    b.axis = rev->getAxis();
    b.velocity_lower = b.dof->getVelocityLowerLimit();
    b.velocity_upper = b.dof->getVelocityUpperLimit();
    b.s.head<3>() = b.axis;
    leg_dofs_.push_back(static_cast<int>(i));
    if (static_cast<int>(b.dof->getIndexInSkeleton()) != 5 + static_cast<int>(leg_dofs_.size()))
      throw InvalidArgument("RigidRobotStep: leg dofs must follow the bodies' order");
  }

  if (inertia_sign_ == 0)
    throw InvalidArgument("RigidRobotStep: unexpected layout of DART's spatial inertia");

  // Collision shapes, in the order DART's collision group holds them (the skeleton's shape
  // nodes); DART's detector tests (ground, shape) pairs in that order.
  for (std::size_t i = 0; i < robot->getNumShapeNodes(); ++i) {
    const dart::dynamics::ShapeNode* node = robot->getShapeNode(i);
    if (node->getCollisionAspect() == nullptr || !node->getShape()) continue;
    Shape s;
    s.node = node;
    s.body = static_cast<int>(node->getBodyNodePtr()->getIndexInSkeleton());
    s.rel = node->getRelativeTransform();
    const auto& type = node->getShape()->getType();
    if (type == dart::dynamics::SphereShape::getStaticType()) {
      s.sphere = true;
      s.radius =
          static_cast<const dart::dynamics::SphereShape*>(node->getShape().get())->getRadius();
    } else if (type == dart::dynamics::BoxShape::getStaticType()) {
      s.size = static_cast<const dart::dynamics::BoxShape*>(node->getShape().get())->getSize();
    } else {
      throw InvalidArgument("RigidRobotStep: shape '" + node->getName() +
                            "' is neither a box nor a sphere");
    }
    const dart::math::BoundingBox& box = node->getShape()->getBoundingBox();
    s.bound = box.getMin().cwiseAbs().cwiseMax(box.getMax().cwiseAbs()).norm();
    const auto* d = node->getDynamicsAspect();
    if (d == nullptr || gd == nullptr)
      throw InvalidArgument("RigidRobotStep: every shape needs a dynamics aspect");
    s.mu1 = std::min(gd->getPrimaryFrictionCoeff(), d->getPrimaryFrictionCoeff());
    s.mu2 = std::min(gd->getSecondaryFrictionCoeff(), d->getSecondaryFrictionCoeff());
    if (!(s.mu1 > kFrictionThreshold || s.mu2 > kFrictionThreshold) ||
        gd->getPrimarySlipCompliance() > 0 || d->getPrimarySlipCompliance() > 0 ||
        gd->getSecondarySlipCompliance() > 0 || d->getSecondarySlipCompliance() > 0 ||
        gd->getFirstFrictionDirection().squaredNorm() >= kTangentEpsilonSquared ||
        d->getFirstFrictionDirection().squaredNorm() >= kTangentEpsilonSquared) {
      throw InvalidArgument("RigidRobotStep: shape '" + node->getName() +
                            "' needs friction, no slip compliance, no friction direction");
    }
    s.restitution = gd->getRestitutionCoeff() * d->getRestitutionCoeff();
    shapes_.push_back(s);
    box_objects_->shapes.push_back(
        std::make_unique<ShapeObject>(box_objects_->detector.get(), node));
  }

  dantzig_ = std::make_shared<dart::constraint::DantzigBoxedLcpSolver>();
  pgs_ = std::make_shared<dart::constraint::PgsBoxedLcpSolver>();
  contacts_.reserve(kInitialContacts);
  load();
}

RigidRobotStep::~RigidRobotStep() = default;

void RigidRobotStep::load() {
  // The FreeJoint's static accessors: no Eigen::VectorXd temporaries.
  const auto* root = static_cast<const dart::dynamics::FreeJoint*>(robot_->getRootJoint());
  root_q_ = root->getPositionsStatic();
  root_v_ = root->getVelocitiesStatic();
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    bodies_[i].q = bodies_[i].dof->getPosition();
    bodies_[i].dq = bodies_[i].dof->getVelocity();
  }
}

void RigidRobotStep::store() const {
  auto* root = static_cast<dart::dynamics::FreeJoint*>(robot_->getRootJoint());
  root->setPositionsStatic(root_q_);
  root->setVelocitiesStatic(root_v_);
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    bodies_[i].dof->setPosition(bodies_[i].q);
    bodies_[i].dof->setVelocity(bodies_[i].dq);
  }
}

double RigidRobotStep::leg_position(int i) const {
  return bodies_[static_cast<std::size_t>(leg_dofs_[static_cast<std::size_t>(i)])].q;
}

// Relative and world transforms (FreeJoint::convertToTransform for the root;
// T_parent_to_joint * expAngular(axis q) for a revolute joint; world = parent world * relative).
void RigidRobotStep::kinematics() {
  Body& root = bodies_[0];
  root.t_rel = dart::dynamics::FreeJoint::convertToTransform(root_q_);
  root.t = root.t_rel;
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    Body& b = bodies_[i];
    b.t_rel = compose(b.parent_to_joint, dart::math::expAngular(b.axis * b.q));
    b.t = compose(bodies_[static_cast<std::size_t>(b.parent)].t, b.t_rel);
  }
}

// Spatial velocities in body frames (BodyNode::updateVelocity): AdInvT(T_rel, V_parent) + S dq.
void RigidRobotStep::velocities() {
  bodies_[0].v = root_v_;
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    Body& b = bodies_[i];
    b.v = ad_inv_t(b.t_rel, bodies_[static_cast<std::size_t>(b.parent)].v) + b.s * b.dq;
  }
}

// Skeleton::computeForwardDynamics for a skeleton whose joints but the root are kinematic.
void RigidRobotStep::forward_dynamics() {
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    Body& b = bodies_[i];
    b.partial_acc = ad(b.v, b.s * b.dq);
  }
  bodies_[0].partial_acc.setZero();
  for (std::size_t k = bodies_.size(); k-- > 0;) {
    Body& b = bodies_[k];
    // BodyNode::updateArtInertia: the child's inertia added through its kinematic joint.
    b.subtree = b.own;
    for (int c : b.children) {
      const Body& ch = bodies_[static_cast<std::size_t>(c)];
      b.subtree.add(ch.subtree, ch.t_rel);
    }
    // BodyNode::updateBiasForce: the Coriolis and centrifugal terms, then the children's bias
    // forces with their joints' prescribed accelerations. Gravity, uniform, is added once at the
    // root for the whole rigid robot below (DART adds each body's and carries it up: the same
    // sum).
    b.bias = -dad(b.v, b.own.apply(inertia_sign_, b.v));
    for (int c : b.children) {
      const Body& ch = bodies_[static_cast<std::size_t>(c)];
      const Eigen::Vector6d beta =
          ch.bias + ch.subtree.apply(inertia_sign_, ch.partial_acc + ch.s * ch.ddq);
      b.bias += dad_inv_t(ch.t_rel, beta);
    }
    // Joint::updateTotalForce of a kinematic joint: the VELOCITY actuator's acceleration reaches
    // the command in one step; a LOCKED joint stops.
    if (k > 0) {
      if (b.locked) {
        b.dq = 0.0;
        b.ddq = 0.0;
      } else {
        b.ddq = (b.command - b.dq) / dt_;
      }
    }
  }
  // The root (a dynamic FreeJoint with identity Jacobian): a = AI^-1 (0 - bias), with AI's
  // Cholesky factor (DART inverts AI; the same to round-off).
  Body& root = bodies_[0];
  Eigen::Vector6d gravity;  // [0; R^T g] (AdInvRLinear): gravity's acceleration in the root frame
  gravity.head<3>().setZero();
  gravity.tail<3>().noalias() = root.t.linear().transpose() * gravity_;
  root.bias -= root.subtree.apply(inertia_sign_, gravity);
  root_factor_ = cholesky6(root.subtree.matrix(inertia_sign_));
  const Eigen::Vector6d total_force = -root.bias;
  root_a_ = solve6(root_factor_, total_force);
}

int RigidRobotStep::collide() {
  contacts_.clear();
  auto add = [&](int body, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                 double depth, const Shape& s) {
    for (const Contact& c : contacts_)
      if ((c.point - point).norm() < kDuplicateTolerance) return;
    Contact c;
    c.body = body;
    c.point = point;
    c.normal = normal;
    c.depth = depth;
    c.mu1 = s.mu1;
    c.mu2 = s.mu2;
    c.restitution = s.restitution;
    c.bounce = s.restitution > kRestitutionThreshold;
    contacts_.push_back(c);
  };
  const Eigen::Vector3d half_ground = 0.5 * ground_size_;
  for (std::size_t k = 0; k < shapes_.size(); ++k) {
    const Shape& s = shapes_[k];
    // The shape's height first (the same sum as its transform's), the whole transform if low.
    const Eigen::Isometry3d& body_tf = bodies_[static_cast<std::size_t>(s.body)].t;
    const Eigen::Vector3d& r = s.rel.translation();
    const double z = (body_tf.linear()(2, 0) * r[0] + body_tf.linear()(2, 1) * r[1] +
                      body_tf.linear()(2, 2) * r[2]) +
                     body_tf.translation()[2];
    if (z - s.bound > ground_top_ + kHeightMargin) continue;
    const Eigen::Isometry3d tf = compose(body_tf, s.rel);
    if (s.sphere) {
      // DART's collideBoxSphere(ground, sphere): the sphere centre clipped to the box.
      const Eigen::Vector3d c0 = tf.translation();
      Eigen::Vector3d p = ground_tf_.inverse() * c0;
      bool inside = true;
      for (int a = 0; a < 3; ++a) {
        if (p[a] < -half_ground[a]) {
          p[a] = -half_ground[a];
          inside = false;
        }
        if (p[a] > half_ground[a]) {
          p[a] = half_ground[a];
          inside = false;
        }
      }
      auto nearest_face = [&](double* depth) {
        double min = half_ground[0] - std::abs(p[0]);
        int idx = 0;
        double tmin = half_ground[1] - std::abs(p[1]);
        if (tmin < min) {
          min = tmin;
          idx = 1;
        }
        tmin = half_ground[2] - std::abs(p[2]);
        if (tmin < min) {
          min = tmin;
          idx = 2;
        }
        Eigen::Vector3d normal = Eigen::Vector3d::Zero();
        normal[idx] = p[idx] > 0.0 ? -1.0 : 1.0;
        *depth = min;
        return Eigen::Vector3d(ground_tf_.linear() * normal);
      };
      if (inside) {
        double min = 0;
        const Eigen::Vector3d normal = nearest_face(&min);
        add(s.body, c0, normal, min + s.radius, s);
        continue;
      }
      const Eigen::Vector3d contact_point = ground_tf_ * p;
      Eigen::Vector3d normal = contact_point - c0;
      const double mag = normal.norm();
      const double penetration = s.radius - mag;
      if (penetration < 0.0) continue;
      if (mag > kCollisionEpsilon) {
        normal *= 1.0 / mag;
      } else {
        double unused = 0;
        normal = nearest_face(&unused);
      }
      add(s.body, contact_point, normal, penetration, s);
    } else {
      // DART's own box-box routine (ODE's dBoxBox), called directly.
      box_result_.clear();
      dart::collision::collideBoxBox(box_objects_->ground.get(), box_objects_->shapes[k].get(),
                                     ground_size_, ground_tf_, s.size, tf, box_result_);
      for (std::size_t c = 0; c < box_result_.getNumContacts(); ++c) {
        const dart::collision::Contact& ct = box_result_.getContact(c);
        add(s.body, ct.point, ct.normal, ct.penetrationDepth, s);
      }
    }
  }
  return static_cast<int>(contacts_.size());
}

// ContactConstraint rows, BoxedLcpConstraintSolver's LCP, ContactConstraint::applyImpulse and
// Skeleton::computeImpulseForwardDynamics for the rigid robot.
void RigidRobotStep::solve_contacts(int count) {
  const int n = 3 * count;
  const int skip = dPAD(n);
  if (g_.rows() < n) {
    const int cap = std::max(n, 3 * kInitialContacts);
    g_.resize(cap, 6);
    w_.resize(cap, 6);
    const int cap_skip = dPAD(cap);
    a_.resize(static_cast<Eigen::Index>(cap) * cap_skip);
    a0_.resize(a_.size());
    for (Eigen::VectorXd* v : {&x_, &b_, &lo_, &hi_, &x0_, &b0_, &lo0_, &hi0_}) v->resize(cap);
    findex_.resize(cap);
    findex0_.resize(cap);
  }
  const double inv_dt = 1.0 / dt_;
  const double erp = dart::constraint::ContactConstraint::getErrorReductionParameter();
  const double allowance = dart::constraint::ContactConstraint::getErrorAllowance();
  const double max_erv = dart::constraint::ContactConstraint::getMaxErrorReductionVelocity();
  const double cfm = dart::constraint::ContactConstraint::getConstraintForceMixing();
  const Body& root = bodies_[0];
  for (int c = 0; c < count; ++c) {
    const Contact& ct = contacts_[static_cast<std::size_t>(c)];
    const Body& body = bodies_[static_cast<std::size_t>(ct.body)];
    const Eigen::Matrix<double, 3, 2> d = tangent_basis(ct.normal);
    // The robot body's rows (DART's body B; the ground, body A, is not reactive): J in the
    // body's frame for the rows' velocities, and G, the same unit forces at the contact point in
    // the root's frame (what DART's bias-impulse recursion carries to the root).
    const Eigen::Vector3d point = body.t.inverse() * ct.point;
    const Eigen::Vector3d root_point = root.t.inverse() * ct.point;
    const Eigen::Vector3d dirs[3] = {-ct.normal, -d.col(0), -d.col(1)};
    for (int r = 0; r < 3; ++r) {
      Eigen::Vector3d dir;
      dir.noalias() = body.t.linear().transpose() * dirs[r];
      Eigen::Vector6d jr;
      jr.head<3>() = point.cross(dir);
      jr.tail<3>() = dir;
      b_[3 * c + r] = 0.0 - jr.dot(body.v);
      Eigen::Vector3d root_dir;
      root_dir.noalias() = root.t.linear().transpose() * dirs[r];
      Eigen::Vector6d gr;
      gr.head<3>() = root_point.cross(root_dir);
      gr.tail<3>() = root_dir;
      g_.row(3 * c + r) = gr.transpose();
      // W = G L^-T, so that A = G M^-1 G^T = W W^T.
      w_.row(3 * c + r) = forward6(root_factor_, gr).transpose();
      x_[3 * c + r] = 0.0;
    }
    lo_[3 * c] = 0.0;
    hi_[3 * c] = std::numeric_limits<double>::infinity();
    findex_[3 * c] = -1;
    lo_[3 * c + 1] = -ct.mu1;
    hi_[3 * c + 1] = ct.mu1;
    findex_[3 * c + 1] = 3 * c;
    lo_[3 * c + 2] = -ct.mu2;
    hi_[3 * c + 2] = ct.mu2;
    findex_[3 * c + 2] = 3 * c;
    // Error reduction (penetration) and restitution velocity on the normal row.
    double bounce = ct.depth - allowance;
    if (bounce < 0.0) {
      bounce = 0.0;
    } else {
      bounce *= erp * inv_dt;
      if (bounce > max_erv) bounce = max_erv;
    }
    if (ct.bounce) {
      const double restitution_velocity = b_[3 * c] * ct.restitution;
      if (restitution_velocity > kBouncingVelocityThreshold && restitution_velocity > bounce)
        bounce = std::min(restitution_velocity, kMaxBouncingVelocity);
    }
    b_[3 * c] += bounce;
  }
  // A = G M^-1 G^T = W W^T (row-major, row stride `skip`), DART's constraint force mixing on the
  // diagonal.
  double* a = a_.data();
  for (int i = 0; i < n; ++i) {
    for (int j = i; j < n; ++j) {
      const double v = w_.row(i).dot(w_.row(j));
      a[i * skip + j] = v;
      a[j * skip + i] = v;
    }
    a[i * skip + i] += a[i * skip + i] * cfm;
  }
  // The LCP as BoxedLcpConstraintSolver solves it: Dantzig (stopping early, as a fallback
  // exists), then PGS on the saved terms if Dantzig fails or gives NaN, zero if NaN remains.
  std::copy(a, a + static_cast<std::ptrdiff_t>(n) * skip, a0_.data());
  x0_.head(n) = x_.head(n);
  b0_.head(n) = b_.head(n);
  lo0_.head(n) = lo_.head(n);
  hi0_.head(n) = hi_.head(n);
  findex0_.head(n) = findex_.head(n);
  bool success =
      dantzig_->solve(n, a, x_.data(), b_.data(), 0, lo_.data(), hi_.data(), findex_.data(), true);
  if (success && x_.head(n).hasNaN()) success = false;
  if (!success) {
    ++counts_.lcp_fallbacks;
    pgs_->solve(n, a0_.data(), x0_.data(), b0_.data(), 0, lo0_.data(), hi0_.data(), findex0_.data(),
                false);
    x_.head(n) = x0_.head(n);
  }
  if (x_.head(n).hasNaN()) {
    ++counts_.lcp_failures;
    x_.head(n).setZero();
  }
  // The impulses (ContactConstraint::applyImpulse: normal, then the two frictions) as one
  // impulse on the root, G^T x, and the root's velocity change M^-1 G^T x (DART carries each
  // body's impulse to the root through its bias-impulse recursion: the same sum).
  Eigen::Vector6d impulse = Eigen::Vector6d::Zero();
  for (int r = 0; r < n; ++r) impulse += g_.row(r).transpose() * x_[r];
  root_v_ += solve6(root_factor_, impulse);
}

// Skeleton::integratePositions: q += dq dt; the FreeJoint's Q <- Q * convertToTransform(v dt).
void RigidRobotStep::integrate_positions() {
  const Eigen::Isometry3d diff = dart::dynamics::FreeJoint::convertToTransform(root_v_ * dt_);
  const Eigen::Isometry3d next = bodies_[0].t_rel * diff;
  root_v_ = dart::math::AdR(diff.inverse(), root_v_);
  root_q_ = dart::dynamics::FreeJoint::convertToPositions(next);
  for (std::size_t i = 1; i < bodies_.size(); ++i) bodies_[i].q += bodies_[i].dq * dt_;
}

void RigidRobotStep::current_contacts(std::vector<Eigen::Isometry3d>* transforms,
                                      std::vector<Contact>* contacts) {
  kinematics();
  collide();
  transforms->clear();
  for (const Body& b : bodies_) transforms->push_back(b.t);
  *contacts = contacts_;
}

void RigidRobotStep::step(const double* commands) {
  // GenericJoint::setCommand of a VELOCITY actuator clips the command to the velocity limits.
  for (std::size_t i = 0; i < leg_dofs_.size(); ++i) {
    Body& b = bodies_[static_cast<std::size_t>(leg_dofs_[i])];
    b.command = std::max(b.velocity_lower, std::min(commands[i], b.velocity_upper));
  }
  kinematics();
  velocities();
  forward_dynamics();
  // Skeleton::integrateVelocities.
  {
    // FreeJoint::integrateVelocities (DART 6.12): the body-frame spatial acceleration plus
    // w x v on the linear part, i.e. the origin's classical acceleration in the body frame.
    const Eigen::Vector3d coriolis = root_v_.head<3>().cross(root_v_.tail<3>());
    root_v_ = root_v_ + root_a_ * dt_;
    root_v_.tail<3>() += coriolis * dt_;
  }
  for (std::size_t i = 1; i < bodies_.size(); ++i)
    bodies_[i].dq = bodies_[i].dq + bodies_[i].ddq * dt_;
  velocities();
  const int count = collide();
  counts_.contacts += count;
  if (count > 0) solve_contacts(count);
  integrate_positions();
  ++counts_.steps;
}

}  // namespace drops::hexapod
