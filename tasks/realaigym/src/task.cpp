#include "drops/realaigym/task.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "drops/core/errors.hpp"

namespace drops::realaigym {

PlantParameters leaderboard_plant(Leaderboard leaderboard) {
  return leaderboard == Leaderboard::kV1 ? design_a0_model_2_0() : design_c1_model_1_0();
}

ScoreDefinition leaderboard_score(Leaderboard leaderboard) {
  return leaderboard == Leaderboard::kV1 ? simulation_v1() : simulation_v2();
}

bool TaskOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (!(std::isfinite(sim_dt) && sim_dt > 0)) return fail("sim_dt must be > 0");
  if (!(std::isfinite(dt) && dt >= sim_dt)) return fail("dt must be >= sim_dt");
  if (std::abs(dt / sim_dt - std::round(dt / sim_dt)) > 1e-9 * (dt / sim_dt))
    return fail("dt must be a whole number of sim_dt (" + std::to_string(sim_dt) + " s)");
  if (!(std::isfinite(duration) && duration >= dt)) return fail("duration must be >= dt");
  if (!(std::isfinite(max_torque) && max_torque > 0)) return fail("max_torque must be > 0");
  if (!(std::isfinite(reward_sigma) && reward_sigma > 0)) return fail("reward_sigma must be > 0");
  return true;
}

int TaskOptions::substeps() const { return static_cast<int>(std::lround(dt / sim_dt)); }

SwingupTask::SwingupTask(const TaskOptions& options)
    : options_(options), score_(leaderboard_score(options.leaderboard)) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("realaigym task: " + why);
  horizon_ = static_cast<int>(std::lround(options.duration / options.dt));
  score_.t_final = options.duration;
}

void SwingupTask::observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const {
  obs[0] = x[2];
  obs[1] = x[3];
  obs[2] = std::cos(x[0]);
  obs[3] = std::sin(x[0]);
  obs[4] = std::cos(x[1]);
  obs[5] = std::sin(x[1]);
}

double SwingupTask::reward(const VectorXd& x) const {
  const double l1 = score_.link1_length, l2 = score_.link2_length;
  const Eigen::Vector2d tip = end_effector_position(l1, l2, {x[0], x[1]});
  const double d2 = tip[0] * tip[0] + (tip[1] - l1 - l2) * (tip[1] - l1 - l2);
  if (!std::isfinite(d2)) return 0.0;  // a diverged model state earns nothing
  return std::exp(-0.5 * d2 / (options_.reward_sigma * options_.reward_sigma));
}

bool SwingupTask::solved(const rollout::Trajectory& trajectory) const {
  const Eigen::Index n = trajectory.states.rows();
  if (n < 2 || trajectory.nonfinite_step >= 0) return false;
  const VectorXd t = VectorXd::LinSpaced(n, 0.0, options_.dt * static_cast<double>(n - 1));
  const double time = swingup_time(t, trajectory.states, score_.link1_length, score_.link2_length,
                                   score_.height_fraction, score_.t_final);
  return time < t[n - 1];
}

std::optional<rollout::Reflection> SwingupTask::reflection() const {
  rollout::Reflection r;
  r.state_sign = -VectorXd::Ones(4);
  r.state_offset = VectorXd::Zero(4);
  r.action_sign = -VectorXd::Ones(1);
  return r;
}

std::optional<rollout::Goal> SwingupTask::goal() const {
  rollout::Goal g;
  g.state = VectorXd::Zero(4);
  g.state[0] = std::numbers::pi;
  g.action = VectorXd::Zero(1);
  g.action_limit = VectorXd::Constant(1, options_.max_torque);
  g.angles = {0, 1};
  return g;
}

PlantSystem::PlantSystem(const PlantParameters& plant, const TaskOptions& options)
    : plant_(plant), options_(options) {
  std::string why;
  if (!plant.IsValid(&why)) throw InvalidArgument("realaigym plant: " + why);
  if (!options.IsValid(&why)) throw InvalidArgument("realaigym task: " + why);
}

