// identify() (issue 68): the open-loop errors against a naive oracle, MI's phi against the
// system that wrote the log, the subsample of the final fit, phi's posterior with a parameter at
// its bound, and the checks of its inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/identify.hpp"

namespace drops {
namespace {

using experiment::IdentifyModel;
using experiment::IdentifyOptions;
using experiment::LogColumns;
using experiment::LogTable;
using experiment::RecordedLog;

constexpr double kDt = 0.01;

// A damped mass driven by a gain: x = [p, v], dx = [v dt, (gain u - damping v) dt] (explicit
// Euler, the log's exact dynamics). phi = [gain, damping]; a negative damping is refused.
class DrivenMass final : public model::MeanFunction {
 public:
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"gain", "damping"}; }
  void check_phi(const VectorXd& phi) const override {
    if (phi.size() != 2 || phi[1] < 0) throw InvalidArgument("damping < 0");
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    dx[0] = x[1] * kDt;
    dx[1] = (phi[0] * u[0] - phi[1] * x[1]) * kDt;
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<DrivenMass>();
  }
};

LogColumns mass_columns() {
  LogColumns c;
  c.state = {{"p", experiment::LogQuantity::kOther, "", ""},
             {"v", experiment::LogQuantity::kOther, "", ""}};
  c.action = {"u"};
  return c;
}

// A log of K steps of the driven mass at phi, one row per step (time k dt in integer ms so that
// the resampled grid holds every row).
RecordedLog mass_log(const VectorXd& phi, int K, std::uint64_t seed, const std::string& name) {
  Rng rng(seed);
  DrivenMass m;
  LogTable t;
  t.source = name;
  t.columns = {"time", "p", "v", "u"};
  t.values.resize(K + 1, 4);
  VectorXd x = VectorXd::Zero(2), u(1), dx(2);
  for (int k = 0; k <= K; ++k) {
    u[0] = std::sin(0.05 * k) + 0.5 * rng.normal();
    t.values.row(k) << k * 10.0, x[0], x[1], u[0];
    m.evaluate(x, u, phi, dx);
    x += dx;
  }
  experiment::LogOptions o;
  o.dt = kDt;
  o.time_scale = 1e-3;
  return experiment::resample_log(t, mass_columns(), o);
}

model::PriorParameters mass_parameters(double gain, double damping) {
  model::PriorParameters p;
  p.names = {"gain", "damping"};
  p.values = (VectorXd(2) << gain, damping).finished();
  p.tunable = {0, 1};
  p.lower = (VectorXd(2) << 0.1, 0.0).finished();
  p.upper = (VectorXd(2) << 10.0, 5.0).finished();
  p.choices.assign(2, {});
  return p;
}

IdentifyModel mass_model(model::ModelType type, double gain, double damping) {
  IdentifyModel m;
  m.type = model::to_string(type);
  m.options.type = type;
  m.task = experiment::feature_task(2, 1, kDt);
  m.prior = std::make_shared<DrivenMass>();
  m.parameters = mass_parameters(gain, damping);
  return m;
}

IdentifyOptions mass_options() {
  IdentifyOptions o;
  o.logs = {"fit"};
  o.columns = mass_columns();
  o.log.dt = kDt;
  o.log.time_scale = 1e-3;
  o.horizons = {0.1, 0.5};
  o.start_spacing = 0.25;
  o.threads = 2;
  return o;
}

double naive_quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - lo) * (v[hi] - v[lo]);
}

TEST(Identify, OpenLoopErrorsAreTheMedianAndP90OfNaiveRolloutsFromEveryStartPoint) {
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const RecordedLog log = mass_log(truth, 300, 7, "val");
  ASSERT_EQ(log.segments.size(), 1u);
  const auto& seg = log.segments[0];
  const int K = seg.transitions();
  ASSERT_EQ(K, 300);
  auto wrong =
      model::make_prior_only_model(std::make_shared<DrivenMass>(), mass_parameters(1.5, 1.0));
  const auto rows = experiment::prediction_errors(*wrong, log, "val", {0.1, 0.5}, 0.25);
  ASSERT_EQ(rows.size(), 6u);  // (one step, 0.1 s, 0.5 s) x 2 states
  for (const auto& r : rows) {
    // The oracle: a rollout per start (every 25 steps; every step for one step).
    const int spacing = r.steps == 1 ? 1 : 25;
    std::vector<double> e;
    for (int k = 0; k + r.steps <= K; k += spacing) {
      const MatrixXd x = experiment::open_loop_rollout(*wrong, seg.x.row(k).transpose(),
                                                       seg.u.middleRows(k, r.steps));
      e.push_back(std::abs(x(r.steps, r.dim) - seg.x(k + r.steps, r.dim)));
    }
    EXPECT_EQ(r.n, static_cast<int>(e.size())) << r.horizon;
    EXPECT_NEAR(r.median, naive_quantile(e, 0.5), 1e-12) << r.horizon << " " << r.state;
    EXPECT_NEAR(r.p90, naive_quantile(e, 0.9), 1e-12) << r.horizon << " " << r.state;
    if (r.steps > 1 || r.dim == 1) EXPECT_GT(r.median, 0);  // one step of p: v dt, exact
  }
  // The system that wrote the log predicts it exactly.
  auto right =
      model::make_prior_only_model(std::make_shared<DrivenMass>(), mass_parameters(2.0, 0.5));
  for (const auto& r : experiment::prediction_errors(*right, log, "val", {0.1, 0.5}, 0.25))
    EXPECT_LT(r.p90, 1e-9) << r.horizon << " " << r.state;
}

