// GP-MI, paper Algorithm 2 (§IV-B), read top-down:
//
//   procedure GP-MI(D, M, phi_0)
//     phi* = argmax_phi S(phi)                          outer loop: Subplex over phi
//       S(phi) = score_i( max_{h_i} log p(dx_i - M_i(X; phi) | X, h_i) )   inner loop: Rprop per
//                                                        output GP; score = log sum_i exp (the sum
//                                                        of the likelihoods)
//     return phi*, with the kernels fitted at phi*
//
// identify_phi() below is that procedure; nested_search() is the paper's literal nesting and
// alternating_search() the block-coordinate ascent on the same score.
#include "drops/model/gp_mi.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/gp/reflected_pairs.hpp"
#include "drops/gp/sparse_gp.hpp"
#include "drops/opt/subplex.hpp"

namespace drops::model {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The residual targets dx - M(x, u; phi), or nothing when the simulator returned a non-finite
/// output on some transition (counted in *nonfinite): such a phi scores -inf.
bool residuals(const MeanFunction& prior, const Dataset& d, const VectorXd& phi, MatrixXd& out,
               long* nonfinite) {
  long bad = 0;
  out = d.dx - prior_outputs(prior, d.x, d.u, phi, &bad);
  *nonfinite += bad;
  return bad == 0;
}

/// A GP without data like `proto` (its options), default hyper-parameters.
gp::Gp fresh_like(const gp::Gp& /*proto*/, int input_dim) { return gp::Gp(input_dim); }
gp::SparseGp fresh_like(const gp::SparseGp& proto, int input_dim) {
  return gp::SparseGp(input_dim, proto.options());
}

/// Refits one output GP on (in, t) from its current hyper-parameters; returns Rprop's iterations.
/// A sparse GP chooses its inducing inputs for the current kernel, is fitted with them, and then
/// chooses them again for the fitted kernel (its bound is evaluated with those).
int refit(gp::Gp& g, const MatrixXd& in, const Eigen::Ref<const VectorXd>& t,
          const gp::RpropOptions& rprop) {
  g.compute(in, t);
  return g.optimize_h_params(rprop).iterations;
}
int refit(gp::SparseGp& g, const MatrixXd& in, const Eigen::Ref<const VectorXd>& t,
          const gp::RpropOptions& rprop) {
  const VectorXd y = t;
  g.compute(in, y);
  const int its = g.optimize_h_params(rprop).iterations;
  g.compute(in, y);
  return its;
}

/// True when the 2n entries of t are a reflected pair's targets: entry n + i is sign times entry
/// i, to 1e-9 of the targets' scale (round-off of the prior on mirrored states).
bool mirrored(const Eigen::Ref<const VectorXd>& t, Eigen::Index n, double sign) {
  if (n <= 0 || t.size() != 2 * n) return false;
  const double scale = 1.0 + t.cwiseAbs().maxCoeff();
  return (t.tail(n) - sign * t.head(n)).cwiseAbs().maxCoeff() <= 1e-9 * scale;
}

/// An exact GP on data laid out as reflected pairs (Dataset::pairs) whose targets follow the
/// layout (row n + i = sign times row i, to round-off): the kernel fit on the n recorded rows
/// (gp::fit_reflected_pairs, the 2n fit's search), then the GP computed on all rows. Other
/// cases: refit().
int refit(gp::Gp& g, const MatrixXd& in, const Eigen::Ref<const VectorXd>& t,
          const gp::RpropOptions& rprop, const ReflectedPairs& pairs, Eigen::Index output) {
  const Eigen::Index n = pairs.n;
  if (n > 0 && in.rows() == 2 * n && !rprop.penalty) {
    const double sign = pairs.sign[output];
    if (mirrored(t, n, sign)) {
      VectorXd h = g.h_params();
      try {
        const int its = gp::fit_reflected_pairs(h, in.topRows(n), pairs.flip, t.head(n), sign,
                                                rprop)
                            .iterations;
        // One factorisation on the 2n rows, at the fitted h: drop the old data first, so
        // that setting h does not refactorise it.
        g.compute(MatrixXd(0, in.cols()), VectorXd(0));
        g.set_h_params(h);
        g.compute(in, t);
        return its;
      } catch (const NumericalError&) {
        // The start does not factorise without the jitter the 2n GP adds (Gp::compute): points
        // on the mirror plane make A - B nearly singular. The 2n fit below handles it.
      }
    }
  }
  return refit(g, in, t, rprop);
}
int refit(gp::SparseGp& g, const MatrixXd& in, const Eigen::Ref<const VectorXd>& t,
          const gp::RpropOptions& rprop, const ReflectedPairs& /*pairs*/, Eigen::Index /*output*/) {
  return refit(g, in, t, rprop);
}

template <class G>
VectorXd fit_output_gps_impl(std::vector<G>& gps, const MatrixXd& in, const MatrixXd& targets,
                             const gp::RpropOptions& rprop, long* iterations,
                             const ReflectedPairs& pairs = {}) {
  check_size("fit_output_gps: target columns vs GPs", static_cast<long>(gps.size()), targets.cols());
  const auto E = static_cast<Eigen::Index>(gps.size());
  VectorXd ll(E);
  std::vector<int> its(gps.size(), 0);
  parallel_for(gps.size(), [&](std::size_t i) {
    auto& g = gps[i];
    const auto e = static_cast<Eigen::Index>(i);
    its[i] = refit(g, in, targets.col(e), rprop, pairs, e);
    ll[e] = g.log_marginal_likelihood();
  });
  for (int k : its) *iterations += k;
  return ll;
}

/// True when every column of t (2n rows, one per output) is mirrored() under the pairs' sign.
bool mirrored_targets(const MatrixXd& t, const ReflectedPairs& pairs) {
  if (pairs.n <= 0 || pairs.sign.size() != t.cols()) return false;
  for (Eigen::Index e = 0; e < t.cols(); ++e)
    if (!mirrored(t.col(e), pairs.n, pairs.sign[e])) return false;
  return true;
}

/// GP-MI's scores with the kernels fixed (alternating_search's phi step) on reflected pairs, by
/// blocks: with targets [t; sign t] the 2n GP's log marginal likelihood is
/// c - t^T C_s^-1 t (gp/reflected_pairs.hpp, C_s = A + sign B + sigma_n^2 I on the n recorded
/// inputs), c independent of the targets. So a score needs the prior on the n recorded rows and
/// one triangular solve of n per output, instead of 2n rows and two solves of 2n.
struct PairScores {
  Dataset recorded;                 // the n recorded rows
  std::vector<MatrixXd> factors;    // per output, the lower Cholesky factor of C_s (n x n)
  VectorXd constant;                // per output, c
  bool ok = false;
};

/// The block scores of the exact GPs fitted on the 2n rows of d to targets t (the round's
/// residuals); ok is false, and the caller scores on the 2n rows, unless the data and t are
/// reflected pairs and the blocks reproduce every GP's quadratic form t^T K^-1 t to 1e-6.
PairScores pair_scores(const std::vector<gp::Gp>& gps, const Dataset& d, const MatrixXd& t) {
  PairScores ps;
  const Eigen::Index n = d.pairs.n;
  if (!mirrored_targets(t, d.pairs) || d.gp_in.rows() != 2 * n) return ps;
  std::vector<int> top(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) top[static_cast<std::size_t>(i)] = static_cast<int>(i);
  const MatrixXd X1 = d.gp_in.topRows(n), X2 = d.gp_in.bottomRows(n);
  const auto E = static_cast<Eigen::Index>(gps.size());
  ps.factors.resize(gps.size());
  ps.constant.resize(E);
  for (Eigen::Index e = 0; e < E; ++e) {
    const gp::Gp& g = gps[static_cast<std::size_t>(e)];
    if (g.size() != 2 * n) return ps;
    MatrixXd C = g.kernel().gram(X1, X1);
    C += d.pairs.sign[e] * g.kernel().gram(X1, X2);
    C = 0.5 * (C + C.transpose()).eval();
    C.diagonal().array() += g.noise_variance();
    Eigen::LLT<MatrixXd> llt(C);
    if (llt.info() != Eigen::Success) return ps;
    MatrixXd L = llt.matrixL();
    const double q2n = t.col(e).dot(g.alpha());
    VectorXd v = t.col(e).head(n);
    L.triangularView<Eigen::Lower>().solveInPlace(v);
    const double q = 2.0 * v.squaredNorm();
    // (round-off of an ill-conditioned K reaches ~1e-7 here; a jitter the 2n GP needed, more)
    if (!(std::abs(q - q2n) <= 1e-6 * (1.0 + std::abs(q2n)))) return ps;
    ps.constant[e] = g.log_marginal_likelihood() + 0.5 * q2n;
    ps.factors[static_cast<std::size_t>(e)] = std::move(L);
  }
  ps.recorded = d.rows(top);
  ps.ok = true;
  return ps;
}
PairScores pair_scores(const std::vector<gp::SparseGp>&, const Dataset&, const MatrixXd&) {
  return {};
}

/// True for an exact GP with the squared-exponential ARD kernel (the kernel of
/// gp::reflected_pairs_log_likelihood).
bool is_exact_se(const gp::Gp& g) {
  return dynamic_cast<const gp::SquaredExpArd*>(&g.kernel()) != nullptr;
}
bool is_exact_se(const gp::SparseGp&) { return false; }

/// The outer loop: Subplex over the tunable entries of phi (discrete ones exhaustively) from
/// parameters.values, maximising S(phi) = score(full phi); candidates the prior rejects score
/// -inf. Returns the search's summary, in full-phi terms.
opt::SubplexSummary search_phi(const MeanFunction& prior, const PriorParameters& parameters,
                               const GpMiOptions& options,
                               const std::function<double(const VectorXd&)>& score) {
  opt::MixedBox box{parameters.lower, parameters.upper, parameters.choices};
  opt::SubplexOptions so;
  so.max_evaluations = options.max_evaluations;
  so.xtol_rel = options.xtol_rel;
  so.ftol_rel = options.ftol_rel;
  auto s = opt::maximize_mixed(
      [&](const VectorXd& tuned) {
        const VectorXd phi = parameters.with_tuned(tuned);
        prior.check_phi(phi);  // InvalidArgument: -inf
        return score(phi);
      },
      parameters.tuned(), box, so);
  s.best_x = parameters.with_tuned(s.best_x);
  return s;
}

/// The paper's nesting: each evaluation of S(phi) refits every output's kernel with Rprop at the
/// residuals of phi, warm-started from the best kernels so far or from a new GP's kernels
/// (options.candidate_start). On return gps hold the kernels of the best phi.
template <class G>
GpMiSummary nested_search(const MeanFunction& prior, const PriorParameters& parameters,
                          const Dataset& d, const GpMiOptions& options,
                          const gp::RpropOptions& inner, std::vector<G>& gps,
                          const ModelProgress& progress) {
  GpMiSummary s;
  const std::size_t E = gps.size();
  std::vector<VectorXd> best_h(E);
  for (std::size_t i = 0; i < E; ++i) best_h[i] = gps[i].h_params();
  const bool from_initial = options.candidate_start == GpMiCandidateStart::kInitial;
  const VectorXd initial_h = gp::Gp(static_cast<int>(d.gp_in.cols())).h_params();
  double best_score = -kInf;
  int evals = 0;
  std::atomic<long> rprop_its{0};
  // The candidate's score after its kernels' fit with the given Rprop options; h: the fitted
  // kernels (empty for an output whose fit failed). states (E, or empty): Rprop searches to
  // continue (the screen's), updated.
  auto fit = [&](const VectorXd& phi, const gp::RpropOptions& rprop, std::vector<VectorXd>& h,
                 std::vector<gp::RpropState>& states) {
    MatrixXd t;
    h.assign(E, VectorXd());
    if (!residuals(prior, d, phi, t, &s.nonfinite_prior_outputs)) return -kInf;
    VectorXd ll(static_cast<Eigen::Index>(E));
    parallel_for(E, [&](std::size_t i) {  // inner loop: Rprop per output GP
      G g = fresh_like(gps[i], static_cast<int>(d.gp_in.cols()));
      g.set_h_params(from_initial ? initial_h : best_h[i]);
      gp::RpropState* state = states.empty() ? nullptr : &states[i];
      const int before = state != nullptr ? state->iterations : 0;
      try {
        g.compute(d.gp_in, VectorXd(t.col(static_cast<Eigen::Index>(i))));
        rprop_its += g.optimize_h_params(rprop, state).iterations - before;
        ll[static_cast<Eigen::Index>(i)] = g.log_marginal_likelihood();
        h[i] = g.h_params();
      } catch (const NumericalError&) {
        ll[static_cast<Eigen::Index>(i)] = -kInf;
      }
    });
    return gp_mi_score(ll, options.score);
  };
  // The screen (GpMiOptions::screen_iterations): a short fit of every listed candidate, in the
  // order of the search below, and the screened scores' best.
  const bool all_discrete = std::all_of(parameters.choices.begin(), parameters.choices.end(),
                                        [](const auto& c) { return !c.empty(); });
  // Each candidate's searches stop after the screen's iterations and are continued for those that
  // pass it, so that their fits are the unscreened ones.
  std::vector<double> screened;
  std::vector<std::vector<gp::RpropState>> screen_states;
  double best_screened = -kInf;
  if (options.screen_iterations > 0 && options.screen_iterations < options.inner_rprop_iterations &&
      all_discrete) {
    gp::RpropOptions short_fit = inner;
    short_fit.max_iterations = options.screen_iterations;
    std::vector<VectorXd> h;
    search_phi(prior, parameters, options, [&](const VectorXd& phi) {
      screen_states.emplace_back(E);
      screened.push_back(fit(phi, short_fit, h, screen_states.back()));
      best_screened = std::max(best_screened, screened.back());
      return screened.back();
    });
  }
  std::vector<gp::RpropState> no_states;
  auto S = [&](const VectorXd& phi) {
    const int k = evals++;
    const bool was_screened = static_cast<std::size_t>(k) < screened.size();
    if (was_screened &&
        !(screened[static_cast<std::size_t>(k)] >= best_screened - options.screen_margin)) {
      ++s.screened_out;
      return -kInf;
    }
    std::vector<VectorXd> h;
    const double sc = fit(phi, inner, h,
                          was_screened ? screen_states[static_cast<std::size_t>(k)] : no_states);
    if (sc > best_score) {
      best_score = sc;
      for (std::size_t i = 0; i < E; ++i)
        if (h[i].size()) best_h[i] = h[i];
    }
    if (progress && k % 10 == 0) progress("gp-mi", k, best_score);
    return sc;
  };
  const auto r = search_phi(prior, parameters, options, S);
  s.evaluations = r.evaluations;
  s.rprop_iterations = rprop_its;
  s.phi = parameters.values;
  if (std::isfinite(r.best_value)) {
    s.phi = r.best_x;
    s.score = r.best_value;
    for (std::size_t i = 0; i < E; ++i) gps[i].set_h_params(best_h[i]);
  }
  return s;
}

/// Block-coordinate ascent on S: (a) fit the kernels at the current phi, (b) Subplex over phi
/// with the kernels fixed (each evaluation re-solves with the factorisations kept), until phi
/// moves by less than 1e-3 of its interval or `rounds` rounds. On return gps hold the kernels of
/// the last round.
template <class G>
GpMiSummary alternating_search(const MeanFunction& prior, const PriorParameters& parameters,
                               const Dataset& d, const GpMiOptions& options,
                               const gp::RpropOptions& inner, std::vector<G>& gps,
                               const ModelProgress& progress) {
  GpMiSummary s;
  s.phi = parameters.values;
  const Eigen::Index E = static_cast<Eigen::Index>(gps.size());
  for (int round = 0; round < options.rounds; ++round) {
    // (a) kernels at the current phi.
    MatrixXd targets;
    if (!residuals(prior, d, s.phi, targets, &s.nonfinite_prior_outputs))
      break;  // keep phi; the caller's final fit reports the error
    fit_output_gps_impl(gps, d.gp_in, targets, inner, &s.rprop_iterations, d.pairs);
    // (b) phi with the kernels fixed; on reflected pairs whose residuals stay mirrored, by
    // blocks (PairScores: the same scores to round-off, the prior on the recorded rows only).
    PriorParameters p = parameters;
    p.values = s.phi;
    int evals = 0;
    PairScores blocks = pair_scores(gps, d, targets);
    auto S = [&](const VectorXd& phi) {
      const int k = evals++;
      MatrixXd t;
      VectorXd ll(E);
      if (blocks.ok) {
        if (!residuals(prior, blocks.recorded, phi, t, &s.nonfinite_prior_outputs)) return -kInf;
        for (Eigen::Index i = 0; i < E; ++i) {
          VectorXd v = t.col(i);
          blocks.factors[static_cast<std::size_t>(i)].triangularView<Eigen::Lower>().solveInPlace(
              v);
          ll[i] = blocks.constant[i] - v.squaredNorm();
        }
      } else {
        if (!residuals(prior, d, phi, t, &s.nonfinite_prior_outputs)) return -kInf;
        for (Eigen::Index i = 0; i < E; ++i) {
          auto& g = gps[static_cast<std::size_t>(i)];
          g.set_targets(t.col(i));
          ll[i] = g.log_marginal_likelihood();
        }
      }
      const double sc = gp_mi_score(ll, options.score);
      if (progress && k % 50 == 0) progress("gp-mi", s.evaluations + k, sc);
      return sc;
    };
    auto r = search_phi(prior, p, options, S);
    if (blocks.ok && std::isfinite(r.best_value)) {
      // The blocks assume the prior mirrors its outputs (M(R x, R u) = sign M(x, u)), checked at
      // the round's start; a prior that does so only at some phi is caught at the phi found, and
      // the step is searched again on every row.
      MatrixXd t;
      long unused = 0;
      if (!residuals(prior, d, r.best_x, t, &unused) || !mirrored_targets(t, d.pairs)) {
        s.evaluations += r.evaluations;
        blocks.ok = false;
        evals = 0;
        r = search_phi(prior, p, options, S);
      }
    }
    s.evaluations += r.evaluations;
    s.rounds = round + 1;
    double move = 0;
    for (std::size_t k = 0; k < parameters.tunable.size(); ++k) {
      const int i = parameters.tunable[k];
      const auto kk = static_cast<Eigen::Index>(k);
      const double width = std::max(1e-12, parameters.upper[kk] - parameters.lower[kk]);
      move = std::max(move, std::abs(r.best_x[i] - s.phi[i]) / width);
    }
    if (std::isfinite(r.best_value)) {
      s.phi = r.best_x;
      s.score = r.best_value;
    }
    if (move < 1e-3) break;
  }
  return s;
}

}  // namespace

