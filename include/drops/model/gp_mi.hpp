#pragma once
/// \file GP-MI, paper Algorithm 2 (§IV-B): the simulator prior's parameters phi chosen to
/// maximise the sum of the likelihoods of the E output GPs fitted to the residuals
/// dx - M(x, u; phi), with the kernels refit at phi*. The nested search is the paper's
/// (Subplex over phi outside, Rprop over each output's kernel inside); the alternating search
/// ascends the same score block by block, much faster. settings.md §4 gives the reference's values.

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "drops/core/types.hpp"
#include "drops/gp/gp.hpp"
#include "drops/gp/sparse_gp.hpp"
#include "drops/model/dataset.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::model {

/// How GP-MI searches phi. Both maximise the same score
///   S(phi) = max_{h_1..h_E} score(log p(dx_1 - M_1(phi) | X, h_1), ..., log p(dx_E - M_E(phi) | X, h_E)).
enum class GpMiSearch {
  /// Paper's nested loops: every Subplex evaluation of phi refits all E kernels with Rprop
  /// (inner_rprop_iterations iterations, started as GpMiOptions::candidate_start says).
  kNested,
  /// Block-coordinate ascent on the same score: Subplex over phi with the kernels fixed (each
  /// evaluation costs N simulator calls and E O(N^2) solves), then refit the kernels at the new
  /// phi, for up to `rounds` rounds or until phi stops moving. Much cheaper; same fixed points.
  /// When every tunable parameter is discrete, GP-MI uses kNested instead: with the kernels fitted
  /// to the starting candidate's residuals, the others are scored against them and the search
  /// stays at its start (measured on a family of 7 discrete priors).
  kAlternating,
};

/// How GP-MI combines the E output GPs' log marginal likelihoods l_i into its score.
enum class GpMiScore {
  /// log sum_i exp(l_i): the paper's "sum of the likelihoods" (settings.md §4). Dominated by the
  /// single best-fitting output, so with outputs that every prior predicts alike (the joint
  /// outputs of a legged robot, a position integrated from the previous velocity) it can ignore
  /// the outputs that tell the priors apart.
  kSumOfLikelihoods,
  /// sum_i l_i: the joint log likelihood of the independent output GPs (the product of the
  /// likelihoods), which every output informs. The default.
  kSumOfLogLikelihoods,
};

/// Where the nested search's kernel fit of each candidate phi starts (GpMiSearch::kNested, which
/// GP-MI also uses for a purely discrete phi): the start of the inner Rprop loop of paper
/// Algorithm 2, which the paper leaves open.
enum class GpMiCandidateStart {
  /// From the kernels of the best candidate so far (the first candidate: from the model's current
  /// kernels, fitted at the previous episode's phi). Cheap for a continuous phi, whose neighbours
  /// have similar kernels; with a few inner Rprop iterations it favours the candidates whose
  /// kernels it starts from (measured on a family of 7 discrete priors, docs/architecture.md).
  kBestSoFar,
  /// From a new GP's kernels (length scales 1, signal variance 1) for every candidate: the
  /// candidates are compared on equal terms, whatever the previous episode chose.
  kInitial,
};

/// Which phi the model's Monte-Carlo rollouts use (GpMiOptions::rollout_phi).
enum class RolloutPhi {
  /// Every rollout uses phi*, GP-MI's point estimate (the paper).
  kPoint,
  /// Rollout r of every policy uses sample r mod S of S draws from phi's posterior (PhiPosterior,
  /// continuous tunable entries), drawn once per episode after learning; Black-DROPS draws S =
  /// the most rollouts any of its evaluations uses (the search's, the re-evaluation's, the
  /// prediction's), so every policy meets the same models (common random numbers): a search with
  /// one rollout per policy plans on one draw (posterior sampling), and the re-evaluation and
  /// the predicted return average over many.
  /// Under sample s the model is the simulator at phi_s plus the output GPs conditioned on the
  /// residuals dx - M(x, u; phi_s) of the same data (kernels as fitted at phi*): near the data
  /// the samples agree (the GPs take up the difference), away from it they differ as the
  /// simulators at the phi the data cannot tell apart do.
  kPosterior,
};

