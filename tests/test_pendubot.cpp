// Pendubot dynamics, prior, task and reward (settings.md §2).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "drops/core/errors.hpp"
#include "drops/pendubot/pendubot.hpp"

using namespace drops;
using namespace drops::pendubot;

namespace {
std::array<double, 4> fine_reference(const Params& p, std::array<double, 4> x, double u, double dt) {
  // Very fine RK4 (1000 substeps): the oracle for "integration accuracy".
  return step(p, x, u, dt, 1000, 3.5);
}
}  // namespace

TEST(Pendubot, PriorWithActualParametersReproducesTheRealStep) {
  const TaskOptions o;
  PendubotSystem real(Params{}, o);
  PendubotPrior prior(o);
  Rng rng(3);
  const VectorXd phi = Params{}.to_phi();
  for (int k = 0; k < 200; ++k) {
    VectorXd x(4), u(1), dx(4);
    x << rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(-4, 4), rng.uniform(-4, 4);
    u << rng.uniform(-3.5, 3.5);
    prior.evaluate(x, u, phi, dx);
    const VectorXd next = real.step(x, u, rng);
    EXPECT_LT((x + dx - next).cwiseAbs().maxCoeff(), 1e-12);
    // and both agree with a fine integration to RK4 accuracy
    const auto ref = fine_reference(Params{}, {x[0], x[1], x[2], x[3]}, u[0], o.dt);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(next[i], ref[i], 1e-4 * (1 + std::abs(ref[i])));
  }
}

TEST(Pendubot, OtherParametersGiveADifferentStep) {
  PendubotPrior prior;
  VectorXd x(4), u(1), a(4), b(4);
  x << 0.3, -0.2, 2.5, 3.0;
  u << 1.0;
  prior.evaluate(x, u, Params{}.to_phi(), a);
  prior.evaluate(x, u, preset("tunable").to_phi(), b);
  EXPECT_GT((a - b).norm(), 1e-3);
}

TEST(Pendubot, HangingAtRestStaysAtRestWithoutTorque) {
  const auto next = step(Params{}, {0, 0, std::numbers::pi, std::numbers::pi}, 0.0, 0.05, 5, 3.5);
  for (double v : next) EXPECT_TRUE(std::isfinite(v));
  EXPECT_NEAR(next[0], 0, 1e-12);
  EXPECT_NEAR(next[2], std::numbers::pi, 1e-12);
}

TEST(Pendubot, EnergyIsConservedWithoutFriction) {
  Params p;
  p.b1 = p.b2 = 0;
  auto energy = [&](const std::array<double, 4>& x) {
    // kinetic + potential of the two uniform links (y up, theta from upright)
    const double I1 = p.m1 * p.l1 * p.l1 / 12, I2 = p.m2 * p.l2 * p.l2 / 12;
    const double v1x = -0.5 * p.l1 * std::cos(x[2]) * x[0], v1y = -0.5 * p.l1 * std::sin(x[2]) * x[0];
    const double v2x = -p.l1 * std::cos(x[2]) * x[0] - 0.5 * p.l2 * std::cos(x[3]) * x[1];
    const double v2y = -p.l1 * std::sin(x[2]) * x[0] - 0.5 * p.l2 * std::sin(x[3]) * x[1];
    const double T = 0.5 * p.m1 * (v1x * v1x + v1y * v1y) + 0.5 * I1 * x[0] * x[0] +
                     0.5 * p.m2 * (v2x * v2x + v2y * v2y) + 0.5 * I2 * x[1] * x[1];
    const double V = p.m1 * p.g * 0.5 * p.l1 * std::cos(x[2]) +
                     p.m2 * p.g * (p.l1 * std::cos(x[2]) + 0.5 * p.l2 * std::cos(x[3]));
    return T + V;
  };
  std::array<double, 4> x{0, 0, 2.0, 2.5};
  const double e0 = energy(x);
  for (int t = 0; t < 50; ++t) x = step(p, x, 0.0, 0.05, 20, 3.5);
  EXPECT_NEAR(energy(x), e0, 1e-4 * std::abs(e0) + 1e-6);
}

TEST(Pendubot, SingularParametersAreRejected) {
  PendubotPrior prior;
  VectorXd phi = Params{}.to_phi();
  phi[1] = 0.0;  // m2 = 0 makes the inertia matrix singular
  EXPECT_THROW(prior.check_phi(phi), InvalidArgument);
  phi[1] = std::nan("");
  EXPECT_THROW(prior.check_phi(phi), InvalidArgument);
  Params p;
  p.l1 = 0.001;
  EXPECT_THROW(PendubotSystem(p, TaskOptions{}), InvalidArgument);
}

