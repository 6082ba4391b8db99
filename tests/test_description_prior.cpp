// drops::description::DescriptionPrior (a URDF or MJCF file as the simulator prior, issue 64)
// against the analytic double pendulum of tests/double_pendulum.hpp, on the DFKI double
// pendulum's URDF (tests/data/double-pendulum-dfki) and on an MJCF written here: accelerations,
// one control step and 2 s trajectories with the file's and with changed phi, each kind of phi
// against the equations, energy conservation, clones and threads, and bad input.
// Built only with DROPS_WITH_MUJOCO (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "double_pendulum.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/description/description_prior.hpp"

using namespace drops;
using description::DescriptionPrior;
using description::DescriptionPriorOptions;
using fixtures::DoublePendulumParams;

namespace {

const std::string kDfki = DROPS_TEST_DATA "/double-pendulum-dfki/double_pendulum.urdf";

// Every phi kind the double pendulum has, in this order.
const std::vector<std::string> kAllPhi = {
    "Link1.mass",      "Link2.mass",      "Link1.com.y",     "Link1.com.z",     "Link2.com.y",
    "Link2.com.z",     "Link1.inertia",   "Link2.inertia",   "Joint1.damping",  "Joint2.damping",
    "Joint1.friction", "Joint2.friction", "Joint1.armature", "Joint2.armature", "Joint1.gear",
    "Joint2.gear",     "gravity"};

// The URDF turns Link2's frame by rpy_x = -3.1416 from Link1's; the analytic model's frame of a
// link has "along" = -z and "across" = +y at rpy 0. (com.x lies along the joints' axis: no effect
// on the planar motion.)
constexpr double kRpyX[2] = {0.0, -3.1416};

void set_com(DoublePendulumParams& p, int link, double y, double z) {
  const double c = std::cos(kRpyX[link]), s = std::sin(kRpyX[link]);
  const double ym = c * y - s * z, zm = s * y + c * z;  // Rx(rpy) (0, y, z)
  p.com_along[link] = -zm;
  p.com_across[link] = ym;
}

// The analytic model of phi (kAllPhi's order) on the DFKI file.
DoublePendulumParams params_of(const VectorXd& phi) {
  DoublePendulumParams p = fixtures::dfki_urdf_double_pendulum();
  const DoublePendulumParams file = p;
  p.mass = {phi[0], phi[1]};
  set_com(p, 0, phi[2], phi[3]);
  set_com(p, 1, phi[4], phi[5]);
  p.inertia = {phi[6] * file.inertia[0], phi[7] * file.inertia[1]};
  p.damping = {phi[8], phi[9]};
  p.coulomb = {phi[10], phi[11]};
  p.armature = {phi[12], phi[13]};
  p.torque_scale = {phi[14], phi[15]};
  p.gravity = phi[16];
  return p;
}

DescriptionPrior dfki_prior(std::vector<std::string> parameters = kAllPhi) {
  DescriptionPriorOptions o;
  o.file = kDfki;
  o.parameters = std::move(parameters);
  return DescriptionPrior(o);
}

// Every kind away from the file's values (the engine study's "all changed").
VectorXd changed_phi() {
  VectorXd phi(17);
  phi << 0.75, 0.5, 0.01, -0.25, 0.006, 0.18, 0.012 / 0.05472, 0.005 / 0.02522, 0.05, 0.02, 0.06,
      0.1, 2.19e-3, 2.19e-3, 1.3, 0.8, 9.5;
  return phi;
}

struct States {
  MatrixXd x, u;  // (B, 4), (B, 2)
};

States random_states(int b, double max_speed, double max_torque, std::uint64_t seed) {
  Rng rng(seed);
  States s{MatrixXd(b, 4), MatrixXd(b, 2)};
  for (int i = 0; i < b; ++i) {
    for (int j = 0; j < 2; ++j) {
      s.x(i, j) = rng.uniform(-M_PI, M_PI);
      s.x(i, 2 + j) = rng.uniform(-max_speed, max_speed);
      s.u(i, j) = rng.uniform(-max_torque, max_torque);
    }
  }
  return s;
}

// max over the states of |qdd(prior) - qdd(analytic)| and max |qdd(analytic)|.
std::pair<double, double> acceleration_error(const DescriptionPrior& prior, const VectorXd& phi,
                                             const States& s) {
  const DoublePendulumParams p = params_of(phi);
  double err = 0, scale = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    const VectorXd x = s.x.row(i).transpose(), u = s.u.row(i).transpose();
    const Eigen::Vector2d ref = fixtures::joint_accelerations(p, x, u);
    err = std::max(err, (prior.joint_accelerations(x, u, phi) - ref).cwiseAbs().maxCoeff());
    scale = std::max(scale, ref.cwiseAbs().maxCoeff());
  }
  return {err, scale};
}

