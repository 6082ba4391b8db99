// The realaigym_pendubot task: the system, the prior and the episode metrics agree with the plant
// (drops/realaigym/plant.hpp) and the scorer (score.hpp); the declared reflection holds for the
// real system; the plugin builds a setup whose pieces fit together.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "drops/control/balance.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/realaigym/plugin.hpp"
#include "drops/realaigym/task.hpp"

namespace rg = drops::realaigym;
using drops::MatrixXd;
using drops::VectorXd;

namespace {

// An episode of H control periods on the system under a torque that changes every period.
drops::rollout::Trajectory run(const rg::PlantSystem& system, const rg::SwingupTask& task) {
  const int h = task.horizon();
  drops::rollout::Trajectory tr;
  tr.states = MatrixXd(h + 1, 4);
  tr.actions = MatrixXd(h, 1);
  tr.rewards = VectorXd(h);
  drops::Rng rng(1);
  VectorXd x = task.initial_state();
  tr.states.row(0) = x.transpose();
  for (int t = 0; t < h; ++t) {
    VectorXd u(1);
    u[0] = 7.0 * std::sin(0.9 * t) - 0.05 * x[2];  // exceeds the 6 N m limit at times
    x = system.step(x, u, rng);
    tr.actions.row(t) = u.transpose();
    tr.states.row(t + 1) = x.transpose();
    tr.rewards[t] = task.reward(x);
  }
  return tr;
}

}  // namespace

TEST(RealAIGymTask,
     TheEpisodeAtTwoMillisecondsPassesThroughTheSystemsStatesAndUsesTheClippedTorque) {
  for (rg::Leaderboard lb : {rg::Leaderboard::kV1, rg::Leaderboard::kV2}) {
    rg::TaskOptions o;
    o.leaderboard = lb;
    o.duration = 1.0;  // 50 periods of 20 ms
    const rg::SwingupTask task(o);
    const rg::PlantParameters plant = rg::leaderboard_plant(lb);
    const rg::PlantSystem system(plant, o);
    const drops::rollout::Trajectory ep = run(system, task);
    const rg::ScoreDefinition def = rg::leaderboard_score(lb);
    const rg::SwingupTrajectory fine = rg::leaderboard_trajectory(
        plant, def, ep.states.row(0).transpose(), ep.actions, o.substeps(), o.sim_dt);
    ASSERT_EQ(fine.t.size(), 500);
    // v1's rows start after the first step (t = 2 ms, x(2 ms)); v2's at t = 0 with x(0).
    const int first = def.rows_after_step ? 1 : 0;
    EXPECT_NEAR(fine.t[0], first * 0.002, 1e-15);
    for (int t = 1; t < task.horizon(); ++t) {
      const int row = t * o.substeps() - first;
      EXPECT_EQ(fine.x.row(row), ep.states.row(t)) << "control step " << t;
      // The torque after (v2) or before (v1) that row: the period's action, clipped to 6.
      const double u = ep.actions(def.rows_after_step ? t - 1 : t, 0);
      EXPECT_EQ(fine.tau(row, 0), std::clamp(u, -6.0, 6.0));
      EXPECT_EQ(fine.tau(row, 1), 0.0);
    }
  }
}

