// The configuration side of a description-file prior (prior.model, issue 64): the grammar's
// errors, the relative path, the recorded digest, and the pendubot from its MJCF file
// (tasks/pendubot/data/pendubot.xml) against the hand-written prior: transitions and whole
// episodes of the same policy. Needs MuJoCo (DROPS_WITH_MUJOCO).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/description/experiment_factory.hpp"
#include "drops/experiment/description_prior.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "drops/pendubot/plugin.hpp"

using namespace drops;
namespace fs = std::filesystem;

namespace {

const std::string kFile = std::string(DROPS_SOURCE_DIR) + "/tasks/pendubot/data/pendubot.xml";

const experiment::Registry& registry() {
  static const std::unique_ptr<experiment::Registry> r = [] {
    auto reg = std::make_unique<experiment::Registry>();
    experiment::register_builtin_algorithms(*reg);
    pendubot::register_task(*reg);
    reg->set_description_prior_factory(description::experiment_factory());
    return reg;
  }();
  return *r;
}

/// The file's phi of a hand-written phi [m1, m2, l1, l2, b1, b2] (l1 = 0.5, the file's; b2 the
/// file's tendon damping): [Link1.mass, Link1.inertia, Link2.mass, Link2.inertia, Link2.com.z,
/// Joint1.damping], the inertia scales m l^2 / 12 over the file's 0.5 * 0.5^2 / 12.
std::string file_parameters(const VectorXd& hand) {
  std::ostringstream o;
  o.precision(17);
  o << "[{name: Link1.mass, bounds: [0.05, 1], value: " << hand[0] << "},"
    << " {name: Link1.inertia, bounds: [0.05, 4], value: " << 8 * hand[0] * hand[2] * hand[2]
    << "}, {name: Link2.mass, bounds: [0.05, 1], value: " << hand[1] << "},"
    << " {name: Link2.inertia, bounds: [0.01, 4], value: " << 8 * hand[1] * hand[3] * hand[3]
    << "}, {name: Link2.com.z, bounds: [0.025, 0.5], value: " << hand[3] / 2 << "},"
    << " {name: Joint1.damping, value: " << hand[4] << ", tunable: false}]";
  return o.str();
}

experiment::Experiment file_experiment(const VectorXd& hand, std::vector<std::string> more = {}) {
  std::vector<std::string> o = {"prior.model=" + kFile, "prior.parameters=" + file_parameters(hand),
                                "model.type=gp_mi"};
  o.insert(o.end(), more.begin(), more.end());
  return experiment::make_experiment(registry(), experiment::load_settings(registry(), "", o));
}

std::string error_of(const std::vector<std::string>& overrides) {
  try {
    experiment::make_experiment(registry(), experiment::load_settings(registry(), "", overrides));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

/// Table I's actual pendubot and prior A (tunable & useful) in the hand-written phi.
VectorXd actual() { return pendubot::preset("actual").to_phi(); }
VectorXd prior_a() { return pendubot::preset("tunable-useful").to_phi(); }

}  // namespace

// One step of every kind of state (hanging, upright, spinning; torques inside and beyond the
// clip) agrees with the hand-written equations to round-off: the same RK4 (5 substeps of 10 ms)
// on the same dynamics, MuJoCo's mass matrix and bias forces instead of the closed form.
TEST(PendubotFromFile, OneStepAgreesWithTheHandWrittenPriorAtTableIsValues) {
  for (const VectorXd& hand : {actual(), prior_a()}) {
    const auto e = file_experiment(hand);
    const pendubot::PendubotPrior ref;
    const VectorXd phi_file = e.setup.prior_parameters.values;
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> angle(-4, 4), speed(-12, 12), torque(-5, 5);
    MatrixXd X(200, 4), U(200, 1);
    for (int b = 0; b < 200; ++b) {
      X.row(b) << speed(gen), speed(gen), angle(gen), angle(gen);
      U(b, 0) = torque(gen);
    }
    MatrixXd dX;
    e.setup.prior->evaluate_batch(X, U, phi_file, dX);
    double worst = 0;
    for (int b = 0; b < 200; ++b) {
      VectorXd dx(4);
      ref.evaluate(X.row(b).transpose(), U.row(b).transpose(), hand, dx);
      worst = std::max(worst, (dX.row(b).transpose() - dx).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(worst, 1e-9) << "phi " << hand.transpose();
  }
}

// A whole episode (50 steps of 50 ms) of one network policy, each prior alone as the
// dynamics (x_{t+1} = x_t + M(x_t, u_t; phi)): the same states within 1e-7 rad and rad/s over
// the swing, where the errors of round-off grow along the trajectory.
TEST(PendubotFromFile, WholeEpisodesOfOnePolicyAgreeWithTheHandWrittenPrior) {
  for (const VectorXd& hand : {actual(), prior_a()}) {
    auto e = file_experiment(hand);
    const pendubot::PendubotPrior ref;
    const auto& task = *e.setup.task;
    Rng rng(3);
    for (int episode = 0; episode < 5; ++episode) {
      VectorXd theta(e.setup.policy->param_dim());
      for (Eigen::Index i = 0; i < theta.size(); ++i)
        theta[i] = std::uniform_real_distribution<double>(-1, 1)(rng);
      e.setup.policy->set_params(theta);
      VectorXd xa = task.initial_state(), xb = xa, obs(task.observation_dim()), u(1), dx(4);
      double worst = 0, reward_a = 0, reward_b = 0;
      for (int t = 0; t < task.horizon(); ++t) {
        task.observe(xa, obs);
        e.setup.policy->act(obs, t * task.dt(), u);
        e.setup.prior->evaluate(xa, u, e.setup.prior_parameters.values, dx);
        xa += dx;
        task.observe(xb, obs);
        e.setup.policy->act(obs, t * task.dt(), u);
        ref.evaluate(xb, u, hand, dx);
        xb += dx;
        worst = std::max(worst, (xa - xb).cwiseAbs().maxCoeff());
        reward_a += task.reward(xa);
        reward_b += task.reward(xb);
      }
      EXPECT_LT(worst, 1e-7) << "episode " << episode << ", phi " << hand.transpose();
      EXPECT_NEAR(reward_a, reward_b, 1e-7);
    }
  }
}

TEST(DescriptionPriorConfig, BuildsTheParametersTunableSetAndBoundsFromTheList) {
  const auto e = file_experiment(prior_a());
  const auto& p = e.setup.prior_parameters;
  EXPECT_EQ(p.names, (std::vector<std::string>{"Link1.mass", "Link1.inertia", "Link2.mass",
                                               "Link2.inertia", "Link2.com.z",
                                               "Joint1.damping"}));
  EXPECT_EQ(p.tunable, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_DOUBLE_EQ(p.values[0], 0.65);
  EXPECT_DOUBLE_EQ(p.values[4], 0.2);
  EXPECT_DOUBLE_EQ(p.lower[4], 0.025);
  EXPECT_DOUBLE_EQ(p.upper[3], 4);
  EXPECT_EQ(e.setup.prior_label, "pendubot.xml");
  EXPECT_TRUE(std::isnan(e.setup.phi_actual.at(0)));
  EXPECT_EQ(e.default_run_name(""), "pendubot-gp_mi-pendubot.xml-seed1");
}

// A value left out is the file's: Link2.com.z = 0.25 m, Joint1.damping = 0.1 N m s.
TEST(DescriptionPriorConfig, AValueLeftOutIsTheFilesValue) {
  const auto e = experiment::make_experiment(
      registry(), experiment::load_settings(
                      registry(), "",
                      {"prior.model=" + kFile,
                       "prior.parameters=[{name: Link2.com.z, bounds: [0.1, 0.4]}, "
                       "{name: Joint1.damping, tunable: false}]"}));
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[0], 0.25);
  EXPECT_DOUBLE_EQ(e.setup.prior_parameters.values[1], 0.1);
  EXPECT_EQ(e.setup.prior_parameters.tunable, (std::vector<int>{0}));
}

TEST(DescriptionPriorConfig, AFileThatCannotBeReadIsRefusedNamingIt) {
  const std::string m = error_of({"prior.model=/nonexistent/robot.urdf"});
  EXPECT_NE(m.find("prior.model"), std::string::npos) << m;
  EXPECT_NE(m.find("/nonexistent/robot.urdf"), std::string::npos) << m;
}

TEST(DescriptionPriorConfig, AnUnknownNameListsTheNamesTheFileHas) {
  const std::string m =
      error_of({"prior.model=" + kFile, "prior.parameters=[{name: Link3.mass, bounds: [0, 1]}]"});
  EXPECT_NE(m.find("Link3"), std::string::npos) << m;
  EXPECT_NE(m.find("Link1, Link2"), std::string::npos) << m;
  EXPECT_NE(m.find("pendubot.xml"), std::string::npos) << m;
  const std::string j = error_of(
      {"prior.model=" + kFile, "prior.parameters=[{name: Joint7.damping, bounds: [0, 1]}]"});
  EXPECT_NE(j.find("Joint1, Joint2"), std::string::npos) << j;
}

TEST(DescriptionPriorConfig, ANonPhysicalBoundIsRefusedNamingTheFileAndTheParameter) {
  const std::string m = error_of(
      {"prior.model=" + kFile, "prior.parameters=[{name: Link1.mass, bounds: [-0.1, 1]}]"});
  EXPECT_NE(m.find("lower bound of Link1.mass"), std::string::npos) << m;
  EXPECT_NE(m.find("pendubot.xml"), std::string::npos) << m;
  const std::string i = error_of(
      {"prior.model=" + kFile, "prior.parameters=[{name: Link2.inertia, bounds: [-1, 2]}]"});
  EXPECT_NE(i.find("lower bound of Link2.inertia"), std::string::npos) << i;
  // A starting value outside the prior's domain, with the parameter fixed (no bounds).
  const std::string v = error_of({"prior.model=" + kFile,
                                  "prior.parameters=[{name: Joint1.damping, value: -1, "
                                  "tunable: false}]"});
  EXPECT_NE(v.find("starting values"), std::string::npos) << v;
  EXPECT_NE(v.find("Joint1.damping"), std::string::npos) << v;
}

TEST(DescriptionPriorConfig, EntriesWithoutBoundsNamesOrKnownFieldsAreRefused) {
  const auto error = [](const std::string& list) {
    return error_of({"prior.model=" + kFile, "prior.parameters=" + list});
  };
  EXPECT_NE(error("[{name: Link1.mass}]").find("needs bounds"), std::string::npos);
  EXPECT_NE(error("[{bounds: [0, 1]}]").find("no name"), std::string::npos);
  EXPECT_NE(error("[{name: Link1.mass, bound: [0, 1]}]").find("unknown field 'bound'"),
            std::string::npos);
  EXPECT_NE(error("[{name: Link1.mass, bounds: [1, 0]}]").find("lower < upper"),
            std::string::npos);
  EXPECT_NE(error("[{name: Link1.mass, bounds: [0, 1], value: 2}]").find("outside its bounds"),
            std::string::npos);
  EXPECT_NE(error("[{name: Link1.mass, bounds: [0, 1]}, {name: Link1.mass, bounds: [0, 1]}]")
                .find("listed twice"),
            std::string::npos);
  EXPECT_NE(error("[{name: Link1.mass, bounds: [0.6, 1]}]").find("the file's value 0.5"),
            std::string::npos);
  EXPECT_NE(error("{name: Link1.mass}").find("expected a list"), std::string::npos);
}

// prior.model relative to the configuration file's directory, then the working directory; the
// run records the file's digest, which changes with its bytes (a resume is then refused).
TEST(DescriptionPriorConfig, ARelativePathIsTheConfigFilesAndTheDigestFollowsTheBytes) {
  const fs::path dir = fs::temp_directory_path() / ("drops-desc-config-" + std::to_string(::getpid()));
  fs::create_directories(dir / "robot");
  fs::copy_file(kFile, dir / "robot" / "p.xml", fs::copy_options::overwrite_existing);
  std::ofstream(dir / "run.yaml") << "prior:\n  model: robot/p.xml\n  parameters:\n"
                                     "    - {name: Link1.mass, bounds: [0.1, 1]}\n";
  const auto s = experiment::load_settings_file(registry(), (dir / "run.yaml").string(), {});
  EXPECT_EQ(fs::path(s.at("prior.model")), (dir / "robot" / "p.xml").lexically_normal());
  const auto digest = [&] {
    return experiment::make_experiment(registry(), s).setup.declaration.at("prior.model.sha256");
  };
  const std::string before = digest();
  EXPECT_EQ(before.size(), 64u);
  std::ofstream(dir / "robot" / "p.xml", std::ios::app) << "<!-- changed -->\n";
  EXPECT_NE(digest(), before);
  fs::remove_all(dir);
}

TEST(DescriptionPriorConfig, ParametersWithoutAFileAreRefused) {
  const std::string m = error_of({"prior.parameters=[{name: Link1.mass, bounds: [0, 1]}]"});
  EXPECT_NE(m.find("prior.model is empty"), std::string::npos) << m;
}

TEST(DescriptionPriorConfig, ATaskWithoutAPriorModelKeepsItsOwnPrior) {
  const auto e =
      experiment::make_experiment(registry(), experiment::load_settings(registry(), "", {}));
  EXPECT_EQ(e.setup.prior_parameters.names.front(), "m1");
  EXPECT_EQ(e.setup.declaration.count("prior.model"), 0u);
}
