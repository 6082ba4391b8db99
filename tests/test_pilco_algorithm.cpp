// PILCO and PILCO with priors as algorithms (algo::run_pilco, algo::Pilco) on the test pendulum
// (tests/pendulum_task.hpp) with tiny budgets: what each episode records, thread-count
// independence, resuming from a saved state, the first real episode of PILCO with priors, and the
// experiment layer's checks. The learning itself is tested end to end (integration/, slow).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "drops/algo/pilco.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run_directory.hpp"
#include "fixtures.hpp"
#include "pendulum_task.hpp"
#include "torque_cost_task.hpp"

namespace {

using drops::algo::EpisodeRecord;
using drops::algo::PhaseRecord;
using drops::algo::PilcoOptions;
using drops::algo::RunState;
using drops::testing::PendulumPrior;
using drops::testing::PendulumSystem;
using drops::testing::PendulumTask;

PilcoOptions Tiny(bool with_prior = false) {
  PilcoOptions o;
  o.with_prior = with_prior;
  o.episodes = 3;
  o.seed = 7;
  o.centres = 10;
  o.sim_episodes = 3;
  o.lbfgs.max_evaluations = 15;
  o.rprop.max_iterations = 50;
  return o;
}

struct Recorded {
  std::vector<EpisodeRecord> episodes;
  std::vector<RunState> states;
  std::vector<PhaseRecord> phases;         // complete phases
  std::vector<PhaseRecord> phases_so_far;  // reported while the phase ran
  std::vector<drops::algo::Status> simulated;  // the "simulation episode" statuses
  drops::algo::RunSummary summary;
};

Recorded RunPilco(const PilcoOptions& o, const drops::rollout::System& real,
                  const RunState* resume = nullptr) {
  Recorded r;
  drops::algo::Callbacks cb;
  cb.on_episode = [&](const EpisodeRecord& e) { r.episodes.push_back(e); };
  cb.on_state = [&](const RunState& s) { r.states.push_back(s); };
  cb.on_phase = [&](const PhaseRecord& p) {
    if (p.complete)
      r.phases.push_back(p);
    else
      r.phases_so_far.push_back(p);
  };
  cb.on_status = [&](const drops::algo::Status& s) {
    if (s.phase == "simulation episode") r.simulated.push_back(s);
  };
  auto prior = std::make_shared<PendulumPrior>();
  drops::model::PriorParameters pp;
  pp.names = {"m", "l"};
  pp.values = Eigen::Vector2d(0.8, 1.0);  // a wrong mass: the simulator is not the real pendulum
  r.summary = drops::algo::run_pilco(std::make_shared<PendulumTask>(), real, prior, pp,
                                     drops::testing::pendulum_task_model(), o, cb, resume);
  return r;
}

void ExpectSameEpisode(const EpisodeRecord& a, const EpisodeRecord& b) {
  EXPECT_EQ(a.episode, b.episode);
  EXPECT_EQ(a.theta, b.theta);
  EXPECT_EQ(a.real.states, b.real.states);
  EXPECT_EQ(a.real.actions, b.real.actions);
  EXPECT_EQ(a.predicted.states, b.predicted.states);
  EXPECT_TRUE(a.predicted_return == b.predicted_return ||
              (std::isnan(a.predicted_return) && std::isnan(b.predicted_return)));
}

bool IsPartialSimulation(const RunState& s) {
  return s.extra.count("simulation.partial.episodes") > 0;
}

}  // namespace

