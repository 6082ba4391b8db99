#pragma once
/// \file Two DART pieces that make a hexapod physics step cheaper without changing what it
/// computes (issue 14; docs/benchmarks.md, "Hexapod model rollouts"):
///
/// - GroundContactFilter: the collision filter of a world whose only collisions are between one
///   static ground box (top face z = ground_top) and the shapes of robots without self-collision.
///   It lets through only pairs (ground, robot shape) whose robot shape's bounding sphere reaches
///   the plane z = ground_top + 1e-6 m: the pairs DART's default BodyNodeCollisionFilter lets
///   through in that world (never two robot shapes, since self-collision is off) minus those that
///   cannot touch (DART's sphere-box and box-box tests report nothing for a shape entirely above
///   the box). That costs two pointer comparisons and a height test per pair instead of DART's
///   look-ups, and skips the box-box tests of the raised links (together a sixth of a prior
///   step). The contacts, and their order, are unchanged: bit-identical steps.
///
/// - RigidRobotContactSolver: DART's boxed-LCP constraint solver (Dantzig, PGS fallback) with a
///   cheaper construction of the LCP matrix A when the constrained skeleton moves as one rigid
///   body during the impulse solve, which is the case when every joint but its root free joint is
///   kinematic (the prior's VELOCITY actuators and LOCKED joints: DART prescribes their
///   velocities, and impulses change only the root's 6-D velocity). DART builds A one row at a
///   time: a unit impulse on the row, a velocity-change pass over the whole skeleton, the velocity
///   change read at every row (rows x bodies work). With a rigid skeleton A = G M^-1 G^T, where G
///   (rows x 6) maps the root's body velocity to the rows' velocities and M is the root's
///   articulated (here composite) inertia; the solver measures V = G M^-1 with six unit impulses on
///   the root (six passes whatever the number of contacts) and forms A = V M V^T. Everything
///   else (the rows' right-hand sides, bounds, friction indices and constraint force mixing from
///   the constraints themselves, the LCP solvers and their fallback, the impulses applied) is
///   DART's. A equals DART's up to round-off (the same products in another order), so
///   trajectories agree to round-off amplified by the contact dynamics;
///   test_hexapod_prior_reference measures it. Any other group (a constraint that is not a contact,
///   a dynamic joint, e.g. the "real" robot's servos) is solved by DART's own algorithm.
///
/// Includes DART: for the drops_hexapod target's sources only (see robot_dart.hpp).

#include <dart/collision/CollisionFilter.hpp>
#include <dart/constraint/BoxedLcpConstraintSolver.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <utility>
#include <vector>

namespace drops::hexapod {

/// Lets through the pairs (ground, robot shape) that can touch; see the file comment. Valid for a
/// world in which every shape but the ground belongs to robots without self-collision checks and
/// the ground is a box whose top face is the plane z = ground_top. Thread-safety: const,
/// stateless after construction.
class GroundContactFilter final : public dart::collision::CollisionFilter {
 public:
  /// ground: the ground's collision shape frame (not null); robot: the skeleton whose collision
  /// shapes are tested against it (their bounding spheres are taken from their shapes now: shapes
  /// must not be resized later); ground_top: world z of the ground's top face, m. Both must
  /// outlive the filter's use. A shape of another skeleton is always tested (no height test).
  GroundContactFilter(const dart::dynamics::ShapeFrame* ground,
                      const dart::dynamics::Skeleton& robot, double ground_top);
  /// True (skip the pair) unless exactly one of the two is the ground and the other's bounding
  /// sphere reaches z = ground_top + 1e-6 m in its current pose (any height for a shape not of
  /// `robot`). Called by DART's detector for every pair of its collision group.
  bool ignoresCollision(const dart::collision::CollisionObject* object1,
                        const dart::collision::CollisionObject* object2) const override;

 private:
  const dart::dynamics::ShapeFrame* ground_;
  double ground_top_;
  // Robot collision shape frames and their bounding-sphere radii (m), sorted by pointer.
  std::vector<std::pair<const dart::dynamics::ShapeFrame*, double>> radii_;
};

/// DART's BoxedLcpConstraintSolver (Dantzig, PGS fallback) with the LCP matrix of a rigid robot
/// built from six root impulses; see the file comment. Assumes the contacts have no slip
/// compliance (DART's default; the hexapod's shapes set none): DART adds it to the friction rows'
/// diagonal, this path does not. Valid for a world with one mobile skeleton (checked at every
/// solve; otherwise DART's algorithm). Install with World::setConstraintSolver before setting the
/// collision detector (make_world does). Not thread-safe (one per world).
class RigidRobotContactSolver final : public dart::constraint::BoxedLcpConstraintSolver {
 public:
  /// Number of constrained groups solved by the rigid-robot path since construction (for tests).
  long rigid_groups() const { return rigid_groups_; }
  /// Number of constrained groups solved by DART's own algorithm since construction.
  long generic_groups() const { return generic_groups_; }
  /// false: every group goes through DART's own algorithm (tests compare the two paths).
  void set_rigid_enabled(bool enabled) { rigid_enabled_ = enabled; }

 protected:
  /// Builds and solves the LCP of `group` and applies its impulses, as DART's does (see the class).
  void solveConstrainedGroup(dart::constraint::ConstrainedGroup& group) override;

 private:
  // True when every constraint of `group` is a ContactConstraint and every joint of the single
  // skeleton they constrain, except its root FreeJoint, is kinematic; sets *skeleton.
  bool rigid(dart::constraint::ConstrainedGroup& group, dart::dynamics::Skeleton** skeleton) const;
  Eigen::MatrixXd v_;   // rows x 6: velocity change of each row per unit root impulse
  Eigen::MatrixXd vm_;  // rows x 6: V M
  Eigen::MatrixXd a_;   // rows x rows: V M V^T
  bool rigid_enabled_ = true;
  long rigid_groups_ = 0;
  long generic_groups_ = 0;
};

}  // namespace drops::hexapod