bool GpMiOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_evaluations < 1) return fail("gp_mi.max_evaluations must be >= 1");
  if (!(xtol_rel >= 0) || !(ftol_rel >= 0)) return fail("gp_mi tolerances must be >= 0");
  if (rounds < 1) return fail("gp_mi.rounds must be >= 1");
  if (inner_rprop_iterations < 1) return fail("gp_mi.inner_rprop_iterations must be >= 1");
  if (max_points < 0) return fail("gp_mi.max_points must be >= 0");
  if (screen_iterations < 0)
    return fail("gp_mi.screen_iterations must be >= 0, got " + std::to_string(screen_iterations));
  if (!(screen_margin >= 0.0) || !std::isfinite(screen_margin))
    return fail("gp_mi.screen_margin must be a finite value >= 0");
  return true;
}

double log_sum_exp(const VectorXd& v) {
  if (v.size() == 0) return -kInf;
  const double m = v.maxCoeff();
  if (!std::isfinite(m)) return m;
  return m + std::log((v.array() - m).exp().sum());
}

double gp_mi_score(const VectorXd& ll, GpMiScore score) {
  if (score == GpMiScore::kSumOfLikelihoods) return log_sum_exp(ll);
  if ((ll.array() == -kInf).any()) return -kInf;
  return ll.sum();
}

