// hexapod_prior_scores: what GP-MI sees when it chooses a prior on a hexapod run's data
// (docs/hexapod.md, "Leg identification").
//
//   build/tasks/hexapod/tools/hexapod_prior_scores RUN_DIR K [walls RATIO SNR] [friction MU]
//                                                  [period P]
//
// For each prior of the family (intact, leg 0..5 removed), fits a gp_prior model with that prior
// on the measured transitions of episodes 1..K of RUN_DIR (episodes/NNN/real.csv) and prints the
// log marginal likelihoods of its 48 output GPs, combined four ways: the paper's score
// log sum_i exp(l_i) (model.gp_mi.score: sum_likelihoods), sum_i l_i (sum_log_likelihoods), and
// sum_i l_i over the 36 joint outputs and over the 12 body outputs. "walls RATIO SNR" enables
// PILCO's soft walls in the kernel fits, as `drops run` on the hexapod (10 500). "friction MU"
// gives the priors' ground this Coulomb coefficient (hexapod.prior.ground_friction; default 1,
// the "real" robot's floor is 0.4). "period P" gives the priors' velocity actuators this period
// (hexapod.prior.velocity_gain_period; default settings.md's pi). A diagnostic:
// full kernel fits per prior (GP-MI's nested search does the same fits warm-started), no timing.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/model/gp_mi.hpp"
#include "hexapod_run_data.hpp"

int main(int argc, char** argv) {
  namespace hx = drops::hexapod;
  // Options after RUN_DIR K, in any order: "walls RATIO SNR", "friction MU", "period P".
  char** walls = nullptr;
  double mu = 1.0;
  double period = hx::HexapodPriorOptions{}.simulator.velocity_gain_period;
  bool usage = argc < 3;
  for (int a = 3; a < argc && !usage;) {
    const std::string w = argv[a];
    if (w == "walls" && a + 2 < argc) {
      walls = argv + a;
      a += 3;
    } else if (w == "friction" && a + 1 < argc) {
      mu = std::atof(argv[a + 1]);
      a += 2;
    } else if (w == "period" && a + 1 < argc) {
      period = std::atof(argv[a + 1]);
      a += 2;
    } else {
      usage = true;
    }
  }
  if (usage) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K [walls RATIO SNR] [friction MU] [period P]\n"
                 "  GP-MI's scores of the 7 removed-leg priors on episodes 1..K of RUN_DIR\n",
                 argv[0]);
    return 2;
  }
  try {
    const std::string dir = argv[1];
    const int k = std::atoi(argv[2]);
    const std::vector<drops::Transition> data = drops::tools::read_episodes(dir, k);
    const drops::model::ModelOptions options = drops::tools::gp_prior_options(walls);
    std::printf("%zu transitions (episodes 1-%d of %s)\n", data.size(), k, dir.c_str());
    std::printf("%-7s | %14s | %12s | %12s | %12s\n", "prior", "log sum exp l", "sum l",
                "sum l joints", "sum l body");
    for (int leg = -1; leg < hx::kNumLegs; ++leg) {
      auto task = std::make_shared<hx::HexapodTask>();
      hx::HexapodPriorOptions prior_options;
      prior_options.pool_capacity = 1;
      prior_options.simulator.ground_friction = mu;
      prior_options.simulator.velocity_gain_period = period;
      auto prior = std::make_shared<hx::HexapodPrior>(prior_options);
      drops::model::PriorParameters fixed = hx::HexapodPrior::prior_parameters();
      fixed.values[0] = leg;  // gp_prior keeps the starting values
      auto model = drops::model::make_model(options, task, prior, fixed);
      const drops::model::ModelSummary s = model->learn(data);
      const drops::VectorXd& l = s.log_likelihoods;
      const double joints = l.head(hx::kBodyPos).sum();
      const double body = l.tail(hx::kStateDim - hx::kBodyPos).sum();
      std::printf("%-7s | %14.2f | %12.2f | %12.2f | %12.2f\n",
                  leg < 0 ? "intact" : ("leg" + std::to_string(leg)).c_str(),
                  drops::model::log_sum_exp(l), l.sum(), joints, body);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_prior_scores: %s\n", e.what());
    return 1;
  }
  return 0;
}