TEST(Identify, MiRecoversThePhiThatWroteTheLogsAndBeatsThePriorOnValidation) {
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 400, 1, "fit")};
  const std::vector<RecordedLog> val = {mass_log(truth, 200, 2, "val")};
  std::vector<std::string> lines;
  const auto r =
      experiment::identify(mass_model(model::ModelType::kMi, 1.0, 2.0), fit, val, mass_options(),
                           [&](const std::string& s) { lines.push_back(s); });
  EXPECT_NEAR(r.summary.phi[0], 2.0, 1e-3);
  EXPECT_NEAR(r.summary.phi[1], 0.5, 1e-3);
  EXPECT_EQ(r.summary.points, 400);
  EXPECT_FALSE(lines.empty());
  ASSERT_EQ(r.summary.errors.size(), r.summary.prior_errors.size());
  for (std::size_t k = 0; k < r.summary.errors.size(); ++k) {
    EXPECT_LT(r.summary.errors[k].median, 1e-4);
    if (r.summary.errors[k].steps > 1)
      EXPECT_GT(r.summary.prior_errors[k].median, 100 * r.summary.errors[k].median);
  }
}

TEST(Identify, MaxPointsLearnsFromTheEvenlySpacedSubset) {
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 400, 1, "fit")};
  IdentifyOptions o = mass_options();
  o.max_points = 100;
  const auto r = experiment::identify(mass_model(model::ModelType::kGp, 1, 1), fit, {}, o);
  EXPECT_EQ(r.summary.transitions, 400);
  EXPECT_EQ(r.summary.points, 100);
  ASSERT_EQ(r.data.size(), 100u);
  const auto all = fit[0].transitions();
  for (int k = 0; k < 100; ++k)  // model::subsample: rows floor(k N / m)
    EXPECT_EQ(r.data[static_cast<std::size_t>(k)].x, all[static_cast<std::size_t>(4 * k)].x);
  EXPECT_EQ(r.summary.model.points, 100);
  EXPECT_TRUE(r.summary.phi.size() == 0);
}

TEST(Identify, GpMiPosteriorIsFiniteForTheParametersOffTheirBoundsWhenOneSitsOnIt) {
  // No damping: GP-MI puts it on its lower bound 0, where a stencil step would be refused.
  const VectorXd truth = (VectorXd(2) << 2.0, 0.0).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 150, 3, "fit")};
  const auto r =
      experiment::identify(mass_model(model::ModelType::kGpMi, 1.0, 0.0), fit, {}, mass_options());
  EXPECT_NEAR(r.summary.phi[0], 2.0, 0.05);
  EXPECT_EQ(r.summary.phi[1], 0.0);
  EXPECT_TRUE(std::isfinite(r.summary.phi_lower95[0]));
  EXPECT_LT(r.summary.phi_lower95[0], r.summary.phi[0]);
  EXPECT_GT(r.summary.phi_upper95[0], r.summary.phi[0]);
  EXPECT_TRUE(std::isnan(r.summary.phi_lower95[1]));  // held at its bound
  EXPECT_EQ(r.summary.model.phi_posterior.names, std::vector<std::string>{"gain"});
}

