// The prior's dedicated rigid-body step (PriorEngine::kRigid, src/rigid_step.hpp) against DART's
// world step (PriorEngine::kDart) from the same states, and against the reference trajectories of
// tests/data/prior_reference.txt (prior_reference_cases.hpp). Includes DART (contacts are compared
// with the DART world's own collision result).
//
// Tolerances: see the constants below; each is about 10-100 times the largest deviation measured
// on the reference machine (docs/benchmarks.md, "A dedicated rigid-body step"), written next to it.
// DROPS_RIGID_VERBOSE=1 in the environment prints the measured deviations and counts.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/CollisionResult.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/Shape.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/simulation/World.hpp>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "contact_solver.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "prior_reference_cases.hpp"
#include "rigid_step.hpp"

// Counts the process's heap allocations while g_count_allocations is set (this test binary
// interposes glibc's malloc, calloc and realloc). Not under a sanitizer: ASan and TSan interpose
// malloc and free themselves, and at ASan's start-up glibc's dlerror string would come from this
// malloc (glibc's heap) and go to ASan's free, which aborts ("CHECK failed: tsd_key_inited"); the
// allocation test is skipped there.
namespace {
bool g_count_allocations = false;
long g_allocations = 0;
}  // namespace
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DROPS_COUNTS_ALLOCATIONS 0
#else
#define DROPS_COUNTS_ALLOCATIONS 1
extern "C" void* __libc_malloc(std::size_t);
extern "C" void* __libc_calloc(std::size_t, std::size_t);
extern "C" void* __libc_realloc(void*, std::size_t);
extern "C" void* malloc(std::size_t n) {
  if (g_count_allocations) ++g_allocations;
  return __libc_malloc(n);
}
extern "C" void* calloc(std::size_t n, std::size_t size) {
  if (g_count_allocations) ++g_allocations;
  return __libc_calloc(n, size);
}
extern "C" void* realloc(void* p, std::size_t n) {
  if (g_count_allocations) ++g_allocations;
  return __libc_realloc(p, n);
}
#endif

