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
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/opt/subplex.hpp"

namespace drops::model {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The residual targets dx - M(x, u; phi), or nothing when the simulator returned a non-finite
/// output on some transition (counted in *nonfinite): such a phi scores -inf.
bool residuals(const MeanFunction& prior, const Dataset& d, const VectorXd& phi, MatrixXd& out,
               long* nonfinite) {
  long bad = 0;
  out = d.dx - prior_outputs(prior, d.x, d.u, phi, &bad);
  *nonfinite += bad;
  return bad == 0;
}

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
GpMiSummary nested_search(const MeanFunction& prior, const PriorParameters& parameters,
                          const Dataset& d, const GpMiOptions& options,
                          const gp::RpropOptions& inner, std::vector<gp::Gp>& gps,
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
      gp::Gp g(static_cast<int>(d.gp_in.cols()));
      g.set_h_params(from_initial ? initial_h : best_h[i]);
      gp::RpropState* state = states.empty() ? nullptr : &states[i];
      const int before = state != nullptr ? state->iterations : 0;
      try {
        g.compute(d.gp_in, t.col(static_cast<Eigen::Index>(i)));
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
  if (options.screen_iterations > 0 && all_discrete) {
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
GpMiSummary alternating_search(const MeanFunction& prior, const PriorParameters& parameters,
                               const Dataset& d, const GpMiOptions& options,
                               const gp::RpropOptions& inner, std::vector<gp::Gp>& gps,
                               const ModelProgress& progress) {
  GpMiSummary s;
  s.phi = parameters.values;
  const Eigen::Index E = static_cast<Eigen::Index>(gps.size());
  for (int round = 0; round < options.rounds; ++round) {
    // (a) kernels at the current phi.
    MatrixXd targets;
    if (!residuals(prior, d, s.phi, targets, &s.nonfinite_prior_outputs))
      break;  // keep phi; the caller's final fit reports the error
    fit_output_gps(gps, d.gp_in, targets, inner, &s.rprop_iterations);
    // (b) phi with the kernels fixed.
    PriorParameters p = parameters;
    p.values = s.phi;
    int evals = 0;
    auto S = [&](const VectorXd& phi) {
      const int k = evals++;
      MatrixXd t;
      if (!residuals(prior, d, phi, t, &s.nonfinite_prior_outputs)) return -kInf;
      VectorXd ll(E);
      for (Eigen::Index i = 0; i < E; ++i) {
        auto& g = gps[static_cast<std::size_t>(i)];
        g.set_targets(t.col(i));
        ll[i] = g.log_marginal_likelihood();
      }
      const double sc = gp_mi_score(ll, options.score);
      if (progress && k % 50 == 0) progress("gp-mi", s.evaluations + k, sc);
      return sc;
    };
    const auto r = search_phi(prior, p, options, S);
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
  if (screen_iterations < 0 || (screen_iterations > 0 && screen_iterations >= inner_rprop_iterations))
    return fail("gp_mi.screen_iterations must be 0 (no screen) or in [1, inner_rprop_iterations = " +
                std::to_string(inner_rprop_iterations) + "), got " + std::to_string(screen_iterations));
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
                        const gp::RpropOptions& rprop, long* iterations) {
  check_size("fit_output_gps: target columns vs GPs", static_cast<long>(gps.size()), targets.cols());
  const auto E = static_cast<Eigen::Index>(gps.size());
  VectorXd ll(E);
  std::vector<int> its(gps.size(), 0);
  parallel_for(gps.size(), [&](std::size_t i) {
    auto& g = gps[i];
    g.compute(in, targets.col(static_cast<Eigen::Index>(i)));
    its[i] = g.optimize_h_params(rprop).iterations;
    ll[static_cast<Eigen::Index>(i)] = g.log_marginal_likelihood();
  });
  for (int k : its) *iterations += k;
  return ll;
}

GpMiSummary identify_phi(const MeanFunction& prior, const PriorParameters& parameters,
                         const Dataset& data, const GpMiOptions& options,
                         const gp::RpropOptions& rprop, std::vector<gp::Gp>& gps,
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
  const Dataset d = data.rows(subsample(data.size(), options.max_points));
  // A purely discrete phi is searched nested: with kernels fitted to one candidate's residuals
  // (alternating search), every other candidate is scored against them and the search stays
  // where it started (measured on a family of 7 discrete priors).
  const bool all_discrete = std::all_of(parameters.choices.begin(), parameters.choices.end(),
                                        [](const auto& c) { return !c.empty(); });
  if (options.search == GpMiSearch::kAlternating && !all_discrete)
    return alternating_search(prior, parameters, d, options, inner, gps, progress);
  return nested_search(prior, parameters, d, options, inner, gps, progress);
}

VectorXd PhiPosterior::stddev() const { return covariance.diagonal().cwiseSqrt(); }

MatrixXd PhiPosterior::correlation() const {
  const VectorXd s = stddev();
  MatrixXd c = covariance.array() / (s * s.transpose()).array();
  c.diagonal().setOnes();
  return c;
}

PhiPosterior phi_posterior(const MeanFunction& prior, const PriorParameters& parameters,
                           const Dataset& data, const std::vector<gp::Gp>& gps) {
  PhiPosterior post;
  std::vector<int> at;  // indices into phi of the continuous tunable parameters
  std::vector<double> step;
  for (std::size_t k = 0; k < parameters.tunable.size(); ++k) {
    if (!parameters.choices[k].empty()) continue;
    const int i = parameters.tunable[k];
    const auto kk = static_cast<Eigen::Index>(k);
    at.push_back(i);
    step.push_back(1e-4 * (parameters.upper[kk] - parameters.lower[kk]));
    post.names.push_back(static_cast<std::size_t>(i) < parameters.names.size()
                             ? parameters.names[static_cast<std::size_t>(i)]
                             : "phi" + std::to_string(i));
  }
  const auto K = static_cast<Eigen::Index>(at.size());
  post.mean.resize(K);
  for (Eigen::Index a = 0; a < K; ++a) post.mean[a] = parameters.values[at[static_cast<std::size_t>(a)]];
  post.covariance = MatrixXd::Constant(K, K, std::numeric_limits<double>::quiet_NaN());
  if (K == 0) return post;
  std::vector<gp::Gp> g = gps;
  const auto E = static_cast<Eigen::Index>(g.size());
  // L at phi* + sum_a d_a step_a e_a.
  auto L = [&](const std::vector<std::pair<Eigen::Index, int>>& moves) {
    VectorXd phi = parameters.values;
    for (const auto& [a, d] : moves) phi[at[static_cast<std::size_t>(a)]] += d * step[static_cast<std::size_t>(a)];
    try {
      prior.check_phi(phi);
    } catch (const InvalidArgument&) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    long bad = 0;
    const MatrixXd t = data.dx - prior_outputs(prior, data.x, data.u, phi, &bad);
    if (bad) return std::numeric_limits<double>::quiet_NaN();
    double sum = 0;
    for (Eigen::Index i = 0; i < E; ++i) {
      auto& gi = g[static_cast<std::size_t>(i)];
      gi.set_targets(t.col(i));
      sum += gi.log_marginal_likelihood();
    }
    return sum;
  };
  const double l0 = L({});
  MatrixXd A(K, K);  // -H
  for (Eigen::Index a = 0; a < K; ++a) {
    const double sa = step[static_cast<std::size_t>(a)];
    A(a, a) = -(L({{a, 1}}) - 2 * l0 + L({{a, -1}})) / (sa * sa);
    for (Eigen::Index b = 0; b < a; ++b) {
      const double sb = step[static_cast<std::size_t>(b)];
      A(a, b) = A(b, a) = -(L({{a, 1}, {b, 1}}) - L({{a, 1}, {b, -1}}) - L({{a, -1}, {b, 1}}) +
                            L({{a, -1}, {b, -1}})) /
                          (4 * sa * sb);
    }
  }
  if (!A.allFinite()) return post;
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

}  // namespace drops::model
