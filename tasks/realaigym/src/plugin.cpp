// The RealAIGym task plugin: keys, factory, episode metrics and report labels.
#include "drops/realaigym/plugin.hpp"

#include <algorithm>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/keys.hpp"
#include "drops/policy/policy.hpp"
#include "drops/realaigym/task.hpp"

namespace drops::realaigym {
namespace {

using experiment::KeySpec;
using experiment::Settings;

/// The values of the task's keys, each declared once in key_table().
struct RealAIGymKeys {
  TaskOptions task;
  /// realaigym.prior: "other-design" (the design the other leaderboard simulates: A.0 model 2.0
  /// for v2, C.1 model 1.0 for v1) or "actual" (the plant itself).
  std::string prior = "other-design";
  experiment::Names tunable = {"m1", "m2", "l1", "r1", "r2", "I1", "I2"};
  policy::NeuralNetPolicyOptions policy;
};

/// The search interval of each prior parameter (prior_parameter_names' order): wide enough for
/// both designs (masses 0.52-0.63 kg, l1 and r1 0.2-0.3 m, r2 0.18-0.26 m, I 0.024-0.053 kg m^2).
const std::array<experiment::Interval, 7> kBounds = {
    {{0.1, 2.0}, {0.1, 2.0}, {0.05, 1.0}, {0.0, 1.0}, {0.0, 1.0}, {1e-3, 0.2}, {1e-3, 0.2}}};

const experiment::KeyTable<RealAIGymKeys>& key_table() {
  static const experiment::KeyTable<RealAIGymKeys> t = [] {
    experiment::KeyTable<RealAIGymKeys> k;
    const auto task = [](auto& keys) -> auto& { return keys.task; };
    k.add(
         "realaigym.leaderboard", [=](auto& keys) -> auto& { return task(keys).leaderboard; })
        .values({{"v2", Leaderboard::kV2}, {"v1", Leaderboard::kV1}})
        .help(
            "the leaderboard, its plant and its score: v2 (simulation_v2: design C.1 model 1.0, "
            "tanh score) or v1 (simulation_v1: design A.0 model 2.0, linear score)");
    k.add(
         "realaigym.dt", [=](auto& keys) -> auto& { return task(keys).dt; })
        .range(0.002, 1)
        .unit("s")
        .help("control period: the policy's torque is held over dt / 2 ms RK4 steps");
    k.add(
         "realaigym.duration", [=](auto& keys) -> auto& { return task(keys).duration; })
        .range(0.01, 100)
        .unit("s")
        .help("episode length (the leaderboards': 10 s)");
    k.add(
         "realaigym.max_torque", [=](auto& keys) -> auto& { return task(keys).max_torque; })
        .range(1e-3, 6)
        .unit("N m")
        .help("the policy's torque bound on joint 1 (the plant's limit: 6 N m)");
    k.add(
         "realaigym.reward_sigma", [=](auto& keys) -> auto& { return task(keys).reward_sigma; })
        .range(1e-3, 10)
        .unit("m")
        .help("width sigma of the reward exp(-d^2 / (2 sigma^2)), d the tip's distance to upright");
    k.add("realaigym.prior", &RealAIGymKeys::prior)
        .values({{"other-design", "other-design"}, {"actual", "actual"}})
        .help(
            "the simulator prior: the plant's equations with the other leaderboard's design "
            "(other-design) or with the plant's own parameters (actual)");
    k.add("realaigym.prior_tunable", &RealAIGymKeys::tunable)
        .allowed(prior_parameter_names())
        .help("prior parameters that GP-MI and MI may tune");
    k.include(experiment::neural_net_policy_key_table(), &RealAIGymKeys::policy);
    return k;
  }();
  return t;
}

class RealAIGymPlugin final : public experiment::TaskPlugin {
 public:
  std::string name() const override { return "realaigym_pendubot"; }
  std::string description() const override {
    return "The RealAIGym simulation leaderboard's swing-up (DFKI Underactuated Lab): their "
           "double pendulum with joint 2 passive swings up from hanging and balances for 10 s; "
           "episodes carry the leaderboard's criteria and RealAI score.";
  }

  std::vector<KeySpec> keys() const override { return key_table().specs(); }

