// The pendubot task plugin: keys, factory and report labels.
#include "drops/pendubot/plugin.hpp"

#include <algorithm>
#include <map>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/pendubot/ite_descriptor.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "drops/policy/policy.hpp"

namespace drops::pendubot {
namespace {

using experiment::KeySpec;
using experiment::Settings;

const std::vector<std::string> kParams = {"m1", "m2", "l1", "l2", "b1", "b2"};
/// IT&E's grid: cells per dimension of the 6-D tip descriptor (docs/ite.md, the study).
constexpr int kIteBinsPerDimension = 5;
/// Table I's priors in the paper's order (the report's panels A-D), then the actual system.
const std::vector<std::string> kPanelOrder = {"tunable-useful", "tunable", "tunable-misleading",
                                              "partially-tunable", "actual"};
const std::vector<std::string> kPanelTitles = {"A tunable & useful", "B tunable",
                                               "C tunable & misleading", "D partially tunable",
                                               "actual system"};

class PendubotPlugin final : public experiment::TaskPlugin {
 public:
  std::string name() const override { return "pendubot"; }
  std::string description() const override {
    return "The pendubot swing-up (paper §V-A): a two-link arm driven at its first joint must "
           "swing up from hanging and balance upright; the simulator prior is the same dynamics "
           "with the parameters of one of Table I's priors.";
  }

  std::map<std::string, std::string> shared_defaults() const override {
    // The paper's score: on Table I's four priors it solved as early as the joint likelihood
    // (the library's default) or earlier (docs/decisions/gp-mi-score.md).
    return {{"model.gp_mi.score", "sum_likelihoods"}};
  }

  std::vector<KeySpec> keys() const override {
    const Params actual;
    const TaskOptions to;
    const policy::NeuralNetPolicyOptions po;
    std::vector<KeySpec> s;
    auto add = [&](KeySpec k) { s.push_back(std::move(k)); };
    auto num = [](double v) {
      std::ostringstream o;
      o << v;
      return o.str();
    };
    const VectorXd phi = actual.to_phi();
    for (std::size_t i = 0; i < kParams.size(); ++i) {
      const std::string& p = kParams[i];
      const bool mass = p[0] == 'm', len = p[0] == 'l';
      const std::string unit = mass ? "kg" : len ? "m" : "N m s";
      const std::string what = mass  ? "mass of link "
                               : len ? "length of link "
                                     : "viscous friction of joint ";
      add({"system." + p, "double", num(phi[static_cast<Eigen::Index>(i)]),
           mass || len ? kMinMassOrLength : 0.0, 100, {}, unit,
           "actual (\"real\") system: " + what + p.substr(1) + " (Table I, actual)"});
    }
    add({"prior.preset", "enum", "tunable-useful", 0, 0, preset_names(), "-",
         "starting prior of Table I: tunable-useful (A), tunable (B), tunable-misleading (C), "
         "partially-tunable (D), or actual"});
    for (const auto& p : kParams)
      add({"prior." + p, "double", "", p[0] == 'b' ? 0.0 : kMinMassOrLength, 100, {},
           p[0] == 'm' ? "kg" : p[0] == 'l' ? "m" : "N m s",
           "prior's " + p + " (empty = the preset's value); a custom prior is the preset plus these"});
    add({"prior.tunable", "names", "[m1, m2, l1, l2]", 0, 0, kParams, "-",
         "parameters that GP-MI and MI may tune (the others stay fixed)"});
    for (const auto& p : kParams) {
      const bool ml = p[0] != 'b';
      add({"prior.bounds." + p, "interval", ml ? "[0.05, 1.0]" : "[0.0, 1.0]",
           ml ? kMinMassOrLength : 0.0, 100, {}, ml ? (p[0] == 'm' ? "kg" : "m") : "N m s",
           std::string("search interval of ") + p + " when tunable" +
               (ml ? " (lower >= 0.01: the inertia matrix is singular at 0)" : "")});
    }
    add({"pendubot.dt", "double", num(to.dt), 1e-4, 1, {}, "s", "control period"});
    add({"pendubot.duration", "double", num(to.duration), 0.01, 100, {}, "s",
         "episode length (>= 3 pendubot.dt)"});
    add({"pendubot.max_torque", "double", num(to.max_torque), 1e-3, 100, {}, "N m",
         "torque bound |u|"});
    add({"pendubot.substeps", "int", num(to.substeps), 1, 1000, {}, "-",
         "RK4 substeps per control period"});
    add({"pendubot.reward_sigma", "double", num(to.reward_sigma), 1e-3, 10, {}, "m",
         "width sigma_c of the reward"});
    add({"pendubot.solved_radius", "double", num(to.solved_radius), 1e-3, 2, {}, "m",
         "solved: the tip stays within this distance of upright ..."});
    add({"pendubot.solved_window", "double", num(to.solved_window), 0, 100, {}, "s",
         "... for the whole last solved_window seconds of the episode"});
    add({"policy.hidden_units", "int", num(po.hidden_units), 1, 1000, {}, "-",
         "tanh units of the network policy"});
    return s;
  }

