// hexapod_rollout_error: where a hexapod model's rollout of a held-out episode drifts from what
// the "real" robot did (docs/hexapod.md, "Why the model overrates gaits").
//
//   build/tasks/hexapod/tools/hexapod_rollout_error RUN_DIR K EPISODE REMOVED_LEG
//       [walls RATIO SNR [samples N [noise step|rollout] [scale S]] [trace]]
//
// Trains a gp_prior model (fixed prior: REMOVED_LEG, -1 = intact) on the measured transitions of
// episodes 1..K of RUN_DIR, then replays the recorded actions of EPISODE (K + 1 for a held-out
// gait, <= K for one the model was trained on; the gait is open loop, so its actions depend on
// time only; a comma-separated list replays each on the same model) from the recorded first
// state, on the mean of:
//   prior        the prior alone;
//   model        the model (prior + GP residual);
//   model|joints the model with the joint angles and velocities reset to the measured ones before
//                every step (does the drift come through the joints?);
//   model|body   the model with the body's state but x and y reset to the measured one before
//                every step (the sum of one-step forward predictions from measured states).
// Prints the forward distance / 4 s (the walking speed) of each, the real one, and the RMS error
// of the body height, roll and pitch along the rollout. Mean rollouts, no sampling: a
// diagnostic, single-threaded, no timing. With "samples N", also N sampled rollouts of the model
// (each draw clipped at 1 sigma, as the policy search's; rollout i on stream i, so two episodes
// replayed with the same N see common random numbers): the mean, standard deviation and 25th
// percentile of their speeds, the spread that a pessimistic policy choice would use, and how many
// reached the task's tilt limit (a fall for the reward). "noise rollout" draws the clipped z once
// per rollout instead of once per step (x + mu + S sigma z with the same z at every step: errors
// correlated in time, as a function drawn from the GP once); "scale S" multiplies sigma by S.
// "trace" prints, per step of the model's mean rollout, the real and the model's roll, pitch and
// height, the prior's and the GP residual's share of the predicted roll and pitch steps and their
// predictive sd, and the output of largest sd.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/rollout/rollout.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"
#include "hexapod_run_data.hpp"

