// The hexapod task plugin: keys, factory and report labels.
#include "drops/hexapod/plugin.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/keys.hpp"
#include "drops/hexapod/ite_descriptor.hpp"
#include "drops/ite/behaviour.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/simulator.hpp"
#include "drops/hexapod/task.hpp"

namespace drops::hexapod {
namespace {

using experiment::KeySpec;
using experiment::Settings;

const std::vector<std::string> kLegChoices = {"intact", "leg0", "leg1", "leg2",
                                              "leg3",   "leg4", "leg5"};
const std::vector<std::string> kDamageChoices = {"none", "leg0", "leg1", "leg2",
                                                 "leg3", "leg4", "leg5"};
/// "intact"/"none" -> -1, "legk" -> k.
int leg_index(const std::string& name) {
  return name == "intact" || name == "none" ? -1 : name[3] - '0';
}

/// The legs of `names` by their index (leg_index), for an enum key.
experiment::Choices<int> leg_values(const std::vector<std::string>& names) {
  experiment::Choices<int> c;
  for (const auto& n : names) c.emplace_back(n, leg_index(n));
  return c;
}

/// The values of the hexapod's keys, each declared once in key_table() with the field it sets;
/// the defaults are these initialisers (and those of the options structs inside).
struct HexapodKeys {
  HexapodTaskOptions task;                       ///< hexapod.horizon, hexapod.reward.tilt_penalty
  int prior_start = -1;                          ///< hexapod.prior.start: a leg removed, -1 none
  experiment::Names prior_choices = kLegChoices;  ///< hexapod.prior.choices
  /// hexapod.prior.engine, ground_friction, velocity_gain_period and hexapod.guard.
  HexapodPriorOptions prior;
  int removed_leg = -1;       ///< hexapod.damage.removed_leg (-1: none)
  int shortened_leg = -1;     ///< hexapod.damage.shortened_leg (-1: none)
  double tibia_factor = 0.5;  ///< hexapod.damage.tibia_factor
  int blocked_leg = -1;       ///< hexapod.damage.blocked_leg (-1: none)
  int blocked_joint = 1;      ///< hexapod.damage.blocked_joint
  double blocked_angle = 0;   ///< hexapod.damage.blocked_angle, rad
  bool noise = true;          ///< hexapod.noise
  DutyFactorOptions duty;     ///< hexapod.ite.contact_height
};

experiment::KeyTable<HexapodKeys> make_key_table() {
  experiment::KeyTable<HexapodKeys> t;
  t.add("hexapod.horizon", [](auto& k) -> auto& { return k.task.horizon; })
      .range(1, 10000)
      .help("control steps of 0.1 s per episode (40 = the paper's 4 s)");
  t.add("hexapod.reward.tilt_penalty", [](auto& k) -> auto& { return k.task.tilt_penalty; })
      .range(0, 1000)
      .unit("per step")
      .help("reward when the body is tilted 90 degrees or more (subtracted per control step; "
            "settings.md: 10, the paper's task). The walking reward is the forward position "
            "times dt, about 0.01 per step for a good gait, so this sets how much a predicted "
            "fall weighs against speed in the policy search "
            "(docs/decisions/hexapod-tilt-penalty.md)");
  t.add("hexapod.prior.start", &HexapodKeys::prior_start)
      .values(leg_values(kLegChoices))
      .help("the prior simulator of episode 1 and of gp_prior, GP-MI's starting point: the "
            "intact robot or leg k removed (legs 0 rear-left, 1 mid-left, 2 front-left, 3 "
            "front-right, 4 mid-right, 5 rear-right)");
  t.add("hexapod.prior.choices", &HexapodKeys::prior_choices)
      .allowed(kLegChoices)
      .help("the prior family GP-MI and MI search exhaustively (the paper's 7)");
  const auto sim = [](auto& k) -> auto& { return k.prior.simulator; };
  t.add("hexapod.prior.engine", [=](auto& k) -> auto& { return sim(k).engine; })
      .values({{"dart", PriorEngine::kDart}, {"rigid", PriorEngine::kRigid}})
      .help("how the prior simulator computes a physics step: rigid (a dedicated step for the "
            "prior's kinematic legs, DART's physics to round-off, the prior alone about 7 times "
            "faster; docs/benchmarks.md) or dart (DART's world step, the engine of the first "
            "campaigns)");
  t.add("hexapod.prior.ground_friction", [=](auto& k) -> auto& { return sim(k).ground_friction; })
      .range(0.05, 2)
      .help("Coulomb friction coefficient of the prior's ground (1: DART's default, that of "
            "every result before this key; the \"real\" robot's floor is 0.4; "
            "docs/decisions/hexapod-prior-gap.md)");
  t.add("hexapod.prior.velocity_gain_period",
        [=](auto& k) -> auto& { return sim(k).velocity_gain_period; })
      .range(1, 1000)
      .help("the prior's velocity actuators command (q_target - q) / (period * 0.01 s), clipped "
            "to 7 rad/s (settings.md: pi; 1 closes the gap in one 10 ms step, below 1 would "
            "overshoot). Larger values make slower actuators, closer to the \"real\" robot's "
            "torque-limited servos (docs/decisions/hexapod-prior-gap.md)");
  t.add("hexapod.damage.removed_leg", &HexapodKeys::removed_leg)
      .values(leg_values(kDamageChoices))
      .help("the leg removed from the \"real\" robot (the paper's damage: a rear leg, leg0 or "
            "leg5)");
  t.add("hexapod.damage.shortened_leg", &HexapodKeys::shortened_leg)
      .values(leg_values(kDamageChoices))
      .help("a leg of the real robot whose tibia is shortened (damage outside the prior family)");
  t.add("hexapod.damage.tibia_factor", &HexapodKeys::tibia_factor)
      .range(0.05, 1)
      .help("the shortened tibia's length as a fraction of the intact one");
  t.add("hexapod.damage.blocked_leg", &HexapodKeys::blocked_leg)
      .values(leg_values(kDamageChoices))
      .help("a leg of the real robot with one joint blocked (damage outside the prior family)");
  t.add("hexapod.damage.blocked_joint", &HexapodKeys::blocked_joint)
      .range(0, 2)
      .help("which joint of blocked_leg is blocked (0 hip, 1 femur, 2 tibia)");
  t.add("hexapod.damage.blocked_angle", &HexapodKeys::blocked_angle)
      .range(-1.5707963267948966, 1.5707963267948966)
      .unit("rad")
      .help("the angle the blocked joint is held at (within its limits)");
  t.add("hexapod.noise", &HexapodKeys::noise)
      .help("measurement noise on the real robot's state (motion capture, encoders)");
  t.add("hexapod.ite.contact_height", [](auto& k) -> auto& { return k.duty.contact_height; })
      .range(0, 0.2)
      .unit("m")
      .help("IT&E's duty-factor descriptor: a foot touches the ground when its lowest point is "
            "at most this high (docs/ite.md)");
  t.add("hexapod.guard", [](auto& k) -> auto& { return k.prior.guard.policy; })
      .values({{"stop", StateGuardPolicy::kStop}, {"clamp", StateGuardPolicy::kClamp}})
      .help("what the prior does with an implausible predicted state (non-finite, beyond joint "
            "limits, body height out of range): stop that rollout, or clamp the state and go "
            "on; every event is counted in the episode summary");
  return t;
}

const experiment::KeyTable<HexapodKeys>& key_table() {
  static const experiment::KeyTable<HexapodKeys> t = make_key_table();
  return t;
}

class HexapodPlugin final : public experiment::TaskPlugin {
 public:
  std::string name() const override { return "hexapod"; }
  std::string description() const override {
    return "Hexapod locomotion (paper §V-B) in DART: a 6-legged robot (48-D state, 18 joint "
           "targets) learns the 36-parameter open-loop gait that walks fastest; the prior family "
           "is the intact robot and its 6 single-leg removals, the \"real\" robot has servos, "
           "friction, noise and optional damage.";
  }

