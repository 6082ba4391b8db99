// The cart-pole as a drops task: its configuration keys, the experiment it builds, its report
// labels. Registered by main.cpp (cartpole::register_task).
#include <sstream>

#include "cartpole.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/keys.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/policy/policy.hpp"

namespace cartpole {
namespace {

/// The values of the cart-pole's keys, each declared once in key_table() with the field it sets;
/// the defaults are these initialisers (and those of Params and Options).
struct CartPoleKeys {
  Params real;                                      ///< cartpole.pole_length
  double prior_pole_length = 0.35;                  ///< cartpole.prior.pole_length
  drops::experiment::Interval bounds = {0.1, 1.0};  ///< cartpole.prior.bounds
  Options task;                                     ///< cartpole.duration
};

const drops::experiment::KeyTable<CartPoleKeys>& key_table() {
  static const drops::experiment::KeyTable<CartPoleKeys> t = [] {
    drops::experiment::KeyTable<CartPoleKeys> k;
    k.add("cartpole.pole_length", [](auto& c) -> auto& { return c.real.pole_length; })
        .range(0.05, 5)
        .unit("m")
        .help("the real pole's length");
    k.add("cartpole.prior.pole_length", &CartPoleKeys::prior_pole_length)
        .range(0.05, 5)
        .unit("m")
        .help("the simulator prior's pole length (GP-MI's start)");
    k.add("cartpole.prior.bounds", &CartPoleKeys::bounds)
        .range(0.05, 5)
        .unit("m")
        .help("the interval GP-MI searches the pole length in");
    k.add("cartpole.duration", [](auto& c) -> auto& { return c.task.duration; })
        .range(0.5, 60)
        .unit("s")
        .help("episode length");
    return k;
  }();
  return t;
}

class CartPolePlugin final : public drops::experiment::TaskPlugin {
 public:
  std::string name() const override { return "cartpole"; }
  std::string description() const override {
    return "Cart-pole swing-up (an example of your own robot): the prior's pole length is wrong "
           "and tunable.";
  }
  std::vector<drops::experiment::KeySpec> keys() const override { return key_table().specs(); }
  drops::experiment::TaskSetup make(const drops::experiment::Settings& st) const override {
    const CartPoleKeys k = key_table().read(st);
    Options o = k.task;
    const Params real = k.real;
    o.goal_length = real.pole_length;
    Params prior = real;
    prior.pole_length = k.prior_pole_length;
    const auto& bounds = k.bounds;
    if (prior.pole_length < bounds[0] || prior.pole_length > bounds[1])
      throw drops::ConfigError("config key 'cartpole.prior.pole_length' = '" +
                               st.at("cartpole.prior.pole_length") +
                               "': outside cartpole.prior.bounds");

    drops::experiment::TaskSetup s;
    s.task = std::make_shared<SwingUpTask>(o);
    s.real = std::make_unique<RealCartPole>(real, o);
    drops::policy::NeuralNetPolicyOptions po;
    po.observation_dim = 5;
    po.input_scale = VectorXd(5);
    po.input_scale << 1, 5, 10, 1, 1;
    po.max_action = o.max_force;
    s.policy = std::make_unique<drops::policy::NeuralNetPolicy>(po);
    s.prior = std::make_shared<Prior>(real, o);  // the prior differs in its pole length only
    auto& p = s.prior_parameters;
    p.names = {"pole_length"};
    p.values = prior.to_phi();
    p.tunable = {0};
    p.lower = VectorXd::Constant(1, bounds[0]);
    p.upper = VectorXd::Constant(1, bounds[1]);
    p.choices = {{}};  // continuous
    s.phi_actual = {real.pole_length};
    s.prior_label = prior_label(st);
    s.state_names = {"x", "dx", "theta", "dtheta"};
    s.action_names = {"force"};
    return s;
  }
  std::string prior_label(const drops::experiment::Settings& st) const override {
    return "l" + st.at("cartpole.prior.pole_length");
  }
  drops::experiment::ReportInfo report_info(const drops::experiment::Settings& st) const override {
    drops::experiment::ReportInfo r;
    r.panel.label = "prior " + prior_label(st);
    r.panel.title = "prior pole length " + st.at("cartpole.prior.pole_length") + " m";
    r.phi_tunable = {"pole_length"};
    // How figures label phi and the trajectory columns (a name without a label is shown as is).
    r.phi_labels["pole_length"] = {"pole length", "m"};
    r.column_labels = {{"x", {"cart position", "m"}},
                       {"dx", {"cart velocity", "m/s"}},
                       {"theta", {"pole angle", "rad"}},
                       {"dtheta", {"pole velocity", "rad/s"}},
                       {"force", {"force on the cart", "N"}}};
    return r;
  }
};

}  // namespace

void register_task(drops::experiment::Registry& registry) {
  registry.add_task(std::make_unique<CartPolePlugin>());
}

}  // namespace cartpole
