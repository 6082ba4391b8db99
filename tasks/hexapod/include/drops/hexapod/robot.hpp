#pragma once
/// \file The hexapod ("pexod") robot description of paper §V-B (settings.md §6), as plain data.
///
/// This header does not include DART, so it may be included from any translation unit (also one
/// compiled with -march=native). The DART skeleton and world are built from a HexapodSpec by
/// robot_dart.hpp, which only the drops_hexapod target includes.
///
/// Conventions (ours; settings.md gives the attachment points and link masses only):
/// - Body frame: x forward, y left, z up; origin at the centre of the body box.
/// - Legs, numbered as settings.md: 0 rear-left, 1 mid-left, 2 front-left, 3 front-right,
///   4 mid-right, 5 rear-right. Leg k's hip joint sits at (attach_x[k], attach_y[k], 0).
/// - In the zero configuration every leg points straight out sideways (+y for legs 0-2, -y for
///   legs 3-5): the hip link (hip_length) and the femur (femur_length) are horizontal, the tibia
///   (tibia_length) hangs vertically down and ends in the centre of the foot sphere.
/// - Joint 1 ("leg<k>_hip") turns about the vertical axis; a positive angle swings the foot
///   forward (+x) on every leg. Joint 2 ("leg<k>_femur") and joint 3 ("leg<k>_tibia") turn about
///   the horizontal axis perpendicular to the leg; a positive angle lifts the part outboard of the
///   joint (the foot goes up). Joint 2 = a, joint 3 = -a therefore lifts the foot by
///   femur_length * sin(a) and keeps the tibia vertical, which is what the controller of
///   settings.md §6 does (joint 2 = (pi/4) s, joint 3 = -(pi/4) s).
/// - Joint vector order (18 entries, used for angles, velocities and targets everywhere in
///   drops::hexapod): index 3 k + j for leg k = 0..5 and joint j = 0 (hip), 1 (femur), 2 (tibia).

#include <array>
#include <string>

namespace drops::hexapod {

/// Number of legs.
inline constexpr int kNumLegs = 6;
/// Joints per leg.
inline constexpr int kJointsPerLeg = 3;
/// Number of leg joints (the 18 actuated degrees of freedom).
inline constexpr int kNumJoints = kNumLegs * kJointsPerLeg;

/// Per-leg options: intact by default; a removed leg, a shortened tibia or a blocked joint model
/// damage (issue 4). A removed leg has no bodies and no joints in the skeleton.
struct LegOptions {
  bool removed = false;              ///< true: the leg (3 bodies, foot, 3 joints) is not built
  double tibia_length_factor = 1.0;  ///< tibia length = factor * HexapodSpec::tibia_length, (0, 1]
  int blocked_joint = -1;            ///< -1: none; 0, 1 or 2: this joint is held at blocked_angle
  double blocked_angle = 0.0;        ///< rad, within that joint's position limits
};

/// Dimensions, masses and limits of the hexapod. Lengths in m, masses in kg, angles in rad,
/// velocities in rad/s, torques in N m. Defaults: settings.md §6, except where marked "ours".
/// Total mass with the defaults: 1.031 + 6 (0.02 + 0.184 + 0.04) = 2.495 kg.
struct HexapodSpec {
  // Body box (x = length, y = width, z = height) and mass.
  double body_length = 0.24;
  double body_width = 0.20;
  double body_height = 0.04;
  double body_mass = 1.031;
  /// Leg attachment points in the body frame (x, y), leg order as in the file comment.
  std::array<double, kNumLegs> attach_x = {-0.13, -0.01, 0.11, 0.11, -0.01, -0.13};
  std::array<double, kNumLegs> attach_y = {0.04, 0.08, 0.04, -0.04, -0.08, -0.04};
  // Link lengths. hip_length and femur_length are ours (settings.md does not give them).
  double hip_length = 0.06;
  double femur_length = 0.085;
  double tibia_length = 0.14;  ///< from the tibia joint to the centre of the foot sphere
  double foot_radius = 0.025;
  /// Side of the square cross-section of the hip, femur and tibia boxes (ours; visual/collision).
  double link_thickness = 0.02;
  // Link masses; the tibia mass includes the foot.
  double hip_mass = 0.02;
  double femur_mass = 0.184;
  double tibia_mass = 0.04;
  // Limits of every leg joint.
  double hip_limit = 1.5707963267948966;   ///< |joint 1| <= pi/2
  double knee_limit = 0.7853981633974483;  ///< |joint 2|, |joint 3| <= pi/4
  double max_velocity = 7.0;               ///< |joint velocity| limit, rad/s
  double max_torque = 30.0;                ///< |joint torque| limit, N m
  /// Per-leg damage options (all intact by default).
  std::array<LegOptions, kNumLegs> legs{};

  /// The intact robot.
  static HexapodSpec intact();
  /// The intact robot without leg `leg` (0..5); leg = -1 gives the intact robot. These are the 7
  /// priors of GP-MI (settings.md §6). Throws InvalidArgument for any other value.
  static HexapodSpec with_leg_removed(int leg);

  /// Position limit (rad, symmetric) of joint j = 0, 1, 2 of a leg.
  double joint_limit(int j) const { return j == 0 ? hip_limit : knee_limit; }
  /// Number of legs that are not removed.
  int num_present_legs() const;
  /// True when all sizes and masses are positive and finite, the tibia factors are in (0, 1],
  /// blocked joints are in -1..2 with angles inside their limits; otherwise false with the reason
  /// (naming the field and its value) in *why when why is not null.
  bool IsValid(std::string* why = nullptr) const;
  /// Throws InvalidArgument with the reason of IsValid when invalid.
  void check() const;
};

/// Name of joint j (0..2) of leg k (0..5): "leg<k>_hip", "leg<k>_femur", "leg<k>_tibia".
/// The child body of a joint has the same name with "_link" appended ("leg3_hip_link"); the foot
/// sphere is the shape "leg<k>_foot" on the tibia body. Throws InvalidArgument out of range.
std::string joint_name(int leg, int joint);
/// Name of the child body of joint j of leg k ("leg<k>_<hip|femur|tibia>_link").
std::string body_name(int leg, int joint);
/// Name of the foot shape of leg k ("leg<k>_foot").
std::string foot_name(int leg);
/// Name of the robot's root body ("body") and its free joint ("root").
inline constexpr const char* kBodyName = "body";
inline constexpr const char* kRootJointName = "root";
inline constexpr const char* kSkeletonName = "hexapod";
inline constexpr const char* kGroundName = "ground";

}  // namespace drops::hexapod
