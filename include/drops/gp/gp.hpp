#pragma once
/// \file Gaussian process regression with one scalar output (paper eq. 3-6).

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <memory>
#include <string>
#include <vector>

#include "drops/gp/kernel.hpp"

namespace drops::gp {

/// Options of the iRprop- hyper-parameter search (Igel & Huesken 2000; settings.md §3).
struct RpropOptions {
  int max_iterations = 300;  ///< iterations (gradient evaluations), >= 1
  double delta0 = 0.1;       ///< initial step per parameter (log space), > 0
  double delta_min = 1e-6;   ///< smallest step, > 0; the search stops when every step is below it
  double delta_max = 50.0;   ///< largest step, >= delta0
  double eta_minus = 0.5;    ///< step decrease factor in (0, 1)
  double eta_plus = 1.2;     ///< step increase factor, > 1
  /// Stop early when the best log-likelihood improved by less than this over the last
  /// `patience` iterations (0 disables early stopping: run max_iterations).
  double tolerance = 0.0;
  int patience = 10;  ///< iterations over which `tolerance` is measured, >= 1
  /// PILCO's soft walls on extreme hyper-parameters (Deisenroth 2010, gp/hypCurb.m; settings.md §3:
  /// the reference used them for the no-prior variant). When enabled, Rprop maximises
  ///   log p(y | X, h) - sum_d ((log l_d - log s_d) / log(max_length_scale_ratio))^power
  ///                   - ((log sigma_f - log sigma_n) / log(max_snr))^power,
  /// s_d being the standard deviation of input d in the training data (dimensions with s_d <
  /// 1e-12 carry no information and are not penalised). With power 30 the walls are flat inside
  /// l_d in [s_d / ratio, ratio s_d] and sigma_f / sigma_n in [1 / max_snr, max_snr] and steep
  /// outside. They keep a GP on few points in many dimensions from interpolating noise (sigma_n
  /// driven to its floor, signal-to-noise ratios of 1e5), which ruins its predictions away from
  /// the data. Likelihoods reported (RpropSummary, log_marginal_likelihood) stay unpenalised.
  bool penalty = false;
  double max_length_scale_ratio = 100.0;  ///< > 1 (PILCO: 100)
  double max_snr = 500.0;                 ///< > 1 (PILCO: 500)
  int power = 30;                         ///< even, >= 2 (PILCO: 30)
  /// Returns true when every field is in range; otherwise false and, if why != nullptr, the reason.
  bool IsValid(std::string* why) const;
};

/// Result of Gp::optimize_h_params.
struct RpropSummary {
  int iterations = 0;                 ///< gradient evaluations performed
  double initial_log_likelihood = 0;  ///< log p(y | X, h) at the warm start
  double final_log_likelihood = 0;    ///< at the best iterate (the one kept)
  double final_penalty = 0;           ///< the soft walls' value there (0 without penalty)
  int cholesky_failures = 0;          ///< iterates rejected because K was not positive definite
};

/// Where an iRprop- search stopped, so that a later Gp::optimize_h_params call with a larger
/// max_iterations continues it: the continued search takes exactly the steps the uninterrupted
/// one would have taken (the same iterates, bit for bit). Opaque: filled by optimize_h_params.
struct RpropState {
  bool started = false;   ///< false: the next call starts a new search from the GP's h
  bool finished = false;  ///< converged (every step at delta_min) or stopped by the tolerance rule
  int iterations = 0;     ///< gradient evaluations so far (the start included)
  int cholesky_failures = 0;
  double initial_log_likelihood = 0;
  Eigen::VectorXd h;      ///< the next iterate, stepped to but not evaluated yet
  Eigen::VectorXd g, g_prev, delta, best_h, best_g;
  double best_f = 0;
  std::vector<double> best_history;
};

/// Scalar-output GP regression, zero mean on the targets it is given (the caller subtracts the prior
/// mean M(x, phi) first, paper eq. 4), with any Kernel (kernel.hpp). Hyper-parameters in log space:
///   h = [kernel h (dim K), log sigma_n]  (dim K + 1),
/// sigma_n^2 being the observation-noise variance. With the default squared-exponential ARD kernel
/// (K = D + 1), h = [log l_1 .. log l_D, log sigma_f, log sigma_n] (dim D + 2) and the GP uses
/// dedicated fast paths (factorisation, gradient, SIMD prediction kernels); other kernels go
/// through Kernel::gram. Defaults: l = 1, sigma_f^2 = 1, sigma_n^2 = 0.01.
///
/// Usage: set data with compute(X, y), optionally optimize_h_params(), then predict().
/// After compute(), every const member is thread-safe (predict may run concurrently).
class Gp {
 public:
  /// GP with the squared-exponential ARD kernel on inputs of dimension input_dim (>= 1). Throws
  /// InvalidArgument otherwise.
  explicit Gp(int input_dim = 1);
  /// GP with a copy of `kernel` (its current hyper-parameters) and sigma_n^2 = 0.01. Throws
  /// InvalidArgument when kernel.input_dim() < 1.
  explicit Gp(const Kernel& kernel);
  Gp(const Gp& other);
  Gp& operator=(const Gp& other);
  Gp(Gp&&) noexcept = default;
  Gp& operator=(Gp&&) noexcept = default;
  ~Gp();