namespace {

namespace hx = drops::hexapod;
using drops::Transition;
using drops::VectorXd;

enum class Forcing { kNone, kJoints, kBody };

/// How a sampled rollout draws its predictive noise.
struct Noise {
  bool per_rollout = false;  ///< one clipped z per rollout (true) or a new one per step (false)
  double scale = 1.0;        ///< sigma multiplied by this
};

struct RolloutError {
  double speed = 0;      ///< forward distance / duration, m/s
  double rms_z = 0;      ///< body height error, m
  double rms_tilt = 0;   ///< roll and pitch error, rad
};

/// Mean rollout of `model` (or of the prior when model is null) along the recorded episode.
RolloutError replay(const std::vector<Transition>& real, double dt,
                    const drops::model::DynamicsModel* model, const hx::HexapodPrior& prior,
                    const VectorXd& phi, Forcing forcing, bool trace) {
  VectorXd x = real.front().x;
  VectorXd dx(hx::kStateDim);
  drops::Prediction p;
  double sq_z = 0, sq_tilt = 0;
  for (std::size_t t = 0; t < real.size(); ++t) {
    if (forcing == Forcing::kJoints) x.head(hx::kBodyPos) = real[t].x.head(hx::kBodyPos);
    if (forcing == Forcing::kBody)
      x.tail(hx::kStateDim - hx::kBodyPos - 2) = real[t].x.tail(hx::kStateDim - hx::kBodyPos - 2);
    if (model != nullptr) {
      model->predict(x, real[t].u, p);
      dx = p.mean;
      if (trace) {
        VectorXd from_prior(hx::kStateDim);
        prior.evaluate(x, real[t].u, phi, from_prior);
        const VectorXd next = real[t].x + real[t].dx;
        const VectorXd sd = p.var.cwiseMax(0.0).cwiseSqrt();
        Eigen::Index widest = 0;
        sd.maxCoeff(&widest);
        std::printf("t%2zu real r %+.3f p %+.3f z %.3f | model r %+.3f p %+.3f z %.3f | "
                    "dr prior %+.4f gp %+.4f sd %.4f | dp prior %+.4f gp %+.4f sd %.4f | "
                    "largest sd %.4f (output %ld)\n",
                    t, next[hx::kBodyRpy], next[hx::kBodyRpy + 1], next[hx::kBodyPos + 2],
                    x[hx::kBodyRpy] + dx[hx::kBodyRpy], x[hx::kBodyRpy + 1] + dx[hx::kBodyRpy + 1],
                    x[hx::kBodyPos + 2] + dx[hx::kBodyPos + 2], from_prior[hx::kBodyRpy],
                    dx[hx::kBodyRpy] - from_prior[hx::kBodyRpy], sd[hx::kBodyRpy],
                    from_prior[hx::kBodyRpy + 1], dx[hx::kBodyRpy + 1] - from_prior[hx::kBodyRpy + 1],
                    sd[hx::kBodyRpy + 1], sd[widest], static_cast<long>(widest));
      }
    } else {
      prior.evaluate(x, real[t].u, phi, dx);
    }
    x += dx;
    const VectorXd next = real[t].x + real[t].dx;
    sq_z += std::pow(x[hx::kBodyPos + 2] - next[hx::kBodyPos + 2], 2);
    sq_tilt += std::pow(x[hx::kBodyPos + 3] - next[hx::kBodyPos + 3], 2) +
               std::pow(x[hx::kBodyPos + 4] - next[hx::kBodyPos + 4], 2);
  }
  const double n = static_cast<double>(real.size());
  RolloutError e;
  e.speed = (x[hx::kBodyPos] - real.front().x[hx::kBodyPos]) / (n * dt);
  e.rms_z = std::sqrt(sq_z / n);
  e.rms_tilt = std::sqrt(sq_tilt / (2 * n));
  return e;
}

/// Speed (forward distance / duration, m/s) of a sampled rollout of `model` along the recorded
/// episode's actions, its draws from `rng` clipped at 1 sigma as ModelSystem's (the default
/// Noise is exactly ModelSystem's step); *fell is set when the rollout reached a state the task
/// treats as a fall (HexapodTask::absorbing: the tilt limit). A non-finite prediction stops the
/// rollout at its last finite state (as in the policy search) and sets *nonfinite.
double sampled_speed(const std::vector<Transition>& real, double dt, const hx::HexapodTask& task,
                     const drops::model::DynamicsModel& model, const Noise& noise,
                     drops::Rng& rng, bool* fell,
                     bool* nonfinite) {
  auto draw = [&rng](VectorXd& z) {
    for (Eigen::Index i = 0; i < z.size(); ++i) z[i] = std::clamp(rng.normal(), -1.0, 1.0);
  };
  VectorXd x = real.front().x;
  VectorXd z(hx::kStateDim);
  if (noise.per_rollout) draw(z);
  drops::Prediction p;
  *fell = *nonfinite = false;
  for (const Transition& t : real) {
    model.predict(x, t.u, p);
    if (!noise.per_rollout) draw(z);
    const VectorXd next = x + p.mean + noise.scale * p.var.cwiseMax(0.0).cwiseSqrt().cwiseProduct(z);
    if (!next.allFinite()) {
      *nonfinite = true;
      break;
    }
    x = next;
    *fell = *fell || task.absorbing(x);
  }
  return (x[hx::kBodyPos] - real.front().x[hx::kBodyPos]) /
         (static_cast<double>(real.size()) * dt);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K EPISODE REMOVED_LEG [walls RATIO SNR]\n"
                 "         [samples N [noise step|rollout] [scale S]] [trace]\n"
                 "  mean rollouts of EPISODE's actions (or of each of E1,E2,...) on the prior\n"
                 "  alone and on a gp_prior model trained on episodes 1..K (REMOVED_LEG: -1\n"
                 "  intact, 0..5); samples N: also N sampled model rollouts (mean, sd, 25th\n"
                 "  percentile of their speeds, and how many reached the tilt limit), their\n"
                 "  clipped draws new per step (the policy search's) or once per rollout, sigma\n"
                 "  scaled by S (1); trace: per step of the mean model rollout, roll, pitch,\n"
                 "  height and the predictive sd\n",
                 argv[0]);
    return 2;
  }
  try {
    char** walls = nullptr;
    int samples = 0;
    Noise noise;
    bool trace = false;
    for (int i = 5; i < argc; ++i) {
      const std::string word = argv[i];
      auto value = [&](int count) {
        if (i + count >= argc) throw drops::InvalidArgument("'" + word + "' needs a value");
        char** at = argv + i + 1;
        i += count;
        return at;
      };
      if (word == "walls") {
        walls = value(2) - 1;  // gp_prior_options reads "walls RATIO SNR"
      } else if (word == "samples") {
        samples = std::atoi(*value(1));
        if (samples < 2) throw drops::InvalidArgument("samples N needs N >= 2");
      } else if (word == "noise") {
        const std::string mode = *value(1);
        if (mode != "step" && mode != "rollout")
          throw drops::InvalidArgument("noise must be step or rollout, not '" + mode + "'");
        noise.per_rollout = mode == "rollout";
      } else if (word == "scale") {
        const char* text = *value(1);
        char* end = nullptr;
        noise.scale = std::strtod(text, &end);
        if (end == text || *end != '\0' || !(noise.scale >= 0))
          throw drops::InvalidArgument("scale S needs a number S >= 0, not '" +
                                       std::string(text) + "'");
      } else if (word == "trace") {
        trace = true;
      } else {
        throw drops::InvalidArgument("unknown option '" + word +
                                     "' (walls, samples, noise, scale or trace)");
      }
    }
    const std::string dir = argv[1];
    const int k = std::atoi(argv[2]);
    const int leg = std::atoi(argv[4]);
    std::vector<int> episodes;  // EPISODE, or a comma-separated list replayed on one model
    for (std::size_t at = 0;;) {
      const std::string list = argv[3];
      const std::size_t comma = list.find(',', at);
      episodes.push_back(std::atoi(list.substr(at, comma - at).c_str()));
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
    const std::vector<Transition> train = drops::tools::read_episodes(dir, k);
    const drops::tools::FixedLegModel fitted = drops::tools::fit_fixed_leg_model(
        leg, drops::tools::gp_prior_options(walls), train);
    const auto& model = fitted.model;
    const double dt = fitted.task->dt();
    for (const int episode : episodes) {
      const std::vector<Transition> test =
          drops::tools::read_transitions(drops::tools::episode_file(dir, episode));
      if (test.empty())
        throw drops::InvalidArgument("episode " + std::to_string(episode) + " is empty");
      const Transition& last = test.back();
      const double real_speed =
          (last.x[hx::kBodyPos] + last.dx[hx::kBodyPos] - test.front().x[hx::kBodyPos]) /
          (static_cast<double>(test.size()) * dt);
      std::printf("%zu training transitions (episodes 1-%d); episode %d walked %.4f m/s\n",
                  train.size(), k, episode, real_speed);
      std::printf("%-14s | %12s | %10s | %10s\n", "rollout", "speed (m/s)", "RMS z (m)",
                  "RMS tilt");
      struct Row {
        const char* name;
        const drops::model::DynamicsModel* model;
        Forcing forcing;
      };
      for (const Row& r : {Row{"prior", nullptr, Forcing::kNone},
                           Row{"model", model.get(), Forcing::kNone},
                           Row{"prior|joints", nullptr, Forcing::kJoints},
                           Row{"model|joints", model.get(), Forcing::kJoints},
                           Row{"model|body", model.get(), Forcing::kBody}}) {
        const RolloutError e = replay(test, dt, r.model, *fitted.prior, fitted.phi, r.forcing,
                                      trace && r.model != nullptr && r.forcing == Forcing::kNone);
        std::printf("%-14s | %12.4f | %10.4f | %10.4f\n", r.name, e.speed, e.rms_z, e.rms_tilt);
      }
      if (samples == 0) continue;
      std::vector<double> v;
      int falls = 0, stopped = 0;
      for (int i = 0; i < samples; ++i) {
        drops::Rng rng(static_cast<std::uint64_t>(i) + 1);
        bool fell = false, nonfinite = false;
        v.push_back(sampled_speed(test, dt, *fitted.task, *model, noise, rng, &fell, &nonfinite));
        falls += fell ? 1 : 0;
        stopped += nonfinite ? 1 : 0;
      }
      double mean = 0, sq = 0;
      for (double s : v) mean += s;
      mean /= samples;
      for (double s : v) sq += (s - mean) * (s - mean);
      std::sort(v.begin(), v.end());
      std::printf("%d sampled model rollouts: mean %.4f sd %.4f q25 %.4f min %.4f (m/s); "
                  "%d reached the tilt limit\n",
                  samples, mean, std::sqrt(sq / (samples - 1)),
                  v[static_cast<std::size_t>(samples / 4)], v.front(), falls);
      if (stopped > 0)
        std::printf("  %d of them stopped at a non-finite prediction\n", stopped);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_rollout_error: %s\n", e.what());
    return 1;
  }
  return 0;
}
