#pragma once
// A single pendulum swing-up for PILCO's tests (tests only; in the spirit of pilco-matlab's
// pendulum scenario): a rod of mass m and length l on a motor with |u| <= 2.5 N m, too weak to lift
// it directly (m g l / 2 = 4.91 N m), so it must swing up. theta = 0 upright, pi hanging.
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/problem.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/pilco/task_model.hpp"

namespace drops::testing {

/// Physical parameters: mass (kg), length (m), viscous friction (N m s), gravity (m/s^2).
struct PendulumParams {
  double m = 1.0, l = 1.0, b = 0.01, g = 9.82;
};

inline constexpr double kPendulumMaxTorque = 2.5;  // N m
inline constexpr double kPendulumDt = 0.1;         // s

/// One control period from x = [dtheta, theta] under torque u (clipped), RK4 with 10 substeps:
/// theta'' = (u - b theta' + m g (l / 2) sin theta) / (m l^2 / 3).
inline VectorXd pendulum_step(const PendulumParams& p, const VectorXd& x, double u) {
  u = std::clamp(u, -kPendulumMaxTorque, kPendulumMaxTorque);
  auto f = [&](double w, double th) {
    return (u - p.b * w + p.m * p.g * 0.5 * p.l * std::sin(th)) / (p.m * p.l * p.l / 3.0);
  };
  double w = x[0], th = x[1];
  const int n = 10;
  const double h = kPendulumDt / n;
  for (int i = 0; i < n; ++i) {
    const double k1w = f(w, th), k1t = w;
    const double k2w = f(w + 0.5 * h * k1w, th + 0.5 * h * k1t), k2t = w + 0.5 * h * k1w;
    const double k3w = f(w + 0.5 * h * k2w, th + 0.5 * h * k2t), k3t = w + 0.5 * h * k2w;
    const double k4w = f(w + h * k3w, th + h * k3t), k4t = w + h * k3w;
    w += h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
    th += h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
  }
  VectorXd next(2);
  next << w, th;
  return next;
}

/// The swing-up: start hanging at rest, 4 s episodes (H = 40), reward exp(-d^2 / (2 0.5^2)) with d
/// the tip's distance to upright; solved when the tip stays within 0.2 m of upright for the last
/// second.
class PendulumTask final : public rollout::Task {
 public:
  explicit PendulumTask(int horizon = 40, double length = 1.0) : horizon_(horizon), l_(length) {}
  std::string name() const override { return "test_pendulum"; }
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  int observation_dim() const override { return 2; }
  int horizon() const override { return horizon_; }
  double dt() const override { return kPendulumDt; }
  VectorXd initial_state() const override {
    VectorXd x(2);
    x << 0.0, std::numbers::pi;
    return x;
  }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override { obs = x; }
  double distance(const VectorXd& x) const {
    return l_ * std::hypot(std::sin(x[1]), std::cos(x[1]) - 1.0);
  }
  double reward(const VectorXd& x) const override {
    const double d = distance(x);
    return std::exp(-0.5 * d * d / (0.5 * 0.5));
  }
  bool solved(const rollout::Trajectory& tr) const override {
    const int last = static_cast<int>(std::lround(1.0 / kPendulumDt));
    for (int t = horizon_ - last + 1; t <= horizon_; ++t)
      if (distance(tr.states.row(t).transpose()) > 0.2) return false;
    return true;
  }

 private:
  int horizon_;
  double l_;
};

/// The "real" pendulum.
class PendulumSystem final : public rollout::System {
 public:
  explicit PendulumSystem(PendulumParams p = {}) : p_(p) {}
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng&) const override {
    return pendulum_step(p_, x, u[0]);
  }

 private:
  PendulumParams p_;
};

/// The same physics as a simulator prior, phi = [m, l] (b and g as given).
class PendulumPrior final : public model::MeanFunction {
 public:
  explicit PendulumPrior(PendulumParams p = {}) : p_(p) {}
  int state_dim() const override { return 2; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"m", "l"}; }
  void check_phi(const VectorXd& phi) const override {
    if (phi.size() != 2 || !(phi.array() > 0.01).all())
      throw InvalidArgument("PendulumPrior: phi = [m, l] > 0.01");
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    PendulumParams p = p_;
    p.m = phi[0];
    p.l = phi[1];
    dx = pendulum_step(p, x, u[0]) - x;
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<PendulumPrior>(*this);
  }

 private:
  PendulumParams p_;
};

/// The pendulum as PILCO sees it: x_aug = [dtheta, theta, sin theta, cos theta], policy and GP
/// inputs {0, 2, 3}, the tip distance |C (x_aug - z)| with C = l [0 0 1 0; 0 0 0 1], z = (0, 0, 0,
/// 1), reward width 0.5, Sigma_0 = diag(0.1, 0.1)^2 (pilco-matlab's pendulum).
inline pilco::TaskModel pendulum_task_model(double length = 1.0) {
  pilco::TaskModel m;
  m.config.state_dim = 2;
  m.config.angles = {1};
  m.config.policy_inputs = {0, 2, 3};
  m.config.dynamics_inputs = {0, 2, 3};
  m.config.max_u = VectorXd::Constant(1, kPendulumMaxTorque);
  m.cost_map = Eigen::MatrixXd::Zero(2, 4);
  m.cost_map(0, 2) = m.cost_map(1, 3) = length;
  m.cost_target = VectorXd::Zero(4);
  m.cost_target[3] = 1.0;
  m.reward_width = 0.5;
  m.initial_cov = Eigen::Vector2d(0.01, 0.01).asDiagonal();
  m.policy_length_scales = Eigen::Vector3d(1.0, 0.7, 0.7);
  return m;
}

}  // namespace drops::testing