// One control step of the analytic model: 10 RK4 substeps of 1 ms.
Eigen::Vector4d analytic_step(const DoublePendulumParams& p, Eigen::Vector4d x,
                              const Eigen::Vector2d& u) {
  for (int k = 0; k < 10; ++k) x = fixtures::rk4_step(p, x, u, 1e-3);
  return x;
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "(no InvalidArgument thrown)";
}

}  // namespace

TEST(DescriptionPrior, LoadsTheDfkiUrdfWithItsJointsBodiesAndTheFilesValuesAsTheStartOfPhi) {
  const auto prior = dfki_prior();
  EXPECT_EQ(prior.state_dim(), 4);
  EXPECT_EQ(prior.action_dim(), 2);
  EXPECT_EQ(prior.joint_names(), (std::vector<std::string>{"Joint1", "Joint2"}));
  EXPECT_EQ(prior.parameter_names(), kAllPhi);
  // Fixed links stay bodies of their own (fusestatic off): Weight is not merged into Link2.
  EXPECT_EQ(prior.body_names(),
            (std::vector<std::string>{"base_link", "Link1", "Link2", "Weight"}));
  VectorXd file(17);
  file << 0.608, 0.6306, 0, -0.27401315789473685, 0, 0.16634950840469392, 1, 1, 0.08089, 0, 0.09335,
      0.1865, 0, 0, 1, 1, 9.81;
  EXPECT_LT((prior.default_phi() - file).cwiseAbs().maxCoeff(), 1e-12)
      << prior.default_phi().transpose();
  EXPECT_NO_THROW(prior.check_phi(prior.default_phi()));
  const auto available = prior.available_parameters();
  EXPECT_EQ(available.size(), 4 * 5 + 2 * 4 + 1u);
  EXPECT_NE(std::find(available.begin(), available.end(), "Weight.mass"), available.end());
}

TEST(DescriptionPrior, AccelerationsAgreeWithTheAnalyticDoublePendulumWithTheFilesAndChangedPhi) {
  const auto prior = dfki_prior();
  const States s = random_states(1000, 5.0, 2.0, 1);
  for (const VectorXd& phi : {prior.default_phi(), changed_phi()}) {
    const auto [err, scale] = acceleration_error(prior, phi, s);
    // Measured: 1.4e-13 (file) and 2.3e-13 (changed) rad/s^2, of up to 124 and 222 rad/s^2.
    EXPECT_LT(err, 1e-10) << "phi = " << phi.transpose() << ", max |qdd| " << scale;
    EXPECT_GT(scale, 10.0);
  }
}

TEST(DescriptionPrior, EachKindOfPhiChangesTheAccelerationsAsTheEquationsSay) {
  const auto prior = dfki_prior();
  const States s = random_states(200, 5.0, 2.0, 2);
  const VectorXd file = prior.default_phi();
  // One kind at a time (an entry of kAllPhi and its new value), each far enough from the file's
  // that ignoring it would fail: mass, centre of mass, inertia, damping, friction, armature,
  // gear, gravity.
  const std::vector<std::pair<int, double>> changes = {
      {0, 0.9},   {1, 0.4},   {2, 0.03}, {3, -0.2},  {4, -0.02}, {5, 0.25},
      {6, 0.3},   {7, 2.0},   {8, 0.3},  {9, 0.05},  {10, 0.3},  {11, 0.02},
      {12, 0.01}, {13, 5e-3}, {14, 2.0}, {15, -0.5}, {16, 3.7}};
  for (const auto& [index, value] : changes) {
    VectorXd phi = file;
    phi[index] = value;
    prior.check_phi(phi);
    const auto [err, scale] = acceleration_error(prior, phi, s);
    // Measured: 0.6e-13 to 1.4e-13 rad/s^2 for every kind.
    EXPECT_LT(err, 1e-10) << kAllPhi[index] << " = " << value;
    // The change moves the accelerations by more than the tolerance: the test can fail.
    double moved = 0;
    for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
      const VectorXd x = s.x.row(i).transpose(), u = s.u.row(i).transpose();
      moved = std::max(
          moved, (prior.joint_accelerations(x, u, phi) - prior.joint_accelerations(x, u, file))
                     .cwiseAbs()
                     .maxCoeff());
    }
    EXPECT_GT(moved, 1e-3) << kAllPhi[index] << " = " << value << " does not act";
  }
}