  std::vector<KeySpec> keys() const override { return key_table().specs(); }

  std::map<std::string, std::string> shared_defaults() const override {
    // The gait's parameters in [0, 1] are theta + 0.5; rollouts cost about 50 times the
    // default task's; the GPs on 40-400 points in 66 input dimensions need the soft walls
    // (docs/hexapod.md).
    // The search's budget and GP-MI's score and candidate start were chosen by measurement
    // (docs/decisions/hexapod-search-budget.md, hexapod-gp-mi-score.md and
    // hexapod-gp-mi-candidate-start.md): with 5,000 evaluations,
    // the joint likelihood (the paper's sum of likelihoods named a leg-removed prior for the
    // intact robot in 32 of 45 episodes) and every candidate's kernels fitted from a new GP's,
    // the best speeds at episode 8 of any setting measured, intact and without leg 5.
    // The trust region around the best real gait: the model overrates gaits far from its data
    // (docs/decisions/hexapod-trust-region.md).
    // Length scales within 3 times their input's spread (10 before the walls study): the model's
    // rollouts err less on new gaits and on the data
    // (docs/decisions/hexapod-length-scale-walls.md).
    // The candidate screen: 20 of the 50 Rprop iterations for every removed-leg prior, the rest
    // for those within 100 nats of the best; it named the winner of the full fits at every
    // identification measured (docs/decisions/hexapod-gp-mi-candidate-screen.md).
    return {{"policy.bound", "0.5"},
            {"optimizer.max_evaluations", "5000"},
            {"optimizer.trust_region", "true"},
            {"optimizer.reevaluation_rollouts", "20"},
            {"model.gp_mi.score", "sum_log_likelihoods"},
            {"model.gp_mi.candidate_start", "initial"},
            {"model.gp_mi.screen_iterations", "20"},
            {"model.gp_mi.screen_margin", "100"},
            {"model.rprop.max_length_scale_ratio", "3"},
            {"model.rprop.penalty", "on"},
            // IT&E: the reference archive's genotype (36 genes on 21 levels, each re-drawn with
            // probability 0.05); returns of good gaits lie in [0, 2.5] like the reference's
            // metres, so M-BOA's reference kernel and kappa apply unscaled (docs/ite.md).
            {"ite.mutation", "resample"},
            {"ite.mutation_rate", "0.05"},
            {"ite.performance_scale", "1"},
            // The reference observes the covered distance, negative values set to 0: a fall
            // (-10 per tipped step here) counts as no progress, not as -250 (docs/ite.md).
            {"ite.observation_floor", "0"},
            {"ite.evaluations", "400000"}};
  }

