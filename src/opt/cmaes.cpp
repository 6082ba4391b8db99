#include "drops/opt/cmaes.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <numeric>
#include <utility>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"

// Implementation notes (see the header for the contract):
// - The CMA-ES core follows Hansen's tutorial (2016): default weights, learning rates and damping,
//   cumulative step-size adaptation, rank-one + rank-mu update, and the tutorial's active update
//   (negative recombination weights for the worst half, scaled by min(alpha_mu^-, alpha_mueff^-,
//   alpha_posdef^-), and multiplied by n / ||C^{-1/2} y||^2 in the covariance update).
// - The search runs in an unconstrained "genotype" space; each sample x is mapped into the box by
//   the piecewise-quadratic transformation T (linear in the interior, quadratic next to each
//   bound, periodic/mirrored beyond), and the objective is evaluated at T(x). Start points are
//   mapped back by the inverse of T so that T(m0) = x0.
// - Elitism re-injects the best candidate of the current run (the best-ever of this run) in place
//   of the worst sample of a generation, with y = (x_best - m) / sigma, whose Mahalanobis norm is
//   capped at sqrt(n) + 2n/(n+2) (Hansen 2011, "Injecting external solutions into CMA-ES"). The
//   best over all runs is tracked separately and reported.
// - All random numbers come from one Rng on the calling thread; the objective gets a per-evaluation
//   stream derive_seed(seed, {run, generation, index}) (index >= lambda for re-evaluations).