VectorXd fit_output_gps(std::vector<gp::Gp>& gps, const MatrixXd& in, const MatrixXd& targets,
                        const gp::RpropOptions& rprop, long* iterations,
                        const ReflectedPairs& pairs) {
  return fit_output_gps_impl(gps, in, targets, rprop, iterations, pairs);
}

VectorXd fit_output_gps(std::vector<gp::SparseGp>& gps, const MatrixXd& in,
                        const MatrixXd& targets, const gp::RpropOptions& rprop, long* iterations) {
  return fit_output_gps_impl(gps, in, targets, rprop, iterations);
}

namespace {

template <class G>
GpMiSummary identify_phi_impl(const MeanFunction& prior, const PriorParameters& parameters,
                              const Dataset& data, const GpMiOptions& options,
                              const gp::RpropOptions& rprop, std::vector<G>& gps,
                              const ModelProgress& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("identify_phi: " + why);
  parameters.check();
  check_size("identify_phi: GPs vs prior state_dim", prior.state_dim(),
             static_cast<long>(gps.size()));
  check_size("identify_phi: data x columns vs prior state_dim", prior.state_dim(), data.x.cols());
  // The kernel fits inside the search: the final fit's options with fewer iterations.
  gp::RpropOptions inner = rprop;
  inner.max_iterations = options.inner_rprop_iterations;
  const Dataset d = options.max_points > 0 && data.size() > options.max_points
                        ? data.rows(subsample(data.size(), options.max_points))
                        : data;
  // A purely discrete phi is searched nested: with kernels fitted to one candidate's residuals
  // (alternating search), every other candidate is scored against them and the search stays
  // where it started (measured on a family of 7 discrete priors).
  const bool all_discrete = std::all_of(parameters.choices.begin(), parameters.choices.end(),
                                        [](const auto& c) { return !c.empty(); });
  if (options.search == GpMiSearch::kAlternating && !all_discrete)
    return alternating_search(prior, parameters, d, options, inner, gps, progress);
  return nested_search(prior, parameters, d, options, inner, gps, progress);
}

}  // namespace

