// The prior's trajectories after the speed-ups of issue 14 against the reference written by the
// code before them (tests/data/prior_reference.txt; see make_prior_reference.cpp and
// prior_reference_cases.hpp), and the two contact paths of RigidRobotContactSolver against each
// other. Includes DART (the solver is reached through PriorSimulator::world()).
//
// Tolerances, from the deviations measured on the reference machine (docs/benchmarks.md):
// - joint angles and velocities are kinematic in the prior (velocity actuators): they matched to
//   the last bit; asserted within 1e-12;
// - the body's pose and velocities change at round-off in each step where the LCP matrix of the
//   rigid robot is built (the same products in another order), and contact dynamics amplify it:
//   after 40 steps the largest deviation was 1.4e-9 m in position, 9.5e-9 rad in orientation and
//   4.1e-8 m/s or rad/s in velocity (the intact tripod gait), and the walking speeds agreed
//   within 3.6e-10 m/s. Asserted: 1e-6 m and rad, 1e-5 m/s and rad/s, and a walking
//   speed within 1e-6 m/s: margins of about 100 over what was measured, for other compilers and
//   CPUs, and still far below anything physical;
// - one step from a recorded state: at most 5.4e-15; asserted 1e-12;
// - the "real" robot (servos: DART's own contact path, with the new filter): bit-identical.
#include <gtest/gtest.h>

#include <dart/simulation/World.hpp>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "contact_solver.hpp"
#include "prior_reference_cases.hpp"

namespace drops::hexapod {
namespace {

std::map<std::string, Eigen::MatrixXd> load_reference(std::string* header) {
  return testing::read_prior_reference(std::string(DROPS_HEXAPOD_TEST_DATA) + "/prior_reference.txt",
                                       header);
}

double block_max(const Eigen::MatrixXd& d, int begin, int end) {
  return d.middleCols(begin, end - begin).cwiseAbs().maxCoeff();
}

TEST(HexapodPriorReference, TrajectoriesMatchTheCodeBeforeTheSpeedUps) {
  std::string header;
  const auto reference = load_reference(&header);
  EXPECT_NE(header.find("commit"), std::string::npos) << header;
  const auto cases = testing::prior_reference_cases();
  ASSERT_EQ(reference.size(), cases.size());
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const auto it = reference.find(c.name);
    ASSERT_NE(it, reference.end());
    ASSERT_EQ(it->second.rows(), c.rows.rows());
    ASSERT_EQ(it->second.cols(), kStateDim);
    const Eigen::MatrixXd d = c.rows - it->second;
    ASSERT_TRUE(d.allFinite());
    if (c.name.rfind("real", 0) == 0) {
      EXPECT_EQ(d.cwiseAbs().maxCoeff(), 0.0);
      continue;
    }
    EXPECT_LE(block_max(d, kJointPos, kJointVel + kNumJoints), 1e-12);
    const bool one_step = c.name.rfind("onestep", 0) == 0;
    const double pose = one_step ? 1e-12 : 1e-6, velocity = one_step ? 1e-12 : 1e-5;
    EXPECT_LE(block_max(d, kBodyPos, kBodyLinVel), pose);
    EXPECT_LE(block_max(d, kBodyLinVel, kStateDim), velocity);
    if (!one_step) {
      // Walking speed over the 4 s episode.
      EXPECT_LE(std::abs(d(d.rows() - 1, kBodyPos) - d(0, kBodyPos)) / 4.0, 1e-6);
    }
  }
}

RigidRobotContactSolver& solver_of(const PriorSimulator& sim) {
  auto* s = dynamic_cast<RigidRobotContactSolver*>(sim.world()->getConstraintSolver());
  EXPECT_NE(s, nullptr);
  return *s;
}

TEST(HexapodPriorReference, RigidContactPathAgreesWithDartsOwnOnManyContacts) {
  // The robot dropped on its back, tilted, spinning: box contacts of the body and the links
  // (many LCP rows). One step with the rigid-robot path against one with DART's row-by-row
  // construction, from the same state: the same physics up to round-off.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(kStateDim);
  for (int i = 0; i < kNumJoints; ++i) {
    x[kJointPos + i] = 0.3 * std::sin(i + 1.0);
    x[kJointVel + i] = 2.0 * std::cos(i + 1.0);
  }
  x.segment<3>(kBodyPos) << 0.1, -0.05, 0.03;
  x.segment<3>(kBodyRpy) << 3.0, 0.2, 0.5;
  x.segment<3>(kBodyLinVel) << 0.3, -0.2, -0.5;
  x.segment<3>(kBodyAngVel) << 1.0, -0.5, 0.8;
  GaitController ctrl;
  ctrl.set_params(tripod_gait());
  for (int removed : {-1, 5}) {
    SCOPED_TRACE(removed);
    PriorSimulator fast(HexapodSpec::with_leg_removed(removed));
    PriorSimulator dart(HexapodSpec::with_leg_removed(removed));
    solver_of(dart).set_rigid_enabled(false);
    Eigen::VectorXd a = x, b = x;
    for (int t = 0; t < 3; ++t) {
      fast.set_state(a);
      fast.step(ctrl.targets(0.1 * t));
      dart.set_state(a);  // the same start state for both, every step
      dart.step(ctrl.targets(0.1 * t));
      a = fast.state();
      b = dart.state();
      EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-10) << t;
    }
    EXPECT_GT(solver_of(fast).rigid_groups(), 0);
    EXPECT_EQ(solver_of(dart).rigid_groups(), 0);
    EXPECT_GT(solver_of(dart).generic_groups(), 0);
  }
}

TEST(HexapodPriorReference, ServoRobotAlwaysUsesDartsOwnContactPath) {
  // The "real" robot's joints are force-driven (dynamic): the rigid-robot path does not apply.
  PriorSimulator real(HexapodSpec{}, real_simulator_defaults());
  GaitController ctrl;
  ctrl.set_params(tripod_gait());
  for (int t = 0; t < 5; ++t) real.step(ctrl.targets(0.1 * t));
  EXPECT_EQ(solver_of(real).rigid_groups(), 0);
  EXPECT_GT(solver_of(real).generic_groups(), 0);
}

}  // namespace
}  // namespace drops::hexapod