namespace drops::opt {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Piecewise-quadratic boundary transformation (one coordinate).
struct CoordBox {
  double lb = -kInf, ub = kInf;
  double al = 0, au = 0;  // widths of the quadratic zones next to lb / ub
  bool has_lb() const { return std::isfinite(lb); }
  bool has_ub() const { return std::isfinite(ub); }
};

CoordBox make_coord_box(double lb, double ub) {
  CoordBox b;
  b.lb = lb;
  b.ub = ub;
  const double half_width = (b.has_lb() && b.has_ub()) ? 0.5 * (ub - lb) : kInf;
  if (b.has_lb()) b.al = std::min(half_width, (1.0 + std::abs(lb)) / 20.0);
  if (b.has_ub()) b.au = std::min(half_width, (1.0 + std::abs(ub)) / 20.0);
  return b;
}

double transform_coord(double x, const CoordBox& b) {
  const bool lo = b.has_lb(), hi = b.has_ub();
  if (!lo && !hi) return x;
  if (lo && hi) {
    const double lb = b.lb, ub = b.ub, al = b.al, au = b.au, w = ub - lb;
    if (!std::isfinite(x)) return x > 0 ? ub : (x < 0 ? lb : 0.5 * (lb + ub));  // overflowed sample
    // Shift into one period [lb - 2al - w/2, ub + 2au + w/2) when far away.
    const double start = lb - 2.0 * al - 0.5 * w;
    const double stop = ub + 2.0 * au + 0.5 * w;
    if (x < start || x > stop) {
      const double period = 2.0 * (w + al + au);
      x -= period * std::floor((x - start) / period);
    }
    // Mirror into [lb - al, ub + au].
    if (x > ub + au) x -= 2.0 * (x - ub - au);
    if (x < lb - al) x += 2.0 * (lb - al - x);
    double y;
    if (x < lb + al) {
      y = lb + (x - (lb - al)) * (x - (lb - al)) / (4.0 * al);
    } else if (x < ub - au) {
      y = x;
    } else {
      y = ub - (x - (ub + au)) * (x - (ub + au)) / (4.0 * au);
    }
    return std::clamp(y, lb, ub);  // guards rounding only
  }
  if (lo) {
    const double lb = b.lb, al = b.al;
    if (x < lb - al) x = 2.0 * (lb - al) - x;
    if (x < lb + al) return std::max(lb, lb + (x - (lb - al)) * (x - (lb - al)) / (4.0 * al));
    return x;
  }
  const double ub = b.ub, au = b.au;
  if (x > ub + au) x = 2.0 * (ub + au) - x;
  if (x > ub - au) return std::min(ub, ub - (x - (ub + au)) * (x - (ub + au)) / (4.0 * au));
  return x;
}

// Inverse of transform_coord for y inside the box (returns the preimage closest to the box).
double inverse_coord(double y, const CoordBox& b) {
  if (b.has_lb() && y < b.lb + b.al) return b.lb - b.al + 2.0 * std::sqrt(b.al * (y - b.lb));
  if (b.has_ub() && y > b.ub - b.au) return b.ub + b.au - 2.0 * std::sqrt(b.au * (b.ub - y));
  return y;
}

struct Box {
  std::vector<CoordBox> coords;
  VectorXd transform(const VectorXd& x) const {
    VectorXd y(x.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) y(i) = transform_coord(x(i), coords[i]);
    return y;
  }
  VectorXd inverse(const VectorXd& y) const {
    VectorXd x(y.size());
    for (Eigen::Index i = 0; i < y.size(); ++i) x(i) = inverse_coord(y(i), coords[i]);
    return x;
  }
};

// ---------------------------------------------------------------------------------------------
// Strategy parameters of one run (tutorial defaults).
struct Params {
  int n = 0, lambda = 0, mu = 0;
  VectorXd w;  // lambda weights, positive ones sum to 1; negative ones (active) scaled
  double sum_w = 1;
  double mueff = 1, cc = 0, cs = 0, c1 = 0, cmu = 0, damps = 1, chin = 1;
  double eigen_gap = 1;  // generations between two eigendecompositions of C
};

Params make_params(int n, int lambda, bool active) {
  Params p;
  p.n = n;
  p.lambda = lambda;
  p.mu = lambda / 2;
  VectorXd wp(lambda);
  for (int i = 0; i < lambda; ++i) wp(i) = std::log((lambda + 1) / 2.0) - std::log(i + 1.0);
  double spos = 0, spos2 = 0, sneg = 0, sneg2 = 0;
  for (int i = 0; i < lambda; ++i) {
    if (wp(i) > 0) {
      spos += wp(i);
      spos2 += wp(i) * wp(i);
    } else if (wp(i) < 0) {
      sneg += wp(i);
      sneg2 += wp(i) * wp(i);
    }
  }
  p.mueff = spos * spos / spos2;
  const double mueff_neg = sneg2 > 0 ? sneg * sneg / sneg2 : 0.0;
  const double dn = n;
  p.cc = (4.0 + p.mueff / dn) / (dn + 4.0 + 2.0 * p.mueff / dn);
  p.cs = (p.mueff + 2.0) / (dn + p.mueff + 5.0);
  p.c1 = 2.0 / ((dn + 1.3) * (dn + 1.3) + p.mueff);
  p.cmu = std::min(1.0 - p.c1,
                   2.0 * (p.mueff - 2.0 + 1.0 / p.mueff) / ((dn + 2.0) * (dn + 2.0) + p.mueff));
  p.cmu = std::max(0.0, p.cmu);
  p.damps = 1.0 + 2.0 * std::max(0.0, std::sqrt((p.mueff - 1.0) / (dn + 1.0)) - 1.0) + p.cs;
  p.chin = std::sqrt(dn) * (1.0 - 1.0 / (4.0 * dn) + 1.0 / (21.0 * dn * dn));

  double neg_scale = 0.0;
  if (active && sneg < 0 && p.cmu > 0) {
    const double alpha_mu = 1.0 + p.c1 / p.cmu;
    const double alpha_mueff = 1.0 + 2.0 * mueff_neg / (p.mueff + 2.0);
    const double alpha_posdef = (1.0 - p.c1 - p.cmu) / (dn * p.cmu);
    neg_scale = std::min({alpha_mu, alpha_mueff, alpha_posdef}) / (-sneg);
  }
  p.w.resize(lambda);
  for (int i = 0; i < lambda; ++i) p.w(i) = wp(i) >= 0 ? wp(i) / spos : wp(i) * neg_scale;
  p.sum_w = p.w.sum();
  // Lazy eigendecomposition: every lambda / (c1 + cmu) / n / 10 generations (the usual O(n^2)
  // amortisation), but at most 0.1 / (c1 + cmu) generations, so that C never changes by more than
  // about 10% of its memory between two decompositions (matters for lambda > n, e.g. IPOP runs).
  p.eigen_gap = std::min(1.0, lambda / dn) / (10.0 * (p.c1 + p.cmu));
  return p;
}

double sanitize(double v) { return std::isfinite(v) ? v : kInf; }

// Uncertainty measure s of Hansen et al. (2009): rank changes of the re-evaluated candidates in the
// joint ranking of the lambda first values and the nre re-evaluations, minus the changes expected
// from the theta-percentile of rank differences. s > 0 means the ranking is dominated by noise.
double uncertainty_measure(const std::vector<double>& f, const std::vector<double>& f2) {
  const int lambda = static_cast<int>(f.size());
  const int nre = static_cast<int>(f2.size());
  const int total = lambda + nre;
  std::vector<double> all(f);
  all.insert(all.end(), f2.begin(), f2.end());
  std::vector<int> order(total);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return all[a] < all[b]; });
  std::vector<int> rank(total);  // 1-based
  for (int r = 0; r < total; ++r) rank[order[r]] = r + 1;
  constexpr double theta = 0.2;
  auto delta_lim = [&](int r) {  // percentile theta/2 of {|k - r| : k = 1 .. total - 1}
    std::vector<double> d;
    d.reserve(total - 1);
    for (int k = 1; k < total; ++k) d.push_back(std::abs(static_cast<double>(k - r)));
    std::sort(d.begin(), d.end());
    const double pos = (theta / 2.0) * (d.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, d.size() - 1);
    return d[lo] + (pos - lo) * (d[hi] - d[lo]);
  };
  double s = 0;
  for (int i = 0; i < nre; ++i) {
    const int r_old = rank[i], r_new = rank[lambda + i];
    const int diff = r_new - r_old;
    const int delta = diff - (diff > 0 ? 1 : (diff < 0 ? -1 : 0));
    s += 2.0 * std::abs(delta) - delta_lim(r_new - (f2[i] > f[i] ? 1 : 0)) -
         delta_lim(r_old - (f[i] > f2[i] ? 1 : 0));
  }
  return s / nre;
}