TEST(Identify, RefusesAPriorOrTaskWhoseDtOrDimensionsDifferFromTheLogs) {
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 50, 1, "fit")};
  IdentifyModel m = mass_model(model::ModelType::kMi, 1, 1);
  m.prior_dt = 0.02;
  EXPECT_THROW(experiment::identify(m, fit, {}, mass_options()), InvalidArgument);
  m = mass_model(model::ModelType::kMi, 1, 1);
  m.task = experiment::feature_task(2, 1, 0.02);
  EXPECT_THROW(experiment::identify(m, fit, {}, mass_options()), InvalidArgument);
  m.task = experiment::feature_task(3, 1, kDt);
  EXPECT_THROW(experiment::identify(m, fit, {}, mass_options()), InvalidArgument);
  m = mass_model(model::ModelType::kGpMi, 1, 1);
  m.prior = nullptr;
  EXPECT_THROW(experiment::identify(m, fit, {}, mass_options()), InvalidArgument);
  IdentifyOptions o = mass_options();
  o.horizons = {0.5, 0.1};
  EXPECT_THROW(experiment::identify(mass_model(model::ModelType::kMi, 1, 1), fit, {}, o),
               InvalidArgument);
  EXPECT_THROW(experiment::feature_task(2, 1, 0.0), InvalidArgument);
  EXPECT_THROW(experiment::feature_task(2, 1, kDt, {3, nullptr}), InvalidArgument);
}

// The saved model (model.json + data.csv) loaded again predicts what the fitted one does, mean
// and variance, without learning: for each built-in variant, on states of another log.
TEST(Identify, LoadedModelPredictsAsTheFittedOneWithoutRefitting) {
  namespace fs = std::filesystem;
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 120, 1, "fit")};
  const RecordedLog val = mass_log(truth, 60, 2, "val");
  const auto& seg = val.segments.at(0);
  for (const auto type : {model::ModelType::kGp, model::ModelType::kGpPrior,
                          model::ModelType::kGpMi, model::ModelType::kMi}) {
    const IdentifyModel what = mass_model(type, 1.5, 1.0);
    const auto r = experiment::identify(what, fit, {}, mass_options());
    const fs::path dir = fs::path(::testing::TempDir()) / ("identify-load-" + what.type);
    fs::remove_all(dir);
    experiment::write_identify_directory(dir, r, mass_options(), "{}\n");
    const auto loaded = experiment::load_identified_model(dir, what);
    EXPECT_EQ(loaded->phi(), r.model->phi()) << what.type;
    Prediction a, b;
    double worst = 0;
    for (Eigen::Index k = 0; k < seg.u.rows(); ++k) {
      const VectorXd x = seg.x.row(k).transpose() + VectorXd::Constant(2, 0.01 * k);
      r.model->predict(x, seg.u.row(k).transpose(), a);
      loaded->predict(x, seg.u.row(k).transpose(), b);
      worst = std::max(
          {worst, (a.mean - b.mean).cwiseAbs().maxCoeff(), (a.var - b.var).cwiseAbs().maxCoeff()});
    }
    EXPECT_LE(worst, 1e-12) << what.type;
    // The starting model (not learned) predicts otherwise: the comparison can fail.
    if (type != model::ModelType::kGp) {
      auto fresh =
          model::make_prior_only_model(std::make_shared<DrivenMass>(), mass_parameters(1.5, 1.0));
      fresh->predict(seg.x.row(5).transpose(), seg.u.row(5).transpose(), b);
      r.model->predict(seg.x.row(5).transpose(), seg.u.row(5).transpose(), a);
      EXPECT_GT((a.mean - b.mean).cwiseAbs().maxCoeff(), 1e-6) << what.type;
    }
  }
}

TEST(Identify, LoadRefusesAnotherModelTypeOrACutDataFileNamingTheFile) {
  namespace fs = std::filesystem;
  const VectorXd truth = (VectorXd(2) << 2.0, 0.5).finished();
  const std::vector<RecordedLog> fit = {mass_log(truth, 60, 1, "fit")};
  const IdentifyModel what = mass_model(model::ModelType::kGpPrior, 2.0, 0.5);
  const auto r = experiment::identify(what, fit, {}, mass_options());
  const fs::path dir = fs::path(::testing::TempDir()) / "identify-load-bad";
  fs::remove_all(dir);
  experiment::write_identify_directory(dir, r, mass_options(), "{}\n");
  try {
    experiment::load_identified_model(dir, mass_model(model::ModelType::kGp, 2.0, 0.5));
    ADD_FAILURE() << "a gp_prior model loaded as gp";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("model.json"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "data.csv", std::ios::app) << "1,2\n";
  try {
    experiment::load_identified_model(dir, what);
    ADD_FAILURE() << "a data.csv with a short line loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("data.csv: line 62 has 2 values, expected 5"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace drops