namespace drops::hexapod {
namespace {

PriorOptions rigid_options(double control_dt = 0.1) {
  PriorOptions o;
  o.engine = PriorEngine::kRigid;
  o.control_dt = control_dt;
  return o;
}

PriorOptions dart_options(double control_dt = 0.1) {
  PriorOptions o;
  o.control_dt = control_dt;
  return o;
}

// Largest |a - b| over [begin, end) of two 48-D states or of two matrices' columns.
double block_max(const Eigen::MatrixXd& d, int begin, int end) {
  return d.middleCols(begin, end - begin).cwiseAbs().maxCoeff();
}

bool verbose() { return std::getenv("DROPS_RIGID_VERBOSE") != nullptr; }

// A random state: joints anywhere within their limits with velocities up to 5 rad/s, the body
// between 2 cm and 25 cm above the ground in any roll (on its back too), pitch up to 1 rad,
// linear velocities up to 1 m/s and angular up to 3 rad/s.
Eigen::VectorXd random_state(Rng& rng) {
  const HexapodSpec spec;
  Eigen::VectorXd x(kStateDim);
  for (int i = 0; i < kNumJoints; ++i) {
    const double lim = spec.joint_limit(i % kJointsPerLeg);
    x[kJointPos + i] = rng.uniform(-lim, lim);
    x[kJointVel + i] = rng.uniform(-5.0, 5.0);
  }
  x[kBodyPos] = rng.uniform(-1.0, 1.0);
  x[kBodyPos + 1] = rng.uniform(-1.0, 1.0);
  x[kBodyPos + 2] = rng.uniform(0.02, 0.25);
  x[kBodyRpy] = rng.uniform(-3.2, 3.2);
  x[kBodyRpy + 1] = rng.uniform(-1.0, 1.0);
  x[kBodyRpy + 2] = rng.uniform(-3.2, 3.2);
  for (int i = 0; i < 3; ++i) {
    x[kBodyLinVel + i] = rng.uniform(-1.0, 1.0);
    x[kBodyAngVel + i] = rng.uniform(-3.0, 3.0);
  }
  return x;
}

Eigen::VectorXd random_targets(Rng& rng) {
  const HexapodSpec spec;
  Eigen::VectorXd u(kNumJoints);
  for (int i = 0; i < kNumJoints; ++i) {
    const double lim = spec.joint_limit(i % kJointsPerLeg);
    u[i] = rng.uniform(-lim, lim);
  }
  return u;
}

struct Deviation {
  double joints = 0, pose = 0, velocity = 0;
  void add(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    const Eigen::MatrixXd d = (a - b).transpose();
    joints = std::max(joints, block_max(d, kJointPos, kJointVel + kNumJoints));
    pose = std::max(pose, block_max(d, kBodyPos, kBodyLinVel));
    velocity = std::max(velocity, block_max(d, kBodyLinVel, kStateDim));
  }
};

// The bodies' transforms and the contacts the rigid step computes are DART's, to the bit: the same
// count, order, points, normals and depths as DART's detector on the world, from random states
// (robots on their backs, links and body on the ground).
TEST(HexapodRigidStep, TransformsAndContactsAreDarts) {
  Rng rng(11);
  long contacts = 0, boxes = 0;
  for (int removed : {-1, 5, 0}) {
    SCOPED_TRACE(removed);
    PriorSimulator dart(HexapodSpec::with_leg_removed(removed), dart_options());
    const auto world = dart.world();
    const auto robot = world->getSkeleton(1);
    RigidRobotStep rigid(world, robot);
    std::vector<Eigen::Isometry3d> transforms;
    std::vector<RigidRobotStep::Contact> found;
    dart::collision::CollisionResult result;
    auto* solver = world->getConstraintSolver();
    for (int n = 0; n < 200; ++n) {
      dart.set_state(random_state(rng));
      rigid.load();
      rigid.current_contacts(&transforms, &found);
      ASSERT_EQ(transforms.size(), robot->getNumBodyNodes());
      for (std::size_t b = 0; b < transforms.size(); ++b) {
        EXPECT_EQ((transforms[b].matrix() - robot->getBodyNode(b)->getWorldTransform().matrix())
                      .cwiseAbs()
                      .maxCoeff(),
                  0.0)
            << b;
      }
      solver->getCollisionGroup()->collide(solver->getCollisionOption(), &result);
      ASSERT_EQ(found.size(), result.getNumContacts()) << n;
      for (std::size_t c = 0; c < found.size(); ++c) {
        const auto& ct = result.getContact(c);
        const auto* body =
            ct.collisionObject2->getShapeFrame()->asShapeNode()->getBodyNodePtr().get();
        EXPECT_EQ(found[c].body, static_cast<int>(body->getIndexInSkeleton()));
        EXPECT_EQ(found[c].point, ct.point) << n << " " << c;
        EXPECT_EQ(found[c].normal, ct.normal) << n << " " << c;
        EXPECT_EQ(found[c].depth, ct.penetrationDepth) << n << " " << c;
        boxes += ct.collisionObject2->getShape()->getType() == "BoxShape" ? 1 : 0;
      }
      contacts += static_cast<long>(found.size());
    }
  }
  if (verbose()) std::printf("contacts %ld, of which with boxes %ld\n", contacts, boxes);
  EXPECT_GT(boxes, 100);
  EXPECT_GT(contacts - boxes, 100);
}

// One physics step (control_dt = physics_dt) from random states, many of them with the body or
// links on the ground: the contacts the rigid step finds are DART's (same count, points,
// normals, depths, in the same order), and the states after the step agree.
TEST(HexapodRigidStep, OnePhysicsStepFromRandomStatesMatchesDart) {
  // Measured (600 states; intact, legs 5 and 0 removed; up to 53 contacts): joints 0
  // (bit-identical), pose 2.5e-11 m or rad, velocities 2.4e-9 m/s or rad/s. For scale, DART's own
  // two constructions of the LCP matrix (RigidRobotContactSolver's and DART's row-by-row one)
  // differ by 5.8e-11 and 4.0e-9 on the same states: the LCPs of many contacts (rank 6, up to
  // 159 rows) amplify round-off in A to this level.
  constexpr double kJoints = 0.0, kPose = 1e-9, kVelocity = 1e-7;
  Rng rng(3);
  Deviation dev, dart_paths;
  long contacts = 0, max_contacts = 0;
  for (int removed : {-1, 5, 0}) {
    SCOPED_TRACE(removed);
    PriorSimulator dart(HexapodSpec::with_leg_removed(removed), dart_options(0.01));
    PriorSimulator generic(HexapodSpec::with_leg_removed(removed), dart_options(0.01));
    dynamic_cast<RigidRobotContactSolver*>(generic.world()->getConstraintSolver())
        ->set_rigid_enabled(false);
    PriorSimulator rigid(HexapodSpec::with_leg_removed(removed), rigid_options(0.01));
    for (int n = 0; n < 200; ++n) {
      const Eigen::VectorXd x = random_state(rng), u = random_targets(rng);
      for (PriorSimulator* sim : {&dart, &generic, &rigid}) {
        sim->set_state(x);
        sim->step(u);
      }
      const auto& result = dart.world()->getConstraintSolver()->getLastCollisionResult();
      const long found = static_cast<long>(result.getNumContacts());
      contacts += found;
      max_contacts = std::max(max_contacts, found);
      dev.add(rigid.state(), dart.state());
      dart_paths.add(generic.state(), dart.state());
    }
  }
  if (verbose()) {
    std::printf(
        "one physics step: contacts %ld (max %ld per step); rigid - DART: joints %.3g pose "
        "%.3g velocity %.3g; DART's two LCP constructions: joints %.3g pose %.3g "
        "velocity %.3g\n",
        contacts, max_contacts, dev.joints, dev.pose, dev.velocity, dart_paths.joints,
        dart_paths.pose, dart_paths.velocity);
  }
  EXPECT_GT(max_contacts, 12);  // robots on their backs: body and link boxes on the ground
  EXPECT_LE(dev.joints, kJoints);
  EXPECT_LE(dev.pose, kPose);
  EXPECT_LE(dev.velocity, kVelocity);
}

// One control step (10 physics steps) from the same random states and from recorded states of
// the "real" robot (the onestep cases of the reference data).
TEST(HexapodRigidStep, OneControlStepMatchesDart) {
  // Measured (400 random and 320 recorded states): joints 0, pose 1.7e-10, velocities 4.0e-9.
  constexpr double kJoints = 0.0, kPose = 3e-9, kVelocity = 1e-7;
  Rng rng(5);
  Deviation dev;
  const std::vector<Transition> data = testing::real_data(testing::damaged(-1), 2);
  // The three priors of the reference data, and a spec with a LOCKED joint and a short tibia.
  HexapodSpec damaged;
  damaged.legs[2].blocked_joint = 1;
  damaged.legs[2].blocked_angle = 0.3;
  damaged.legs[4].tibia_length_factor = 0.6;
  for (const HexapodSpec& spec :
       {HexapodSpec::with_leg_removed(-1), HexapodSpec::with_leg_removed(5),
        HexapodSpec::with_leg_removed(0), damaged}) {
    PriorSimulator dart(spec, dart_options());
    PriorSimulator rigid(spec, rigid_options());
    auto one = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
      dart.set_state(x);
      rigid.set_state(x);
      dart.step(u);
      rigid.step(u);
      dev.add(rigid.state(), dart.state());
    };
    for (int n = 0; n < 100; ++n) {
      const Eigen::VectorXd x = random_state(rng);
      one(x, random_targets(rng));
    }
    for (const Transition& t : data) one(t.x, t.u);
  }
  if (verbose()) {
    std::printf("one control step: joints %.3g pose %.3g velocity %.3g\n", dev.joints, dev.pose,
                dev.velocity);
  }
  EXPECT_LE(dev.joints, kJoints);
  EXPECT_LE(dev.pose, kPose);
  EXPECT_LE(dev.velocity, kVelocity);
}

std::map<std::string, Eigen::MatrixXd> load_reference() {
  return testing::read_prior_reference(std::string(DROPS_HEXAPOD_TEST_DATA) + "/prior_reference.txt");
}

struct CaseDeviations {
  Deviation episode, one_step;
  double speed = 0;
};

// Deviations of `cases` from `reference` (by name), episodes (chain, sim) and one-step cases
// (onestep) apart; the "real" robot's cases are skipped.
CaseDeviations compare(const std::vector<testing::ReferenceCase>& cases,
                       const std::map<std::string, Eigen::MatrixXd>& reference, const char* label) {
  CaseDeviations out;
  for (const auto& c : cases) {
    if (c.name.rfind("real", 0) == 0) continue;
    const auto it = reference.find(c.name);
    EXPECT_NE(it, reference.end()) << c.name;
    if (it == reference.end()) continue;
    EXPECT_EQ(it->second.rows(), c.rows.rows()) << c.name;
    if (it->second.rows() != c.rows.rows()) continue;
    const Eigen::MatrixXd d = c.rows - it->second;
    EXPECT_TRUE(d.allFinite()) << c.name;
    const bool one = c.name.rfind("onestep", 0) == 0;
    Deviation& dev = one ? out.one_step : out.episode;
    for (Eigen::Index r = 0; r < d.rows(); ++r) dev.add(c.rows.row(r), it->second.row(r));
    if (!one) {
      out.speed = std::max(out.speed, std::abs(d(d.rows() - 1, kBodyPos) - d(0, kBodyPos)) / 4.0);
    }
    if (verbose()) {
      std::printf("%s %-20s joints %.3g pose %.3g velocity %.3g\n", label, c.name.c_str(),
                  block_max(d, kJointPos, kJointVel + kNumJoints),
                  block_max(d, kBodyPos, kBodyLinVel), block_max(d, kBodyLinVel, kStateDim));
    }
  }
  if (verbose()) {
    std::printf(
        "%s: episodes: joints %.3g pose %.3g velocity %.3g speed %.3g; one step: joints "
        "%.3g pose %.3g velocity %.3g\n",
        label, out.episode.joints, out.episode.pose, out.episode.velocity, out.speed,
        out.one_step.joints, out.one_step.pose, out.one_step.velocity);
  }
  return out;
}

// The reference cases (40-step prior-only model rollouts and simulator episodes of 4 gaits x 3
// priors, one-step predictions at 80 recorded states; prior_reference_cases.hpp) computed with
// the rigid step, against the same cases computed with DART's step now and against the reference
// file (the code before issue 14's speed-ups).
TEST(HexapodRigidStep, ReferenceCasesMatchDartAndTheReferenceData) {
  const auto dart = testing::prior_reference_cases(dart_options());
  const auto rigid = testing::prior_reference_cases(rigid_options());
  ASSERT_EQ(dart.size(), rigid.size());
  std::map<std::string, Eigen::MatrixXd> dart_now;
  for (const auto& c : dart) dart_now[c.name] = c.rows;
  // Measured against DART now: episodes joints 0, pose 2.9e-9 m or rad, velocities 1.2e-8, the
  // walking speed 1.1e-10 m/s; one step joints 0, pose 6.7e-16, velocities 3.1e-15.
  const CaseDeviations now = compare(rigid, dart_now, "rigid - DART");
  EXPECT_LE(now.episode.joints, 0.0);
  EXPECT_LE(now.episode.pose, 1e-7);
  EXPECT_LE(now.episode.velocity, 3e-7);
  EXPECT_LE(now.speed, 3e-9);
  EXPECT_LE(now.one_step.joints, 0.0);
  EXPECT_LE(now.one_step.pose, 5e-14);
  EXPECT_LE(now.one_step.velocity, 2e-13);
  // Measured against the reference data: episodes joints 0, pose 6.6e-9, velocities 2.8e-8,
  // speed 2.5e-10; one step joints 0, pose 3.3e-16, velocities 7.1e-15 (DART's path now: 1.4e-9,
  // 4.1e-8 and 3.6e-10 on episodes, test_hexapod_prior_reference).
  const CaseDeviations data = compare(rigid, load_reference(), "rigid - data");
  EXPECT_LE(data.episode.joints, 1e-12);
  EXPECT_LE(data.episode.pose, 3e-7);
  EXPECT_LE(data.episode.velocity, 1e-6);
  EXPECT_LE(data.speed, 1e-8);
  EXPECT_LE(data.one_step.joints, 1e-12);
  EXPECT_LE(data.one_step.pose, 3e-14);
  EXPECT_LE(data.one_step.velocity, 2e-13);
}

// The rigid step's own code does not touch the heap: ten physics steps without contacts (the
// robot in the air) allocate nothing. With contacts, DART's Dantzig routine (dSolveLCP) allocates
// its working arrays on each call, and DART's box-box routine adds each contact to a
// CollisionResult's hash sets; those are counted and printed, not asserted.
TEST(HexapodRigidStep, StepAllocatesOnlyInsideDartsRoutines) {
  if (!DROPS_COUNTS_ALLOCATIONS) GTEST_SKIP() << "allocations are not counted under a sanitizer";
  const std::vector<Transition> data = testing::real_data(testing::damaged(-1), 2);
  PriorSimulator rigid(HexapodSpec{}, rigid_options());
  auto count = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
    rigid.set_state(x);
    g_allocations = 0;
    g_count_allocations = true;
    rigid.step(u);
    g_count_allocations = false;
    return g_allocations;
  };
  count(data[0].x, data[0].u);  // warm-up: the contact buffers reach their capacity
  {
    // RigidRobotStep::step itself, 5 m up (no contact). (PriorSimulator::step adds one
    // allocation per control step: DART's transform check when it reads the body's orientation.)
    PriorSimulator dart(HexapodSpec{}, dart_options());
    Eigen::VectorXd air = data[0].x;
    air[kBodyPos + 2] = 5.0;
    dart.set_state(air);
    RigidRobotStep step(dart.world(), dart.world()->getSkeleton(1));
    const std::vector<double> commands(static_cast<std::size_t>(step.num_leg_dofs()), 1.0);
    step.step(commands.data());
    g_allocations = 0;
    g_count_allocations = true;
    for (int n = 0; n < 10; ++n) step.step(commands.data());
    g_count_allocations = false;
    EXPECT_EQ(g_allocations, 0);
    EXPECT_EQ(step.counts().contacts, 0);
  }
  long walking = 0, fallen = 0;
  for (const Transition& t : data) walking += count(t.x, t.u);
  Rng rng(17);
  for (int n = 0; n < 50; ++n) {
    const Eigen::VectorXd x = random_state(rng), u = random_targets(rng);
    fallen += count(x, u);
  }
  if (verbose()) {
    std::printf(
        "allocations per control step: %.1f from the recorded (walking) states, %.1f from "
        "random states (box contacts)\n",
        walking / static_cast<double>(data.size()), fallen / 50.0);
  }
}

TEST(HexapodRigidStep, ServoActuationAndDynamicJointsAreRefused) {
  PriorOptions o = rigid_options();
  o.actuation = Actuation::kServo;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("kRigid"), std::string::npos) << why;
  EXPECT_TRUE(rigid_options().IsValid());
  EXPECT_THROW(PriorSimulator(HexapodSpec{}, o), InvalidArgument);
  // The step itself refuses a skeleton with dynamic (force-driven) leg joints.
  PriorSimulator servo(HexapodSpec{}, real_simulator_defaults());
  try {
    RigidRobotStep step(servo.world(), servo.world()->getSkeleton(1));
    ADD_FAILURE() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("VELOCITY or LOCKED"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace drops::hexapod