// Shared state of one cmaes_minimize call.
struct Search {
  const Objective* objective = nullptr;   // one candidate per call (cmaes_minimize)
  const BatchObjective* batch = nullptr;  // whole batches (cmaes_minimize_batch)
  const CmaesOptions& options;
  const CmaesCallback& callback;
  Box box;
  int n;
  Rng rng;
  CmaesSummary summary;
  bool has_best = false;
  bool global_stop = false;

  Search(const Objective* obj, const BatchObjective* bat, const CmaesOptions& opt,
         const CmaesCallback& cb, Box b, int dim)
      : objective(obj),
        batch(bat),
        options(opt),
        callback(cb),
        box(std::move(b)),
        n(dim),
        rng(opt.seed) {}

  // Evaluates pheno[i] for i in [0, count) with streams {run, gen, offset + i}.
  void evaluate(const std::vector<VectorXd>& pheno, int count, int offset, int run, int gen,
                std::vector<double>& out) {
    std::vector<std::uint64_t> streams(count);
    for (int i = 0; i < count; ++i)
      streams[i] = derive_seed(options.seed,
                               {static_cast<std::uint64_t>(run), static_cast<std::uint64_t>(gen),
                                static_cast<std::uint64_t>(offset + i)});
    if (batch) {
      const std::vector<VectorXd> xs(pheno.begin(), pheno.begin() + count);
      out.clear();
      (*batch)(xs, streams, out);
      if (static_cast<int>(out.size()) != count)
        throw InvalidArgument("cmaes_minimize_batch: objective returned " +
                              std::to_string(out.size()) + " values for " + std::to_string(count) +
                              " candidates");
      for (double& v : out) v = sanitize(v);
    } else {
      out.assign(count, kInf);
      auto body = [&](std::size_t i) { out[i] = sanitize((*objective)(pheno[i], streams[i])); };
      if (options.parallel) {
        parallel_for(static_cast<std::size_t>(count), body);
      } else {
        for (int i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
      }
    }
    summary.evaluations += count;
  }

  // Calls the user callback (if any) after a generation; false when it asks to stop.
  bool report(double sigma, int lambda) {
    if (!callback) return true;
    const CmaesProgress progress{summary.evaluations,
                                 summary.restarts,
                                 summary.generations,
                                 summary.best_value,
                                 sigma,
                                 lambda};
    return callback(progress);
  }

  void offer_global(const VectorXd& pheno, double value) {
    if (!has_best || value < summary.best_value) {
      has_best = true;
      summary.best_value = value;
      summary.best_x = pheno;
    }
    // The keep_best best distinct points, sorted (a point evaluated twice keeps its better value).
    auto& best = summary.best_candidates;
    const auto keep = static_cast<std::size_t>(options.keep_best);
    if (best.size() >= keep && !(value < best.back().value)) return;
    for (auto it = best.begin(); it != best.end(); ++it) {
      if (it->x.size() == pheno.size() && (it->x.array() == pheno.array()).all()) {
        if (!(value < it->value)) return;
        best.erase(it);
        break;
      }
    }
    const auto pos = std::upper_bound(best.begin(), best.end(), value,
                                      [](double v, const CmaesCandidate& c) { return v < c.value; });
    best.insert(pos, CmaesCandidate{pheno, value});
    if (best.size() > keep) best.pop_back();
  }

  // x0 as evaluated when options.evaluate_start (its value is the start_value of the summary).
  bool start_evaluated = false;
  VectorXd start_pheno;

  // One CMA-ES run from `start` (x0 when from_start); returns its stop reason and sets
  // global_stop / termination when the whole search must end. record receives the run's counts.
  std::string run(int run_index, int lambda, double sigma, const VectorXd& start, bool from_start,
                  long run_budget, const char* budget_reason, CmaesRun& record);
};

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t k = v.size() / 2;
  return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
}

