#include "drops/realaigym/score.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/realaigym/plant.hpp"

namespace drops::realaigym {

namespace {

void check_samples(const char* what, Eigen::Index n) {
  if (n < 2) {
    throw InvalidArgument(std::string(what) + ": a trajectory needs at least 2 samples, got " +
                          std::to_string(n));
  }
}

void check_columns(const char* what, const MatrixXd& m, Eigen::Index cols, Eigen::Index rows) {
  check_size((std::string(what) + ": columns").c_str(), cols, m.cols());
  check_size((std::string(what) + ": rows").c_str(), rows, m.rows());
}

// Population standard deviation (numpy's std, ddof = 0).
double population_std(const VectorXd& v) {
  if (v.size() == 0) return 0.0;
  const double mean = v.mean();
  return std::sqrt((v.array() - mean).square().mean());
}

bool in_range(double v, double lo) { return std::isfinite(v) && v >= lo; }

}  // namespace

bool ScoreDefinition::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  const std::pair<const char*, double CriterionValues::*> fields[] = {
      {"swingup_time", &CriterionValues::swingup_time},
      {"energy", &CriterionValues::energy},
      {"max_tau", &CriterionValues::max_tau},
      {"integrated_tau", &CriterionValues::integrated_tau},
      {"tau_cost", &CriterionValues::tau_cost},
      {"tau_smoothness", &CriterionValues::tau_smoothness},
      {"velocity_cost", &CriterionValues::velocity_cost}};
  for (const auto& [name, field] : fields) {
    if (!in_range(weights.*field, 0.0))
      return fail(std::string("weight of ") + name + " must be >= 0");
    if (weights.*field != 0.0 && !(in_range(normalization.*field, 0.0) && normalization.*field > 0))
      return fail(std::string("normalization of ") + name + " must be > 0 (its weight is not 0)");
  }
  if (!(in_range(link1_length, 0.0) && link1_length > 0)) return fail("link1_length must be > 0");
  if (!(in_range(link2_length, 0.0) && link2_length > 0)) return fail("link2_length must be > 0");
  if (!std::isfinite(height_fraction)) return fail("height_fraction must be finite");
  if (!(in_range(t_final, 0.0) && t_final > 0)) return fail("t_final must be > 0");
  return true;
}

ScoreDefinition simulation_v1() {
  ScoreDefinition d;
  d.name = "simulation_v1";
  d.formula = ScoreFormula::kLinear;
  d.rows_after_step = true;
  d.weights = {.swingup_time = 0.2,
               .energy = 0.1,
               .max_tau = 0.1,
               .integrated_tau = 0.1,
               .tau_cost = 0.1,
               .tau_smoothness = 0.2,
               .velocity_cost = 0.2};
  d.normalization = {.swingup_time = 10.0,
                     .energy = 100.0,
                     .max_tau = 6.0,
                     .integrated_tau = 60.0,
                     .tau_cost = 360.0,
                     .tau_smoothness = 12.0,
                     .velocity_cost = 1000.0};
  const PlantParameters plant = design_a0_model_2_0();
  d.link1_length = plant.length[0];
  d.link2_length = plant.length[1];
  return d;
}

ScoreDefinition simulation_v2() {
  ScoreDefinition d;
  d.name = "simulation_v2";
  d.formula = ScoreFormula::kTanh;
  d.weights = {.swingup_time = 1.0,
               .energy = 1.0,
               .max_tau = 0.0,
               .integrated_tau = 0.0,
               .tau_cost = 1.0,
               .tau_smoothness = 1.0,
               .velocity_cost = 1.0};
  d.normalization = {.swingup_time = 20.0,
                     .energy = 60.0,
                     .max_tau = 1.0,
                     .integrated_tau = 1.0,
                     .tau_cost = 20.0,
                     .tau_smoothness = 0.1,
                     .velocity_cost = 400.0};
  const PlantParameters plant = design_c1_model_1_0();
  d.link1_length = plant.length[0];
  d.link2_length = plant.length[1];
  return d;
}

double swingup_time(const VectorXd& t, const MatrixXd& x, double l1, double l2,
                    double height_fraction, double t_final) {
  const Eigen::Index n = t.size();
  check_samples("swingup_time", n);
  check_columns("swingup_time: x", x, 4, n);
  if (t[n - 1] < 0.99 * t_final) return std::numeric_limits<double>::infinity();
  const double goal_height = height_fraction * (l1 + l2);
  Eigen::Index first_up = n - 1;
  for (Eigen::Index i = n - 2; i >= 1; --i) {
    const double height = end_effector_position(l1, l2, x.row(i).head<2>().transpose())[1];
    if (!(height > goal_height)) break;
    first_up = i;
  }
  return t[first_up];
}

