// The cart-pole as a drops task: its configuration keys, the experiment it builds, its report
// labels. Registered by main.cpp (cartpole::register_task).
#include <sstream>

#include "cartpole.hpp"
#include "drops/core/errors.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/policy/policy.hpp"

namespace cartpole {
namespace {

using drops::experiment::get_double;

class CartPolePlugin final : public drops::experiment::TaskPlugin {
 public:
  std::string name() const override { return "cartpole"; }
  std::string description() const override {
    return "Cart-pole swing-up (an example of your own robot): the prior's pole length is wrong "
           "and tunable.";
  }
  std::vector<drops::experiment::KeySpec> keys() const override {
    return {{"cartpole.pole_length", "double", "0.5", 0.05, 5, {}, "m",
             "the real pole's length"},
            {"cartpole.prior.pole_length", "double", "0.35", 0.05, 5, {}, "m",
             "the simulator prior's pole length (GP-MI's start)"},
            {"cartpole.prior.bounds", "interval", "[0.1, 1.0]", 0.05, 5, {}, "m",
             "the interval GP-MI searches the pole length in"},
            {"cartpole.duration", "double", "4", 0.5, 60, {}, "s", "episode length"}};
  }
  drops::experiment::TaskSetup make(const drops::experiment::Settings& st) const override {
    Options o;
    o.duration = get_double(st, "cartpole.duration");
    Params real;
    real.pole_length = get_double(st, "cartpole.pole_length");
    o.goal_length = real.pole_length;
    Params prior = real;
    prior.pole_length = get_double(st, "cartpole.prior.pole_length");
    const auto bounds = drops::experiment::get_interval(st, "cartpole.prior.bounds");
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
