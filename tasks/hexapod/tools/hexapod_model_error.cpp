// hexapod_model_error: how well the prior alone and the GP model with that prior predict a
// held-out episode of a hexapod run directory (docs/hexapod.md, "The GP residual").
//
//   build/bench/hexapod_model_error RUN_DIR K REMOVED_LEG [walls RATIO SNR] [offset]
//
// Trains a gp_prior model (fixed prior: REMOVED_LEG, -1 = intact) on the measured transitions of
// episodes 1..K of RUN_DIR (episodes/NNN/real.csv), then prints the one-step root-mean-square
// error of dx = x_{t+1} - x_t on episode K + 1, per block of the 48-D state, for the prior alone
// and for the model, and the signed mean error of the body's forward step on that episode and on
// the training data; "walls RATIO SNR" enables PILCO's soft walls in the kernel fits
// (gp::RpropOptions::penalty). "offset" adds a third model whose prior is shifted by the mean
// residual of the training data (a constant mean for the residual GPs, the data's average): does
// the learned correction then carry to a new gait? A diagnostic, not a benchmark:
// single-threaded, no timing.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"
#include "hexapod_run_data.hpp"

namespace {

using drops::Transition;
using drops::VectorXd;
using drops::model::MeanFunction;

/// The prior plus a constant dx offset (dim E): the "offset" model of the diagnostic.
class OffsetPrior final : public MeanFunction {
 public:
  OffsetPrior(std::shared_ptr<const MeanFunction> base, VectorXd offset)
      : base_(std::move(base)), offset_(std::move(offset)) {}
  int state_dim() const override { return base_->state_dim(); }
  int action_dim() const override { return base_->action_dim(); }
  std::vector<std::string> parameter_names() const override { return base_->parameter_names(); }
  void check_phi(const VectorXd& phi) const override { base_->check_phi(phi); }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    base_->evaluate(x, u, phi, dx);
    dx += offset_;
  }
  std::unique_ptr<MeanFunction> clone() const override {
    return std::make_unique<OffsetPrior>(std::shared_ptr<const MeanFunction>(base_->clone()),
                                         offset_);
  }

 private:
  std::shared_ptr<const MeanFunction> base_;
  VectorXd offset_;
};

namespace hx = drops::hexapod;
using drops::tools::episode_file;
using drops::tools::read_transitions;

}  // namespace

int main(int argc, char** argv) {
  const bool offset = argc > 4 && std::string(argv[argc - 1]) == "offset";
  const int words = argc - (offset ? 1 : 0);
  if (words != 4 && words != 7) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K REMOVED_LEG [walls RATIO SNR] [offset]\n"
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

    const drops::model::ModelOptions options =
        drops::tools::gp_prior_options(words == 7 ? argv + 4 : nullptr);
    const drops::tools::FixedLegModel fitted =
        drops::tools::fit_fixed_leg_model(leg, options, train);
    const auto& model = fitted.model;
    const auto& prior = fitted.prior;
    const VectorXd& phi = fitted.phi;
    VectorXd dx_prior(hx::kStateDim);
    // The "offset" model: the prior shifted by the training data's mean residual.
    std::unique_ptr<drops::model::DynamicsModel> shifted;
    if (offset) {
      VectorXd mean_residual = VectorXd::Zero(hx::kStateDim);
      for (const Transition& t : train) {
        prior->evaluate(t.x, t.u, phi, dx_prior);
        mean_residual += t.dx - dx_prior;
      }
      mean_residual /= static_cast<double>(train.size());
      shifted = drops::model::make_model(options, fitted.task,
                                         std::make_shared<OffsetPrior>(prior, mean_residual),
                                         fitted.parameters);
      shifted->learn(train);
    }

    const char* names[] = {"joint angles", "joint velocities", "body position",
                           "roll pitch yaw", "linear velocity", "angular velocity"};
    const int begin[] = {hx::kJointPos, hx::kJointVel,    hx::kBodyPos,    hx::kBodyRpy,
                         hx::kBodyLinVel, hx::kBodyAngVel, hx::kStateDim};
    double sq_dx[6] = {}, sq_prior[6] = {}, sq_model[6] = {}, sq_shifted[6] = {};
    drops::Prediction p;
    drops::Prediction q;
    for (const Transition& t : test) {
      prior->evaluate(t.x, t.u, phi, dx_prior);
      model->predict(t.x, t.u, p);
      if (shifted) shifted->predict(t.x, t.u, q);
      for (int b = 0; b < 6; ++b) {
        for (int j = begin[b]; j < begin[b + 1]; ++j) {
          sq_dx[b] += t.dx[j] * t.dx[j];
          sq_prior[b] += std::pow(dx_prior[j] - t.dx[j], 2);
          sq_model[b] += std::pow(p.mean[j] - t.dx[j], 2);
          if (shifted) sq_shifted[b] += std::pow(q.mean[j] - t.dx[j], 2);
        }
      }
    }
    std::printf("%zu training transitions (episodes 1-%d), %zu test transitions (episode %d)\n",
                train.size(), k, test.size(), k + 1);
    std::printf("one-step RMSE of dx  | %-10s | %-10s | %-10s%s\n", "RMS dx", "prior", "model",
                shifted ? " | offset" : "");
    for (int b = 0; b < 6; ++b) {
      const double n = static_cast<double>(test.size()) * (begin[b + 1] - begin[b]);
      std::printf("%-20s | %10.4f | %10.4f | %10.4f", names[b], std::sqrt(sq_dx[b] / n),
                  std::sqrt(sq_prior[b] / n), std::sqrt(sq_model[b] / n));
      if (shifted) std::printf(" | %10.4f", std::sqrt(sq_shifted[b] / n));
      std::printf("\n");
    }
    // The forward displacement per step (the walking speed's component): signed mean errors, on
    // the held-out episode and on the training data, show whether the model corrects the
    // prior's bias where it has data (the walking speed is this mean over 40 steps / 4 s).
    const int x = hx::kBodyPos;
    auto bias = [&](const std::vector<Transition>& set, double out[4]) {
      out[0] = out[1] = out[2] = out[3] = 0;
      for (const Transition& t : set) {
        prior->evaluate(t.x, t.u, phi, dx_prior);
        model->predict(t.x, t.u, p);
        out[0] += t.dx[x];
        out[1] += dx_prior[x] - t.dx[x];
        out[2] += p.mean[x] - t.dx[x];
        if (shifted) {
          shifted->predict(t.x, t.u, q);
          out[3] += q.mean[x] - t.dx[x];
        }
      }
      for (int i = 0; i < 4; ++i) out[i] *= 1000.0 / static_cast<double>(set.size());
    };
    double on_test[4], on_train[4];
    bias(test, on_test);
    bias(train, on_train);
    std::printf("body x per step (mm) | %-10s | %-10s | %-10s%s\n", "real mean", "prior bias",
                "model bias", shifted ? " | offset bias" : "");
    for (const auto& [label, v] : {std::pair<const char*, const double*>{"held-out episode", on_test},
                                   {"training data", on_train}}) {
      std::printf("%-20s | %10.3f | %10.3f | %10.3f", label, v[0], v[1], v[2]);
      if (shifted) std::printf(" | %10.3f", v[3]);
      std::printf("\n");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_model_error: %s\n", e.what());
    return 1;
  }
  return 0;
}