  /// Input dimension D.
  int input_dim() const;
  /// Number of training points N.
  int size() const;

  /// Hyper-parameters h (dim K + 1, log space, see class comment): exactly the vector last set
  /// (set_h_params or Rprop), so set_h_params(h_params()) restores the GP bit for bit.
  Eigen::VectorXd h_params() const;
  /// Sets h (dim K + 1, finite); if data is present, recomputes the factorisation.
  /// Throws InvalidArgument on wrong size, non-finite values or |h_i| so large that exp(2 h_i)
  /// over/underflows (~350); NumericalError if the factorisation fails (the GP is then unchanged).
  void set_h_params(const Eigen::VectorXd& h);

  /// Current kernel (its hyper-parameters are the first K entries of h).
  const Kernel& kernel() const;
  /// Observation-noise variance sigma_n^2 = exp(2 h[K]).
  double noise_variance() const;

  /// Stores training data and factorises K + sigma_n^2 I. X: N x D (one input per row), y: N.
  /// N may be 0 (then predictions are the prior: mean 0, variance sigma_f^2).
  /// Cholesky failures are retried with jitter 1e-9 * 10^k added to the diagonal (k < 6), then
  /// NumericalError is thrown. Throws InvalidArgument on size mismatch or non-finite data. On any
  /// throw the GP keeps its previous data. Cost O(N^2 D + N^3 / 3).
  void compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);

  /// Replaces only the targets y (dim N) keeping X and h: reuses the factorisation (O(N^2)).
  /// Used by GP-MI when only the prior mean changes. Throws InvalidArgument on size mismatch or
  /// non-finite values.
  void set_targets(const Eigen::VectorXd& y);

  /// log p(y | X, h) = -1/2 y^T K^-1 y - 1/2 log|K| - N/2 log 2 pi (paper eq. 5), K including noise
  /// (and the jitter, if the last factorisation needed one). 0 when N = 0. O(N).
  double log_marginal_likelihood() const;
  /// d log p / d h (dim K + 1), analytic: 1/2 tr((alpha alpha^T - K^-1) dK/dh_j) (Rasmussen &
  /// Williams 2006, eq. 5.9). The jitter, if any, is treated as a constant. Zero vector when N = 0.
  /// Cost O(N^3) (K^-1 from the Cholesky factor) + O(N^2 D).
  Eigen::VectorXd log_marginal_likelihood_gradient() const;

  /// Maximises the log marginal likelihood (minus options' soft walls, if enabled) over h with
  /// iRprop- (Igel & Huesken 2000), starting from
  /// the current h (warm start); one analytic gradient per iteration. On return h is the best iterate
  /// seen and the GP is refactorised with it (alpha, predictions, likelihood all refer to it).
  /// Box: every iterate after the start is clamped to [-10, 10] for the kernel's log
  /// hyper-parameters (SE-ARD: log l_d, log sigma_f) and log sigma_n in [log 1e-5, 10] (noise std
  /// >= 1e-5) to stay numerically safe; a parameter stopped
  /// by the box keeps a step <= delta0. Stops after options.max_iterations gradient evaluations
  /// (the start included), when every step has shrunk to delta_min, or by the tolerance/patience rule.
  /// An iterate whose Cholesky fails (even after jitter) or whose likelihood/gradient is not finite
  /// counts as -inf: it is counted in cholesky_failures, all steps shrink by eta_minus and the search
  /// resumes from the best iterate. Requires data (N >= 1). Throws InvalidArgument on invalid options,
  /// N = 0, or options.penalty with a kernel other than SE-ARD (the walls are defined on its h). Not thread-safe (mutates the GP). Cost per iteration: O(N^3) (Cholesky + K^-1).
  ///
  /// state (optional): a search stopped by max_iterations can be continued. With a state that
  /// has started, the search resumes where that state says (the GP must hold the data and
  /// targets it was started on; its current h is ignored) and runs until options.max_iterations
  /// gradient evaluations in all; on return the state says where it stopped. RpropSummary's
  /// iterations and initial likelihood then count from the search's start.
  RpropSummary optimize_h_params(const RpropOptions& options = {}, RpropState* state = nullptr);