// Hansen 2009's Stagnation test on the run's per-generation best and median values.
bool stagnated(const std::vector<double>& best, const std::vector<double>& median, int n,
               int lambda) {
  const std::size_t gens = best.size();
  const auto min_len = static_cast<std::size_t>(120.0 + std::ceil(30.0 * n / lambda));
  if (gens < min_len) return false;
  const std::size_t len =
      std::min<std::size_t>(20000, std::max(min_len, static_cast<std::size_t>(0.2 * gens)));
  const std::size_t part = std::max<std::size_t>(1, static_cast<std::size_t>(0.3 * len));
  auto first = [&](const std::vector<double>& h) {
    return median_of(std::vector<double>(h.end() - len, h.end() - len + part));
  };
  auto last = [&](const std::vector<double>& h) {
    return median_of(std::vector<double>(h.end() - part, h.end()));
  };
  return last(best) >= first(best) && last(median) >= first(median);
}

std::string Search::run(int run_index, int lambda, double sigma, const VectorXd& start,
                        bool from_start, long run_budget, const char* budget_reason,
                        CmaesRun& record) {
  const Params p = make_params(n, lambda, options.active);
  const double sigma_start = sigma;
  VectorXd m = box.inverse(start);
  long& run_evals = record.evaluations;
  record.lambda = lambda;
  record.sigma0 = sigma;
  record.from_start = from_start;
  record.evaluations = 0;
  record.generations = 0;
  record.best_value = kInf;
  // The distribution mean in the box whenever the run stops.
  struct MeanOnExit {
    const Box& box;
    const VectorXd& m;
    CmaesRun& record;
    ~MeanOnExit() { record.final_mean = box.transform(m); }
  } mean_on_exit{box, m, record};
  VectorXd ps = VectorXd::Zero(n), pc = VectorXd::Zero(n);
  MatrixXd C = MatrixXd::Identity(n, n), B = MatrixXd::Identity(n, n);
  MatrixXd inv_sqrt_c = MatrixXd::Identity(n, n);
  VectorXd D = VectorXd::Ones(n);
  int last_eigen_gen = 0;
  run_evals = 0;

  // Best of this run (genotype, phenotype, value), for elitism; x0 when evaluated and started from.
  bool run_has_best = false;
  VectorXd run_best_geno, run_best_pheno;
  double run_best_value = kInf;
  if (from_start && start_evaluated) {
    run_has_best = true;
    run_best_geno = m;
    run_best_pheno = start_pheno;
    run_best_value = summary.start_value;
  }
  std::vector<double> hist_gen_best, hist_gen_median;  // per generation, for Stagnation

  const int hist_len = 10 + static_cast<int>(std::ceil(30.0 * n / lambda));
  std::deque<double> hist_best;
  const int equal_len = 10 + n;
  std::deque<bool> hist_equal;
  const double max_iter =
      100.0 + 150.0 * (n + 3.0) * (n + 3.0) / std::sqrt(static_cast<double>(lambda));
  const int nre = options.uncertainty_handling ? std::max(1, lambda / 10) : 0;
  const double alpha_sigma = 1.0 + 2.0 / (n + 10.0);
  const double cy = std::sqrt(static_cast<double>(n)) + 2.0 * n / (n + 2.0);

  MatrixXd Z(n, lambda), Y(n, lambda), X(n, lambda);
  std::vector<VectorXd> pheno(lambda);
  std::vector<double> f, f2;

  for (int gen = 0;; ++gen) {
    const long remaining = options.max_evaluations - summary.evaluations;
    if (remaining <= 0) {
      global_stop = true;
      summary.termination = CmaesTermination::kMaxEvaluations;
      return "MaxFunEvals";
    }
    if (run_evals + lambda > run_budget) return budget_reason;

    // Lazy eigendecomposition of C.
    if (gen - last_eigen_gen >= p.eigen_gap && gen > 0) {
      last_eigen_gen = gen;
      C = 0.5 * (C + C.transpose()).eval();
      Eigen::SelfAdjointEigenSolver<MatrixXd> es(C);
      const VectorXd ev = es.eigenvalues();
      if (es.info() != Eigen::Success || !ev.allFinite() || ev.minCoeff() <= 0.0)
        return "ConditionCov";
      B = es.eigenvectors();
      D = ev.cwiseSqrt();
      inv_sqrt_c = B * D.cwiseInverse().asDiagonal() * B.transpose();
      if (ev.maxCoeff() > options.max_condition * ev.minCoeff()) return "ConditionCov";
    }

    // Sampling (calling thread only).
    for (int k = 0; k < lambda; ++k)
      for (int i = 0; i < n; ++i) Z(i, k) = rng.normal();
    Y.noalias() = B * D.asDiagonal() * Z;
    X = (sigma * Y).colwise() + m;
    for (int k = 0; k < lambda; ++k) pheno[k] = box.transform(X.col(k));

    // Evaluation (possibly truncated by the global budget).
    const bool reeval = nre > 0 && remaining >= lambda + nre;
    const int count = static_cast<int>(std::min<long>(lambda, remaining));
    evaluate(pheno, count, 0, run_index, gen, f);
    run_evals += count;
    for (int k = 0; k < count; ++k) {
      offer_global(pheno[k], f[k]);
      record.best_value = std::min(record.best_value, f[k]);
    }
    if (count < lambda) {
      ++summary.generations;
      ++record.generations;
      report(sigma, lambda);  // the search ends here whatever the answer
      global_stop = true;
      summary.termination = CmaesTermination::kMaxEvaluations;
      return "MaxFunEvals";
    }
    double s_uncertainty = -1.0;
    std::vector<double> fr(f);  // values used for ranking
    if (reeval) {
      std::vector<VectorXd> re(pheno.begin(), pheno.begin() + nre);
      evaluate(re, nre, lambda, run_index, gen, f2);
      run_evals += nre;
      for (int k = 0; k < nre; ++k) {
        offer_global(pheno[k], f2[k]);
        record.best_value = std::min(record.best_value, f2[k]);
      }
      s_uncertainty = uncertainty_measure(f, f2);
      for (int k = 0; k < nre; ++k) fr[k] = 0.5 * (f[k] + f2[k]);
    }
    if (has_best && summary.best_value <= options.stop_fitness) {
      ++summary.generations;
      ++record.generations;
      report(sigma, lambda);  // the search ends here whatever the answer
      global_stop = true;
      summary.termination = CmaesTermination::kStopFitness;
      return "StopFitness";
    }

    // Sorted values of the sampled population (before the elite re-injection): the flat-fitness
    // escape and the stopping criteria look at these, so that a re-injected old best does not make
    // the run look stagnant (TolHistFun) while its samples still improve.
    std::vector<double> fs(fr);
    std::sort(fs.begin(), fs.end());

    // Elitism: the run's best candidate from the previous generations (the elite) is re-injected in
    // place of this generation's worst sample when it beats every sample of this generation.
    const double gen_best = fs.front();
    const bool inject = options.elitism && run_has_best && run_best_value < gen_best;
    const VectorXd elite_geno = inject ? run_best_geno : VectorXd();
    const VectorXd elite_pheno = inject ? run_best_pheno : VectorXd();
    const double elite_value = run_best_value;
    // Update the run's best from this generation's evaluations.
    for (int k = 0; k < lambda; ++k) {
      const double v = (reeval && k < nre) ? std::min(f[k], f2[k]) : f[k];
      if (!run_has_best || v < run_best_value) {
        run_has_best = true;
        run_best_value = v;
        run_best_geno = X.col(k);
        run_best_pheno = pheno[k];
      }
    }
    if (inject) {
      int worst = 0;
      for (int k = 1; k < lambda; ++k)
        if (fr[k] >= fr[worst]) worst = k;
      // y consistent with the current mean and step size; its Mahalanobis norm is capped at c_y
      // (Hansen 2011) so that an elite far from the mean cannot dominate the update.
      VectorXd y = (elite_geno - m) / sigma;
      const double mnorm = (inv_sqrt_c * y).norm();
      if (mnorm > cy) y *= cy / mnorm;
      Y.col(worst) = y;
      X.col(worst) = elite_geno;
      pheno[worst] = elite_pheno;
      fr[worst] = elite_value;
    }

    // Selection.
    std::vector<int> idx(lambda);
    std::iota(idx.begin(), idx.end(), 0);
    std::stable_sort(idx.begin(), idx.end(), [&](int a, int b) { return fr[a] < fr[b]; });
    MatrixXd Ys(n, lambda);
    for (int k = 0; k < lambda; ++k) Ys.col(k) = Y.col(idx[k]);

    // Mean, paths, step size, covariance (tutorial, c_m = 1).
    const VectorXd yw = Ys.leftCols(p.mu) * p.w.head(p.mu);
    m += sigma * yw;
    ps = (1.0 - p.cs) * ps + std::sqrt(p.cs * (2.0 - p.cs) * p.mueff) * (inv_sqrt_c * yw);
    const double ps_norm = ps.norm();
    const double hsig_den = std::sqrt(1.0 - std::pow(1.0 - p.cs, 2.0 * (gen + 1)));
    const bool hsig = ps_norm / hsig_den < (1.4 + 2.0 / (n + 1.0)) * p.chin;
    pc = (1.0 - p.cc) * pc + (hsig ? std::sqrt(p.cc * (2.0 - p.cc) * p.mueff) : 0.0) * yw;
    VectorXd wc = p.w;
    if (p.mu < lambda && wc.tail(lambda - p.mu).minCoeff() < 0.0) {
      const MatrixXd zs = inv_sqrt_c * Ys.rightCols(lambda - p.mu);
      for (int k = p.mu; k < lambda; ++k) {
        if (wc(k) < 0) {
          const double z2 = zs.col(k - p.mu).squaredNorm();
          wc(k) = z2 > 0 ? wc(k) * n / z2 : 0.0;
        }
      }
    }
    const double delta_h = hsig ? 0.0 : p.cc * (2.0 - p.cc);
    C *= 1.0 + p.c1 * delta_h - p.c1 - p.cmu * p.sum_w;
    C.noalias() += p.c1 * pc * pc.transpose();
    C.noalias() += p.cmu * (Ys * wc.asDiagonal() * Ys.transpose());
    sigma *= std::exp(std::min(1.0, (p.cs / p.damps) * (ps_norm / p.chin - 1.0)));

    // Uncertainty handling and flat-fitness escape.
    if (reeval && s_uncertainty > 0) sigma *= alpha_sigma;
    const int k_flat = std::max(0, static_cast<int>(std::ceil(0.7 * lambda)) - 1);
    if (fs[0] == fs[k_flat]) sigma *= std::exp(0.2 + p.cs / p.damps);

    ++summary.generations;
    ++record.generations;
    if (!report(sigma, lambda)) {
      global_stop = true;
      summary.termination = CmaesTermination::kCallback;
      return "Callback";
    }

    // Stopping criteria of the run.
    hist_best.push_back(fs[0]);
    if (static_cast<int>(hist_best.size()) > hist_len) hist_best.pop_front();
    // EqualFunVals compares the best with the ceil(0.1 + lambda/4)-th best (at least the 2nd).
    const int k_equal =
        std::min(lambda - 1, std::max(1, static_cast<int>(std::ceil(0.1 + lambda / 4.0)) - 1));
    hist_equal.push_back(fs[0] == fs[k_equal]);
    if (static_cast<int>(hist_equal.size()) > equal_len) hist_equal.pop_front();

    if (!std::isfinite(sigma) || !m.allFinite() || !C.allFinite()) return "NumericalError";
    const double hmin = *std::min_element(hist_best.begin(), hist_best.end());
    const double hmax = *std::max_element(hist_best.begin(), hist_best.end());
    if (gen >= 1 && std::max(hmax, fs.back()) - std::min(hmin, fs.front()) < options.tol_fun)
      return "TolFun";
    if (static_cast<int>(hist_best.size()) >= hist_len && hmax - hmin < options.tol_hist_fun)
      return "TolHistFun";
    if (std::count(hist_equal.begin(), hist_equal.end(), true) * 3 > equal_len)
      return "EqualFunVals";
    hist_gen_best.push_back(fs.front());
    hist_gen_median.push_back(fs[fs.size() / 2]);
    if (options.stagnation && stagnated(hist_gen_best, hist_gen_median, n, lambda))
      return "Stagnation";
    const VectorXd sd = C.diagonal().cwiseMax(0.0).cwiseSqrt();
    if ((sigma * sd.array() < options.tol_x).all() &&
        (sigma * pc.array().abs() < options.tol_x).all())
      return "TolX";
    if (sigma / sigma_start > 1e20 * D.maxCoeff()) return "TolUpSigma";
    {
      const int axis = gen % n;
      const VectorXd shifted = m + (0.1 * sigma * D(axis)) * B.col(axis);
      if ((shifted.array() == m.array()).all()) return "NoEffectAxis";
      if (((m.array() + 0.2 * sigma * sd.array()) == m.array()).any()) return "NoEffectCoord";
    }
    if (gen + 1 >= max_iter) return "MaxIter";
  }
}

}  // namespace