TEST(DescriptionPrior, OneControlStepIsTenRk4SubstepsOfTheAnalyticModel) {
  const auto prior = dfki_prior();
  const States s = random_states(300, 5.0, 2.0, 3);
  for (const VectorXd& phi : {prior.default_phi(), changed_phi()}) {
    MatrixXd dX;
    prior.evaluate_batch(s.x, s.u, phi, dX);
    ASSERT_EQ(dX.rows(), 300);
    ASSERT_EQ(dX.cols(), 4);
    const DoublePendulumParams p = params_of(phi);
    double err = 0;
    for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
      const Eigen::Vector4d x = s.x.row(i).transpose();
      const Eigen::Vector4d ref = analytic_step(p, x, s.u.row(i).transpose()) - x;
      err = std::max(err, (dX.row(i).transpose() - ref).cwiseAbs().maxCoeff());
      // evaluate() gives the batch's row.
      if (i < 5) {
        VectorXd dx(4);
        prior.evaluate(x, s.u.row(i).transpose(), phi, dx);
        EXPECT_EQ(dx, VectorXd(dX.row(i).transpose()));
      }
    }
    // Measured: 1.8e-15 (rad, rad/s) with either phi.
    EXPECT_LT(err, 1e-11) << "phi = " << phi.transpose();
  }
}

TEST(DescriptionPrior, TwoSecondTrajectoriesAgreeWithTheAnalyticModel) {
  const auto prior = dfki_prior();
  const States s = random_states(20, 3.0, 1.0, 4);
  for (const VectorXd& phi : {prior.default_phi(), changed_phi()}) {
    const DoublePendulumParams p = params_of(phi);
    double err = 0;
    for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
      Eigen::Vector4d a = s.x.row(i).transpose();
      VectorXd b = a, dx(4);
      const Eigen::Vector2d u = s.u.row(i).transpose();
      for (int k = 0; k < 200; ++k) {
        a = analytic_step(p, a, u);
        prior.evaluate(b, u, phi, dx);
        b += dx;
        err = std::max(err, (b.head(2) - a.head<2>()).cwiseAbs().maxCoeff());
      }
    }
    // The motion is chaotic: agreement to round-off over 2 s means the same equations. Measured:
    // 8.9e-14 (file) and 1.7e-13 (changed) rad.
    EXPECT_LT(err, 1e-9) << "phi = " << phi.transpose();
  }
}

TEST(DescriptionPrior, EnergyIsConservedOverTwoSecondsWithoutFrictionDampingOrTorque) {
  auto prior = dfki_prior();
  VectorXd phi = prior.default_phi();
  phi[8] = phi[9] = phi[10] = phi[11] = 0.0;  // damping and friction
  const DoublePendulumParams p = params_of(phi);
  const States s = random_states(10, 3.0, 0.0, 5);
  double drift = 0, scale = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    VectorXd x = s.x.row(i).transpose(), dx(4);
    const double e0 = fixtures::energy(p, x);
    for (int k = 0; k < 200; ++k) {
      prior.evaluate(x, Eigen::Vector2d::Zero(), phi, dx);
      x += dx;
      drift = std::max(drift, std::abs(fixtures::energy(p, x) - e0));
    }
    scale = std::max(scale, std::abs(e0));
  }
  // RK4 at 1 ms: the drift is the integrator's. Measured: 1.9e-9 J, energies up to 4.9 J.
  EXPECT_LT(drift, 1e-7) << "largest |E0| " << scale;
  // With damping the energy falls: the check can fail.
  phi[8] = 0.08089;
  VectorXd x = s.x.row(0).transpose(), dx(4);
  const double e0 = fixtures::energy(p, x);
  for (int k = 0; k < 200; ++k) {
    prior.evaluate(x, Eigen::Vector2d::Zero(), phi, dx);
    x += dx;
  }
  EXPECT_LT(fixtures::energy(p, x), e0 - 1e-3);
}

