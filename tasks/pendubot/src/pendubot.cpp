#include "drops/pendubot/pendubot.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "drops/core/errors.hpp"

namespace drops::pendubot {

VectorXd Params::to_phi() const {
  VectorXd phi(6);
  phi << m1, m2, l1, l2, b1, b2;
  return phi;
}

Params Params::from_phi(const VectorXd& phi) {
  check_size("pendubot phi [m1, m2, l1, l2, b1, b2]", 6, phi.size());
  Params p;
  p.m1 = phi[0];
  p.m2 = phi[1];
  p.l1 = phi[2];
  p.l2 = phi[3];
  p.b1 = phi[4];
  p.b2 = phi[5];
  return p;
}

void Params::check() const {
  const std::array<std::pair<const char*, double>, 4> positive{
      {{"m1", m1}, {"m2", m2}, {"l1", l1}, {"l2", l2}}};
  for (const auto& [name, v] : positive) {
    if (!std::isfinite(v) || v < kMinMassOrLength) {
      throw InvalidArgument(std::string("pendubot parameter ") + name + " = " + std::to_string(v) +
                            " is invalid: masses and lengths must be >= " +
                            std::to_string(kMinMassOrLength) +
                            " (the inertia matrix is singular at 0)");
    }
  }
  for (const auto& [name, v] : std::array<std::pair<const char*, double>, 3>{
           {{"b1", b1}, {"b2", b2}, {"g", g}}}) {
    if (!std::isfinite(v) || v < 0) {
      throw InvalidArgument(std::string("pendubot parameter ") + name + " = " + std::to_string(v) +
                            " is invalid: must be finite and >= 0");
    }
  }
}

std::vector<std::string> parameter_names() { return {"m1", "m2", "l1", "l2", "b1", "b2"}; }

std::vector<std::string> preset_names() {
  return {"actual", "tunable-useful", "tunable", "tunable-misleading", "partially-tunable"};
}

Params preset(const std::string& name) {
  Params p;  // actual
  if (name == "actual") return p;
  if (name == "tunable-useful") {
    p.m1 = 0.65;
    p.l2 = 0.4;
  } else if (name == "tunable") {
    p.m2 = 0.75;
  } else if (name == "tunable-misleading") {
    p.l2 = 0.25;
  } else if (name == "partially-tunable") {
    p.m1 = 0.65;
    p.m2 = 0.35;
    p.b1 = 0.0;
    p.b2 = 0.0;
  } else {
    std::string allowed;
    for (const auto& n : preset_names()) allowed += (allowed.empty() ? "" : ", ") + n;
    throw InvalidArgument("unknown pendubot prior preset '" + name + "' (allowed: " + allowed + ")");
  }
  return p;
}

std::array<double, 4> derivative(const Params& p, const std::array<double, 4>& x, double u) {
  const double dth1 = x[0], dth2 = x[1], th1 = x[2], th2 = x[3];
  const double I1 = p.m1 * p.l1 * p.l1 / 12.0;
  const double I2 = p.m2 * p.l2 * p.l2 / 12.0;
  // Two sincos instead of four trigonometric calls: the prior runs inside every rollout step.
  double s1, c1_, s2, c2_;
  sincos(th1, &s1, &c1_);
  sincos(th2, &s2, &c2_);
  const double s12 = s1 * c2_ - c1_ * s2, c12 = c1_ * c2_ + s1 * s2;
  const double a11 = p.l1 * p.l1 * (0.25 * p.m1 + p.m2) + I1;
  const double a12 = 0.5 * p.m2 * p.l1 * p.l2 * c12;
  const double a22 = 0.25 * p.l2 * p.l2 * p.m2 + I2;
  const double c1 = p.g * p.l1 * s1 * (0.5 * p.m1 + p.m2) -
                    0.5 * p.m2 * p.l1 * p.l2 * dth2 * dth2 * s12 + u - p.b1 * dth1;
  const double c2 = 0.5 * p.m2 * p.l2 * (p.l1 * dth1 * dth1 * s12 + p.g * s2) -
                    p.b2 * dth2;
  const double det = a11 * a22 - a12 * a12;  // > 0 for valid parameters (checked)
  const double ddth1 = (a22 * c1 - a12 * c2) / det;
  const double ddth2 = (a11 * c2 - a12 * c1) / det;
  return {ddth1, ddth2, dth1, dth2};
}

std::array<double, 4> step(const Params& p, const std::array<double, 4>& x, double u, double dt,
                           int substeps, double max_torque) {
  u = std::clamp(u, -max_torque, max_torque);
  const double h = dt / substeps;
  std::array<double, 4> s = x, tmp;
  for (int k = 0; k < substeps; ++k) {
    const auto k1 = derivative(p, s, u);
    for (int i = 0; i < 4; ++i) tmp[i] = s[i] + 0.5 * h * k1[i];
    const auto k2 = derivative(p, tmp, u);
    for (int i = 0; i < 4; ++i) tmp[i] = s[i] + 0.5 * h * k2[i];
    const auto k3 = derivative(p, tmp, u);
    for (int i = 0; i < 4; ++i) tmp[i] = s[i] + h * k3[i];
    const auto k4 = derivative(p, tmp, u);
    for (int i = 0; i < 4; ++i) s[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  }
  return s;
}

std::array<double, 2> tip_position(const VectorXd& x, double l1, double l2) {
  return {-l1 * std::sin(x[2]) - l2 * std::sin(x[3]), l1 * std::cos(x[2]) + l2 * std::cos(x[3])};
}

bool TaskOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(dt > 0) || !(duration >= dt))
    return fail("need dt > 0 and duration >= dt, got dt = " + std::to_string(dt) +
                ", duration = " + std::to_string(duration));
  if (substeps < 1) return fail("need substeps >= 1");
  if (!(max_torque > 0) || !(reward_sigma > 0)) return fail("need max_torque > 0 and reward_sigma > 0");
  if (!(solved_radius > 0) || !(solved_window >= 0))
    return fail("need solved_radius > 0 and solved_window >= 0");
  return true;
}