bool CmaesOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(std::isfinite(sigma0) && sigma0 >= 0.0))
    return fail("sigma0 = " + fmt(sigma0) + ": expected a finite value >= 0 (0 = automatic)");
  if (lambda != 0 && lambda < 2)
    return fail("lambda = " + std::to_string(lambda) + ": expected >= 2 (0 = default)");
  if (max_evaluations < 1)
    return fail("max_evaluations = " + std::to_string(max_evaluations) + ": expected >= 1");
  if (max_run_evaluations < 0)
    return fail("max_run_evaluations = " + std::to_string(max_run_evaluations) +
                ": expected >= 0 (0 = no per-run budget)");
  if (keep_best < 1) return fail("keep_best = " + std::to_string(keep_best) + ": expected >= 1");
  if (max_restarts < 0)
    return fail("max_restarts = " + std::to_string(max_restarts) + ": expected >= 0");
  if (!(tol_x >= 0.0)) return fail("tol_x = " + fmt(tol_x) + ": expected >= 0");
  if (!(tol_fun >= 0.0)) return fail("tol_fun = " + fmt(tol_fun) + ": expected >= 0");
  if (!(tol_hist_fun >= 0.0))
    return fail("tol_hist_fun = " + fmt(tol_hist_fun) + ": expected >= 0");
  if (!(max_condition > 1.0))
    return fail("max_condition = " + fmt(max_condition) + ": expected > 1");
  if (std::isnan(stop_fitness)) return fail("stop_fitness = nan: expected a number");
  if (why) why->clear();
  return true;
}

