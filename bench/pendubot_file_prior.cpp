// The pendubot's description-file prior (tasks/pendubot/data/pendubot.xml through
// drops::description, MuJoCo) against its hand-written prior (pendubot::PendubotPrior): prior
// evaluations per second, one state per call and batches of 100, as a run calls them (through
// the task's joint mapping). Prints a Markdown table for docs/benchmarks.md. CPU time of this
// thread (std::clock), so that other processes on the machine weigh less. Then the file prior's
// integration error against its substeps per control period (the task's dt = 0.05 s; the
// hand-written prior and the plant use 5 RK4 substeps of 10 ms), against 200 substeps as the
// reference, over random states and torques.
// Usage: pendubot_file_prior [seconds per measurement, default 2]
#include <fmt/format.h>

#include <algorithm>
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

// The largest |dx - dx_ref| over 200 random joint states and torques (angles rad, velocities
// rad/s) of the file prior with `substeps` RK4 substeps per control period against 200.
std::pair<double, double> substep_error(const experiment::Experiment& file, int substeps) {
  description::DescriptionPriorOptions o;
  o.file = std::string(DROPS_SOURCE_DIR) + "/tasks/pendubot/data/pendubot.xml";
  o.joints = {"Joint1", "Joint2"};
  o.actuated = {"Joint1"};
  o.parameters = file.setup.prior_parameters.names;
  o.dt = 0.05;
  o.substeps = substeps;
  const description::DescriptionPrior coarse(o);
  o.substeps = 200;
  const description::DescriptionPrior fine(o);
  const VectorXd& phi = file.setup.prior_parameters.values;
  std::mt19937 gen(2);
  std::uniform_real_distribution<double> a(-4, 4), v(-10, 10), u(-3.5, 3.5);
  double ea = 0, ev = 0;
  VectorXd x(4), uu(1), d1(4), d2(4);
  for (int k = 0; k < 200; ++k) {
    x << a(gen), a(gen), v(gen), v(gen);
    uu << u(gen);
    coarse.evaluate(x, uu, phi, d1);
    fine.evaluate(x, uu, phi, d2);
    ea = std::max(ea, (d1 - d2).head(2).cwiseAbs().maxCoeff());
    ev = std::max(ev, (d1 - d2).tail(2).cwiseAbs().maxCoeff());
  }
  return {ea, ev};
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
  fmt::print(
      "\n| substeps per 0.05 s | max abs error, angles (rad) | max abs error, velocities (rad/s) "
      "|\n|---|---|---|\n");
  for (const int k : {1, 2, 5, 10, 20}) {
    const auto [ea, ev] = substep_error(file, k);
    fmt::print("| {} | {:.1e} | {:.1e} |\n", k, ea, ev);
  }
}