pilco::TaskModel pilco_task_model(const TaskOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("pendubot task: " + why);
  pilco::TaskModel m;
  m.config.state_dim = 4;
  m.config.angles = {2, 3};
  m.config.policy_inputs = {0, 1, 4, 5, 6, 7};
  m.config.dynamics_inputs = {0, 1, 4, 5, 6, 7};
  m.config.max_u = VectorXd::Constant(1, options.max_torque);
  // x_aug = [dth1, dth2, th1, th2, sin th1, cos th1, sin th2, cos th2]; the tip is
  // (-l1 sin th1 - l2 sin th2, l1 cos th1 + l2 cos th2) and the goal (0, l1 + l2).
  m.cost_map = MatrixXd::Zero(2, 8);
  m.cost_map(0, 4) = options.goal_l1;
  m.cost_map(0, 6) = options.goal_l2;
  m.cost_map(1, 5) = options.goal_l1;
  m.cost_map(1, 7) = options.goal_l2;
  m.cost_target = VectorXd::Zero(8);
  m.cost_target[5] = m.cost_target[7] = 1.0;
  m.reward_width = options.reward_sigma;
  VectorXd s0(4);
  s0 << 0.1, 0.1, 0.01, 0.01;
  m.initial_cov = s0.array().square().matrix().asDiagonal();
  m.policy_length_scales = VectorXd(6);
  m.policy_length_scales << 1, 1, 0.7, 0.7, 0.7, 0.7;
  return m;
}

SwingUpTask::SwingUpTask(const TaskOptions& options) : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("pendubot task: " + why);
  horizon_ = static_cast<int>(std::lround(options.duration / options.dt));
}

VectorXd SwingUpTask::initial_state() const {
  VectorXd x(4);
  x << 0, 0, std::numbers::pi, std::numbers::pi;
  return x;
}

void SwingUpTask::observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const {
  obs[0] = x[0];
  obs[1] = x[1];
  obs[2] = std::cos(x[2]);
  obs[3] = std::sin(x[2]);
  obs[4] = std::cos(x[3]);
  obs[5] = std::sin(x[3]);
}

std::optional<rollout::Reflection> SwingUpTask::reflection() const {
  rollout::Reflection r;
  r.state_sign = -VectorXd::Ones(4);
  r.state_offset = VectorXd::Zero(4);
  r.state_offset[2] = r.state_offset[3] = 2 * std::numbers::pi;
  r.action_sign = -VectorXd::Ones(1);
  return r;
}

std::optional<rollout::Goal> SwingUpTask::goal() const {
  rollout::Goal g;
  g.state = VectorXd::Zero(4);
  g.action = VectorXd::Zero(1);
  g.action_limit = VectorXd::Constant(1, options_.max_torque);
  g.angles = {2, 3};
  return g;
}

double SwingUpTask::goal_distance(const VectorXd& x) const {
  const auto tip = tip_position(x, options_.goal_l1, options_.goal_l2);
  const double gy = options_.goal_l1 + options_.goal_l2;
  return std::hypot(tip[0], tip[1] - gy);
}

double SwingUpTask::reward(const VectorXd& x) const {
  const double d = goal_distance(x);
  if (!std::isfinite(d)) return 0.0;  // a diverged model state earns nothing
  return std::exp(-0.5 * d * d / (options_.reward_sigma * options_.reward_sigma));
}

bool SwingUpTask::solved(const rollout::Trajectory& trajectory) const {
  const int steps = static_cast<int>(std::lround(options_.solved_window / options_.dt));
  const int n = static_cast<int>(trajectory.states.rows());
  if (n < steps + 1) return false;
  for (int t = n - steps; t < n; ++t) {
    if (!(goal_distance(trajectory.states.row(t).transpose()) <= options_.solved_radius))
      return false;
  }
  return true;
}

PendubotSystem::PendubotSystem(const Params& params, const TaskOptions& options)
    : params_(params), options_(options) {
  params_.check();
}

VectorXd PendubotSystem::step(const VectorXd& x, const VectorXd& u, Rng& /*rng*/) const {
  check_size("pendubot state", 4, x.size());
  check_size("pendubot action", 1, u.size());
  const auto next = pendubot::step(params_, {x[0], x[1], x[2], x[3]}, u[0], options_.dt,
                                   options_.substeps, options_.max_torque);
  return Eigen::Map<const Eigen::Vector4d>(next.data());
}

PendubotPrior::PendubotPrior(const TaskOptions& options) : options_(options) {}

std::vector<std::string> PendubotPrior::parameter_names() const {
  return pendubot::parameter_names();
}

void PendubotPrior::check_phi(const VectorXd& phi) const { Params::from_phi(phi).check(); }

void PendubotPrior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                             Eigen::Ref<VectorXd> dx) const {
  Params p;
  p.m1 = phi[0];
  p.m2 = phi[1];
  p.l1 = phi[2];
  p.l2 = phi[3];
  p.b1 = phi[4];
  p.b2 = phi[5];
  const std::array<double, 4> s{x[0], x[1], x[2], x[3]};
  const auto next = pendubot::step(p, s, u[0], options_.dt, options_.substeps, options_.max_torque);
  for (int i = 0; i < 4; ++i) dx[i] = next[i] - s[i];
}

std::unique_ptr<model::MeanFunction> PendubotPrior::clone() const {
  return std::make_unique<PendubotPrior>(*this);
}

}  // namespace drops::pendubot