TEST(Pilco, RecordsARandomEpisodeThenLearnedOnesWithTheirPredictions) {
  const PendulumSystem real;
  const Recorded r = RunPilco(Tiny(), real);
  ASSERT_EQ(r.episodes.size(), 3u);
  ASSERT_EQ(r.states.size(), 3u);
  EXPECT_TRUE(r.phases.empty());
  const auto& e1 = r.episodes[0];
  EXPECT_TRUE(e1.random_policy);
  EXPECT_EQ(e1.theta.size(), 0);
  EXPECT_TRUE(std::isnan(e1.predicted_return));
  EXPECT_LE(e1.real.actions.cwiseAbs().maxCoeff(), drops::testing::kPendulumMaxTorque);
  EXPECT_GT(e1.real.actions.cwiseAbs().maxCoeff(), 0.5);  // random, not zero
  const int P = 10 * 3 + 10 * 1 + 3 * 1;  // centres x inputs + targets + log length scales
  for (int k = 1; k < 3; ++k) {
    const auto& e = r.episodes[static_cast<std::size_t>(k)];
    EXPECT_EQ(e.episode, k + 1);
    EXPECT_FALSE(e.random_policy);
    EXPECT_EQ(e.theta.size(), P);
    EXPECT_EQ(e.predicted.states.rows(), 41);
    EXPECT_EQ(e.predicted.actions.rows(), 40);
    EXPECT_NEAR(e.interaction_time, 4.0 * (k + 1), 1e-12);
    EXPECT_EQ(e.model.points, 40 * (k + 1) - 40);
    EXPECT_LE(e.evaluations, 15);
    // The cost width is the reward width and gamma = 1: the predicted return is H - J.
    ASSERT_TRUE(e.details.numbers.count("expected_cost"));
    EXPECT_NEAR(e.predicted_return, 40.0 - e.details.numbers.at("expected_cost"), 1e-9);
    EXPECT_NEAR(e.predicted.rewards.sum(), e.predicted_return, 1e-9);
    EXPECT_LE(e.details.numbers.at("expected_cost"), e.details.numbers.at("expected_cost_start"));
  }
  EXPECT_EQ(r.states.back().data.size(), 120u);
  EXPECT_EQ(r.states.back().model.h_params.size(), 2u);
  EXPECT_EQ(r.states.back().extra.at("theta"), r.episodes.back().theta);
  EXPECT_EQ(r.summary.episodes_done, 3);
}

TEST(Pilco, OneLearnedEpisodeSwingsThePendulumUpAfterTheRandomOne) {
  // A tiny run with a fixed seed (50 centres, the default 150 L-BFGS evaluations, ~2 s): the
  // policy learned from the random episode's 40 transitions already swings up. Measured
  // (seed 1): random return 0.02, learned 19.42 (solved), predicted 17.40.
  PilcoOptions o;
  o.episodes = 2;
  o.seed = 1;
  o.centres = 50;
  const PendulumSystem real;
  const Recorded r = RunPilco(o, real);
  ASSERT_EQ(r.episodes.size(), 2u);
  const auto& random = r.episodes[0];
  const auto& learned = r.episodes[1];
  EXPECT_LT(random.real_return, 1.0);
  EXPECT_GT(learned.real_return, random.real_return + 10.0);
  EXPECT_TRUE(learned.solved);
  EXPECT_EQ(r.summary.first_solved_episode, 2);
  // The model's prediction of the learned policy is close to what the real pendulum did.
  EXPECT_NEAR(learned.predicted_return, learned.real_return, 0.2 * learned.real_return);
}

TEST(Pilco, SameSeedGivesIdenticalEpisodesWithOneAndTwoThreads) {
  const PendulumSystem real;
  Recorded one, two;
  {
    drops::ThreadLimit t(1);
    one = RunPilco(Tiny(), real);
  }
  {
    drops::ThreadLimit t(2);
    two = RunPilco(Tiny(), real);
  }
  ASSERT_EQ(one.episodes.size(), two.episodes.size());
  for (std::size_t k = 0; k < one.episodes.size(); ++k)
    ExpectSameEpisode(one.episodes[k], two.episodes[k]);
}

TEST(Pilco, AResumedRunContinuesWithTheEpisodesOfAnUninterruptedOne) {
  const PendulumSystem real;
  PilcoOptions o = Tiny();
  o.episodes = 4;
  const Recorded full = RunPilco(o, real);
  ASSERT_EQ(full.episodes.size(), 4u);
  for (int k : {1, 2}) {  // after the random episode, and after a learned one
    const Recorded rest = RunPilco(o, real, &full.states[static_cast<std::size_t>(k - 1)]);
    ASSERT_EQ(rest.episodes.size(), static_cast<std::size_t>(4 - k));
    for (std::size_t j = 0; j < rest.episodes.size(); ++j)
      ExpectSameEpisode(rest.episodes[j], full.episodes[static_cast<std::size_t>(k) + j]);
    EXPECT_EQ(rest.summary.episodes_done, 4);
  }
  RunState wrong = full.states[1];
  wrong.data.pop_back();
  EXPECT_THROW(RunPilco(o, real, &wrong), drops::InvalidArgument);
}

