// Exact against sparse output GPs (model.inducing_points, gp::SparseGp) on pendubot transitions:
// learning time and one-step prediction error as N grows, and GP-MI's whole learn() with the
// six-parameter pendubot prior. A plain program (one learning per row, minutes each), not a Google
// Benchmark; docs/benchmarks.md ("Sparse GPs") holds the measured tables.
//
//   build/bench/sparse_gp models N M1,M2,... [--exact] [--exact-iterations=K] [key=value ...]
//   build/bench/sparse_gp gp_mi N M [key=value ...]
//
// Data: episodes of the pendubot system (the default experiment's, the actual parameters) under
// random neural-network policies (parameters uniform in [-1.5, 1.5], seeds 42 on), N transitions;
// validation: 2000 transitions of other episodes (seeds 1042 on). The model options are the
// default pendubot experiment's (drops run's) with model.reflect_transitions=false (N GP points
// for N transitions) and the overrides given.
//
// models: model type gp (no prior: the GPs learn the whole dynamics), one row per model: exact
// (with --exact; --exact-iterations=K limits its Rprop to K iterations, warm-started from an exact
// fit on the first 2000 transitions, to time large N) and sparse with each M. Columns: N, model,
// M used (the largest over outputs), seconds of learn(), Rprop iterations, one-step RMSE of the
// mean per state dimension, and the mean negative log predictive density (NLPD, the variance plus
// the fitted noise) per dimension.
// gp_mi: gp_mi with all six parameters tunable, starting from the "tunable" preset, within
// [0.05, 1] (masses, lengths) and [0, 0.3] (frictions), with model.inducing_points = M. Prints the
// time to the end of the phi search and of the whole learn(), evaluations, rounds, phi, and the
// time of the prior on the N transitions (the simulator part of one phi evaluation).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "drops/algo/black_drops.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "drops/pendubot/pendubot.hpp"
#include "drops/pendubot/plugin.hpp"
#include "drops/rollout/rollout.hpp"

using namespace drops;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

const experiment::Registry& registry() {
  static experiment::Registry registry;
  if (registry.task_names().empty()) {
    experiment::register_builtin_algorithms(registry);
    pendubot::register_task(registry);
  }
  return registry;
}

std::vector<Transition> episodes(const experiment::Experiment& e, int transitions,
                                 std::uint64_t seed) {
  auto pol = e.setup.policy->clone();
  std::vector<Transition> data;
  Rng rng(seed);
  while (static_cast<int>(data.size()) < transitions) {
    VectorXd theta(pol->param_dim());
    for (int i = 0; i < theta.size(); ++i) theta[i] = rng.uniform(-1.5, 1.5);
    pol->set_params(theta);
    for (auto& t : rollout::run_episode(*e.setup.task, *e.setup.real, *pol, rng).transitions())
      if (static_cast<int>(data.size()) < transitions) data.push_back(t);
  }
  return data;
}

struct Errors {
  VectorXd rmse, nlpd;
};

Errors one_step_errors(const model::DynamicsModel& m, const std::vector<Transition>& test,
                       const VectorXd& noise) {
  const auto n = static_cast<Eigen::Index>(test.size());
  const Eigen::Index E = test.front().x.size(), U = test.front().u.size();
  MatrixXd X(n, E), Uu(n, U), mean, var;
  for (Eigen::Index i = 0; i < n; ++i) {
    X.row(i) = test[static_cast<std::size_t>(i)].x.transpose();
    Uu.row(i) = test[static_cast<std::size_t>(i)].u.transpose();
  }
  m.predict_batch(X, Uu, mean, var);
  Errors e{VectorXd::Zero(E), VectorXd::Zero(E)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const VectorXd r = test[static_cast<std::size_t>(i)].dx - mean.row(i).transpose();
    for (Eigen::Index d = 0; d < E; ++d) {
      const double v = var(i, d) + noise[d];
      e.rmse[d] += r[d] * r[d];
      e.nlpd[d] += 0.5 * (std::log(2 * std::numbers::pi * v) + r[d] * r[d] / v);
    }
  }
  e.rmse = (e.rmse / static_cast<double>(n)).cwiseSqrt();
  e.nlpd /= static_cast<double>(n);
  return e;
}

std::string vec(const VectorXd& v, const char* format = "{:.4g}") {
  std::string s;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    s += (i ? " " : "") + fmt::format(fmt::runtime(format), v[i]);
  return s;
}