TEST(Pendubot, PresetsMatchTableI) {
  EXPECT_DOUBLE_EQ(preset("tunable-useful").m1, 0.65);
  EXPECT_DOUBLE_EQ(preset("tunable-useful").l2, 0.4);
  EXPECT_DOUBLE_EQ(preset("tunable").m2, 0.75);
  EXPECT_DOUBLE_EQ(preset("tunable-misleading").l2, 0.25);
  EXPECT_DOUBLE_EQ(preset("partially-tunable").m2, 0.35);
  EXPECT_DOUBLE_EQ(preset("partially-tunable").b1, 0.0);
  EXPECT_THROW(preset("nope"), InvalidArgument);
}

TEST(SwingUpTask, RewardIsOneAtTheGoalAndTinyHanging) {
  SwingUpTask task;
  VectorXd up = VectorXd::Zero(4);
  EXPECT_NEAR(task.reward(up), 1.0, 1e-12);
  const VectorXd down = task.initial_state();
  // tip at (0, -1), goal (0, 1): d = 2, r = exp(-2 / 0.25 * ... ) = exp(-8)
  EXPECT_NEAR(task.reward(down), std::exp(-0.5 * 4 / 0.25), 1e-12);
  EXPECT_EQ(task.horizon(), 50);
}

TEST(SwingUpTask, SolvedNeedsTheWholeLastHalfSecondNearUpright) {
  SwingUpTask task;
  rollout::Trajectory tr;
  tr.states = MatrixXd::Zero(51, 4);
  tr.actions = MatrixXd::Zero(50, 1);
  tr.rewards = VectorXd::Zero(50);
  EXPECT_TRUE(task.solved(tr));
  tr.states(45, 2) = 0.5;  // tip ~0.24 m away inside the window
  EXPECT_FALSE(task.solved(tr));
  tr.states(45, 2) = 0.0;
  tr.states(40, 2) = 0.5;  // outside the last 0.5 s (steps 41..50)
  EXPECT_TRUE(task.solved(tr));
}

TEST(SwingUpTask, ObservationUsesCosSin) {
  SwingUpTask task;
  VectorXd x(4), obs(6);
  x << 1, 2, 0.3, -0.4;
  task.observe(x, obs);
  EXPECT_DOUBLE_EQ(obs[0], 1);
  EXPECT_DOUBLE_EQ(obs[2], std::cos(0.3));
  EXPECT_DOUBLE_EQ(obs[3], std::sin(0.3));
  EXPECT_DOUBLE_EQ(obs[5], std::sin(-0.4));
}

// The task's reflection (the mirror about the vertical) is a symmetry of the dynamics: the
// oracle is the simulator itself, stepped from the mirrored state under the mirrored torque,
// for the actual robot and every prior of Table I; and it is an involution.
TEST(Pendubot, TheReflectionIsASymmetryOfTheRobotAndOfEveryPrior) {
  const SwingUpTask task;
  const auto r = task.reflection();
  ASSERT_TRUE(r.has_value());
  Rng rng(11);
  std::vector<Params> all{Params{}};
  for (const auto& name : preset_names()) all.push_back(preset(name));
  for (const Params& p : all) {
    PendubotSystem sys(p);
    for (int k = 0; k < 50; ++k) {
      Transition t;
      t.x = VectorXd(4);
      t.x << rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(0, 6.3), rng.uniform(0, 6.3);
      t.u = VectorXd::Constant(1, rng.uniform(-4, 4));  // beyond the torque limit too
      t.dx = sys.step(t.x, t.u, rng) - t.x;
      const Transition m = r->apply(t);
      const VectorXd dx = sys.step(m.x, m.u, rng) - m.x;
      EXPECT_LT((dx - m.dx).cwiseAbs().maxCoeff(), 1e-12 * (1 + t.dx.cwiseAbs().maxCoeff()));
      const Transition back = r->apply(m);
      EXPECT_LT((back.x - t.x).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_EQ(back.u, t.u);
      EXPECT_EQ(back.dx, t.dx);
    }
  }
  EXPECT_EQ(r->apply({task.initial_state(), VectorXd::Zero(1), VectorXd::Zero(4)}).x,
            task.initial_state());  // hanging is a fixed point
}