TEST(DescriptionPrior, AnMjcfFileLoadsAndAgreesWithTheAnalyticModel) {
  // Two 1 m, 1 kg uniform rods (the analytic model's defaults), hinges about x.
  const std::string mjcf = R"(<mujoco model="rods">
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="1 0 0" damping="0.1" frictionloss="0.05"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.0833333333333333 0.0833333333333333 0.0833333333333333"/>
      <body name="lower" pos="0 0 -1">
        <joint name="elbow" type="hinge" axis="1 0 0" range="-1 1" limited="true"/>
        <inertial pos="0 0 -0.5" mass="1" diaginertia="0.0833333333333333 0.0833333333333333 0.0833333333333333"/>
      </body>
    </body>
  </worldbody>
  <actuator><position joint="elbow" kp="100"/></actuator>
</mujoco>)";
  DescriptionPriorOptions o;
  o.file = write_temp("rods.xml", mjcf);
  o.actuated = {"elbow"};
  o.parameters = {"lower.mass", "shoulder.damping", "shoulder.friction", "elbow.gear"};
  const DescriptionPrior prior(o);
  EXPECT_EQ(prior.joint_names(), (std::vector<std::string>{"shoulder", "elbow"}));
  EXPECT_EQ(prior.action_dim(), 1);
  const VectorXd phi = prior.default_phi();
  EXPECT_LT((phi - Eigen::Vector4d(1, 0.1, 0.05, 1)).cwiseAbs().maxCoeff(), 1e-12);
  DoublePendulumParams p;
  p.damping = {0.1, 0.0};
  p.coulomb = {0.05, 0.0};
  p.torque_scale = {0.0, 1.0};
  // The elbow's limit (+-1 rad) and the position actuator are off: states beyond it move freely.
  const States s = random_states(200, 5.0, 2.0, 6);
  double err = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    const VectorXd x = s.x.row(i).transpose();
    const Eigen::Vector2d u(0.0, s.u(i, 1));
    const VectorXd a = prior.joint_accelerations(x, u.tail(1), phi);
    err = std::max(err, (a - fixtures::joint_accelerations(p, x, u)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(err, 1e-10);  // measured: 1.4e-13 rad/s^2
}

TEST(DescriptionPrior, CollisionMeshesThatAreMissingAndCommentsDoNotMatter) {
  // The DFKI file's visual meshes are absent already; a collision mesh (also absent) and a
  // comment holding markup are dropped before MuJoCo sees the file.
  std::ifstream in(kDfki);
  std::string urdf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string link2 = "<link\n    name=\"Link2\">";
  const auto at = urdf.find(link2);
  ASSERT_NE(at, std::string::npos);
  urdf.insert(at + link2.size(),
              "\n<!-- <visual><geometry><box size=\"1 1 1\"/></geometry></visual> -->"
              "\n<collision><geometry><mesh filename=\"package://nowhere/Link2.stl\"/>"
              "</geometry></collision>\n<collision/>");
  DescriptionPriorOptions o;
  o.file = write_temp("with_collisions.urdf", urdf);
  o.parameters = kAllPhi;
  const DescriptionPrior prior(o);
  const auto reference = dfki_prior();
  const States s = random_states(20, 5.0, 2.0, 8);
  MatrixXd a, b;
  prior.evaluate_batch(s.x, s.u, changed_phi(), a);
  reference.evaluate_batch(s.x, s.u, changed_phi(), b);
  EXPECT_EQ(a, b);
}

TEST(DescriptionPrior, ANonFiniteStateGivesANonFiniteRowAndLeavesTheOthers) {
  const auto prior = dfki_prior();
  States s = random_states(3, 5.0, 2.0, 9);
  MatrixXd ref;
  prior.evaluate_batch(s.x, s.u, prior.default_phi(), ref);
  s.x(1, 0) = std::nan("");
  MatrixXd dX;
  prior.evaluate_batch(s.x, s.u, prior.default_phi(), dX);
  EXPECT_FALSE(dX.row(1).allFinite());
  EXPECT_EQ(dX.row(0), ref.row(0));
  EXPECT_EQ(dX.row(2), ref.row(2));
}

TEST(DescriptionPrior, ClonesAndTwoThreadsOnOneInstanceGiveTheSameNumbersAsOneThread) {
  const auto prior = dfki_prior();
  const States s = random_states(100, 5.0, 2.0, 7);
  const VectorXd phi_a = prior.default_phi(), phi_b = changed_phi();
  MatrixXd ref_a, ref_b;
  prior.evaluate_batch(s.x, s.u, phi_a, ref_a);
  prior.evaluate_batch(s.x, s.u, phi_b, ref_b);
  const auto copy = prior.clone();
  MatrixXd c;
  copy->evaluate_batch(s.x, s.u, phi_b, c);
  EXPECT_EQ(c, ref_b);
  // Two threads on one instance with different phi, many times over: each call has its own
  // workspace, so neither sees the other's phi.
  std::vector<MatrixXd> out_a(20), out_b(20);
  std::thread t([&] {
    for (auto& m : out_a) prior.evaluate_batch(s.x, s.u, phi_a, m);
  });
  for (auto& m : out_b) prior.evaluate_batch(s.x, s.u, phi_b, m);
  t.join();
  for (int k = 0; k < 20; ++k) {
    EXPECT_EQ(out_a[k], ref_a);
    EXPECT_EQ(out_b[k], ref_b);
  }
}

TEST(DescriptionPrior, BadFilesAndNamesGiveErrorsNamingTheFileAndTheItem) {
  DescriptionPriorOptions o;
  o.file = "/nonexistent/robot.urdf";
  std::string e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("/nonexistent/robot.urdf"), std::string::npos) << e;

  o.file = write_temp("broken.urdf", "<robot name=\"r\"><link name=\"a\"></robot>");
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("broken.urdf"), std::string::npos) << e;
  EXPECT_NE(e.find("does not load"), std::string::npos) << e;

  o.file =
      write_temp("model.sdf", "<?xml version=\"1.0\"?>\n<!-- <robot> -->\n<sdf version=\"1.6\"/>");
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("model.sdf"), std::string::npos) << e;
  EXPECT_NE(e.find("its root element is <sdf>"), std::string::npos) << e;

  e = error_of([] { dfki_prior({"Link3.mass"}); });
  EXPECT_NE(e.find(kDfki), std::string::npos) << e;
  EXPECT_NE(e.find("'Link3.mass'"), std::string::npos) << e;
  EXPECT_NE(e.find("base_link, Link1, Link2, Weight"), std::string::npos) << e;

  e = error_of([] { dfki_prior({"Joint3.damping"}); });
  EXPECT_NE(e.find("'Joint3'"), std::string::npos) << e;
  EXPECT_NE(e.find("Joint1, Joint2"), std::string::npos) << e;

  e = error_of([] { dfki_prior({"Link2.colour"}); });
  EXPECT_NE(e.find("'Link2.colour'"), std::string::npos) << e;
  EXPECT_NE(e.find("<body>.mass"), std::string::npos) << e;

  o.file = kDfki;
  o.joints = {"Joint1", "Elbow"};
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("'Elbow'"), std::string::npos) << e;
  EXPECT_NE(e.find("Joint1, Joint2"), std::string::npos) << e;
  o.joints = {"Joint2"};
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("'Joint1' is not in the state"), std::string::npos) << e;
  o.joints = {};

  o.actuated = {"Joint1"};
  o.parameters = {"Joint2.gear"};
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("'Joint2' is not driven"), std::string::npos) << e;
  o.actuated = {};

  const std::string floating = R"(<mujoco><worldbody><body name="torso"><freejoint name="base"/>
    <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody></mujoco>)";
  o.file = write_temp("floating.xml", floating);
  o.parameters = {};
  e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("floating.xml"), std::string::npos) << e;
  EXPECT_NE(e.find("'base' is free (a floating base)"), std::string::npos) << e;

  const auto prior = dfki_prior({"Link2.mass", "Link2.inertia", "Joint1.friction"});
  e = error_of([&] { prior.check_phi(Eigen::Vector3d(-0.1, 1, 0)); });
  EXPECT_NE(e.find("Link2.mass = -0.1"), std::string::npos) << e;
  e = error_of([&] { prior.check_phi(Eigen::Vector3d(0.5, 0, 0)); });
  EXPECT_NE(e.find("Link2.inertia = 0"), std::string::npos) << e;
  e = error_of([&] { prior.check_phi(Eigen::Vector2d(0.5, 1)); });
  EXPECT_NE(e.find("expected size 3, got 2"), std::string::npos) << e;
}