TEST(PilcoWithPriors, TheFirstRealEpisodeRunsTheSimulationPolicyAndItsPrediction) {
  // The real system is the simulator itself (the prior's phi): the first real episode must repeat
  // the last simulated episode (same policy, same deterministic dynamics, same start),
  // and report the prediction that the simulation phase's last model made of that policy.
  PilcoOptions o = Tiny(true);
  o.episodes = 2;
  drops::testing::PendulumParams sim_params;
  sim_params.m = 0.8;
  const PendulumSystem simulator_as_real(sim_params);
  const Recorded r = RunPilco(o, simulator_as_real);
  ASSERT_EQ(r.phases.size(), 1u);
  const PhaseRecord& sim = r.phases[0];
  EXPECT_EQ(sim.name, "simulation");
  ASSERT_EQ(sim.episodes.size(), 3u);
  const auto& last = sim.episodes.back().numbers;
  // After simulated episodes 1 and 2 (the phase so far), after the simulation phase, then after
  // each real episode.
  ASSERT_EQ(r.states.size(), 5u);
  EXPECT_TRUE(IsPartialSimulation(r.states[0]) && IsPartialSimulation(r.states[1]));
  const RunState& after_sim = r.states[2];
  EXPECT_FALSE(IsPartialSimulation(after_sim));
  EXPECT_EQ(after_sim.episodes_done, 0);
  EXPECT_TRUE(after_sim.data.empty());
  const Eigen::VectorXd& theta_sim = after_sim.extra.at("simulation.theta");
  const EpisodeRecord& e1 = r.episodes[0];
  EXPECT_EQ(e1.theta, theta_sim);
  EXPECT_EQ(e1.selected, "simulation");
  EXPECT_EQ(e1.predicted_return, last.at("predicted_return"));
  EXPECT_EQ(e1.predicted_return, sim.summary.numbers.at("last_predicted_return"));
  // The simulator adds its predicted difference to x (x + (x' - x)): equal up to round-off.
  EXPECT_NEAR(e1.real_return, last.at("return"), 1e-9);
  EXPECT_EQ(e1.interaction_time, 4.0);  // the simulation phase costs no interaction time
  // Episode 2 learns residual GPs on the real data, with the simulator GPs' means as prior mean.
  const EpisodeRecord& e2 = r.episodes[1];
  EXPECT_EQ(e2.selected, "lbfgs");
  EXPECT_EQ(e2.model.points, 40);
  EXPECT_EQ(r.states.back().extra.count("prior.0.centres"), 1u);
  // Each simulated episode was reported as it ended (the command line prints a line per episode),
  // with the return the phase record keeps.
  ASSERT_EQ(r.simulated.size(), sim.episodes.size());
  for (std::size_t k = 0; k < r.simulated.size(); ++k) {
    EXPECT_EQ(r.simulated[k].episode, static_cast<int>(k) + 1);
    EXPECT_EQ(r.simulated[k].budget, 3);
    EXPECT_EQ(r.simulated[k].best, sim.episodes[k].numbers.at("return"));
  }
}

TEST(PilcoWithPriors, ResumesAfterTheSimulationPhaseAndAfterAnEpisodeIdentically) {
  const PendulumSystem real;
  PilcoOptions o = Tiny(true);
  const Recorded full = RunPilco(o, real);
  std::vector<RunState> states;  // after the simulation phase, after episodes 1, 2 and 3
  for (const auto& st : full.states)
    if (!IsPartialSimulation(st)) states.push_back(st);
  ASSERT_EQ(states.size(), 4u);
  for (std::size_t k : {0u, 1u}) {
    const Recorded rest = RunPilco(o, real, &states[k]);
    EXPECT_TRUE(rest.phases.empty());  // the simulation phase is not run again
    ASSERT_EQ(rest.episodes.size(), 3u - k);
    for (std::size_t j = 0; j < rest.episodes.size(); ++j)
      ExpectSameEpisode(rest.episodes[j], full.episodes[k + j]);
  }
}