  experiment::TaskSetup make(const Settings& st) const override {
    const HexapodKeys k = key_table().read(st);
    const experiment::BaseOptions base = experiment::base_options(st);
    experiment::TaskSetup s;
    // The prior family: phi = [removed_leg], one discrete tunable entry (paper §V-B: 7 priors).
    const int prior_start = k.prior_start;
    std::vector<int> choices;
    for (const auto& n : k.prior_choices) choices.push_back(leg_index(n));
    std::sort(choices.begin(), choices.end());
    if (choices.empty())
      throw ConfigError("config key 'hexapod.prior.choices' = '[]': name at least one prior");
    if (std::find(choices.begin(), choices.end(), prior_start) == choices.end())
      throw ConfigError("config key 'hexapod.prior.start' = '" + st.at("hexapod.prior.start") +
                        "': not among hexapod.prior.choices = " + st.at("hexapod.prior.choices"));
    const int removed = k.removed_leg;
    for (const int leg : {k.shortened_leg, k.blocked_leg}) {
      if (leg >= 0 && leg == removed)
        throw ConfigError("config: hexapod.damage: leg" + std::to_string(leg) +
                          " is removed; it cannot also be shortened or blocked");
    }
    auto& p = s.prior_parameters;
    p.names = {"removed_leg"};
    p.values = VectorXd::Constant(1, prior_start);
    p.tunable = {0};
    p.lower = VectorXd::Constant(1, choices.front());
    p.upper = VectorXd::Constant(1, choices.back());
    p.choices = {std::vector<double>(choices.begin(), choices.end())};
    s.phi_actual = {static_cast<double>(removed)};
    s.prior_label = prior_label(st);

    const HexapodTaskOptions to = k.task;
    auto task = std::make_shared<HexapodTask>(to);
    s.task = task;

    RealRobotOptions ro;
    ro.spec = real_robot_spec(st);
    if (!k.noise) ro.noise = MeasurementNoise{0, 0, 0, 0, 0, 0};
    std::string why;
    if (!ro.IsValid(&why)) throw ConfigError("config: hexapod.damage: " + why);
    s.real = std::make_unique<HexapodRealSystem>(ro);

    HexapodGaitPolicyOptions po;
    po.observation_dim = kObservationDim;
    po.theta_bound = base.black_drops.search.theta_bound;
    s.policy = std::make_unique<HexapodGaitPolicy>(po);

    HexapodPriorOptions mo = k.prior;
    mo.pool_capacity = base.threads;  // 0: hardware threads
    auto prior = std::make_shared<HexapodPrior>(mo);
    s.prior = prior;

    for (const char* block : {"q", "dq"})
      for (int k = 0; k < kNumLegs; ++k)
        for (int j = 0; j < kJointsPerLeg; ++j)
          s.state_names.push_back(std::string(block) + "_" + joint_name(k, j));
    for (const char* n : {"x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "wx", "wy", "wz"})
      s.state_names.emplace_back(n);
    for (int k = 0; k < kNumLegs; ++k)
      for (int j = 0; j < kJointsPerLeg; ++j) s.action_names.push_back("u_" + joint_name(k, j));

    // Per episode: the walking speed on the robot and on the model's predicted trajectory, and
    // the state guard's events since the previous episode (policy search and model learning).
    s.metric_names = {"walking_speed_m_s", "predicted_speed_m_s", "guard_evaluations",
                      "guard_stopped", "guard_clamped"};
    auto last = std::make_shared<StateGuardCounts>();
    s.metrics = [task, prior, last](const algo::EpisodeRecord& r) {
      const StateGuardCounts c = prior->guard_counts();
      const double predicted = r.predicted.states.rows() > 1
                                   ? task->walking_speed(r.predicted)
                                   : std::numeric_limits<double>::quiet_NaN();
      std::vector<double> v = {task->walking_speed(r.real), predicted,
                               static_cast<double>(c.evaluations - last->evaluations),
                               static_cast<double>(c.stopped - last->stopped),
                               static_cast<double>(c.clamped - last->clamped)};
      *last = c;
      return v;
    };

    // IT&E's behaviour descriptor: the duty factor on the prior (the starting removed leg), the
    // turned-over robots discarded (docs/ite.md).
    ite::BehaviourDescriptor b;
    for (int k = 0; k < kNumLegs; ++k) b.names.push_back(fmt::format("duty_leg{}", k));
    b.bins.assign(kNumLegs, 5);  // 5^6 = 15,625 cells, the reference grid
    const DutyFactorOptions df = k.duty;
    b.describe = [prior, prior_start, df](const rollout::Trajectory& tr) {
      return duty_factor(tr, prior->pool(prior_start), df);
    };
    const double tilt_limit = to.tilt_limit;
    b.alive = [tilt_limit](const rollout::Trajectory& tr) { return stayed_upright(tr, tilt_limit); };
    b.doc = fmt::format(
        "duty factor: per leg, the fraction of the {} states x_1..x_H (one per {} s) at which the "
        "foot is at most {} m above the ground on the prior; a removed leg 0; episodes in which "
        "the body tilted {:.0f} degrees or more are discarded",
        to.horizon, to.dt, df.contact_height, to.tilt_limit * 180 / 3.14159265358979323846);
    s.algorithm_data.set("ite", std::move(b));
    s.real_system_keys = {"hexapod.damage.removed_leg",   "hexapod.damage.shortened_leg",
                          "hexapod.damage.tibia_factor",  "hexapod.damage.blocked_leg",
                          "hexapod.damage.blocked_joint", "hexapod.damage.blocked_angle",
                          "hexapod.noise"};

    // Foot heights of the real robot's body for the gait diagram (drops plot).
    for (int k = 0; k < kNumLegs; ++k)
      s.state_extra_names.push_back(fmt::format("foot{}_height", k));
    PriorOptions fk = ro.simulator;
    fk.actuation = Actuation::kVelocity;
    auto sim = std::make_shared<PriorSimulator>(ro.spec, fk);
    s.state_extras = [sim](const VectorXd& x) {
      std::vector<double> v(kNumLegs, std::numeric_limits<double>::quiet_NaN());
      if (!x.allFinite()) return v;
      sim->set_state(x);
      const auto f = sim->foot_heights();
      v.assign(f.begin(), f.end());
      return v;
    };
    return s;
  }

  std::string prior_label(const Settings& st) const override {
    return st.at("hexapod.prior.start");
  }


  experiment::ReportInfo report_info(const Settings& st) const override {
    experiment::ReportInfo r;
    std::vector<std::string> parts;
    for (const auto& [key, word] : {std::pair{"hexapod.damage.removed_leg", "removed"},
                                    std::pair{"hexapod.damage.shortened_leg", "shortened"},
                                    std::pair{"hexapod.damage.blocked_leg", "blocked"}}) {
      const std::string v = st.at(key);
      if (v != "none") parts.push_back(v + " " + word);
    }
    std::string label;
    for (const auto& part : parts) label += (label.empty() ? "" : ", ") + part;
    r.panel.label = label.empty() ? "intact" : label;
    r.panel.rank = parts.empty() ? 0 : 1;
    r.panel.title = "real robot: " + r.panel.label;
    // The damage applies to every run, a direct search on the robot too: it stays in the panel.
    r.panel.chosen_by_prior = false;
    r.metric = {"walking_speed_m_s", "walking speed", "m/s", "speed", "predicted_speed_m_s", 0.22,
                "paper's physical robot, intact (0.22 m/s)"};
    // Every episode "succeeds" or not by a speed threshold of ours (HexapodTaskOptions::
    // solved_speed), not a criterion of the paper: reports show speeds instead.
    r.success_criterion = false;
    for (int leg = -1; leg < kNumLegs; ++leg)
      r.phi_value_labels[leg] = leg < 0 ? "intact" : "leg" + std::to_string(leg);
    r.phi_tunable = {"removed_leg"};
    r.phi_labels["removed_leg"] = {"prior: removed leg", ""};
    r.column_labels = {{"x", {"body x", "m"}},
                       {"y", {"body y", "m"}},
                       {"z", {"body height z", "m"}},
                       {"roll", {"roll", "rad"}},
                       {"pitch", {"pitch", "rad"}},
                       {"yaw", {"yaw", "rad"}},
                       {"vx", {"forward velocity", "m/s"}}};
    for (int k = 0; k < kNumLegs; ++k)
      for (int j = 0; j < kJointsPerLeg; ++j)
        r.column_labels["u_" + joint_name(k, j)] = {"target angle " + joint_name(k, j), "rad"};
    return r;
  }
};

}  // namespace

HexapodSpec real_robot_spec(const Settings& st) {
  const HexapodKeys k = key_table().read(st);
  HexapodSpec spec = HexapodSpec::with_leg_removed(k.removed_leg);
  if (k.shortened_leg >= 0)
    spec.legs[static_cast<std::size_t>(k.shortened_leg)].tibia_length_factor = k.tibia_factor;
  if (k.blocked_leg >= 0) {
    auto& leg = spec.legs[static_cast<std::size_t>(k.blocked_leg)];
    leg.blocked_joint = k.blocked_joint;
    leg.blocked_angle = k.blocked_angle;
  }
  return spec;
}

void register_task(experiment::Registry& registry) {
  registry.add_task(std::make_unique<HexapodPlugin>());
}

}  // namespace drops::hexapod