int models(int N, const std::vector<int>& ms, bool exact, int exact_iterations,
           const std::vector<std::string>& overrides) {
  const experiment::Experiment e =
      experiment::make_experiment(registry(), experiment::load_settings(registry(), "", overrides));
  const algo::BlackDropsOptions algo = experiment::black_drops_options(registry(), e.settings);
  const auto data = episodes(e, N, 42);
  const auto test = episodes(e, 2000, 1042);
  fmt::print("N,model,M,seconds,rprop_iterations,rmse_per_dim,nlpd_per_dim\n");
  auto row = [&](const std::string& name, model::ModelOptions o, const model::ModelState* warm) {
    o.type = model::ModelType::kGp;
    auto m = model::make_model(o, e.setup.task, nullptr, {});
    if (warm) m->restore(*warm);
    const auto t0 = Clock::now();
    const model::ModelSummary s = m->learn(data);
    const double seconds = since(t0);
    const auto& gm = static_cast<const model::GpDynamicsModel&>(*m);
    VectorXd noise(static_cast<Eigen::Index>(gm.output_gps().size()));
    int used = 0;
    for (std::size_t i = 0; i < gm.output_gps().size(); ++i) {
      if (gm.sparse()) {
        noise[static_cast<Eigen::Index>(i)] = gm.sparse_output_gps()[i].noise_variance();
        used = std::max(used, gm.sparse_output_gps()[i].inducing_size());
      } else {
        noise[static_cast<Eigen::Index>(i)] = gm.output_gps()[i].noise_variance();
      }
    }
    const Errors err = one_step_errors(*m, test, noise);
    fmt::print("{},{},{},{:.2f},{},{},{}\n", N, name, used, seconds, s.rprop_iterations,
               vec(err.rmse), vec(err.nlpd, "{:.3f}"));
    std::cout.flush();
  };
  if (exact) {
    model::ModelOptions o = algo.model;
    o.inducing_points = 0;
    if (exact_iterations > 0) {
      // Warm start from an exact fit on the first 2000 transitions, then K iterations on N.
      model::ModelOptions w = o;
      w.type = model::ModelType::kGp;
      auto warm = model::make_model(w, e.setup.task, nullptr, {});
      warm->learn(std::vector<Transition>(data.begin(), data.begin() + std::min(N, 2000)));
      const model::ModelState st = warm->state();
      o.rprop.max_iterations = exact_iterations;
      row(fmt::format("exact ({} Rprop iterations from the N = 2000 fit)", exact_iterations), o,
          &st);
    } else {
      row("exact", o, nullptr);
    }
  }
  for (const int m : ms) {
    model::ModelOptions o = algo.model;
    o.inducing_points = m;
    row(fmt::format("sparse M = {}", m), o, nullptr);
  }
  return 0;
}

int gp_mi(int N, int M, const std::vector<std::string>& overrides) {
  const experiment::Experiment e =
      experiment::make_experiment(registry(), experiment::load_settings(registry(), "", overrides));
  const algo::BlackDropsOptions algo = experiment::black_drops_options(registry(), e.settings);
  const auto data = episodes(e, N, 42);
  model::PriorParameters p;
  p.names = pendubot::parameter_names();
  p.values = pendubot::preset("tunable").to_phi();
  p.tunable = {0, 1, 2, 3, 4, 5};
  p.lower.resize(6);
  p.upper.resize(6);
  p.lower << 0.05, 0.05, 0.05, 0.05, 0.0, 0.0;
  p.upper << 1.0, 1.0, 1.0, 1.0, 0.3, 0.3;
  p.choices.assign(6, {});
  model::ModelOptions o = algo.model;
  o.type = model::ModelType::kGpMi;
  o.inducing_points = M;
  auto m = model::make_model(o, e.setup.task, e.setup.prior, p);
  const auto t0 = Clock::now();
  double search_end = -1;
  const model::ModelSummary s = m->learn(data, [&](const std::string& phase, int, double) {
    if (phase == "kernels" && search_end < 0) search_end = since(t0);
  });
  const double total = since(t0);
  // What one phi evaluation's simulator part costs: the prior on every transition.
  MatrixXd X(N, data.front().x.size()), U(N, data.front().u.size()), out;
  for (int i = 0; i < N; ++i) {
    X.row(i) = data[static_cast<std::size_t>(i)].x.transpose();
    U.row(i) = data[static_cast<std::size_t>(i)].u.transpose();
  }
  const auto t1 = Clock::now();
  for (int k = 0; k < 10; ++k) e.setup.prior->evaluate_batch(X, U, s.phi, out);
  const double prior_seconds = since(t1) / 10;
  fmt::print(
      "N,M,search_seconds,total_seconds,phi_evaluations,rounds,rprop_iterations,score,phi\n");
  fmt::print("{},{},{:.1f},{:.1f},{},{},{},{:.2f},{}\n", N, M, search_end, total, s.phi_evaluations,
             s.rounds, s.rprop_iterations, s.score, vec(s.phi));
  fmt::print("actual phi: {}\n", vec(pendubot::Params{}.to_phi()));
  fmt::print("the prior on the {} transitions (one phi evaluation's simulator part): {:.1f} ms\n",
             N, 1e3 * prior_seconds);
  if (!s.phi_posterior.empty()) fmt::print("posterior sd: {}\n", vec(s.phi_posterior.stddev()));
  return 0;
}

std::vector<int> ints(const std::string& s) {
  std::vector<int> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stoi(item));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  drops::use_single_threaded_blas();
  if (argc < 4) {
    std::cerr << "usage: sparse_gp models N M1,M2,... [--exact] [--exact-iterations=K] "
                 "[key=value ...]\n       sparse_gp gp_mi N M [key=value ...]\n";
    return 2;
  }
  const std::string mode = argv[1];
  const int N = std::stoi(argv[2]);
  const std::vector<int> ms = ints(argv[3]);
  bool exact = false;
  int exact_iterations = 0;
  std::vector<std::string> overrides{"model.reflect_transitions=false"};
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--exact")
      exact = true;
    else if (a.rfind("--exact-iterations=", 0) == 0)
      exact_iterations = std::stoi(a.substr(19));
    else
      overrides.push_back(a);
  }
  if (mode == "models") return models(N, ms, exact, exact_iterations, overrides);
  if (mode == "gp_mi") return gp_mi(N, ms.front(), overrides);
  std::cerr << "sparse_gp: unknown mode '" << mode << "' (models | gp_mi)\n";
  return 2;
}