// A run stopped during its simulation phase continues the phase from the last simulated episode:
// the same simulated returns, phase record and real episodes as a run that was never stopped.
TEST(PilcoWithPriors, ResumesInsideTheSimulationPhaseIdentically) {
  const PendulumSystem real;
  PilcoOptions o = Tiny(true);
  o.sim_episodes = 4;
  o.episodes = 2;
  const Recorded full = RunPilco(o, real);
  std::vector<RunState> partial;
  for (const auto& st : full.states)
    if (IsPartialSimulation(st)) partial.push_back(st);
  ASSERT_EQ(partial.size(), 3u);  // after simulated episodes 1, 2 and 3 (not after the last)
  ASSERT_EQ(full.phases.size(), 1u);
  // The phase so far was reported with each of those episodes (summary.json shows it, and a run
  // directory stopped then has it to reopen).
  ASSERT_EQ(full.phases_so_far.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_FALSE(full.phases_so_far[k].complete);
    EXPECT_EQ(full.phases_so_far[k].episodes.size(), k + 1);
    EXPECT_EQ(full.phases_so_far[k].summary.numbers.at("episodes_done"), k + 1.0);
  }
  for (std::size_t k = 0; k < partial.size(); ++k) {
    SCOPED_TRACE("resumed after simulated episode " + std::to_string(k + 1));
    EXPECT_EQ(partial[k].episodes_done, 0);
    EXPECT_TRUE(partial[k].data.empty());  // no real data yet
    const Recorded rest = RunPilco(o, real, &partial[k]);
    ASSERT_EQ(rest.simulated.size(), 3u - k);  // only the episodes still to simulate
    for (std::size_t j = 0; j < rest.simulated.size(); ++j) {
      EXPECT_EQ(rest.simulated[j].episode, full.simulated[k + 1 + j].episode);
      EXPECT_EQ(rest.simulated[j].best, full.simulated[k + 1 + j].best);  // the return
    }
    ASSERT_EQ(rest.phases.size(), 1u);
    const PhaseRecord& a = rest.phases[0];
    const PhaseRecord& b = full.phases[0];
    ASSERT_EQ(a.episodes.size(), b.episodes.size());
    for (std::size_t e = 0; e < a.episodes.size(); ++e) {
      for (const char* key : {"episode", "return", "predicted_return", "solved"}) {
        const double x = a.episodes[e].numbers.at(key), y = b.episodes[e].numbers.at(key);
        EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << key << " of episode " << e + 1;
      }
      EXPECT_EQ(a.episodes[e].texts, b.episodes[e].texts) << "episode " << e + 1;
    }
    EXPECT_EQ(a.summary.numbers.at("last_return"), b.summary.numbers.at("last_return"));
    EXPECT_GE(a.summary.numbers.at("seconds"), 0.0);
    ASSERT_EQ(rest.episodes.size(), full.episodes.size());
    for (std::size_t j = 0; j < rest.episodes.size(); ++j)
      ExpectSameEpisode(rest.episodes[j], full.episodes[j]);
  }
  // A state that does not fit (its simulated episodes are not a whole number of episodes) is an
  // error with the key's name, not a silent restart.
  RunState broken = partial[1];
  broken.extra["simulation.partial.data"].conservativeResize(7);
  try {
    RunPilco(o, real, &broken);
    ADD_FAILURE() << "expected InvalidArgument";
  } catch (const drops::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("simulation.partial.data"), std::string::npos) << e.what();
  }
}