double energy(const MatrixXd& x, const MatrixXd& tau) {
  const Eigen::Index n = x.rows();
  check_samples("energy", n);
  check_columns("energy: x", x, 4, n);
  check_columns("energy: tau", tau, 2, n);
  const MatrixXd dq = x.block(1, 0, n - 1, 2) - x.block(0, 0, n - 1, 2);
  return (dq.array() * tau.topRows(n - 1).array()).abs().sum();
}

double max_torque(const MatrixXd& tau) {
  check_samples("max_torque", tau.rows());
  check_size("max_torque: tau's columns", 2, tau.cols());
  return tau.cwiseAbs().maxCoeff();
}

double integrated_torque(const VectorXd& t, const MatrixXd& tau) {
  const Eigen::Index n = t.size();
  check_samples("integrated_torque", n);
  check_columns("integrated_torque: tau", tau, 2, n);
  const VectorXd dt = t.tail(n - 1) - t.head(n - 1);
  return (tau.topRows(n - 1).cwiseAbs().rowwise().sum().array() * dt.array()).sum();
}

double torque_cost(const VectorXd& t, const MatrixXd& tau) {
  const Eigen::Index n = t.size();
  check_samples("torque_cost", n);
  check_columns("torque_cost: tau", tau, 2, n);
  const VectorXd dt = t.tail(n - 1) - t.head(n - 1);
  return (tau.topRows(n - 1).rowwise().squaredNorm().array() * dt.array()).sum();
}

double torque_smoothness(const MatrixXd& tau) {
  const Eigen::Index n = tau.rows();
  check_samples("torque_smoothness", n);
  check_size("torque_smoothness: tau's columns", 2, tau.cols());
  const MatrixXd du = tau.bottomRows(n - 1) - tau.topRows(n - 1);
  return population_std(du.col(0)) + population_std(du.col(1));
}

double velocity_cost(const VectorXd& t, const MatrixXd& x) {
  const Eigen::Index n = t.size();
  check_samples("velocity_cost", n);
  check_columns("velocity_cost: x", x, 4, n);
  const VectorXd dt = t.tail(n - 1) - t.head(n - 1);
  return (x.block(0, 2, n - 1, 2).rowwise().squaredNorm().array() * dt.array()).sum();
}

double realai_score(bool success, const CriterionValues& c, const ScoreDefinition& d) {
  std::string why;
  if (!d.IsValid(&why)) throw InvalidArgument("realai_score: invalid definition: " + why);
  if (!success) return 0.0;
  const double values[] = {c.swingup_time, c.energy,         c.max_tau,      c.integrated_tau,
                           c.tau_cost,     c.tau_smoothness, c.velocity_cost};
  const double weights[] = {d.weights.swingup_time,   d.weights.energy,   d.weights.max_tau,
                            d.weights.integrated_tau, d.weights.tau_cost, d.weights.tau_smoothness,
                            d.weights.velocity_cost};
  const double norms[] = {d.normalization.swingup_time, d.normalization.energy,
                          d.normalization.max_tau,      d.normalization.integrated_tau,
                          d.normalization.tau_cost,     d.normalization.tau_smoothness,
                          d.normalization.velocity_cost};
  double sum = 0.0;
  int nonzero = 0;
  for (int k = 0; k < 7; ++k) {
    if (weights[k] == 0.0) continue;  // the lab's tanh(0) = 0 and 0 * c / n = 0
    ++nonzero;
    const double term = weights[k] * values[k] / norms[k];
    sum += d.formula == ScoreFormula::kLinear ? term : std::tanh(std::numbers::pi * term);
  }
  if (d.formula == ScoreFormula::kLinear) return 1.0 - sum;
  return nonzero == 0 ? 1.0 : 1.0 - sum / nonzero;
}

Score score(const SwingupTrajectory& tr, const ScoreDefinition& d) {
  std::string why;
  if (!d.IsValid(&why)) throw InvalidArgument("score: invalid definition " + d.name + ": " + why);
  const Eigen::Index n = tr.t.size();
  check_samples("score", n);
  check_columns("score: x", tr.x, 4, n);
  check_columns("score: tau", tr.tau, 2, n);
  Score s;
  CriterionValues& c = s.criteria;
  c.swingup_time =
      swingup_time(tr.t, tr.x, d.link1_length, d.link2_length, d.height_fraction, d.t_final);
  c.energy = energy(tr.x, tr.tau);
  c.max_tau = max_torque(tr.tau);
  c.integrated_tau = integrated_torque(tr.t, tr.tau);
  c.tau_cost = torque_cost(tr.t, tr.tau);
  c.tau_smoothness = torque_smoothness(tr.tau);
  c.velocity_cost = velocity_cost(tr.t, tr.x);
  s.success = c.swingup_time < tr.t[n - 1];
  s.realai_score = realai_score(s.success, c, d);
  return s;
}

}  // namespace drops::realaigym
