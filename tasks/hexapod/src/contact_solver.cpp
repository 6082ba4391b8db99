// GroundContactFilter and RigidRobotContactSolver (contact_solver.hpp). DART translation unit:
// no -march=native.

#include "contact_solver.hpp"

#include <dart/external/odelcpsolver/common.h>

#include <algorithm>
#include <cmath>
#include <dart/collision/CollisionObject.hpp>
#include <dart/constraint/BoxedLcpSolver.hpp>
#include <dart/constraint/ConstrainedGroup.hpp>
#include <dart/constraint/ContactConstraint.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/Joint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/math/Geometry.hpp>

namespace drops::hexapod {

namespace {
// Shapes whose bounding sphere stays this far above the ground are not tested, m.
constexpr double kHeightMargin = 1e-6;
}  // namespace

GroundContactFilter::GroundContactFilter(const dart::dynamics::ShapeFrame* ground,
                                         const dart::dynamics::Skeleton& robot, double ground_top)
    : ground_(ground), ground_top_(ground_top) {
  for (std::size_t i = 0; i < robot.getNumShapeNodes(); ++i) {
    const dart::dynamics::ShapeNode* node = robot.getShapeNode(i);
    if (node->getCollisionAspect() == nullptr || !node->getShape()) continue;
    const dart::math::BoundingBox& box = node->getShape()->getBoundingBox();
    const Eigen::Vector3d far = box.getMin().cwiseAbs().cwiseMax(box.getMax().cwiseAbs());
    radii_.emplace_back(node, far.norm());
  }
  std::sort(radii_.begin(), radii_.end());
}

bool GroundContactFilter::ignoresCollision(const dart::collision::CollisionObject* object1,
                                           const dart::collision::CollisionObject* object2) const {
  const dart::dynamics::ShapeFrame* f1 = object1->getShapeFrame();
  const dart::dynamics::ShapeFrame* f2 = object2->getShapeFrame();
  if ((f1 == ground_) == (f2 == ground_)) return true;  // exactly one must be the ground
  const dart::dynamics::ShapeFrame* other = f1 == ground_ ? f2 : f1;
  const auto it = std::lower_bound(radii_.begin(), radii_.end(), other,
                                   [](const std::pair<const dart::dynamics::ShapeFrame*, double>& e,
                                      const dart::dynamics::ShapeFrame* f) { return e.first < f; });
  if (it == radii_.end() || it->first != other) return false;
  return other->getWorldTransform().translation().z() - it->second > ground_top_ + kHeightMargin;
}

bool RigidRobotContactSolver::rigid(dart::constraint::ConstrainedGroup& group,
                                    dart::dynamics::Skeleton** skeleton) const {
  int mobile = 0;
  for (const auto& s : mSkeletons) mobile += s->isMobile() ? 1 : 0;
  if (mobile != 1) return false;  // two robots could be united in one group
  const std::string* contact_type = &dart::constraint::ContactConstraint::getStaticType();
  dart::dynamics::SkeletonPtr skel;
  for (std::size_t i = 0; i < group.getNumConstraints(); ++i) {
    const dart::constraint::ConstraintBasePtr& c = group.getConstraint(i);
    if (&c->getType() != contact_type) return false;
    dart::dynamics::SkeletonPtr root = c->getRootSkeleton();
    if (i == 0) {
      skel = std::move(root);
    } else if (root != skel) {
      return false;
    }
  }
  if (!skel || skel->getNumTrees() != 1 || skel->getNumJoints() < 1) return false;
  const dart::dynamics::Joint* root_joint = skel->getJoint(0);
  if (root_joint->getNumDofs() != 6 || root_joint->isKinematic() ||
      skel->getRootBodyNode() == nullptr) {
    return false;
  }
  for (std::size_t j = 1; j < skel->getNumJoints(); ++j)
    if (!skel->getJoint(j)->isKinematic()) return false;
  *skeleton = skel.get();
  return true;
}

void RigidRobotContactSolver::solveConstrainedGroup(dart::constraint::ConstrainedGroup& group) {
  const std::size_t count = group.getNumConstraints();
  const std::size_t n = group.getTotalDimension();
  if (n == 0) return;
  dart::dynamics::Skeleton* skel = nullptr;
  // Below 6 rows DART's row-by-row construction needs fewer passes than the 6 root impulses.
  if (!rigid_enabled_ || n < 6 || !rigid(group, &skel)) {
    ++generic_groups_;
    BoxedLcpConstraintSolver::solveConstrainedGroup(group);
    return;
  }
  ++rigid_groups_;
  const Eigen::Index rows = static_cast<Eigen::Index>(n);
  const int skip = dPAD(static_cast<int>(n));
  mA.resize(rows, skip);
  mX.resize(rows);
  mB.resize(rows);
  mW.setZero(rows);
  mLo.resize(rows);
  mHi.resize(rows);
  mFIndex.setConstant(rows, -1);
  mOffset.resize(static_cast<Eigen::Index>(count));
  mOffset[0] = 0;
  for (std::size_t i = 1; i < count; ++i)
    mOffset[i] = mOffset[i - 1] + static_cast<int>(group.getConstraint(i - 1)->getDimension());

  // Right-hand sides, bounds and friction indices, from each constraint as DART gets them.
  dart::constraint::ConstraintInfo info;
  info.invTimeStep = 1.0 / mTimeStep;
  for (std::size_t i = 0; i < count; ++i) {
    const dart::constraint::ConstraintBasePtr& c = group.getConstraint(i);
    const int o = mOffset[i];
    info.x = mX.data() + o;
    info.lo = mLo.data() + o;
    info.hi = mHi.data() + o;
    info.b = mB.data() + o;
    info.findex = mFIndex.data() + o;
    info.w = mW.data() + o;
    c->getInformation(&info);
    for (std::size_t j = 0; j < c->getDimension(); ++j)
      if (mFIndex[o + static_cast<Eigen::Index>(j)] >= 0)
        mFIndex[o + static_cast<Eigen::Index>(j)] += o;
  }

  // V = G M^-1: the rows' velocity changes for a unit impulse on each axis of the root body.
  dart::dynamics::BodyNode* root = skel->getRootBodyNode();
  v_.resize(rows, 6);
  skel->setImpulseApplied(true);
  for (int k = 0; k < 6; ++k) {
    Eigen::Vector6d e = Eigen::Vector6d::Zero();
    e[k] = 1.0;
    skel->clearConstraintImpulses();
    skel->updateBiasImpulse(root, e);
    skel->updateVelocityChange();
    double* col = v_.col(k).data();
    for (std::size_t i = 0; i < count; ++i)
      group.getConstraint(i)->getVelocityChange(col + mOffset[i], false);
  }
  skel->clearConstraintImpulses();
  skel->setImpulseApplied(false);

  // A = V M V^T (G M^-1 G^T), with DART's constraint force mixing on the diagonal.
  const Eigen::Matrix6d& m = root->getArticulatedInertia();
  // Coefficient-based products (no BLAS call for these small sizes; the same on every CPU).
  vm_.noalias() = v_.lazyProduct(m);
  a_.resize(rows, rows);
  a_.triangularView<Eigen::Upper>() = vm_.lazyProduct(v_.transpose());
  const double cfm = dart::constraint::ContactConstraint::getConstraintForceMixing();
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (Eigen::Index j = 0; j < i; ++j) mA(i, j) = mA(j, i) = a_(j, i);  // exactly symmetric
    mA(i, i) = a_(i, i) + a_(i, i) * cfm;
  }

