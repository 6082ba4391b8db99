// Cart-pole dynamics from its Lagrangian (uniform pole, centre of mass at l/2, inertia m l^2/12):
//   (M + m) xdd + (m l / 2)(thdd cos th - thd^2 sin th) = u - b xd
//   (m l / 2) xdd cos th + (m l^2 / 3) thdd - (m g l / 2) sin th = 0
#include "cartpole.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "drops/core/errors.hpp"

namespace cartpole {
namespace {

std::array<double, 4> derivative(const Params& p, const std::array<double, 4>& s, double u) {
  const double xd = s[1], th = s[2], thd = s[3];
  const double M = p.cart_mass, m = p.pole_mass, l = p.pole_length;
  const double a11 = M + m, a12 = 0.5 * m * l * std::cos(th), a22 = m * l * l / 3.0;
  const double c1 = u - p.friction * xd + 0.5 * m * l * thd * thd * std::sin(th);
  const double c2 = 0.5 * m * p.g * l * std::sin(th);
  const double det = a11 * a22 - a12 * a12;
  return {xd, (a22 * c1 - a12 * c2) / det, thd, (a11 * c2 - a12 * c1) / det};
}

}  // namespace

VectorXd Params::to_phi() const { return VectorXd::Constant(1, pole_length); }

void Params::check() const {
  for (const auto& [name, v] : {std::pair{"cart_mass", cart_mass}, std::pair{"pole_mass", pole_mass},
                                std::pair{"pole_length", pole_length}})
    if (!(v >= 0.01) || !std::isfinite(v))
      throw drops::InvalidArgument(std::string("cart-pole ") + name + " = " + std::to_string(v) +
                                   ": must be >= 0.01");
}

std::array<double, 4> step(const Params& p, const Options& o, const std::array<double, 4>& x,
                           double u) {
  u = std::clamp(u, -o.max_force, o.max_force);
  const double h = o.dt / o.substeps;
  std::array<double, 4> s = x;
  for (int k = 0; k < o.substeps; ++k) {
    auto add = [&](const std::array<double, 4>& d, double f) {
      std::array<double, 4> r;
      for (int i = 0; i < 4; ++i) r[i] = s[i] + f * d[i];
      return r;
    };
    const auto k1 = derivative(p, s, u), k2 = derivative(p, add(k1, h / 2), u),
               k3 = derivative(p, add(k2, h / 2), u), k4 = derivative(p, add(k3, h), u);
    for (int i = 0; i < 4; ++i) s[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  }
  return s;
}

int SwingUpTask::horizon() const { return static_cast<int>(std::lround(o_.duration / o_.dt)); }

VectorXd SwingUpTask::initial_state() const {
  VectorXd x(4);
  x << 0, 0, std::numbers::pi, 0;
  return x;
}

void SwingUpTask::observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const {
  obs << x[0], x[1], x[3], std::cos(x[2]), std::sin(x[2]);
}

double SwingUpTask::tip_distance(const VectorXd& x) const {
  const double l = o_.goal_length;
  const double dx = x[0] + l * std::sin(x[2]), dy = l * std::cos(x[2]) - l;
  return std::sqrt(dx * dx + dy * dy);
}

double SwingUpTask::reward(const VectorXd& x) const {
  const double d = tip_distance(x);
  return std::exp(-0.5 * d * d / (o_.reward_sigma * o_.reward_sigma));
}

bool SwingUpTask::solved(const drops::rollout::Trajectory& tr) const {
  const int needed = static_cast<int>(std::lround(o_.solved_time / o_.dt)) + 1;
  int run = 0;
  for (Eigen::Index t = 0; t < tr.states.rows(); ++t) {
    run = tip_distance(tr.states.row(t).transpose()) <= o_.solved_radius ? run + 1 : 0;
    if (run >= needed) return true;
  }
  return false;
}

VectorXd RealCartPole::step(const VectorXd& x, const VectorXd& u, drops::Rng&) const {
  const auto s = cartpole::step(p_, o_, {x[0], x[1], x[2], x[3]}, u[0]);
  return Eigen::Map<const VectorXd>(s.data(), 4);
}

void Prior::check_phi(const VectorXd& phi) const {
  drops::check_size("cart-pole prior phi [pole_length]", 1, phi.size());
  Params p = base_;
  p.pole_length = phi[0];
  p.check();
}

void Prior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                     Eigen::Ref<VectorXd> dx) const {
  Params p = base_;
  p.pole_length = phi[0];
  const auto s = cartpole::step(p, o_, {x[0], x[1], x[2], x[3]}, u[0]);
  for (int i = 0; i < 4; ++i) dx[i] = s[static_cast<std::size_t>(i)] - x[i];
}

}  // namespace cartpole
