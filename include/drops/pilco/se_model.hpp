#pragma once
/// \file Exact moment matching through sums of squared-exponential (SE) "centre" sets: a GP with
/// SE-ARD kernels and E outputs (PILCO's gp0), its posterior mean alone (an RBF network, gp2), and
/// PILCO with priors (an RBF-network prior mean plus a residual GP, baselines.md §2a).

#include <Eigen/Core>
#include <vector>

#include "drops/gp/gp.hpp"
#include "drops/pilco/moments.hpp"

namespace drops::pilco {

/// One set of n SE centres with its own length scales and signal variance. It adds
///   f_B(x) = sum_i w_i alpha^2 exp(-1/2 (x - c_i)^T Lambda^-1 (x - c_i)),  Lambda = diag(l^2),
/// to its output. A GP posterior mean is such a block with c = training inputs and w = beta =
/// (K + sigma_eps^2 I)^-1 y; the prior mean of PILCO with priors is another (c = simulator data,
/// w = gamma). When `gp_variance` is set, the block is a GP posterior whose uncertainty enters the
/// predictive covariance: it adds alpha^2 - tr(k_inverse Q) to its output's variance
/// (Deisenroth 2010, eq. 2.55; gp0.m), the variance of the latent function without noise.
/// Value type.
struct SeBlock {
  Eigen::MatrixXd centres;        ///< c: n x D, one centre per row (n may be 0)
  Eigen::VectorXd weights;        ///< w: n
  Eigen::VectorXd length_scales;  ///< l: D, > 0, in the units of the inputs
  double signal_variance = 1.0;   ///< alpha^2 > 0
  bool gp_variance = false;       ///< whether this block contributes alpha^2 - tr(K^-1 Q)
  /// (K + sigma_eps^2 I)^-1 (n x n, symmetric) when gp_variance; ignored otherwise.
  Eigen::MatrixXd k_inverse;
};

/// One output of an SeModel: the sum of its blocks (e.g. [GP] for PILCO, [prior mean, residual GP]
/// for PILCO with priors).
struct SeOutput {
  std::vector<SeBlock> blocks;
};

/// E outputs on a shared input of dimension D. Output a is f_a(x) = sum over its blocks of f_B(x);
/// outputs are independent given x (one GP per output), as in PILCO. Value type.
struct SeModel {
  int input_dim = 0;              ///< D >= 1
  std::vector<SeOutput> outputs;  ///< E >= 1 outputs
  /// Number of outputs E.
  int output_dim() const { return static_cast<int>(outputs.size()); }
  /// Throws InvalidArgument ("expected X, got Y") when a block's sizes do not match D, its weights,
  /// its length scales or signal variance are not > 0 and finite, or k_inverse is not n x n for a
  /// gp_variance block. Cost O(total size).
  void validate() const;
};

/// The GP posterior of `gp` as a block with variance: c = training inputs, w = alpha, l and
/// alpha^2 = sigma_f^2 from its kernel, k_inverse = (K + sigma_n^2 I)^-1 (O(N^3)). A GP without
/// data gives a block with no centres whose variance is sigma_f^2. Thread-safe (const on gp).
SeBlock gp_block(const gp::Gp& gp);
/// The posterior mean of `gp` only, as an RBF-network block (no variance; PILCO with priors' prior
/// mean m(x) = sum_j gamma_j k(x, x_j), baselines.md §2a). Thread-safe.
SeBlock gp_mean_block(const gp::Gp& gp);
/// PILCO's dynamics model: output a is gp_block(gps[a]). All GPs must have the same input dimension
/// (InvalidArgument otherwise, or if gps is empty).
SeModel gp_model(const std::vector<gp::Gp>& gps);
/// PILCO with priors' model (baselines.md §2a): output a is [gp_mean_block(prior[a]),
/// gp_block(residual[a])], i.e. the simulator GP's mean plus a GP on the residuals r_a = dx_a -
/// m_a(x). Only the residual GP contributes the variance term. Throws InvalidArgument when the
/// sizes differ or an input dimension does not match.
SeModel gp_model_with_prior_mean(const std::vector<gp::Gp>& prior,
                                 const std::vector<gp::Gp>& residual);

/// The FITC sparse GP (Snelson & Ghahramani 2006, "fully independent training conditional"; PILCO's
/// gp1 beyond 300 points, baselines.md §1a) of an SE-ARD GP on data (X, y) with inducing inputs Z,
/// as a block with variance: with Kmm = K(Z, Z) + jitter sigma_f^2 I, Kmn = K(Z, X),
/// Lambda = diag(k(x_i, x_i) - [Knm Kmm^-1 Kmn]_ii) + sigma_n^2 I and
/// Sigma_m = (Kmm + Kmn Lambda^-1 Knm)^-1, the predictive mean is k(x, Z) w with
/// w = Sigma_m Kmn Lambda^-1 y and the latent variance is sigma_f^2 - k(x, Z)^T (Kmm^-1 - Sigma_m)
/// k(x, Z), so c = Z, weights = w, k_inverse = Kmm^-1 - Sigma_m (M x M). With Z = X and no jitter
/// this is the full GP exactly. Centres are the M inducing inputs: moment matching costs O(M^2)
/// instead of O(N^2). X: N x D, y: N, Z: M x D (M >= 1), length_scales: D (> 0), signal and noise
/// variances > 0; jitter >= 0, relative to sigma_f^2 (PILCO's gp1 adds a ridge of 1e-6); a failed
/// Cholesky of Kmm is retried with 10x the jitter up to 1e-2, then NumericalError. Cost
/// O(N M^2 + M^3). Throws InvalidArgument on sizes or invalid values. Thread-safe (pure).
SeBlock fitc_block(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Eigen::MatrixXd& Z,
                   const Eigen::VectorXd& length_scales, double signal_variance,
                   double noise_variance, double jitter = 1e-6);

/// The deterministic part of a block at points X (N x D, one per row): f_B(x_i) =
/// sum_j w_j alpha^2 exp(-1/2 (x_i - c_j)^T Lambda^-1 (x_i - c_j)) (dim N); e.g. the prior mean
/// m(x) of PILCO with priors at the real data, to form the residual targets. Throws
/// InvalidArgument on sizes. Cost O(N n D). Thread-safe (pure).
Eigen::VectorXd block_values(const SeBlock& block, const Eigen::MatrixXd& X);

/// Exact moments of f(x) (dim E) for x ~ N(mu, Sigma) (dim D): mean M, covariance S (latent
/// function, no observation noise) and cross V = Sigma^-1 Cov[x, f] (D x E); with `derivatives`,
/// also dM/dmu, dM/dSigma, dS/dmu, dS/dSigma, dV/dmu, dV/dSigma (conventions: Moments).
/// Equations (Deisenroth 2010 §2.3; gp0.m; baselines.md §1a, §2a), for blocks A, B of outputs a, b:
///   q_i = alpha^2 |Sigma Lambda^-1 + I|^-1/2 exp(-1/2 nu_i^T (Sigma + Lambda)^-1 nu_i), nu_i = c_i
///   - mu M_a = sum_A w_A^T q_A,  V_a = sum_A (Sigma + Lambda_A)^-1 sum_i w_i q_i nu_i Q_ij =
///   k_A(c_i, mu) k_B(c_j, mu) |R|^-1/2 exp(1/2 z^T R^-1 Sigma z), R = Sigma (Lambda_A^-1 +
///          Lambda_B^-1) + I, z = Lambda_A^-1 nu_i + Lambda_B^-1 nu_j
///   S_ab = sum_AB w_A^T Q w_B - M_a M_b + delta_ab sum_{A gp_variance} (alpha_A^2 - tr(K_A^-1
///   Q_AA)).
/// Sigma only has to be positive semi-definite (Sigma = 0 gives the ordinary GP posterior).
/// Cost O(E^2 n^2 D) (and E(E+1)/2 n^2 exponentials) for the moments, the same order (larger
/// constant) for the derivatives; about 4.4 ms (moments) and 5.2 ms (with derivatives) on one
/// thread, 2.2 and 2.8 ms on two, for E = 4, n = 250, D = 7 (bench/bench_pilco.cpp). The output
/// pairs (and the outputs of the first moments) run in parallel through drops::parallel_for, each
/// summed in a fixed order: the same bits for any thread count. Keeps two n x n scratch matrices
/// per thread (largest block pair seen), reused by later calls.
/// Throws InvalidArgument on sizes (mu: D, Sigma: D x D, finite and symmetric to 1e-9 relative) or
/// an invalid model; NumericalError if Sigma is so indefinite that I + Lambda^-1/2 Sigma
/// Lambda^-1/2 is not positive definite. Thread-safe (pure function).
Moments se_moments(const SeModel& model, const Eigen::VectorXd& mu, const Eigen::MatrixXd& sigma,
                   bool derivatives = false);

}  // namespace drops::pilco
