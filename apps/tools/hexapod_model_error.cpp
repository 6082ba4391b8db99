// hexapod_model_error: how well the prior alone and the GP model with that prior predict a
// held-out episode of a hexapod run directory (docs/hexapod.md, "The GP residual").
//
//   build/bench/hexapod_model_error RUN_DIR K REMOVED_LEG [walls RATIO SNR]
//
// Trains a gp_prior model (fixed prior: REMOVED_LEG, -1 = intact) on the measured transitions of
// episodes 1..K of RUN_DIR (episodes/NNN/real.csv), then prints the one-step root-mean-square
// error of dx = x_{t+1} - x_t on episode K + 1, per block of the 48-D state, for the prior alone
// and for the model, and the signed mean error of the body's forward step on that episode and on
// the training data; "walls RATIO SNR" enables PILCO's soft walls in the kernel fits
// (gp::RpropOptions::penalty). A diagnostic, not a benchmark: single-threaded, no timing.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"
#include "hexapod_run_data.hpp"

namespace {

using drops::Transition;
using drops::VectorXd;
namespace hx = drops::hexapod;
using drops::tools::episode_file;
using drops::tools::read_transitions;

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4 && argc != 7) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K REMOVED_LEG [walls RATIO SNR]\n"
                 "  one-step prediction error on episode K+1 of the prior alone and of a gp_prior\n"
                 "  model trained on episodes 1..K (REMOVED_LEG: -1 intact, 0..5)\n",
                 argv[0]);
    return 2;
  }
  try {
    const std::string dir = argv[1];
    const int k = std::atoi(argv[2]);
    const int leg = std::atoi(argv[3]);
    const std::vector<Transition> train = drops::tools::read_episodes(dir, k);
    const std::vector<Transition> test = read_transitions(episode_file(dir, k + 1));

    auto task = std::make_shared<hx::HexapodTask>();
    hx::HexapodPriorOptions prior_options;
    prior_options.pool_capacity = 1;
    auto prior = std::make_shared<hx::HexapodPrior>(prior_options);
    prior->check_phi(VectorXd::Constant(1, leg));
    drops::model::PriorParameters fixed = hx::HexapodPrior::prior_parameters();
    fixed.values[0] = leg;  // gp_prior keeps the starting values
    const drops::model::ModelOptions options =
        drops::tools::gp_prior_options(argc == 7 ? argv + 4 : nullptr);
    auto model = drops::model::make_model(options, task, prior, fixed);
    model->learn(train);

    const char* names[] = {"joint angles", "joint velocities", "body position",
                           "roll pitch yaw", "linear velocity", "angular velocity"};
    const int begin[] = {hx::kJointPos, hx::kJointVel,    hx::kBodyPos,    hx::kBodyRpy,
                         hx::kBodyLinVel, hx::kBodyAngVel, hx::kStateDim};
    double sq_dx[6] = {}, sq_prior[6] = {}, sq_model[6] = {};
    VectorXd dx_prior(hx::kStateDim);
    drops::Prediction p;
    const VectorXd phi = VectorXd::Constant(1, leg);
    for (const Transition& t : test) {
      prior->evaluate(t.x, t.u, phi, dx_prior);
      model->predict(t.x, t.u, p);
      for (int b = 0; b < 6; ++b) {
        for (int j = begin[b]; j < begin[b + 1]; ++j) {
          sq_dx[b] += t.dx[j] * t.dx[j];
          sq_prior[b] += std::pow(dx_prior[j] - t.dx[j], 2);
          sq_model[b] += std::pow(p.mean[j] - t.dx[j], 2);
        }
      }
    }
    std::printf("%zu training transitions (episodes 1-%d), %zu test transitions (episode %d)\n",
                train.size(), k, test.size(), k + 1);
    std::printf("one-step RMSE of dx  | %-10s | %-10s | %-10s\n", "RMS dx", "prior", "model");
    for (int b = 0; b < 6; ++b) {
      const double n = static_cast<double>(test.size()) * (begin[b + 1] - begin[b]);
      std::printf("%-20s | %10.4f | %10.4f | %10.4f\n", names[b], std::sqrt(sq_dx[b] / n),
                  std::sqrt(sq_prior[b] / n), std::sqrt(sq_model[b] / n));
    }
    // The forward displacement per step (the walking speed's component): signed mean errors, on
    // the held-out episode and on the training data, show whether the model corrects the
    // prior's bias where it has data (the walking speed is this mean over 40 steps / 4 s).
    const int x = hx::kBodyPos;
    auto bias = [&](const std::vector<Transition>& set, double out[3]) {
      out[0] = out[1] = out[2] = 0;
      for (const Transition& t : set) {
        prior->evaluate(t.x, t.u, phi, dx_prior);
        model->predict(t.x, t.u, p);
        out[0] += t.dx[x];
        out[1] += dx_prior[x] - t.dx[x];
        out[2] += p.mean[x] - t.dx[x];
      }
      for (int i = 0; i < 3; ++i) out[i] *= 1000.0 / static_cast<double>(set.size());
    };
    double on_test[3], on_train[3];
    bias(test, on_test);
    bias(train, on_train);
    std::printf("body x per step (mm) | %-10s | %-10s | %-10s\n", "real mean", "prior bias",
                "model bias");
    std::printf("%-20s | %10.3f | %10.3f | %10.3f\n", "held-out episode", on_test[0], on_test[1],
                on_test[2]);
    std::printf("%-20s | %10.3f | %10.3f | %10.3f\n", "training data", on_train[0], on_train[1],
                on_train[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_model_error: %s\n", e.what());
    return 1;
  }
  return 0;
}