TEST(DescriptionPrior, BoundsOutsideAParametersPhysicalDomainAreRefusedNamingTheFileAndTheItem) {
  const auto prior =
      dfki_prior({"Link1.mass", "Link2.inertia", "Joint1.damping", "Link2.com.z", "Joint1.gear"});
  EXPECT_EQ(prior.parameter_index("Link2.inertia"), 1);
  EXPECT_EQ(prior.parameter_index("Link3.mass"), -1);
  const auto mass = prior.parameter_domain(0);
  EXPECT_EQ(mass.lower, 0.0);
  EXPECT_FALSE(mass.lower_open);
  EXPECT_EQ(mass.unit, "kg");
  EXPECT_TRUE(prior.parameter_domain(1).lower_open);
  EXPECT_EQ(prior.parameter_domain(2).unit, "N m s/rad");
  EXPECT_EQ(prior.parameter_domain(3).lower, -std::numeric_limits<double>::infinity());
  // Bounds inside the domains pass, the interval's edges included.
  EXPECT_NO_THROW(prior.check_bounds(0, 0.0, 2.0));
  EXPECT_NO_THROW(prior.check_bounds(1, 0.1, 3.0));
  EXPECT_NO_THROW(prior.check_bounds(3, -0.5, 0.5));
  EXPECT_NO_THROW(prior.check_bounds(4, -2.0, 2.0));
  std::string e = error_of([&] { prior.check_bounds(0, -0.1, 0.9); });
  EXPECT_NE(e.find(kDfki), std::string::npos) << e;
  EXPECT_NE(e.find("Link1.mass: bounds [-0.1, 0.9]: non-physical: a mass: >= 0 kg"),
            std::string::npos)
      << e;
  e = error_of([&] { prior.check_bounds(1, 0.0, 2.0); });
  EXPECT_NE(e.find("Link2.inertia: bounds [0, 2]: non-physical: an inertia scale"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("> 0"), std::string::npos) << e;
  e = error_of([&] { prior.check_bounds(2, 0.2, 0.1); });
  EXPECT_NE(e.find("expected lower <= upper"), std::string::npos) << e;
  e = error_of([&] { prior.check_bounds(3, 0.0, std::numeric_limits<double>::infinity()); });
  EXPECT_NE(e.find("expected finite bounds"), std::string::npos) << e;
  e = error_of([&] { prior.parameter_domain(5); });
  EXPECT_NE(e.find("parameter index 5"), std::string::npos) << e;
  // check_phi says the same domain.
  e = error_of([&] { prior.check_phi((VectorXd(5) << 0.5, -1, 0, 0, 1).finished()); });
  EXPECT_NE(e.find("Link2.inertia = -1: expected an inertia scale"), std::string::npos) << e;
}

TEST(DescriptionPrior, AFloatingJointOfAUrdfIsRefusedNamingTheFileAndTheJoint) {
  const std::string urdf = R"(<robot name="floater">
  <link name="world"/>
  <link name="torso"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="float" type="floating"><parent link="world"/><child link="torso"/></joint>
</robot>)";
  DescriptionPriorOptions o;
  o.file = write_temp("floater.urdf", urdf);
  const std::string e = error_of([&] { DescriptionPrior p(o); });
  EXPECT_NE(e.find("floater.urdf"), std::string::npos) << e;
  EXPECT_NE(e.find("is free (a floating base); the prior needs a fixed base"), std::string::npos)
      << e;
}

