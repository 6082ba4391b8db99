#pragma once
/// \file RigidRobotStep: one DART 6.12 world step of the hexapod prior's world (the robot and the
/// ground box of make_world) computed without DART's generic per-step machinery (issue 14;
/// docs/benchmarks.md, "A dedicated rigid-body step").
///
/// In the prior every leg joint is kinematic (a VELOCITY actuator, or LOCKED), so the robot moves
/// as one rigid body whose shape changes with prescribed joint motion. A step then is what
/// dart::simulation::World::step computes for that world, in DART's order:
///  1. forward dynamics: the 19 bodies' transforms and spatial velocities from the root pose and
///     the joint angles and velocities; the articulated (here composite) inertia of the root and
///     its bias force (Coriolis and centrifugal terms, gravity, and the joint accelerations a
///     VELOCITY actuator imposes, ddq = (command - dq) / dt, so that dq reaches the command in
///     one step; zero for a LOCKED joint), each level as DART's articulated-body recursion does
///     it (the same dart::math routines); the root's acceleration from them (through a Cholesky
///     factor of the composite inertia, where DART inverts it);
///  2. velocity integration: dq += ddq dt for every joint; for the root FreeJoint DART 6.12 adds
///     w x v dt to the linear part as well (v_lin += (a_lin + w x v_lin) dt: the origin's
///     classical acceleration in the body frame, measured against DART);
///  3. contacts of the robot's collision shapes with the ground box, as DART's own detector
///     reports them (sphere-box: one contact; box-box: DART's routine, called directly), the
///     contact constraints' rows (normal and two friction directions, Coulomb bounds through
///     friction indices, the error-reduction velocity, constraint force mixing) and the boxed
///     LCP A x = b + w with A = G M^-1 G^T (G: the rows' Jacobians mapped to the root, M: the
///     root's composite inertia), solved by DART's Dantzig solver with its PGS fallback;
///  4. the contact impulses' velocity change of the root (the only dynamic joint);
///  5. position integration: q += dq dt for the joints; for the root DART's FreeJoint update
///     Q <- Q * D with D = convertToTransform(v dt), after which the body-frame velocity is
///     rotated into the new frame, v <- AdR(D^-1, v) (so the world-frame velocity is kept).
/// The joint trajectories are therefore DART's to the bit; the body's state agrees with DART's
/// up to round-off (A, the inertia's factor and the impulse's sum in another order; the bodies'
/// transforms and the contacts are DART's to the bit), which the contact dynamics
/// amplify over many steps (test_hexapod_rigid_step measures both). Nothing is copied from DART:
/// its semantics were taken from its headers (GenericJoint's template code is in them) and from
/// reading its public sources (ContactConstraint, the sphere-box test), written here for this
/// world only, and checked step by step against a DART world (where a source read did not match
/// DART 6.12's behaviour, e.g. the FreeJoint's integration, the measurement decided).
///
/// Includes DART: for the drops_hexapod target's sources only (see robot_dart.hpp).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <dart/collision/CollisionResult.hpp>
#include <dart/constraint/BoxedLcpSolver.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/simulation/World.hpp>
#include <memory>
#include <vector>

#include "drops/hexapod/robot.hpp"

namespace drops::hexapod {

/// Counters of RigidRobotStep since construction (for tests and diagnostics).
struct RigidStepCounts {
  long steps = 0;          ///< world steps taken
  long contacts = 0;       ///< contacts found, summed over steps
  long lcp_fallbacks = 0;  ///< LCPs the Dantzig solver failed and PGS solved
  long lcp_failures = 0;   ///< LCPs left with NaN after both solvers (impulses set to zero)
};

/// The dedicated step of a world built by make_world(robot, ...) whose robot joints are all
/// kinematic except the root FreeJoint; see the file comment. It reads the skeleton's structure,
/// inertias, shapes and friction coefficients once at construction and keeps its own copy of
/// the state: load() copies the skeleton's state in, store() writes it back. The world itself
/// is not stepped (its time is not advanced). Not thread-safe: one per world; no heap
/// allocation in step() except inside DART's box-box routine when a box touches the ground.
class RigidRobotStep {
 public:
  /// world: a world of make_world; robot: the robot skeleton in it. Throws InvalidArgument when
  /// a leg joint is not kinematic (VELOCITY or LOCKED), the root is not a FreeJoint with identity
  /// offsets, a shape is neither a box nor a sphere, or the world has not exactly one other
  /// skeleton (the static ground) with one box shape.
  RigidRobotStep(const dart::simulation::WorldPtr& world, const dart::dynamics::SkeletonPtr& robot);
  ~RigidRobotStep();
  RigidRobotStep(const RigidRobotStep&) = delete;
  RigidRobotStep& operator=(const RigidRobotStep&) = delete;