  /// Predictive variances from the last m training points only (the caller chooses the subset
  /// by the order of the rows it gives compute()): the subset-of-data approximation (Rasmussen &
  /// Williams 2006, §8.3.1) of the variance, k(x,x) - k_m*^T K_mm^-1 k_m*, never below the
  /// exact one (conditioning on fewer observations cannot lower a Gaussian's variance); means
  /// still use every point. The cost of a variance falls from O(N^2) to O(m^2) once N > m; for N <= m
  /// every result is the exact GP's, bit for bit. m = 0 (the default): every point. The setting
  /// survives compute(), set_h_params() and optimize_h_params(), which refactorise the subset
  /// too (O(m^3 / 3) more, once per call, not per Rprop iteration). Throws InvalidArgument when
  /// m < 0, NumericalError when the subset's factorisation fails (the GP is then unchanged). Not
  /// thread-safe (mutates the GP).
  void set_variance_points(int m);
  /// The m of set_variance_points (0: every point); 2 h after set_variance_pairs(h).
  int variance_points() const { return variance_points_; }

  /// set_variance_points(2 h) for a subset laid out as mirror pairs: the last 2 h training points
  /// are h points followed by their mirror images in the same order, under a map M of the inputs
  /// that leaves the kernel unchanged (k(Mx, Mx') = k(x, x'), e.g. a reflection that flips the
  /// signs of some inputs of an SE-ARD kernel; model::ReflectedPairs). The subset's K + sigma_n^2 I
  /// is then [[A, B], [B, A]] and the variance term k_m*^T K_mm^-1 k_m* is
  /// u^T (A + B)^-1 u + w^T (A - B)^-1 w with u, w = (k_1 +- k_2) / sqrt(2) (k_1, k_2: the kernel
  /// with the h points and with their images): two factorisations of h points, so a variance costs
  /// half the O((2h)^2) of set_variance_points(2 h), whose results these equal to round-off.
  /// With N = 2 h (every point in pairs) the exact variances are computed so, by blocks; for
  /// N < 2 h they are the exact GP's (with L), as with set_variance_points. The setting survives
  /// compute(), set_h_params() and optimize_h_params(), as set_variance_points' does, until
  /// set_variance_points is called. Throws InvalidArgument when h < 0 or when the kernel matrix
  /// of the last 2 h points is not of that block form (to 1e-8 sigma_f^2: the rows are not mirror
  /// pairs), NumericalError when a block's factorisation fails; the GP is then unchanged. Not
  /// thread-safe (mutates the GP).
  void set_variance_pairs(int h);
  /// The h of set_variance_pairs (0: the variance subset, if any, is not laid out in pairs).
  int variance_pairs() const { return variance_pairs_; }

  /// Posterior mean k*^T alpha and variance k(x,x) - k*^T K^-1 k* (without noise, clamped at >= 0;
  /// from the last variance_points() training points when N exceeds it) at x (dim D;
  /// InvalidArgument otherwise). Thread-safe after compute(); per-thread scratch, no heap
  /// allocation in steady state.
  void predict(const Eigen::VectorXd& x, double& mean, double& variance) const;

  /// Batched prediction for B query points. Xq: B x D (one query per row); mean, variance: resized
  /// to B (variances as predict(), variance_points() included). Equal to B calls of predict() up
  /// to round-off (~1e-12); much faster for B >= 4. Thread-safe.
  /// A query's results can differ at round-off between batch sizes (Eigen sums the scaled queries'
  /// squared norms in an order that depends on B; the kernel after it does not), never between runs
  /// or thread counts for the same batches.
  /// Hot path of the Monte-Carlo rollouts: uses a per-thread scratch buffer that only grows, so no heap
  /// allocation happens once it has reached N * B and mean/variance already have size B.
  /// Non-finite queries propagate NaN (not checked). Throws InvalidArgument if Xq.cols() != D.
  void predict_batch(const Eigen::MatrixXd& Xq, Eigen::VectorXd& mean,
                     Eigen::VectorXd& variance) const;