TEST(DescriptionPrior, MissingVisualMeshesAreAWarningNotAnError) {
  // The DFKI file names four visual meshes (./meshes/*.obj) that tests/data does not hold.
  const auto prior = dfki_prior({"Link2.mass"});
  ASSERT_EQ(prior.warnings().size(), 1u);
  const std::string& w = prior.warnings()[0];
  EXPECT_NE(w.find(kDfki), std::string::npos) << w;
  for (const char* mesh : {"./meshes/base_link.obj", "./meshes/Link1.obj", "./meshes/Link2.obj",
                           "./meshes/Weight.obj"})
    EXPECT_NE(w.find(mesh), std::string::npos) << w;
  // A mesh that exists is not listed; a package:// name is not resolved, hence not listed.
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "present.obj") << "v 0 0 0\n";
  const std::string urdf = R"(<robot name="one">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="present.obj"/></geometry></visual>
    <visual><geometry><mesh filename="package://robot/arm.dae"/></geometry></visual>
    <visual><geometry><mesh filename="absent/arm.stl" scale="1 1 1"/></geometry></visual></link>
  <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="1 0 0"/></joint>
</robot>)";
  DescriptionPriorOptions o;
  o.file = write_temp("one_mesh_missing.urdf", urdf);
  o.parameters = {"arm.mass"};
  const DescriptionPrior one(o);
  ASSERT_EQ(one.warnings().size(), 1u);
  EXPECT_NE(one.warnings()[0].find("the mesh files absent/arm.stl (of"), std::string::npos)
      << one.warnings()[0];
  // The prior works: the arm hanging still stays still.
  MatrixXd dX;
  one.evaluate_batch(MatrixXd::Zero(1, 2), MatrixXd::Zero(1, 1), one.default_phi(), dX);
  EXPECT_LT(dX.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(DescriptionPrior, AnEngineErrorIsThrownNamingTheFileAndTheProcessGoesOn) {
  // An mjData stack of 24 numbers: enough to compile the model and to step it with its tendons'
  // limits inactive (q = 0), too small for the constraint solver once the four limits are
  // active (q = 1 > 0.1): MuJoCo's mju_error("Stack overflow"), which would exit the process
  // without the prior's hook. (The prior turns joint limits off, not tendon limits.)
  std::string tendons;
  for (int k = 0; k < 4; ++k)
    tendons += "<fixed name=\"t" + std::to_string(k) +
               "\" limited=\"true\" range=\"-0.1 0.1\"><joint joint=\"hinge\" coef=\"1\"/></fixed>";
  const std::string mjcf = R"(<mujoco model="tiny_stack"><size nstack="24"/>
  <worldbody><body name="arm"><joint name="hinge" type="hinge" axis="1 0 0"/>
    <inertial pos="0 0 -0.5" mass="1" diaginertia="0.1 0.1 0.1"/></body></worldbody>
  <tendon>)" + tendons + "</tendon></mujoco>";
  DescriptionPriorOptions o;
  o.file = write_temp("tiny_stack.xml", mjcf);
  const DescriptionPrior prior(o);
  MatrixXd dX;
  prior.evaluate_batch(MatrixXd::Zero(1, 2), MatrixXd::Zero(1, 1), VectorXd(), dX);
  EXPECT_TRUE(dX.allFinite());
  const MatrixXd limits_active = (MatrixXd(1, 2) << 1.0, 0.0).finished();
  for (int k = 0; k < 2; ++k) {  // the second call on a fresh workspace fails the same way
    std::string e = "(no NumericalError thrown)";
    try {
      prior.evaluate_batch(limits_active, MatrixXd::Zero(1, 1), VectorXd(), dX);
    } catch (const NumericalError& err) {
      e = err.what();
    }
    EXPECT_NE(e.find("tiny_stack.xml"), std::string::npos) << e;
    EXPECT_NE(e.find("MuJoCo: Stack overflow"), std::string::npos) << e;
  }
  // The process and the prior go on.
  MatrixXd again;
  prior.evaluate_batch(MatrixXd::Zero(1, 2), MatrixXd::Zero(1, 1), VectorXd(), again);
  EXPECT_TRUE(again.allFinite());
}