  /// Copies the robot's positions and velocities from the DART skeleton.
  void load();
  /// Writes the positions and velocities back into the DART skeleton.
  void store() const;
  /// One world step of the world's time step. commands: velocity command (rad/s) of each
  /// skeleton degree of freedom of a leg joint, in DART's dof order without the root's six
  /// (dim skeleton dofs - 6), clipped to the joint's velocity limits as DART's setCommand does;
  /// ignored for LOCKED joints.
  void step(const double* commands);
  /// Number of leg degrees of freedom (skeleton dofs - 6).
  int num_leg_dofs() const { return static_cast<int>(leg_dofs_.size()); }
  /// Position (rad) of leg dof i (0-based, DART's order without the root's six).
  double leg_position(int i) const;
  /// Counters since construction.
  const RigidStepCounts& counts() const { return counts_; }

  /// A contact of the robot with the ground, as DART's detector reports it (for tests).
  struct Contact {
    int body;                ///< index of the robot's body in the skeleton
    Eigen::Vector3d point;   ///< world frame, m
    Eigen::Vector3d normal;  ///< world frame, unit, from the robot's shape into the ground
    double depth;            ///< penetration depth, m
    double mu1, mu2;         ///< combined friction coefficients
    double restitution;      ///< combined restitution coefficient
    bool bounce;             ///< restitution above DART's threshold
  };
  /// For tests: the bodies' world transforms (dim bodies, DART's order) and the contacts of the
  /// current state, computed by the same code as step() (the state is not advanced).
  void current_contacts(std::vector<Eigen::Isometry3d>* transforms, std::vector<Contact>* contacts);

 private:
  struct Body;
  struct Shape;
  void kinematics();
  void velocities();
  void forward_dynamics();
  int collide();
  void solve_contacts(int contacts);
  void integrate_positions();

  dart::dynamics::SkeletonPtr robot_;
  double dt_ = 0.01;
  double inertia_sign_ = 0;  // sign of DART's spatial inertia's off-diagonal blocks (+-1)
  Eigen::Vector3d gravity_;
  std::vector<Body> bodies_;
  std::vector<Shape> shapes_;
  std::vector<int> leg_dofs_;  // body index of each leg dof
  Eigen::Vector6d root_q_;     // FreeJoint positions (rotation vector, translation)
  Eigen::Vector6d root_v_;     // FreeJoint velocities (body frame: angular, linear)
  Eigen::Vector6d root_a_;
  Eigen::Matrix6d root_factor_;  // Cholesky factor L of the root's composite inertia
  // Ground box.
  Eigen::Isometry3d ground_tf_;
  Eigen::Vector3d ground_size_;
  double ground_top_ = 0.0;
  double ground_friction_ = 1.0;
  double ground_restitution_ = 0.0;
  // Contacts of the current step and the LCP's buffers (grown when a step has more contacts).
  std::vector<Contact> contacts_;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> g_;  // rows x 6: G (root frame)
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> w_;  // rows x 6: G L^-T
  Eigen::VectorXd a_, x_, b_, lo_, hi_, a0_, x0_, b0_, lo0_, hi0_;
  Eigen::VectorXi findex_, findex0_;
  std::shared_ptr<dart::constraint::BoxedLcpSolver> dantzig_, pgs_;
  // DART's box-box routine needs collision objects and a result; see rigid_step.cpp.
  struct BoxObjects;
  std::unique_ptr<BoxObjects> box_objects_;
  dart::collision::CollisionResult box_result_;
  RigidStepCounts counts_;
};

}  // namespace drops::hexapod