GpMiSummary identify_phi(const MeanFunction& prior, const PriorParameters& parameters,
                         const Dataset& data, const GpMiOptions& options,
                         const gp::RpropOptions& rprop, std::vector<gp::Gp>& gps,
                         const ModelProgress& progress) {
  return identify_phi_impl(prior, parameters, data, options, rprop, gps, progress);
}

GpMiSummary identify_phi(const MeanFunction& prior, const PriorParameters& parameters,
                         const Dataset& data, const GpMiOptions& options,
                         const gp::RpropOptions& rprop, std::vector<gp::SparseGp>& gps,
                         const ModelProgress& progress) {
  return identify_phi_impl(prior, parameters, data, options, rprop, gps, progress);
}

VectorXd PhiPosterior::stddev() const { return covariance.diagonal().cwiseSqrt(); }

MatrixXd PhiPosterior::correlation() const {
  const VectorXd s = stddev();
  MatrixXd c = covariance.array() / (s * s.transpose()).array();
  c.diagonal().setOnes();
  return c;
}

namespace {

// The box of Rprop's kernel fits (Gp::optimize_h_params): the kernel's log hyper-parameters in
// [-10, 10], log sigma_n in [log 1e-5, 10]. A hyper-parameter that the fit left on the box is held
// fixed, not marginalised: the fit's gradient pushes it against the box, which keeps it there for
// nearby phi, so it takes up none of a change of phi (and the likelihood's curvature there, e.g.
// flat for a length scale of an input the residual ignores, is not that of a maximum). The others
// get the flat prior over the box as a Gaussian of its variance, as phi gets over its interval: a
// hyper-parameter the data leave flat then takes up at most what that weak prior allows, and the
// eigenvalues are floored at it when the block is indefinite (a fit stopped short of its maximum).
constexpr double kLogHMin = -10.0;
constexpr double kLogHMax = 10.0;
const double kLogNoiseMin = std::log(1e-5);
// A log hyper-parameter within this of a bound is held by the box (Rprop clamps onto the bound).
constexpr double kAtBox = 1e-6;
// Central-difference step on the log hyper-parameters: the analytic gradient varies on a scale
// of order 1 in log space, so the truncation error is ~1e-7 relative, and the step is large
// enough against the gradient's round-off.
constexpr double kLogHStep = 1e-3;

/// What marginalising output GP `fitted`'s kernel hyper-parameters h takes off the negative
/// Hessian of the log likelihood in the continuous phi (K x K, positive semi-definite):
/// C B^-1 C^T, C = -d2 l / dphi dh (K x F) and B = -d2 l / dh2 + P_h (F x F) over the F
/// components of h not held by Rprop's box, l = log p(t | X, h) of this output's residuals t.
/// C from central differences of the analytic h-gradient between the residuals at phi* -+ one
/// step of each phi (up[a], down[a], column `out`, steps `step`); B from central differences of
/// that gradient along each free log hyper-parameter (kLogHStep), symmetrised, plus the flat prior
/// over Rprop's box as a Gaussian of its variance (P_h = 12 / width^2 per component), its
/// eigenvalues floored at the smallest of those precisions. NaN entries when a factorisation or
/// a gradient fails.
template <class G>
MatrixXd kernel_absorption(const G& fitted, Eigen::Index out, const MatrixXd& at_phi,
                           const std::vector<MatrixXd>& up, const std::vector<MatrixXd>& down,
                           const std::vector<double>& step, const ReflectedPairs* pairs,
                           const MatrixXd* recorded_inputs) {
  const auto K = static_cast<Eigen::Index>(up.size());
  const VectorXd h = fitted.h_params();
  const Eigen::Index H = h.size();
  std::vector<Eigen::Index> free;
  VectorXd precision(H);
  for (Eigen::Index j = 0; j < H; ++j) {
    const double lo = j == H - 1 ? kLogNoiseMin : kLogHMin;
    precision[j] = 12.0 / ((kLogHMax - lo) * (kLogHMax - lo));
    if (h[j] > lo + kAtBox && h[j] < kLogHMax - kAtBox) free.push_back(j);
  }
  const auto F = static_cast<Eigen::Index>(free.size());
  MatrixXd absorbed = MatrixXd::Zero(K, K);
  if (F == 0) return absorbed;
  // The likelihood gradient in h at kernels hk for targets t: by the two blocks of N when the
  // rows are reflected pairs (gp::reflected_pairs_log_likelihood, the 2N gradient to round-off at
  // a quarter of the cubic cost), else on the 2N GP; a block that does not factorise without
  // the 2N GP's jitter (points on the mirror plane) sends every later gradient to the 2N GP.
  bool blocks = pairs != nullptr && recorded_inputs != nullptr;
  std::optional<G> g2;
  auto gradient = [&](const VectorXd& hk, const MatrixXd& t) -> VectorXd {
    if (blocks) {
      try {
        VectorXd grad;
        gp::reflected_pairs_log_likelihood(hk, *recorded_inputs, pairs->flip,
                                           t.col(out).head(pairs->n), pairs->sign[out], &grad);
        return grad;
      } catch (const NumericalError&) {
        blocks = false;
      }
    }
    if (!g2) g2.emplace(fitted);
    if (!(g2->h_params().array() == hk.array()).all()) g2->set_h_params(hk);
    g2->set_targets(t.col(out));
    return g2->log_marginal_likelihood_gradient();
  };
  try {
    MatrixXd C(K, F);
    for (Eigen::Index a = 0; a < K; ++a) {
      const VectorXd gu = gradient(h, up[static_cast<std::size_t>(a)]);
      const VectorXd gd = gradient(h, down[static_cast<std::size_t>(a)]);
      for (Eigen::Index f = 0; f < F; ++f)
        C(a, f) = -(gu[free[static_cast<std::size_t>(f)]] - gd[free[static_cast<std::size_t>(f)]]) /
                  (2 * step[static_cast<std::size_t>(a)]);
    }
    MatrixXd B(F, F);
    double min_precision = std::numeric_limits<double>::infinity();
    for (Eigen::Index f = 0; f < F; ++f) {
      const Eigen::Index j = free[static_cast<std::size_t>(f)];
      VectorXd hs = h;
      hs[j] = h[j] + kLogHStep;
      const VectorXd gu = gradient(hs, at_phi);
      hs[j] = h[j] - kLogHStep;
      const VectorXd gd = gradient(hs, at_phi);
      for (Eigen::Index e = 0; e < F; ++e)
        B(e, f) = -(gu[free[static_cast<std::size_t>(e)]] - gd[free[static_cast<std::size_t>(e)]]) /
                  (2 * kLogHStep);
      min_precision = std::min(min_precision, precision[j]);
    }
    if (!C.allFinite() || !B.allFinite()) return MatrixXd::Constant(K, K, kNaN);
    B = 0.5 * (B + B.transpose()).eval();
    for (Eigen::Index f = 0; f < F; ++f) B(f, f) += precision[free[static_cast<std::size_t>(f)]];
    const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(B);
    const VectorXd lambda = eig.eigenvalues().cwiseMax(min_precision);
    const MatrixXd CV = C * eig.eigenvectors();
    absorbed = CV * lambda.cwiseInverse().asDiagonal() * CV.transpose();
  } catch (const NumericalError&) {
    absorbed.setConstant(kNaN);
  }
  return absorbed;
}


template <class G>
PhiPosterior phi_posterior_impl(const MeanFunction& prior, const PriorParameters& parameters,
                                const Dataset& data, const std::vector<G>& gps,
                                PhiPosteriorKernels kernels) {
  PhiPosterior post;
  std::vector<int> at;  // indices into phi of the continuous tunable parameters
  std::vector<double> step;
  for (std::size_t k = 0; k < parameters.tunable.size(); ++k) {
    if (!parameters.choices[k].empty()) continue;
    const int i = parameters.tunable[k];
    const auto kk = static_cast<Eigen::Index>(k);
    const double h = 1e-4 * (parameters.upper[kk] - parameters.lower[kk]);
    // A parameter within one step of its bound is held at its value (it is not marginalised,
    // as a hyper-parameter on its box): the stencil would leave the search interval, often
    // into values the prior refuses (a damping below 0), which made every entry NaN.
    if (parameters.values[i] - h < parameters.lower[kk] ||
        parameters.values[i] + h > parameters.upper[kk])
      continue;
    at.push_back(i);
    step.push_back(h);
    post.names.push_back(static_cast<std::size_t>(i) < parameters.names.size()
                             ? parameters.names[static_cast<std::size_t>(i)]
                             : "phi" + std::to_string(i));
  }
  const auto K = static_cast<Eigen::Index>(at.size());
  post.mean.resize(K);
  for (Eigen::Index a = 0; a < K; ++a) post.mean[a] = parameters.values[at[static_cast<std::size_t>(a)]];
  post.covariance = MatrixXd::Constant(K, K, kNaN);
  if (K == 0) return post;
  std::vector<G> g = gps;
  const auto E = static_cast<Eigen::Index>(g.size());
  // The residual targets at phi* + sum_a d_a step_a e_a (N x E) in *t; false when the prior
  // rejects that phi or returns a non-finite output.
  auto targets = [&](const std::vector<std::pair<Eigen::Index, int>>& moves, MatrixXd* t) {
    VectorXd phi = parameters.values;
    for (const auto& [a, d] : moves) phi[at[static_cast<std::size_t>(a)]] += d * step[static_cast<std::size_t>(a)];
    try {
      prior.check_phi(phi);
    } catch (const InvalidArgument&) {
      return false;
    }
    long bad = 0;
    *t = data.dx - prior_outputs(prior, data.x, data.u, phi, &bad);
    return bad == 0;
  };
  // L = sum_i log p(t_i | X, h_i) with the kernels as fitted.
  auto L = [&](const MatrixXd& t) {
    double sum = 0;
    for (Eigen::Index i = 0; i < E; ++i) {
      auto& gi = g[static_cast<std::size_t>(i)];
      gi.set_targets(t.col(i));
      sum += gi.log_marginal_likelihood();
    }
    return sum;
  };
  auto L_at = [&](const std::vector<std::pair<Eigen::Index, int>>& moves) {
    MatrixXd t;
    return targets(moves, &t) ? L(t) : kNaN;
  };
  MatrixXd t0;
  std::vector<MatrixXd> up(static_cast<std::size_t>(K)), down(static_cast<std::size_t>(K));
  bool ok = targets({}, &t0);
  for (Eigen::Index a = 0; a < K && ok; ++a)
    ok = targets({{a, 1}}, &up[static_cast<std::size_t>(a)]) &&
         targets({{a, -1}}, &down[static_cast<std::size_t>(a)]);
  if (!ok) return post;
  const double l0 = L(t0);
  MatrixXd A(K, K);  // minus the Hessian of L in phi, the kernels fixed
  for (Eigen::Index a = 0; a < K; ++a) {
    const double sa = step[static_cast<std::size_t>(a)];
    A(a, a) = -(L(up[static_cast<std::size_t>(a)]) - 2 * l0 + L(down[static_cast<std::size_t>(a)])) /
              (sa * sa);
    for (Eigen::Index b = 0; b < a; ++b) {
      const double sb = step[static_cast<std::size_t>(b)];
      A(a, b) = A(b, a) = -(L_at({{a, 1}, {b, 1}}) - L_at({{a, 1}, {b, -1}}) -
                            L_at({{a, -1}, {b, 1}}) + L_at({{a, -1}, {b, -1}})) /
                          (4 * sa * sb);
    }
  }
  if (!A.allFinite()) return post;
  // The kernels marginalised: the phi block of the inverse joint negative Hessian over
  // (phi, h_1..h_E) is the inverse of the Schur complement A - sum_i C_i B_i^-1 C_i^T (the
  // h_i blocks are independent given phi).
  if (kernels == PhiPosteriorKernels::kMarginalised) {
    std::vector<MatrixXd> absorbed(static_cast<std::size_t>(E));
    // By blocks when the data are reflected pairs of an exact SE-ARD GP and every stencil's
    // residuals are mirrored (the prior mirrors its outputs).
    bool paired = !gps.empty() && is_exact_se(gps.front()) && data.pairs.n > 0 &&
                  data.gp_in.rows() == 2 * static_cast<Eigen::Index>(data.pairs.n) &&
                  mirrored_targets(t0, data.pairs);
    for (Eigen::Index a = 0; a < K && paired; ++a)
      paired = mirrored_targets(up[static_cast<std::size_t>(a)], data.pairs) &&
               mirrored_targets(down[static_cast<std::size_t>(a)], data.pairs);
    const MatrixXd recorded = paired ? MatrixXd(data.gp_in.topRows(data.pairs.n)) : MatrixXd();
    parallel_for(static_cast<std::size_t>(E), [&](std::size_t i) {
      absorbed[i] = kernel_absorption(gps[i], static_cast<Eigen::Index>(i), t0, up, down, step,
                                      paired ? &data.pairs : nullptr,
                                      paired ? &recorded : nullptr);
    });
    for (const auto& m : absorbed) A -= m;
    if (!A.allFinite()) return post;
  }
  // The flat prior over each search interval enters as a Gaussian of its variance (width^2 / 12):
  // a direction the data do not pin down keeps about the prior's spread, and no direction is
  // allowed more than it (an indefinite -H, phi* not at an exact optimum).
  double min_prior_precision = std::numeric_limits<double>::infinity();
  for (Eigen::Index a = 0; a < K; ++a) {
    const double width = 1e4 * step[static_cast<std::size_t>(a)];
    const double precision = 12.0 / (width * width);
    A(a, a) += precision;
    min_prior_precision = std::min(min_prior_precision, precision);
  }
  const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(A);
  const VectorXd lambda = eig.eigenvalues().cwiseMax(min_prior_precision);
  post.covariance =
      eig.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  return post;
}

}  // namespace

PhiPosterior phi_posterior(const MeanFunction& prior, const PriorParameters& parameters,
                           const Dataset& data, const std::vector<gp::Gp>& gps,
                           PhiPosteriorKernels kernels) {
  return phi_posterior_impl(prior, parameters, data, gps, kernels);
}

PhiPosterior phi_posterior(const MeanFunction& prior, const PriorParameters& parameters,
                           const Dataset& data, const std::vector<gp::SparseGp>& gps,
                           PhiPosteriorKernels kernels) {
  return phi_posterior_impl(prior, parameters, data, gps, kernels);
}

}  // namespace drops::model
