// Example: fit a GP dynamics model whose mean is a tunable simulator, and identify the simulator's
// parameters with GP-MI (paper §IV-B), on two episodes of the "real" pendubot.
//
//   build/examples/fit_gp_with_simulator_prior
#include <cmath>
#include <cstdio>

#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/pendubot/pendubot.hpp"

using namespace drops;

int main() {
  // 1. Data: two episodes of the actual pendubot (Table I, actual) under random network policies.
  auto task = std::make_shared<pendubot::SwingUpTask>();
  pendubot::PendubotSystem real(pendubot::preset("actual"));
  policy::NeuralNetPolicy policy;
  std::vector<Transition> data;
  Rng rng(1);
  for (int episode = 0; episode < 2; ++episode) {
    VectorXd theta(policy.param_dim());
    for (int i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1, 1);
    policy.set_params(theta);
    for (auto& t : rollout::run_episode(*task, real, policy, rng).transitions()) data.push_back(t);
  }

  // 2. The prior: the same simulator with wrong parameters (Table I, prior B: m2 = 0.75), with
  //    m1, m2, l1, l2 tunable in [0.05, 1] and the frictions fixed.
  auto prior = std::make_shared<pendubot::PendubotPrior>();
  model::PriorParameters phi;
  phi.names = pendubot::parameter_names();
  phi.values = pendubot::preset("tunable").to_phi();
  phi.tunable = {0, 1, 2, 3};
  phi.lower = VectorXd::Constant(4, 0.05);
  phi.upper = VectorXd::Constant(4, 1.0);
  phi.choices.assign(4, {});

  // 3. GP-MI: the model learns phi and the GP residual together.
  model::ModelOptions options;
  options.type = model::ModelType::kGpMi;
  auto gp_mi = model::make_model(options, task, prior, phi);
  const auto summary = gp_mi->learn(data);
  std::printf("%s\n", summary.BriefReport().c_str());
  std::printf("identified m1 %.3f m2 %.3f l1 %.3f l2 %.3f (actual 0.5 each)\n", summary.phi[0],
              summary.phi[1], summary.phi[2], summary.phi[3]);

  // 4. Predict a state difference with its uncertainty.
  Prediction p;
  gp_mi->predict(data[10].x, data[10].u, p);
  std::printf("dx = [%.4f %.4f %.4f %.4f] +- [%.1e %.1e %.1e %.1e] (true [%.4f %.4f %.4f %.4f])\n",
              p.mean[0], p.mean[1], p.mean[2], p.mean[3], std::sqrt(p.var[0]),
              std::sqrt(p.var[1]), std::sqrt(p.var[2]), std::sqrt(p.var[3]), data[10].dx[0],
              data[10].dx[1], data[10].dx[2], data[10].dx[3]);
  return 0;
}