std::string CmaesSummary::BriefReport() const {
  const char* why = "MaxEvaluations";
  switch (termination) {
    case CmaesTermination::kMaxEvaluations: why = "MaxEvaluations"; break;
    case CmaesTermination::kMaxRestarts: why = "MaxRestarts"; break;
    case CmaesTermination::kStopFitness: why = "StopFitness"; break;
    case CmaesTermination::kCallback: why = "Callback"; break;
  }
  return "cmaes: best " + fmt(best_value) + " after " + std::to_string(evaluations) +
         " evaluations, " + std::to_string(restarts) +
         (restarts == 1 ? " restart (" : " restarts (") + why + ")";
}

namespace {

CmaesSummary minimize_impl(const Objective* objective, const BatchObjective* batch,
                           const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                           const Eigen::VectorXd& upper, const CmaesOptions& options,
                           const CmaesCallback& callback) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("cmaes: invalid options: " + why);
  const long n = lower.size();
  if (n < 1) throw InvalidArgument("lower: expected size >= 1, got 0");
  check_size("upper", n, upper.size());
  check_size("x0", n, x0.size());
  for (long i = 0; i < n; ++i) {
    const std::string idx = "[" + std::to_string(i) + "]";
    if (std::isnan(lower(i)) || std::isnan(upper(i)) || !(lower(i) < upper(i)))
      throw InvalidArgument("bounds" + idx + ": expected lower < upper, got lower = " +
                            fmt(lower(i)) + ", upper = " + fmt(upper(i)));
    if (!std::isfinite(x0(i)))
      throw InvalidArgument("x0" + idx + " = " + fmt(x0(i)) + " is not finite");
    if (x0(i) < lower(i) || x0(i) > upper(i))
      throw InvalidArgument("x0" + idx + " = " + fmt(x0(i)) + " is outside [lower, upper] = [" +
                            fmt(lower(i)) + ", " + fmt(upper(i)) + "]");
  }

