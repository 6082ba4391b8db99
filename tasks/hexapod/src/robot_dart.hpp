#pragma once
/// \file Builds the DART 6 skeleton of a HexapodSpec and a world with a ground box.
///
/// Includes DART: include this header only from translation units of the drops_hexapod target,
/// which are compiled without -march=native (Debian's DART is built for baseline x86-64 and its
/// classes hold fixed-size Eigen members whose alignment would differ; see CMakeLists.txt).

#include <dart/dynamics/Skeleton.hpp>
#include <dart/simulation/World.hpp>
#include <string>

#include "drops/hexapod/robot.hpp"

namespace drops::hexapod {

/// Builds the robot in code from `spec` (see robot.hpp for frames, names and sign conventions):
/// a FreeJoint "root" carrying the "body" box, and per present leg three RevoluteJoints with box
/// links and a sphere foot on the tibia. Every shape has visual, collision and dynamics aspects
/// (friction coefficient `friction`). Position, velocity and force limits are set from the spec
/// (position limits are not enforced by DART for VELOCITY actuators; the simulators clip targets).
/// Every joint starts at 0 except a blocked joint, which starts at its blocked angle; the body
/// starts at the origin. Actuator types are left at DART's default (FORCE): the simulator sets
/// them. Throws InvalidArgument when spec is invalid or friction is not positive and finite.
/// Thread-safe (builds a new skeleton each call).
dart::dynamics::SkeletonPtr build_skeleton(const HexapodSpec& spec, double friction = 1.0);

/// Options of the world around the robot.
struct WorldOptions {
  double time_step = 0.01;        ///< physics step, s, > 0
  double gravity = 9.81;          ///< m/s^2 along -z, >= 0
  double ground_friction = 1.0;   ///< Coulomb friction coefficient of the ground, > 0
  double ground_size = 20.0;      ///< side of the square ground box, m (top face at z = 0), > 0
  double ground_thickness = 0.2;  ///< m, > 0
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// A world with gravity, the ground (a static box whose top face is the plane z = 0) and `robot`
/// added to it. Uses DART's own collision detector (boxes and spheres only, stateless between
/// steps, so a step is a function of the current state alone) with GroundContactFilter (the
/// ground against every robot shape; the robot does not collide with itself, as DART's default
/// filter without self-collision) and RigidRobotContactSolver (DART's boxed-LCP solver, with a
/// cheaper LCP matrix while every joint but the root is kinematic; contact_solver.hpp). Skeletons
/// added to the world later collide with the ground only, not with the robot or each other.
/// The effective contact friction is DART's combination of the two shapes' coefficients.
/// Throws InvalidArgument when options are invalid or robot is null. Thread-safe.
dart::simulation::WorldPtr make_world(const dart::dynamics::SkeletonPtr& robot,
                                      const WorldOptions& options = {});

}  // namespace drops::hexapod