  experiment::TaskSetup make(const Settings& st) const override {
    using experiment::get_double;
    using experiment::get_int;
    TaskOptions to;
    to.dt = get_double(st, "pendubot.dt");
    to.duration = get_double(st, "pendubot.duration");
    to.max_torque = get_double(st, "pendubot.max_torque");
    to.substeps = static_cast<int>(get_int(st, "pendubot.substeps"));
    to.reward_sigma = get_double(st, "pendubot.reward_sigma");
    to.solved_radius = get_double(st, "pendubot.solved_radius");
    to.solved_window = get_double(st, "pendubot.solved_window");
    // Three control periods at least: IT&E's behaviour descriptor reads the tip at three steps.
    if (to.duration < 3 * to.dt)
      throw ConfigError("config key 'pendubot.duration' = '" + st.at("pendubot.duration") +
                        "': must be >= 3 pendubot.dt (three control periods)");
    VectorXd actual_phi(6);
    for (int i = 0; i < 6; ++i)
      actual_phi[i] = get_double(st, "system." + kParams[static_cast<std::size_t>(i)]);
    const Params actual = Params::from_phi(actual_phi);
    to.goal_l1 = actual.l1;  // the reward uses the actual lengths (settings.md §2)
    to.goal_l2 = actual.l2;

    experiment::TaskSetup s;
    auto& p = s.prior_parameters;
    p.names = kParams;
    p.values = preset(st.at("prior.preset")).to_phi();
    for (int i = 0; i < 6; ++i) {
      const std::string k = "prior." + kParams[static_cast<std::size_t>(i)];
      if (!st.at(k).empty()) p.values[i] = get_double(st, k);
    }
    try {
      Params::from_phi(p.values).check();
    } catch (const InvalidArgument& ex) {
      throw ConfigError(std::string("prior: ") + ex.what());
    }
    for (const auto& n : experiment::get_names(st, "prior.tunable")) {
      const auto it = std::find(kParams.begin(), kParams.end(), n);
      p.tunable.push_back(static_cast<int>(it - kParams.begin()));
    }
    std::sort(p.tunable.begin(), p.tunable.end());
    p.lower.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.upper.resize(static_cast<Eigen::Index>(p.tunable.size()));
    p.choices.assign(p.tunable.size(), {});
    for (std::size_t k = 0; k < p.tunable.size(); ++k) {
      const std::string& name = kParams[static_cast<std::size_t>(p.tunable[k])];
      const auto b = experiment::get_interval(st, "prior.bounds." + name);
      p.lower[static_cast<Eigen::Index>(k)] = b[0];
      p.upper[static_cast<Eigen::Index>(k)] = b[1];
      const double v = p.values[p.tunable[k]];
      if (v < b[0] || v > b[1]) {
        std::ostringstream o;
        o << "config key 'prior.bounds." << name << "' = '" << st.at("prior.bounds." + name)
          << "': the prior's starting " << name << " = " << v << " lies outside it";
        throw ConfigError(o.str());
      }
    }

    policy::NeuralNetPolicyOptions po;
    po.observation_dim = 6;
    po.hidden_units = static_cast<int>(get_int(st, "policy.hidden_units"));
    po.action_dim = 1;
    po.input_scale = VectorXd(6);
    po.input_scale << 10, 10, 1, 1, 1, 1;
    po.max_action = to.max_torque;

    s.task = std::make_shared<SwingUpTask>(to);
    s.real = std::make_unique<PendubotSystem>(actual, to);
    s.policy = std::make_unique<policy::NeuralNetPolicy>(po);
    s.prior = std::make_shared<PendubotPrior>(to);
    s.phi_actual.assign(actual_phi.data(), actual_phi.data() + actual_phi.size());
    s.prior_label = prior_label(st);
    s.pilco = pilco_task_model(to);
    s.state_names = {"dtheta1", "dtheta2", "theta1", "theta2"};
    s.action_names = {"u"};

    // IT&E's behaviour descriptor: the tip at 3 equally spaced times (paper §V-A), with the
    // lengths of the prior the archive is built on (docs/ite.md).
    const double l1 = p.values[2], l2 = p.values[3];
    auto& b = s.behaviour;
    b.names = {"tip_x_1", "tip_y_1", "tip_x_2", "tip_y_2", "tip_x_3", "tip_y_3"};
    b.bins.assign(6, kIteBinsPerDimension);
    b.describe = [l1, l2](const rollout::Trajectory& tr) { return tip_descriptor(tr, l1, l2); };
    const auto steps = tip_descriptor_steps(s.task->horizon());
    b.doc = "tip position (x, y) at steps " + std::to_string(steps[0]) + ", " +
            std::to_string(steps[1]) + " and " + std::to_string(steps[2]) +
            ", each coordinate as (p + L) / 2L with L = l1 + l2 of the prior";
    for (const auto& n : kParams) s.real_system_keys.push_back("system." + n);
    return s;
  }

  std::string prior_label(const Settings& st) const override { return st.at("prior.preset"); }

  experiment::ReportInfo report_info(const Settings& st) const override {
    experiment::ReportInfo r;
    experiment::Panel& p = r.panel;
    p.label = st.at("prior.preset");
    const auto it = std::find(kPanelOrder.begin(), kPanelOrder.end(), p.label);
    p.rank = it == kPanelOrder.end() ? 100 : static_cast<int>(it - kPanelOrder.begin());
    p.title = it == kPanelOrder.end() ? p.label : kPanelTitles[static_cast<std::size_t>(p.rank)];
    r.phi_tunable = experiment::get_names(st, "prior.tunable");
    for (const auto& n : kParams)
      r.phi_labels[n] = {n, n[0] == 'm' ? "kg" : n[0] == 'l' ? "m" : "N·m·s/rad"};
    r.column_labels = {{"theta1", {"θ₁", "rad"}},
                       {"theta2", {"θ₂", "rad"}},
                       {"dtheta1", {"dθ₁/dt", "rad/s"}},
                       {"dtheta2", {"dθ₂/dt", "rad/s"}},
                       {"u", {"torque u", "N·m"}}};
    return r;
  }
};

}  // namespace

void register_task(experiment::Registry& registry) {
  registry.add_task(std::make_unique<PendubotPlugin>());
}

}  // namespace drops::pendubot