  experiment::TaskSetup make(const Settings& st) const override {
    const RealAIGymKeys k = key_table().read(st);
    const TaskOptions& to = k.task;
    std::string why;
    if (!to.IsValid(&why))
      throw ConfigError("realaigym: " + why + " (realaigym.dt = '" + st.at("realaigym.dt") +
                        "', realaigym.duration = '" + st.at("realaigym.duration") + "')");
    const PlantParameters plant = leaderboard_plant(to.leaderboard);
    const ScoreDefinition definition = leaderboard_score(to.leaderboard);
    const PlantParameters start =
        k.prior == "actual"
            ? plant
            : leaderboard_plant(to.leaderboard == Leaderboard::kV2 ? Leaderboard::kV1
                                                                   : Leaderboard::kV2);

    experiment::TaskSetup s;
    auto& p = s.prior_parameters;
    p.names = prior_parameter_names();
    p.values = to_phi(start);
    for (const auto& n : k.tunable)
      p.tunable.push_back(
          static_cast<int>(std::find(p.names.begin(), p.names.end(), n) - p.names.begin()));
    std::sort(p.tunable.begin(), p.tunable.end());
    p.lower.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.upper.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.choices.assign(p.tunable.size(), {});
    for (std::size_t j = 0; j < p.tunable.size(); ++j) {
      const auto& b = kBounds[static_cast<std::size_t>(p.tunable[j])];
      p.lower[static_cast<Eigen::Index>(j)] = b[0];
      p.upper[static_cast<Eigen::Index>(j)] = b[1];
    }

    policy::NeuralNetPolicyOptions po = k.policy;
    po.observation_dim = 6;
    po.action_dim = 1;
    po.input_scale = VectorXd(6);
    po.input_scale << 10, 10, 1, 1, 1, 1;  // velocities of up to ~10 rad/s to order 1
    po.max_action = to.max_torque;

    s.task = std::make_shared<SwingupTask>(to);
    s.real = std::make_unique<PlantSystem>(plant, to);
    s.policy = std::make_unique<policy::NeuralNetPolicy>(po);
    s.prior = std::make_shared<PlantPrior>(plant, to);
    const VectorXd actual = to_phi(plant);
    s.phi_actual.assign(actual.data(), actual.data() + actual.size());
    s.prior_label = k.prior;
    s.state_names = {"q1", "q2", "qd1", "qd2"};
    s.action_names = {"tau1"};
    // The leaderboard's criteria on the episode at 2 ms: the real system is deterministic, so the
    // episode's actions replayed from its first state give the episode itself at the plant's step.
    s.metric_names = metric_names();
    s.metrics = [plant, definition, to](const algo::EpisodeRecord& record) {
      const rollout::Trajectory& real = record.real;
      ScoreDefinition d = definition;
      d.t_final = to.duration;
      const SwingupTrajectory fine = leaderboard_trajectory(
          plant, d, real.states.row(0).transpose(), real.actions, to.substeps(), to.sim_dt);
      return metric_values(score(fine, d));
    };
    return s;
  }

  std::string prior_label(const Settings& st) const override { return key_table().read(st).prior; }

  experiment::ReportInfo report_info(const Settings& st) const override {
    experiment::ReportInfo r;
    const RealAIGymKeys k = key_table().read(st);
    r.panel.label = k.prior;
    r.panel.rank = k.prior == "other-design" ? 0 : 1;
    r.panel.title = k.prior == "other-design" ? "prior: the other design" : "prior: the plant";
    r.metric = {"realai_score",
                "RealAI score",
                "",
                "realai_score",
                "",
                std::numeric_limits<double>::quiet_NaN(),
                ""};
    r.phi_tunable = k.tunable;
    for (const auto& n : prior_parameter_names())
      r.phi_labels[n] = {n, n[0] == 'm' ? "kg" : n[0] == 'I' ? "kg·m²" : "m"};
    r.column_labels = {{"q1", {"q₁", "rad"}},
                       {"q2", {"q₂", "rad"}},
                       {"qd1", {"dq₁/dt", "rad/s"}},
                       {"qd2", {"dq₂/dt", "rad/s"}},
                       {"tau1", {"torque τ₁", "N·m"}}};
    return r;
  }
};

}  // namespace

void register_task(experiment::Registry& registry) {
  registry.add_task(std::make_unique<RealAIGymPlugin>());
}

}  // namespace drops::realaigym
