// One batch of hexapod model rollouts, for profilers (issue 14: where a model rollout's time goes).
//
//   hexapod_rollout_profile N EVALUATIONS [THREADS [RPROP_ITERATIONS [ENGINE]]]
//
// N = 0: the prior alone (make_prior_only_model, intact robot); N > 0: a gp_prior model (intact
// prior, the kernels fitted with RPROP_ITERATIONS (default 20) Rprop iterations: the cost of a
// prediction does not depend on the hyper-parameters, and 1 iteration keeps valgrind's run short)
// on the first N transitions of the "real" robot's episodes (as bench_hexapod). Then EVALUATIONS
// policies (uniform theta in [-0.5, 0.5]^36, fixed seeds) are evaluated with one 40-step rollout
// each through rollout::evaluate_policies, in one call, as a CMA-ES generation is. Under valgrind
// only that call is instrumented:
//
//   valgrind --tool=callgrind --instr-atstart=no build/bench/hexapod_rollout_profile 40 16 1
//
// ENGINE: the prior's physics step, dart (default) or rigid (hexapod::PriorEngine).
// Prints the wall-clock time of the call and the mean return.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/hexapod/policy.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/real_robot.hpp"
#include "drops/hexapod/task.hpp"

using namespace drops;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: hexapod_rollout_profile N EVALUATIONS [THREADS [RPROP_ITERATIONS "
                 "[ENGINE]]]\n");
    return 2;
  }
  const int n = std::atoi(argv[1]);
  const int evaluations = std::atoi(argv[2]);
  const ThreadLimit limit(argc > 3 ? std::atoi(argv[3]) : 1);
  auto task = std::make_shared<hexapod::HexapodTask>();
  hexapod::HexapodPriorOptions prior_options;
  const std::string engine = argc > 5 ? argv[5] : "dart";
  if (engine != "dart" && engine != "rigid") {
    std::fprintf(stderr, "hexapod_rollout_profile: ENGINE must be dart or rigid, got %s\n",
                 engine.c_str());
    return 2;
  }
  prior_options.simulator.engine =
      engine == "rigid" ? hexapod::PriorEngine::kRigid : hexapod::PriorEngine::kDart;
  auto prior = std::make_shared<hexapod::HexapodPrior>(prior_options);
  std::unique_ptr<model::DynamicsModel> model;
  if (n == 0) {
    model = model::make_prior_only_model(prior, hexapod::HexapodPrior::prior_parameters());
  } else {
    const hexapod::HexapodRealSystem real;
    hexapod::HexapodGaitPolicy policy;
    std::vector<Transition> data;
    for (int e = 0; static_cast<int>(data.size()) < n; ++e) {
      Rng rng(derive_seed(42, {static_cast<std::uint64_t>(e)}));
      VectorXd theta(36);
      if (e == 0) {
        theta = policy.theta_of(hexapod::tripod_gait());
      } else {
        for (int i = 0; i < 36; ++i) theta[i] = rng.uniform(-0.5, 0.5);
      }
      policy.set_params(theta);
      for (auto& t : rollout::run_episode(*task, real, policy, rng).transitions())
        if (static_cast<int>(data.size()) < n) data.push_back(t);
    }
    model::ModelOptions o;
    o.type = model::ModelType::kGpPrior;
    o.rprop.max_iterations = argc > 4 ? std::atoi(argv[4]) : 20;
    model = model::make_model(o, task, prior, hexapod::HexapodPrior::prior_parameters());
    model->learn(data);
  }
  const hexapod::HexapodGaitPolicy policy;
  std::vector<VectorXd> thetas;
  std::vector<std::uint64_t> seeds;
  Rng rng(7);
  for (int k = 0; k < evaluations; ++k) {
    VectorXd theta(36);
    for (int i = 0; i < 36; ++i) theta[i] = rng.uniform(-0.5, 0.5);
    thetas.push_back(theta);
    seeds.push_back(derive_seed(9, {static_cast<std::uint64_t>(k)}));
  }
  rollout::RolloutOptions ro;
  VectorXd returns;
  rollout::RolloutStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  CALLGRIND_START_INSTRUMENTATION;
  rollout::evaluate_policies(*task, *model, policy, thetas, seeds, ro, returns, &stats);
  CALLGRIND_STOP_INSTRUMENTATION;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "N = %d, %d evaluations: %.3f s (%.1f evaluations/s), mean return %.6f, stopped %ld\n", n,
      evaluations, s, evaluations / s, returns.mean(), stats.nonfinite_steps);
  return 0;
}