VectorXd PlantSystem::step(const VectorXd& x, const VectorXd& u, Rng& /*rng*/) const {
  check_size("realaigym state", 4, x.size());
  check_size("realaigym action", 1, u.size());
  const Eigen::Vector2d tau = applied_torque(plant_, {u[0], 0.0});
  Eigen::Vector4d s = x;
  for (int k = 0; k < options_.substeps(); ++k) s = rk4_step(plant_, s, tau, options_.sim_dt);
  return s;
}

std::vector<std::string> prior_parameter_names() {
  return {"m1", "m2", "l1", "r1", "r2", "I1", "I2"};
}

VectorXd to_phi(const PlantParameters& p) {
  VectorXd phi(7);
  phi << p.mass[0], p.mass[1], p.length[0], p.com[0], p.com[1], p.inertia[0], p.inertia[1];
  return phi;
}

PlantPrior::PlantPrior(const PlantParameters& base, const TaskOptions& options)
    : base_(base), options_(options) {}

PlantParameters PlantPrior::with_phi(const VectorXd& phi) const {
  PlantParameters p = base_;
  p.mass = {phi[0], phi[1]};
  p.length[0] = phi[2];
  p.com = {phi[3], phi[4]};
  p.inertia = {phi[5], phi[6]};
  return p;
}

void PlantPrior::check_phi(const VectorXd& phi) const {
  check_size("realaigym prior phi", 7, phi.size());
  std::string why;
  if (!with_phi(phi).IsValid(&why)) throw InvalidArgument("realaigym prior: " + why);
}

void PlantPrior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                          Eigen::Ref<VectorXd> dx) const {
  const PlantParameters p = with_phi(phi);
  const Eigen::Vector2d tau = applied_torque(p, {u[0], 0.0});
  Eigen::Vector4d s = x;
  for (int k = 0; k < options_.substeps(); ++k) s = rk4_step(p, s, tau, options_.sim_dt);
  dx = s - x;
}

std::unique_ptr<model::MeanFunction> PlantPrior::clone() const {
  return std::make_unique<PlantPrior>(*this);
}

SwingupTrajectory leaderboard_trajectory(const PlantParameters& plant, const ScoreDefinition& def,
                                         const Eigen::Vector4d& x0, const MatrixXd& actions,
                                         int substeps, double sim_dt) {
  check_size("leaderboard_trajectory: actions' columns", 1, actions.cols());
  if (substeps < 1 || !(sim_dt > 0))
    throw InvalidArgument("leaderboard_trajectory: substeps must be >= 1 and sim_dt > 0");
  const Eigen::Index steps = actions.rows() * substeps;
  MatrixXd tau(steps, 2);
  for (Eigen::Index k = 0; k < steps; ++k)
    tau.row(k) = applied_torque(plant, {actions(k / substeps, 0), 0.0}).transpose();
  const MatrixXd x = simulate_torques(plant, x0, tau, sim_dt);  // steps + 1 rows
  SwingupTrajectory tr{VectorXd(steps), MatrixXd(steps, 4), tau};
  const Eigen::Index first = def.rows_after_step ? 1 : 0;
  for (Eigen::Index i = 0; i < steps; ++i) tr.t[i] = static_cast<double>(i + first) * sim_dt;
  tr.x = x.middleRows(first, steps);
  return tr;
}

std::vector<std::string> metric_names() {
  return {"swingup_success",   "swingup_time_s",     "energy_j",
          "max_tau_nm",        "integrated_tau_nms", "tau_cost",
          "tau_smoothness_nm", "velocity_cost",      "realai_score"};
}

std::vector<double> metric_values(const Score& s) {
  const CriterionValues& c = s.criteria;
  return {s.success ? 1.0 : 0.0, c.swingup_time, c.energy,         c.max_tau,
          c.integrated_tau,      c.tau_cost,     c.tau_smoothness, c.velocity_cost,
          s.realai_score};
}

}  // namespace drops::realaigym
