// The pendubot's description-file prior (tasks/pendubot/data/pendubot.xml through
// drops::description, MuJoCo) against its hand-written prior (pendubot::PendubotPrior): prior
// evaluations per second, one state per call and batches of 100, as a run calls them (through
// the task's joint mapping). Prints a Markdown table for docs/benchmarks.md. CPU time of this
// thread (std::clock), so that other processes on the machine weigh less.
// Usage: pendubot_file_prior [seconds per measurement, default 2]
#include <fmt/format.h>

#include <cstdlib>
#include <ctime>
#include <random>

#include "drops/description/experiment_factory.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/pendubot/plugin.hpp"

using namespace drops;

namespace {

// Evaluations per CPU second of prior on batches of B rows.
double rate(const model::MeanFunction& prior, const VectorXd& phi, int B, double seconds) {
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> a(-4, 4), v(-10, 10), u(-3.5, 3.5);
  MatrixXd X(B, 4), U(B, 1), dX;
  for (int b = 0; b < B; ++b) {
    X.row(b) << v(gen), v(gen), a(gen), a(gen);
    U(b, 0) = u(gen);
  }
  long evaluations = 0;
  const std::clock_t start = std::clock();
  double used = 0;
  VectorXd dx(4);
  while (used < seconds) {
    for (int r = 0; r < 20; ++r) {
      if (B == 1)
        prior.evaluate(X.row(0).transpose(), U.row(0).transpose(), phi, dx);
      else
        prior.evaluate_batch(X, U, phi, dX);
      evaluations += B;
    }
    used = double(std::clock() - start) / CLOCKS_PER_SEC;
  }
  return evaluations / used;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 2.0;
  experiment::Registry registry;
  experiment::register_builtin_algorithms(registry);
  pendubot::register_task(registry);
  registry.set_description_prior_factory(description::experiment_factory());
  const auto hand = experiment::make_experiment(registry, experiment::load_settings(registry, "", {}));
  const auto file = experiment::make_experiment(
      registry, experiment::load_settings_file(
                    registry, std::string(DROPS_SOURCE_DIR) + "/configs/pendubot-gp_mi-file.yaml",
                    {}));
  fmt::print("| prior | batch | evaluations/s (one thread) | us per evaluation |\n|---|---|---|---|\n");
  for (const int B : {1, 100}) {
    for (const auto* e : {&hand, &file}) {
      const double r = rate(*e->setup.prior, e->setup.prior_parameters.values, B, seconds);
      fmt::print("| {} | {} | {:.3g} | {:.2f} |\n",
                 e == &hand ? "hand-written (PendubotPrior)" : "file (pendubot.xml, MuJoCo)", B,
                 r, 1e6 / r);
    }
  }
}