  /// Batched prediction in which query q's mean uses its own weights: mean_q = k*_q^T
  /// weights.col(columns[q]) instead of k*_q^T alpha, the variance as predict_batch (it does not
  /// depend on the targets). weights: N x S, typically columns of solve(y') for other targets y'
  /// on the same inputs and kernel (the GP of those targets, without refactorising); columns: B
  /// entries in [0, S). A query's mean with a column equal to alpha() is the same bits as
  /// predict_batch's. Throws InvalidArgument on Xq.cols() != D, weights.rows() != N, or
  /// columns of the wrong size or out of range. Thread-safe; the SIMD kernels of predict_batch
  /// (squared-exponential ARD), Eigen otherwise.
  void predict_batch(const Eigen::MatrixXd& Xq, const Eigen::MatrixXd& weights,
                     const std::vector<int>& columns, Eigen::VectorXd& mean,
                     Eigen::VectorXd& variance) const;

  /// K^-1 y (dim N) for targets y (dim N) on the current factorisation, by the same two
  /// triangular solves as alpha (so solve(y) of the GP's own targets is alpha(), bit for bit).
  /// O(N^2). Throws InvalidArgument on size mismatch. Thread-safe (const).
  Eigen::VectorXd solve(const Eigen::VectorXd& y) const;

  /// alpha = K^-1 y (dim N).
  const Eigen::VectorXd& alpha() const;

  /// Training inputs X (N x D, one input per row) as last given to compute(); 0 x D before.
  /// Used by moment matching under uncertain inputs (drops::pilco). Thread-safe (const).
  const Eigen::MatrixXd& training_inputs() const;
  /// (K + sigma_n^2 I + jitter I)^-1 (N x N, symmetric): the inverse of the matrix that alpha was
  /// solved with (jitter: see compute(), usually 0). Computed from the Cholesky factor on each call
  /// (O(N^3), nothing cached, the GP is not modified); 0 x 0 when N = 0. Used by PILCO's moment
  /// matching (the alpha_a^2 - tr(K^-1 Q) term of the predictive variance, Deisenroth 2010, gp0.m).
  /// Thread-safe (const).
  Eigen::MatrixXd inverse_covariance() const;

 private:
  // Implementation state (see src/gp/gp.cpp). Invariant after construction / compute(): every
  // member below is consistent with (kernel_, log_sigma_n_, X_, y_); a throwing call leaves it intact.
  int input_dim_;
  std::unique_ptr<Kernel> kernel_;
  const SquaredExpArd* se_ = nullptr;  // kernel_ when it is SE-ARD (fast paths), else null
  double log_sigma_n_;
  Eigen::VectorXd h_;          // K + 1, the log-space h that kernel_ and log_sigma_n_ were made from
  Eigen::MatrixXd X_;          // N x D training inputs
  Eigen::RowVectorXd X_mean_;  // D, column means of X_ (centring keeps the distance expansion accurate)
  // SE-ARD only: N x (D + 2) augmented scaled inputs [xs, -|xs|^2 / 2, 1] with xs = (x - X_mean_) / l,
  // so that one product with a query row [q, 1, -|q|^2 / 2] gives -1/2 of the squared scaled distance.
  Eigen::MatrixXd Xa_;
  Eigen::VectorXd y_;          // N targets
  Eigen::MatrixXd Kf_;         // N x N noise-free kernel matrix (used by the gradient)
  Eigen::MatrixXd L_;          // N x N, lower triangle = Cholesky factor L of K; strict upper = L^T
                               // (so row i of L is contiguous in column i, for predict_batch)
  Eigen::VectorXd alpha_;      // N, K^-1 y
  double jitter_ = 0.0;        // extra diagonal added to K by the last successful factorisation
  int variance_points_ = 0;    // m of set_variance_points (0: all)
  // m x m, laid out as L_: the Cholesky factor of the last m points' K (with the same noise and
  // jitter) when 0 < m < N and the last factorisation made it (with set_variance_pairs, the
  // factor of A + B, also for 2 h = N: see Lw_); otherwise 0 x 0 (variances then
  // use L_, exact: the state inside an Rprop search, between its iterations).
  Eigen::MatrixXd Lv_;
  int variance_pairs_ = 0;  // h of set_variance_pairs (0: not paired)
  // With variance_pairs_ > 0 and 2 h <= N: Lv_ is the h x h factor of A + B + (sigma_n^2 + jitter) I
  // and Lw_ that of A - B + (sigma_n^2 + jitter) I, laid out as L_; otherwise 0 x 0.
  Eigen::MatrixXd Lw_;