/// Options of GP-MI (settings.md §4).
struct GpMiOptions {
  GpMiSearch search = GpMiSearch::kAlternating;
  /// How the per-output likelihoods combine. The joint likelihood by default: it identified every
  /// parameter of a pendulum whose angle output no phi changes, where the paper's sum of the
  /// likelihoods left phi at its start (docs/decisions/gp-mi-score.md). A task may choose the
  /// paper's score as its default (TaskPlugin::shared_defaults, key model.gp_mi.score).
  GpMiScore score = GpMiScore::kSumOfLogLikelihoods;
  /// nested search: where each candidate's kernel fit starts
  GpMiCandidateStart candidate_start = GpMiCandidateStart::kBestSoFar;
  int max_evaluations = 1000;   ///< Subplex evaluations per search (per discrete combination), >= 1
  double xtol_rel = 1e-4;       ///< Subplex relative tolerance on phi, >= 0
  double ftol_rel = 1e-4;       ///< Subplex relative tolerance on the score, >= 0
  int rounds = 5;               ///< alternating search: maximum rounds, >= 1
  int inner_rprop_iterations = 50;  ///< Rprop iterations of the kernel refits inside the search, >= 1
  /// Use at most this many transitions (evenly spaced) inside the phi search; 0 = all. The final
  /// kernel fit always uses all data. >= 0.
  int max_points = 0;
  /// Candidate screen, nested search over a phi whose tuned entries are all discrete (the
  /// candidates are listed, none continuous): first every candidate's kernels get this many Rprop
  /// iterations, then only the candidates whose score is within screen_margin of the best one's
  /// have their Rprop searches continued to inner_rprop_iterations (gp::RpropState: the same
  /// steps as an uninterrupted search). With candidate_start kInitial every fit starts from a new
  /// GP's kernels, so a candidate that passes gets the fit and score it would have without the
  /// screen, and the choice, the kernels and the score are those of the unscreened search
  /// whenever the winner passes. Cost: screen_iterations for every candidate, the rest of
  /// inner_rprop_iterations for those that pass. >= 0; 0 or at least inner_rprop_iterations: no
  /// screen (every candidate fitted in full). Ignored when a tuned entry is continuous.
  int screen_iterations = 0;
  /// The screen's margin in units of the score (nats), >= 0: a candidate whose screened score is
  /// more than this below the best screened score is not fitted further.
  double screen_margin = 0.0;
  /// Which phi the rollouts on the model use: GP-MI's point estimate (the default) or draws from
  /// its posterior (RolloutPhi). Only a continuous tunable phi has a posterior; with none, every
  /// rollout uses the point estimate.
  RolloutPhi rollout_phi = RolloutPhi::kPoint;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// Progress during learning: phase ("gp-mi", "kernels", "mi"), evaluations so far, best score.
using ModelProgress = std::function<void(const std::string& phase, int evaluations, double best)>;

/// What identify_phi did.
struct GpMiSummary {
  VectorXd phi;  ///< phi* (full, dim P); the start when no candidate scored a finite value
  /// S(phi*) as found by the search (-inf when no candidate was valid).
  double score = -std::numeric_limits<double>::infinity();
  int evaluations = 0;             ///< evaluations of S
  int rounds = 0;                  ///< alternating search: rounds performed (0 for nested)
  long rprop_iterations = 0;       ///< Rprop iterations of every kernel fit inside the search
  long nonfinite_prior_outputs = 0;  ///< simulator outputs that were NaN/inf (phi rejected there)
  int screened_out = 0;  ///< candidates the screen left out (GpMiOptions::screen_iterations)
};

/// Whether phi_posterior marginalises the output GPs' kernel hyper-parameters or holds them fixed.
enum class PhiPosteriorKernels {
  kMarginalised,  ///< the joint Laplace approximation over phi and every h_i (the default)
  kFixed,         ///< the kernels held at their fit: the posterior of phi given them
};

/// How sure GP-MI is of phi: the Laplace approximation (Laplace's method, MacKay 2003, ch. 27) of
/// the posterior over the continuous tunable parameters (K of them) at phi* and the kernels' fit
/// h* = (h_1..h_E), from the joint log likelihood (the GPs' marginal likelihood and its gradient
/// in h: Rasmussen & Williams 2006, §5.4)
///   L(phi, h) = sum_i log p(dx_i - M_i(X; phi) | X, h_i)
/// of the E output GPs, h_i the log hyper-parameters of output i (H_i of them; Gp::h_params).
/// With A = -(Hessian of L) at (phi*, h*) in blocks A_pp (K x K), A_ph_i (K x H_i), A_hh_i
/// (H_i x H_i; the outputs do not share hyper-parameters) and P_p, P_h the priors' precisions
/// below, the covariance is the phi block of the inverse of the joint (K + sum H_i) precision,
///   (A_pp + P_p - sum_i A_ph_i (A_hh_i + P_h_i)^-1 A_hp_i)^-1   (K x K, a Schur complement),
/// i.e. the curvature of the profile likelihood max_h L(phi, h): where refitting the kernels takes
/// up part of a change of phi (the residual GPs absorb it), phi is known less well than with the
/// kernels fixed (PhiPosteriorKernels::kFixed: (A_pp + P_p)^-1). A_pp: central second differences
/// of L in phi, steps of 1e-4 of each parameter's search interval; A_ph_i: central differences of
/// the analytic gradient d log p / d h_i (Gp::log_marginal_likelihood_gradient) between those phi
/// steps; A_hh_i: central differences of that gradient along each log hyper-parameter (steps of
/// 1e-3), symmetrised. Priors: flat over each search interval of phi and over Rprop's box of each
/// log hyper-parameter ([-10, 10], log sigma_n in [log 1e-5, 10]; Gp::optimize_h_params), each as
/// a Gaussian of the same variance, P = diag(12 / width^2); the eigenvalues of A_hh_i + P_h_i and
/// of the phi block are floored at the smallest of their prior precisions, so that no direction is
/// allowed more than its prior's spread. A hyper-parameter that the fit left on its box is held
/// fixed (it is not marginalised): the box keeps it there for nearby phi, so it takes up nothing.
/// The soft walls of RpropOptions::penalty are not part of L, so a hyper-parameter they hold
/// counts as free. A direction in which L is flat (two parameters that enter the dynamics only
/// through their product, a parameter the data do not excite) or in which L still rises with the
/// kernels following (phi* short of the maximum of L over phi and h together: the search stopped
/// on a ridge that the kernels' refit follows) keeps about the prior's spread (width / sqrt(12)),
/// so the parameters involved show a standard deviation of the order of their interval and a
/// correlation of about +-1 (the trade-off), where a parameter the data pin down has one orders of
/// magnitude smaller. Units: those of phi.
struct PhiPosterior {
  std::vector<std::string> names;  ///< the continuous tunable parameters (dim K)
  VectorXd mean;                   ///< phi* on them (dim K)
  MatrixXd covariance;             ///< K x K
  VectorXd stddev() const;         ///< sqrt of the diagonal (dim K)
  MatrixXd correlation() const;    ///< K x K, 1 on the diagonal
  bool empty() const { return names.empty(); }
};

/// The PhiPosterior at parameters.values (phi*), for the continuous tunable entries of phi
/// (discrete ones are held at their value; none: an empty posterior). An entry within 1e-4 of
/// its search interval's width of a bound is held at its value too and left out of `names` (the
/// posterior of the others given it; a stencil step across the bound would leave the interval). data: the transitions the
/// GPs were fitted on (gp_in, x, u, dx); gps: the E output GPs fitted at phi* on data.gp_in (not
/// modified: copies are evaluated); kernels: whether their hyper-parameters are marginalised (the
/// default) or held fixed. A stencil point the prior rejects (check_phi) or that gives a
/// non-finite likelihood, or a hyper-parameter step whose factorisation fails, makes the whole
/// covariance NaN. Cost: 2K^2 + 1 evaluations of the prior on the data and E O(N^2) solves each;
/// marginalised, also per output GP with F hyper-parameters off the box 2K + 2F gradients
/// (O(N^3) each) and 2F factorisations, the outputs in parallel (about the final kernel fit's time
/// for the dynamics GPs of a 4-state system at N = 500). On reflected pairs (data.pairs set,
/// SE-ARD kernels, every stencil's residuals mirrored) the gradients are computed by blocks
/// (gp::reflected_pairs_log_likelihood: the same to round-off, a quarter of the cubic cost).
/// Thread-safe (reads only).
PhiPosterior phi_posterior(const MeanFunction& prior, const PriorParameters& parameters,
                           const Dataset& data, const std::vector<gp::Gp>& gps,
                           PhiPosteriorKernels kernels = PhiPosteriorKernels::kMarginalised);
/// The same with sparse output GPs (ModelOptions::inducing_points): L is the sum of their
/// variational bounds (gp::SparseGp, inducing inputs held fixed), each gradient O(N M^2 + M^3).
PhiPosterior phi_posterior(const MeanFunction& prior, const PriorParameters& parameters,
                           const Dataset& data, const std::vector<gp::SparseGp>& gps,
                           PhiPosteriorKernels kernels = PhiPosteriorKernels::kMarginalised);

/// log sum_i exp(v_i), computed stably (max shift). Returns -inf for an empty or all -inf vector.
/// Thread-safe.
double log_sum_exp(const VectorXd& v);

/// GP-MI's score of per-output log likelihoods ll (dim E) under `score` (see GpMiScore); -inf
/// when any entry is -inf under kSumOfLogLikelihoods. Thread-safe.
double gp_mi_score(const VectorXd& ll, GpMiScore score);

/// Fits output GP i on (in, targets.col(i)) for every i, in parallel over outputs: compute(), then
/// Rprop from the GP's current hyper-parameters (warm start). gps: E GPs on in.cols() inputs;
/// in: N x D; targets: N x E. Returns the per-output log marginal likelihoods (dim E) and adds
/// the Rprop iterations to *iterations. Throws NumericalError from a failing factorisation.
/// With pairs (n > 0, in's rows n transitions then their reflections, Dataset::pairs) and an
/// output whose targets follow the layout to round-off (1e-9 relative), Rprop runs on the n
/// recorded rows by gp::fit_reflected_pairs: the 2n fit up to round-off, at a quarter of the
/// cubic cost (not with rprop.penalty; the GP is then computed on all 2n rows). When the start
/// cannot be factorised without jitter (points on the mirror plane), that output is fitted on
/// all 2n rows as without pairs.
VectorXd fit_output_gps(std::vector<gp::Gp>& gps, const MatrixXd& in, const MatrixXd& targets,
                        const gp::RpropOptions& rprop, long* iterations,
                        const ReflectedPairs& pairs = {});
/// The same with sparse output GPs: each chooses its inducing inputs among the rows of `in` for
/// its current kernel (gp::SparseGp::compute), is fitted with Rprop on its bound, then chooses
/// them again for the fitted kernel; the bounds returned are with those. O(E N M^2) per Rprop
/// iteration instead of O(E N^3).
VectorXd fit_output_gps(std::vector<gp::SparseGp>& gps, const MatrixXd& in,
                        const MatrixXd& targets, const gp::RpropOptions& rprop, long* iterations);

/// Paper Algorithm 2: phi* = argmax_phi S(phi) over parameters.tunable within their bounds
/// (discrete choices exhaustively), starting from parameters.values, by options.search.
/// data: the transitions (x, u, dx and the GP inputs), subsampled to options.max_points inside the
/// search. gps: the E output GPs; their hyper-parameters are the warm start on entry (of the
/// first candidate's fits with options.candidate_start = kBestSoFar, of the first round in the
/// alternating search; unused with kInitial), and on return the kernels fitted at phi* inside
/// the search (the caller refits on all data). rprop:
/// the options of the kernel fits, whose iteration count is replaced by
/// options.inner_rprop_iterations. prior.check_phi rejects invalid candidates (score -inf).
/// Throws InvalidArgument when parameters do not fit the prior or the data. Not thread-safe (it
/// runs parallel loops and mutates gps).
GpMiSummary identify_phi(const MeanFunction& prior, const PriorParameters& parameters,
                         const Dataset& data, const GpMiOptions& options,
                         const gp::RpropOptions& rprop, std::vector<gp::Gp>& gps,
                         const ModelProgress& progress = nullptr);
/// The same search on sparse output GPs (gp::SparseGp, ModelOptions::inducing_points): S(phi)
/// from their variational bounds. The alternating search refits them (fit_output_gps) once per
/// round, then scores each phi in O(E N M) with the kernels and inducing inputs fixed; the nested
/// search chooses the inducing inputs again for every candidate's fit.
GpMiSummary identify_phi(const MeanFunction& prior, const PriorParameters& parameters,
                         const Dataset& data, const GpMiOptions& options,
                         const gp::RpropOptions& rprop, std::vector<gp::SparseGp>& gps,
                         const ModelProgress& progress = nullptr);

}  // namespace drops::model
