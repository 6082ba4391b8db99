// drops identify on a real robot (issue 68): the shipped subset of the DFKI double pendulum's
// recordings (tests/data/double-pendulum-dfki: the first 3 s of trajectory_00 to fit, the first
// 2 s of trajectory_01 to validate), the lab's URDF as the prior (drops::description), six phi;
// and the same through a `task: none` configuration (identify_from_settings).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "drops/description/description_prior.hpp"
#include "drops/description/experiment_factory.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/identify.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/pendubot/plugin.hpp"

namespace drops {
namespace {

using description::DescriptionPrior;
using description::DescriptionPriorOptions;
using experiment::IdentifyModel;
using experiment::IdentifyOptions;
using experiment::IdentifyResult;
using experiment::LogQuantity;

const std::string kDir = DROPS_TEST_DATA "/double-pendulum-dfki/";

// The columns of the recordings: angles from hanging (rad) and measured torques (N m); the
// velocities are the Savitzky-Golay derivative of the angles over 20 ms (recorded_log.hpp), in
// the prior's state order [q1, q2, qd1, qd2].
IdentifyOptions dfki_options() {
  IdentifyOptions o;
  o.logs = {kDir + "trajectory_00_first3s.csv"};
  o.validation = {kDir + "trajectory_01_first2s.csv"};
  o.columns.time = "time";
  o.columns.state = {{"pos_meas1", LogQuantity::kAngle, "", ""},
                     {"pos_meas2", LogQuantity::kAngle, "", ""},
                     {"", LogQuantity::kVelocity, "pos_meas1", "vel1"},
                     {"", LogQuantity::kVelocity, "pos_meas2", "vel2"}};
  o.log.derivative_window = 0.02;
  o.columns.action = {"tau_meas1", "tau_meas2"};
  o.log.dt = 0.01;
  o.horizons = {0.1, 0.5, 1.0};
  o.start_spacing = 0.25;
  o.threads = 2;
  return o;
}

// The URDF with six tunable phi: the two inertia scales, damping and Coulomb friction of both
// joints (bounds from 0: a parameter may sit at its bound).
IdentifyModel dfki_model(model::ModelType type) {
  DescriptionPriorOptions po;
  po.file = kDir + "double_pendulum.urdf";
  po.parameters = {"Link1.inertia",  "Link2.inertia",   "Joint1.damping",
                   "Joint2.damping", "Joint1.friction", "Joint2.friction"};
  auto prior = std::make_shared<DescriptionPrior>(po);
  IdentifyModel m;
  m.type = model::to_string(type);
  m.options.type = type;
  m.task = experiment::feature_task(4, 2, 0.01);
  m.prior = prior;
  m.prior_dt = po.dt;
  m.parameters.names = prior->parameter_names();
  m.parameters.values = prior->default_phi();
  m.parameters.tunable = {0, 1, 2, 3, 4, 5};
  m.parameters.lower = (VectorXd(6) << 0.01, 0.01, 0, 0, 0, 0).finished();
  m.parameters.upper = (VectorXd(6) << 2, 2, 0.5, 0.5, 0.5, 0.5).finished();
  m.parameters.choices.assign(6, {});
  return m;
}

double median_at(const std::vector<experiment::PredictionErrors>& e, double h, int dim) {
  for (const auto& r : e)
    if (r.horizon == h && r.dim == dim) return r.median;
  return -1;
}

// Identification is deterministic (no random stream: Rprop, Subplex, an evenly spaced
// subsample), so one run stands for every seed. The derivative window (20 ms) is the one
// docs/results/double-pendulum.md chose on fit recordings only (fit 00, 01, 04, checked on 02,
// against 10 ms); phi and bounds are that page's first candidate set (with the dampings). Measured (2 cores, about 4 s): gp_mi's median open-loop angle errors at
// 0.5 s are 0.057 and 0.124 rad against the URDF's 0.100 and 0.426 (ratios 0.57 and 0.29), at
// 1.0 s 0.048 and 0.118 against 0.120 and 0.265 (0.40 and 0.44); the threshold asks for 0.75 (a
// broken identification stays near the URDF's, 1).
TEST(IdentifyDfki, GpMiPredictsTheValidationRecordingBetterThanTheUrdfAtHalfASecondAndOne) {
  const IdentifyModel m = dfki_model(model::ModelType::kGpMi);
  const IdentifyResult r = experiment::identify(m, dfki_options());
  std::printf("%s", r.summary.BriefReport().c_str());
  ASSERT_EQ(r.summary.transitions, 299);  // 3 s from the first row's time, at 10 ms
  ASSERT_EQ(r.summary.validation_reports.size(), 1u);
  for (double h : {0.5, 1.0})
    for (int dim : {0, 1}) {
      const double model = median_at(r.summary.errors, h, dim);
      const double prior = median_at(r.summary.prior_errors, h, dim);
      std::printf("%g s, q%d: gp_mi %.4f rad, URDF %.4f rad\n", h, dim + 1, model, prior);
      EXPECT_LT(model, 0.75 * prior) << "horizon " << h << " s, angle " << dim + 1;
    }
  // phi's posterior: finite for the parameters off their bounds, even with one at a bound.
  const auto& s = r.summary;
  int finite = 0;
  for (Eigen::Index i = 0; i < s.phi.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double width = m.parameters.upper[i] - m.parameters.lower[i];
    const bool at_bound = s.phi[i] <= m.parameters.lower[i] + 1e-3 * width ||
                          s.phi[i] >= m.parameters.upper[i] - 1e-3 * width;
    if (!at_bound) {
      EXPECT_TRUE(std::isfinite(s.phi_lower95[i])) << s.phi_names[k];
      EXPECT_LE(s.phi_lower95[i], s.phi[i]);
      EXPECT_GE(s.phi_upper95[i], s.phi[i]);
    }
    finite += std::isfinite(s.phi_lower95[i]) ? 1 : 0;
  }
  EXPECT_GE(finite, 4);
}

// drops identify without a task (task: none): the URDF's joints are the state, their torques the
// action; mi with a short search on the subset, through identify_from_settings (the command line's
// and Python's path). The prior at its start is the baseline the identified phi must beat.
TEST(IdentifyDfki, ATaskNoneConfigurationIdentifiesTheUrdfsJointsFromTheirLogs) {
  experiment::Registry reg;
  experiment::register_builtin_algorithms(reg);
  pendubot::register_task(reg);
  reg.set_description_prior_factory(description::experiment_factory());
  const std::string out = ::testing::TempDir() + "identify-dfki-none";
  const std::string yaml =
      "task: none\n"
      "model: {type: mi, mi: {max_evaluations: 300}}\n"
      "prior:\n"
      "  model: " +
      kDir +
      "double_pendulum.urdf\n"
      "  parameters:\n"
      "    - {name: Link1.inertia, bounds: [0.01, 2]}\n"
      "    - {name: Link2.inertia, bounds: [0.01, 2]}\n"
      "identify:\n"
      "  dt: 0.01\n"
      "  logs: [" +
      kDir +
      "trajectory_00_first3s.csv]\n"
      "  validation: [" +
      kDir +
      "trajectory_01_first2s.csv]\n"
      "  columns: {state: [pos_meas1, pos_meas2, d/dt(pos_meas1), d/dt(pos_meas2)], angles: "
      "[pos_meas1, pos_meas2], action: [tau_meas1, tau_meas2]}\n"
      "  derivative_window: 0.02\n"
      "output: " +
      out + "\n";
  const experiment::Settings st = experiment::load_settings(reg, yaml, {});
  const experiment::IdentifyRun run = experiment::identify_from_settings(reg, st);
  const auto& s = run.result.summary;
  EXPECT_EQ(s.state_names,
            (std::vector<std::string>{"pos_meas1", "pos_meas2", "Joint1_vel", "Joint2_vel"}));
  EXPECT_EQ(s.action_names, (std::vector<std::string>{"tau_meas1", "tau_meas2"}));
  EXPECT_EQ(run.directory.filename().string(), "identify-double_pendulum-mi");
  ASSERT_EQ(s.phi.size(), 2);
  for (int dim : {0, 1})
    EXPECT_LT(median_at(s.errors, 0.5, dim), 0.8 * median_at(s.prior_errors, 0.5, dim)) << dim;
  // Without prior.model, or without identify.dt, nothing runs; drops run refuses task none.
  EXPECT_THROW(
      experiment::identify_from_settings(
          reg, experiment::load_settings(reg, yaml, {"prior.model=", "prior.parameters=[]"})),
      ConfigError);
  EXPECT_THROW(experiment::identify_from_settings(
                   reg, experiment::load_settings(reg, yaml, {"identify.dt=0"})),
               ConfigError);
  EXPECT_THROW(experiment::make_experiment(reg, st), ConfigError);
  EXPECT_THROW(experiment::identify_from_settings(
                   reg, experiment::load_settings(reg, yaml, {"prior.joints=[Joint3]"})),
               ConfigError);
}

}  // namespace
}  // namespace drops