  // Factorises K for (kernel, log_sigma_n, X) with the jitter retries and, on success only, commits
  // kernel, noise, X (unless X aliases X_), X_mean_, Xa_, Kf_, L_, jitter_, y_ and alpha_, and
  // Lv_ (made when subset is true and 0 < variance_points_ < N, emptied otherwise). Throws
  // NumericalError.
  void factorise(std::unique_ptr<Kernel> kernel, double log_sigma_n, const Eigen::MatrixXd& X,
                 const Eigen::VectorXd& y, bool subset = true);
  // Applies a log-space h (already validated) and refactorises (factorise's subset).
  void apply_h(const Eigen::VectorXd& h, bool subset = true);
  // Lv_ for m points from Kf (N x N, noise-free) with `diagonal` (sigma_n^2 + jitter) added;
  // 0 x 0 unless 0 < m < N. Throws NumericalError when the factorisation fails.
  static Eigen::MatrixXd subset_factor(const Eigen::MatrixXd& Kf, double diagonal, int m);
  // (Lv_, Lw_) of set_variance_pairs from Kf (N x N, noise-free) with `diagonal` added; both
  // 0 x 0 unless 0 < 2 h <= N. Throws InvalidArgument (not mirror pairs) or NumericalError.
  static void pair_factors(const Eigen::MatrixXd& Kf, double diagonal, int h, Eigen::MatrixXd& Lv,
                           Eigen::MatrixXd& Lw);
  // The first row of the points that variances use: N - m with a subset, else 0.
  Eigen::Index variance_first() const;
  // kv (the kernel with those points, one query per column: N - variance_first() rows) is
  // overwritten by the variance solve; returns the squared norms of its columns, the term
  // k*^T K^-1 k* of each query's variance (with the subset's factor, or its pair factors, or L_).
  void variance_terms(Eigen::Ref<Eigen::MatrixXd> kv, Eigen::Ref<Eigen::VectorXd> ss) const;
  // Points se_ at kernel_ when it is SE-ARD.
  void bind_kernel();
  // Both predict_batch overloads: weights and columns null (alpha for every query) or both set.
  void predict_rows(const Eigen::MatrixXd& Xq, const Eigen::MatrixXd* weights,
                    const std::vector<int>* columns, Eigen::VectorXd& mean,
                    Eigen::VectorXd& variance) const;
};

/// The rows of X (N x D) whose observations the subset-of-data variance (Gp::set_variance_points)
/// should condition on, for GPs that share the inputs X (gps: each already fitted, on X or not;
/// their kernels and noises are what counts). Greedy selection by a pivoted Cholesky
/// factorisation of every GP's K + sigma_n^2 I (Harbrecht, Peters & Schneider 2012; Seeger,
/// Williams & Lawrence 2003 choose by the same variance): each step adds the row whose latent
/// variance given the rows chosen so far, in units of each GP's signal variance and summed over
/// the GPs, is the largest (ties: the lowest row). It stops at m rows, or earlier when no row's
/// exceeds `tolerance` per GP on average: a repeated input is never chosen twice while the noise
/// is below tolerance x sigma_f^2, and every row not chosen keeps a latent variance of at most
/// about G x tolerance x sigma_f^2 more than the exact one. Returns increasing row indices;
/// every row when m <= 0 or N <= m. O(G N m^2) time, O(G N m) memory. Throws InvalidArgument
/// when a GP's input dimension is not X's or tolerance < 0. Thread-safe (reads the GPs).
std::vector<int> greedy_variance_subset(const Eigen::MatrixXd& X, const std::vector<Gp>& gps,
                                        int m, double tolerance = 1e-9);

/// greedy_variance_subset for the subset of Gp::set_variance_pairs: X holds 2 n rows, row n + i
/// the image of row i (i < n) under a map that leaves the GPs' kernels unchanged (the reflected
/// transitions, model::ReflectedPairs). Each step chooses the row i < n whose latent variance plus
/// its image's (given the rows chosen so far, in units of each GP's signal variance, summed over
/// the GPs) is the largest (ties: the lowest row) and adds both. It stops at h pairs, or earlier
/// when no pair's exceeds 2 x `tolerance` per GP on average. Returns the increasing indices
/// i < n of the chosen pairs (the rows i and n + i); every i < n when h <= 0 or n <= h.
/// O(G n h^2) time, O(G n h) memory. Throws InvalidArgument when X has an odd number of rows, a
/// GP's input dimension is not X's, or tolerance < 0. Thread-safe (reads the GPs).
std::vector<int> greedy_variance_pairs(const Eigen::MatrixXd& X, const std::vector<Gp>& gps,
                                       int h, double tolerance = 1e-9);

}  // namespace drops::gp