TEST(RealAIGymTask, ThePriorAtThePlantsParametersIsTheSystemAndTheOtherDesignIsNot) {
  const rg::TaskOptions o;
  const rg::PlantParameters plant = rg::design_c1_model_1_0();
  const rg::PlantSystem system(plant, o);
  const rg::PlantPrior prior(plant, o);
  drops::Rng rng(3);
  const VectorXd x = (VectorXd(4) << 2.0, -0.7, 1.5, -4.0).finished();
  const VectorXd u = (VectorXd(1) << 2.5).finished();
  VectorXd dx(4);
  prior.evaluate(x, u, rg::to_phi(plant), dx);
  EXPECT_EQ(x + dx, system.step(x, u, rng));
  prior.evaluate(x, u, rg::to_phi(rg::design_a0_model_2_0()), dx);
  EXPECT_GT((x + dx - system.step(x, u, rng)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_THROW(prior.check_phi(VectorXd::Zero(7)), drops::InvalidArgument);
  EXPECT_NO_THROW(prior.check_phi(rg::to_phi(plant)));
}

TEST(RealAIGymTask, TheDeclaredReflectionHoldsForTheRealSystem) {
  const rg::TaskOptions o;
  const rg::SwingupTask task(o);
  const rg::PlantSystem system(rg::design_c1_model_1_0(), o);
  const drops::Reflection r = *task.reflection();
  drops::Rng rng(5);
  for (const VectorXd& x : {(VectorXd(4) << 0.3, 1.1, -2.0, 0.5).finished(),
                            (VectorXd(4) << 3.0, -0.2, 6.0, -7.0).finished()}) {
    const VectorXd u = (VectorXd(1) << 1.7).finished();
    const drops::Transition t{x, u, system.step(x, u, rng) - x};
    const drops::Transition m = r.apply(t);
    EXPECT_LT((system.step(m.x, m.u, rng) - m.x - m.dx).cwiseAbs().maxCoeff(), 1e-12);
    // The reward sees the mirrored state as the same distance from upright.
    EXPECT_NEAR(task.reward(m.x), task.reward(x), 1e-15);
  }
}

TEST(RealAIGymTask, SolvedIsTheHeightRuleOnTheControlSteps) {
  rg::TaskOptions o;
  o.duration = 1.0;
  const rg::SwingupTask task(o);
  drops::rollout::Trajectory tr;
  tr.states = MatrixXd::Zero(51, 4);
  tr.actions = MatrixXd::Zero(50, 1);
  tr.rewards = VectorXd::Zero(50);
  EXPECT_FALSE(task.solved(tr));
  tr.states.col(0).tail(20).setConstant(3.14159265358979);  // upright from step 31 to the end
  EXPECT_TRUE(task.solved(tr));
  tr.states(49, 0) = 0.0;  // down at the step before the last: not swung up
  EXPECT_FALSE(task.solved(tr));
}

TEST(RealAIGymTask, ThePluginBuildsASetupWithTheLeaderboardsMetrics) {
  drops::experiment::Registry registry;
  drops::experiment::register_builtin_algorithms(registry);
  rg::register_task(registry);
  const drops::experiment::Settings st = drops::experiment::load_settings(
      registry, "", {"task=realaigym_pendubot", "realaigym.duration=1"});
  const drops::experiment::TaskSetup s = registry.task("realaigym_pendubot").make(st);
  EXPECT_EQ(s.task->horizon(), 50);
  EXPECT_EQ(s.metric_names.size(), 9u);
  EXPECT_EQ(s.metric_names.back(), "realai_score");
  // Starting phi: design A.0's (the other design) while the plant is C.1.
  EXPECT_EQ(s.prior_parameters.values[2], 0.3);
  EXPECT_EQ(s.phi_actual[2], 0.2);
  // The metrics of an episode at rest: no swing-up, no torque, no motion.
  drops::algo::EpisodeRecord record;
  record.real.states = MatrixXd::Zero(51, 4);
  record.real.actions = MatrixXd::Zero(50, 1);
  const std::vector<double> m = s.metrics(record);
  ASSERT_EQ(m.size(), 9u);
  EXPECT_EQ(m[0], 0.0);  // swingup_success
  EXPECT_EQ(m[3], 0.0);  // max_tau_nm
  EXPECT_EQ(m[8], 0.0);  // realai_score
}

// The declared goal (upright at rest, x* = [pi, 0, 0, 0]) is an equilibrium of the plant at zero
// torque, and the LQR of the plant's own dynamics linearised there (policy.balance.mode lqr on a
// perfect model) catches a small offset within the torque limit.
TEST(RealAIGymTask, TheGoalIsTheUprightEquilibriumAndItsLqrCatchesASmallOffset) {
  const rg::TaskOptions o;
  const rg::SwingupTask task(o);
  const auto goal = task.goal();
  ASSERT_TRUE(goal.has_value());
  const rg::PlantParameters plant = rg::leaderboard_plant(o.leaderboard);
  const rg::PlantSystem real(plant, o);
  drops::Rng rng(1);
  VectorXd u0 = VectorXd::Zero(1);
  EXPECT_LT((real.step(goal->state, u0, rng) - goal->state).cwiseAbs().maxCoeff(), 1e-12);
  drops::model::PriorParameters p;
  p.names = rg::prior_parameter_names();
  p.values = rg::to_phi(plant);
  const auto model =
      drops::model::make_prior_only_model(std::make_shared<rg::PlantPrior>(plant, o), p);
  const auto c = drops::control::make_balance_controller(task, *model, {});
  ASSERT_TRUE(c.usable());
  VectorXd x = goal->state, u(1);
  x[0] += 0.05;
  x[1] -= 0.05;
  x[2] = 0.1;
  for (int t = 0; t < 250; ++t) {  // 5 s
    c.act(x, u);
    EXPECT_LE(std::abs(u[0]), o.max_torque);
    x = real.step(x, u, rng);
  }
  EXPECT_LT(goal->error(x).cwiseAbs().maxCoeff(), 1e-4);
}