  // The LCP, as BoxedLcpConstraintSolver solves it: the primary solver (stopping early when a
  // secondary exists), the secondary on the saved terms when the primary fails or gives NaN,
  // and zero impulses if the result still has NaN (DART also logs that case; a library does not).
  if (mSecondaryBoxedLcpSolver) {
    mABackup = mA;
    mXBackup = mX;
    mBBackup = mB;
    mLoBackup = mLo;
    mHiBackup = mHi;
    mFIndexBackup = mFIndex;
  }
  const bool early = mSecondaryBoxedLcpSolver != nullptr;
  bool success = mBoxedLcpSolver->solve(static_cast<int>(n), mA.data(), mX.data(), mB.data(), 0,
                                        mLo.data(), mHi.data(), mFIndex.data(), early);
  if (success && mX.hasNaN()) success = false;
  if (!success && mSecondaryBoxedLcpSolver) {
    mSecondaryBoxedLcpSolver->solve(static_cast<int>(n), mABackup.data(), mXBackup.data(),
                                    mBBackup.data(), 0, mLoBackup.data(), mHiBackup.data(),
                                    mFIndexBackup.data(), false);
    mX = mXBackup;
  }
  if (mX.hasNaN()) mX.setZero();

  for (std::size_t i = 0; i < count; ++i) {
    const dart::constraint::ConstraintBasePtr& c = group.getConstraint(i);
    c->applyImpulse(mX.data() + mOffset[i]);
    c->excite();
  }
}

}  // namespace drops::hexapod