  Box box;
  box.coords.reserve(n);
  double min_width = kInf;
  for (long i = 0; i < n; ++i) {
    box.coords.push_back(make_coord_box(lower(i), upper(i)));
    if (std::isfinite(lower(i)) && std::isfinite(upper(i)))
      min_width = std::min(min_width, upper(i) - lower(i));
  }
  const double sigma_def =
      options.sigma0 > 0 ? options.sigma0 : (std::isfinite(min_width) ? 0.3 * min_width : 1.0);
  const int lambda_def =
      options.lambda > 0 ? options.lambda
                         : 4 + static_cast<int>(std::floor(3.0 * std::log(static_cast<double>(n))));

  Search search(objective, batch, options, callback, std::move(box), static_cast<int>(n));
  CmaesSummary& summary = search.summary;
  summary.best_x = x0;
  summary.best_value = kInf;
  if (options.evaluate_start) {
    std::vector<double> v;
    if (batch) {
      (*batch)({x0}, {derive_seed(options.seed, {kCmaesStartStream})}, v);
      if (v.size() != 1)
        throw InvalidArgument("cmaes_minimize_batch: objective returned " +
                              std::to_string(v.size()) + " values for 1 candidate");
    } else {
      v.assign(1, (*objective)(x0, derive_seed(options.seed, {kCmaesStartStream})));
    }
    summary.evaluations = 1;
    summary.start_value = sanitize(v[0]);
    search.start_evaluated = true;
    search.start_pheno = x0;
    search.offer_global(x0, summary.start_value);
  }