TEST(Pilco, InvalidOptionsAndTaskModelsAreRejected) {
  PilcoOptions o;
  std::string why;
  o.random_rollouts = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.with_prior = true;
  o.sim_episodes = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("sim_episodes"), std::string::npos);
  o = {};
  o.cost_width = -1;
  EXPECT_THROW(drops::algo::Pilco(o, drops::testing::pendulum_task_model()),
               drops::InvalidArgument);
  auto tm = drops::testing::pendulum_task_model();
  tm.cost_target.resize(3);
  EXPECT_THROW(drops::algo::Pilco(PilcoOptions{}, tm), drops::InvalidArgument);
  // A task model that does not fit the task.
  const PendulumSystem real;
  auto tm3 = drops::testing::pendulum_task_model();
  tm3.config.max_u = Eigen::Vector2d(1, 1);
  EXPECT_THROW(
      drops::algo::run_pilco(std::make_shared<PendulumTask>(), real, nullptr, {}, tm3, Tiny()),
      drops::InvalidArgument);
  // PILCO with priors without a prior.
  EXPECT_THROW(drops::algo::run_pilco(std::make_shared<PendulumTask>(), real, nullptr, {},
                                      drops::testing::pendulum_task_model(), Tiny(true)),
               drops::InvalidArgument);
}

TEST(PilcoExperiment, ThePendubotRunsPilcoAndPilcoWithPriorsFromItsSettings) {
  auto e = drops::fixtures::experiment({"algorithm=pilco", "pilco.centres=50", "episodes=4"});
  EXPECT_EQ(e.variant, "pilco");
  EXPECT_FALSE(e.uses_prior);
  EXPECT_EQ(e.runner->name(), "pilco");
  EXPECT_EQ(e.runner->episodes(), 4);
  auto p = drops::fixtures::experiment({"algorithm=pilco_prior", "prior.preset=tunable"});
  EXPECT_EQ(p.variant, "pilco_prior");
  EXPECT_TRUE(p.uses_prior);
  EXPECT_EQ(p.default_run_name(""), "pendubot-pilco_prior-tunable-seed1");
  const auto o = drops::experiment::pilco_options(p.settings, true);
  EXPECT_EQ(o.centres, 200);
  EXPECT_EQ(o.sim_episodes, 40);
  EXPECT_EQ(o.cost_width, 0.0);  // the task's reward width
  EXPECT_THROW(drops::fixtures::experiment({"algorithm=pilco", "pilco.centres=0"}),
               drops::ConfigError);
  EXPECT_THROW(drops::fixtures::experiment({"algorithm=pilco_prior", "pilco.sim_episodes=1"}),
               drops::ConfigError);
}

namespace {
/// A task without a PILCO description (no "pilco" entry in TaskSetup::algorithm_data).
class NoPilcoTask final : public drops::experiment::TaskPlugin {
 public:
  std::string name() const override { return "nopilco"; }
  std::string description() const override { return "a task PILCO cannot run on"; }
  std::vector<drops::experiment::KeySpec> keys() const override { return {}; }
  drops::experiment::TaskSetup make(const drops::experiment::Settings&) const override {
    drops::experiment::TaskSetup s;
    s.task = std::make_shared<PendulumTask>();
    s.real = std::make_unique<PendulumSystem>();
    drops::policy::NeuralNetPolicyOptions po;
    po.observation_dim = 2;
    s.policy = std::make_unique<drops::policy::NeuralNetPolicy>(po);
    return s;
  }
  std::string prior_label(const drops::experiment::Settings&) const override { return ""; }
  drops::experiment::ReportInfo report_info(const drops::experiment::Settings&) const override {
    return {};
  }
};
}  // namespace

TEST(PilcoExperiment, ATaskWithoutAPilcoDescriptionGetsAClearConfigError) {
  drops::experiment::Registry reg;
  drops::experiment::register_builtin_algorithms(reg);
  reg.add_task(std::make_unique<NoPilcoTask>());
  for (const char* a : {"pilco", "pilco_prior"}) {
    const auto s = drops::experiment::load_settings(reg, "", {std::string("algorithm=") + a});
    try {
      drops::experiment::make_experiment(reg, s);
      FAIL() << a;
    } catch (const drops::ConfigError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("'algorithm'"), std::string::npos) << m;
      EXPECT_NE(m.find("does not describe itself to PILCO"), std::string::npos) << m;
    }
  }
}

