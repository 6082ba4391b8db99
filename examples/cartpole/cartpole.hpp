#pragma once
// A cart-pole swing-up: the pole hangs from a cart on a rail and must be swung up and balanced by
// pushing the cart. One parametrised dynamics serves the "real" system and the simulator prior,
// whose pole length may be wrong.

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/model/mean_function.hpp"

namespace cartpole {

using drops::VectorXd;

/// Physical parameters: cart mass M and pole mass m (kg), pole length l (m; a uniform rod, centre
/// of mass at l/2), cart friction b (N s/m), gravity g (m/s^2).
struct Params {
  double cart_mass = 0.5, pole_mass = 0.5, pole_length = 0.5, friction = 0.1, g = 9.82;
  /// phi = [pole_length] (the prior's parameter vector, dim 1).
  VectorXd to_phi() const;
  /// Throws drops::InvalidArgument naming a non-positive mass or length.
  void check() const;
};

/// Settings of the task.
struct Options {
  double dt = 0.1;          ///< control period, s
  double duration = 4.0;    ///< episode length, s
  double max_force = 10.0;  ///< |u| <= max_force, N
  int substeps = 10;        ///< RK4 substeps per control period
  double reward_sigma = 0.25;  ///< width of the reward, m
  double solved_radius = 0.15;  ///< solved: the tip within this of upright ...
  double solved_time = 1.0;     ///< ... for this long without a break (balanced), s
  double goal_length = 0.5;     ///< the actual pole length, for the tip in the reward, m
};

/// Raw state x = [x, dx, theta, dtheta]: cart position (m) and velocity, pole angle from upright
/// (rad, positive when the tip moves towards +x) and its rate. One control period under force u
/// (N, clipped, held), RK4 with substeps. Pure.
std::array<double, 4> step(const Params& p, const Options& o, const std::array<double, 4>& x,
                           double u);

/// The swing-up task: start at rest hanging (theta = pi); observation [x, dx, dtheta, cos theta,
/// sin theta]; reward exp(-d^2 / (2 sigma^2)), d the tip's distance to the upright tip (0, l);
/// solved when the tip stays within solved_radius of it for solved_time without a break.
class SwingUpTask final : public drops::rollout::Task {
 public:
  explicit SwingUpTask(const Options& o) : o_(o) {}
  std::string name() const override { return "cartpole"; }
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  int observation_dim() const override { return 5; }
  int horizon() const override;
  double dt() const override { return o_.dt; }
  VectorXd initial_state() const override;
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override;
  double reward(const VectorXd& x) const override;
  bool solved(const drops::rollout::Trajectory& trajectory) const override;
  /// Distance from the pole's tip to upright above the rail's origin, m.
  double tip_distance(const VectorXd& x) const;

 private:
  Options o_;
};

/// The "real" cart-pole.
class RealCartPole final : public drops::rollout::System {
 public:
  RealCartPole(const Params& p, const Options& o) : p_(p), o_(o) { p_.check(); }
  VectorXd step(const VectorXd& x, const VectorXd& u, drops::Rng& rng) const override;

 private:
  Params p_;
  Options o_;
};

/// The simulator prior M(x, u; phi) = step(x, u; phi) - x, phi = [pole_length] (the other
/// parameters as given).
class Prior final : public drops::model::MeanFunction {
 public:
  Prior(const Params& base, const Options& o) : base_(base), o_(o) {}
  int state_dim() const override { return 4; }
  int action_dim() const override { return 1; }
  std::vector<std::string> parameter_names() const override { return {"pole_length"}; }
  void check_phi(const VectorXd& phi) const override;
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  std::unique_ptr<drops::model::MeanFunction> clone() const override {
    return std::make_unique<Prior>(*this);
  }

 private:
  Params base_;
  Options o_;
};

}  // namespace cartpole