  long budget_large = 0, budget_small = 0, last_large_evals = 0;
  long lambda_large = lambda_def;
  int large_restarts = 0;  // restarts of the large-population regime (limited by max_restarts)
  for (int r = 0;; ++r) {
    const long remaining = options.max_evaluations - summary.evaluations;
    if (remaining <= 0) {
      summary.termination = CmaesTermination::kMaxEvaluations;
      break;
    }
    long lambda = lambda_def;
    double sigma = sigma_def;
    VectorXd start = x0;
    const long run_cap = options.max_run_evaluations > 0 ? options.max_run_evaluations
                                                         : std::numeric_limits<long>::max();
    long run_budget = run_cap;
    const char* budget_reason = "MaxRunEvals";
    bool small = false;
    bool from_start = true;
    if (r > 0) {
      summary.restarts = r;
      // The uniform point is drawn for every restart, so that the random stream does not depend on
      // restart_start.
      VectorXd uniform = x0;
      for (long i = 0; i < n; ++i)
        if (std::isfinite(lower(i)) && std::isfinite(upper(i)))
          uniform(i) = search.rng.uniform(lower(i), upper(i));
      small = options.bipop && budget_small < budget_large;
      from_start = options.restart_start == CmaesRestartStart::kStart ||
                   (options.restart_start == CmaesRestartStart::kMixed && small);
      if (!from_start) start = uniform;
      if (small) {
        const double u = search.rng.uniform();
        lambda = std::max(2L, static_cast<long>(std::floor(
                                  lambda_def * std::pow(0.5 * lambda_large / lambda_def, u * u))));
        sigma = sigma_def * std::pow(10.0, -2.0 * u);
        run_budget = std::max(lambda, last_large_evals / 2);
        if (run_budget < run_cap) {
          budget_reason = "RunBudget";
        } else {
          run_budget = run_cap;
        }
      } else {
        ++large_restarts;
        lambda_large =
            std::min(2 * lambda_large, std::max<long>(lambda_def, options.max_evaluations));
        lambda = lambda_large;
      }
    }
    // A population larger than the remaining budget could not be evaluated anyway; the hard cap
    // only guards memory and int conversions for absurd budgets.
    lambda = std::max(2L, std::min({lambda, remaining, 1L << 24}));
    // A budget below one generation would end the run before it evaluates anything: with a small
    // total (drops direct --evaluations 30: a quarter of it, 7, per run, with lambda = 17) every
    // run ended at once and the search evaluated nothing. Such a run evaluates one generation.
    run_budget = std::max(run_budget, lambda);
    CmaesRun record;
    record.small = small;
    const std::string reason = search.run(r, static_cast<int>(lambda), sigma, start, from_start,
                                          run_budget, budget_reason, record);
    record.stop_reason = reason;
    const long run_evals = record.evaluations;
    summary.run_stop_reasons.push_back(reason);
    summary.runs.push_back(std::move(record));
    if (small) {
      budget_small += run_evals;
    } else {
      budget_large += run_evals;
      last_large_evals = run_evals;
    }
    if (search.global_stop) break;
    if (!small && large_restarts >= options.max_restarts) {
      summary.termination = CmaesTermination::kMaxRestarts;
      break;
    }
  }
  return summary;
}

}  // namespace

CmaesSummary cmaes_minimize(const Objective& objective, const Eigen::VectorXd& x0,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const CmaesOptions& options, const CmaesCallback& callback) {
  if (!objective) throw InvalidArgument("cmaes_minimize: objective is empty");
  return minimize_impl(&objective, nullptr, x0, lower, upper, options, callback);
}

CmaesSummary cmaes_minimize_batch(const BatchObjective& objective, const Eigen::VectorXd& x0,
                                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                  const CmaesOptions& options, const CmaesCallback& callback) {
  if (!objective) throw InvalidArgument("cmaes_minimize_batch: objective is empty");
  return minimize_impl(nullptr, &objective, x0, lower, upper, options, callback);
}

}  // namespace drops::opt