namespace {
/// The built-in pendubot task (its keys, its PILCO description) with TorqueCostTask as the task.
class TorqueCostPlugin final : public drops::experiment::TaskPlugin {
 public:
  explicit TorqueCostPlugin(const drops::experiment::TaskPlugin& pendubot) : p_(pendubot) {}
  std::string name() const override { return "torquecost"; }
  std::string description() const override { return "the pendubot with a torque cost"; }
  std::vector<drops::experiment::KeySpec> keys() const override { return p_.keys(); }
  std::map<std::string, std::string> shared_defaults() const override {
    return p_.shared_defaults();
  }
  drops::experiment::TaskSetup make(const drops::experiment::Settings& s) const override {
    drops::experiment::TaskSetup setup = p_.make(s);
    setup.task = std::make_shared<drops::testing::TorqueCostTask>(setup.task, 0.01, "torquecost");
    return setup;
  }
  std::string prior_label(const drops::experiment::Settings& s) const override {
    return p_.prior_label(s);
  }
  drops::experiment::ReportInfo report_info(const drops::experiment::Settings& s) const override {
    return p_.report_info(s);
  }

 private:
  const drops::experiment::TaskPlugin& p_;
};
}  // namespace

TEST(PilcoExperiment, ATaskThatRewardsActionsIsRefusedByNameOfTheReason) {
  const auto& pendubot = drops::fixtures::registry().task("pendubot");
  drops::experiment::Registry reg;
  drops::experiment::register_builtin_algorithms(reg);
  reg.add_task(std::make_unique<TorqueCostPlugin>(pendubot));
  for (const char* a : {"pilco", "pilco_prior"}) {
    const auto s = drops::experiment::load_settings(
        reg, "", {"task=torquecost", std::string("algorithm=") + a});
    try {
      drops::experiment::make_experiment(reg, s);
      FAIL() << a;
    } catch (const drops::ConfigError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("rewards actions too"), std::string::npos) << m;
    }
  }
  // Black-DROPS takes it.
  EXPECT_NO_THROW(drops::experiment::make_experiment(
      reg, drops::experiment::load_settings(reg, "", {"task=torquecost"})));
}

TEST(PilcoExperiment, ARunDirectoryKeepsTheSimulationPhaseAndReopensAtZeroEpisodes) {
  // PILCO with priors saves its state after the simulation phase, before any real episode
  // (episodes_done = 0): the run directory records the phase and --resume accepts that state.
  const auto e = drops::fixtures::experiment({"algorithm=pilco_prior", "prior.preset=tunable"});
  const std::string yaml = drops::experiment::to_yaml(drops::fixtures::registry(), e.settings);
  const auto dir =
      std::filesystem::temp_directory_path() / ("drops-pilco-phase-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  PhaseRecord phase;
  phase.name = "simulation";
  phase.summary.numbers["episodes"] = 3;
  phase.summary.texts["system"] = "the simulator";
  phase.episodes.resize(3);
  phase.episodes[2].numbers["return"] = 1.5;
  RunState st;
  st.episodes_done = 0;
  st.extra["simulation.theta"] = Eigen::Vector3d(1, 2, 3);
  {
    drops::experiment::RunDirectory rd(dir, yaml, e);
    EXPECT_FALSE(rd.has_checkpoint());
    rd.record_phase(phase);
    rd.save_state(st);
    EXPECT_TRUE(rd.has_checkpoint());
  }
  RunState back;
  {
    const auto rd = drops::experiment::RunDirectory::reopen(dir, e, yaml, &back);
    EXPECT_TRUE(rd->repairs().empty());
  }
  EXPECT_EQ(back.episodes_done, 0);
  EXPECT_EQ(back.extra.at("simulation.theta"), st.extra.at("simulation.theta"));
  std::ifstream in(dir / "summary.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("phases")) << j.dump();
  EXPECT_EQ(j["phases"]["simulation"]["episodes"].size(), 3u);
  EXPECT_EQ(j["phases"]["simulation"]["episodes"][2]["return"], 1.5);
  EXPECT_EQ(j["phases"]["simulation"]["system"], "the simulator");
  std::filesystem::remove_all(dir);
}
