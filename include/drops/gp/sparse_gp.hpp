#pragma once
/// \file Sparse Gaussian-process regression with inducing inputs: the variational free energy
/// (VFE) bound of Titsias (2009), "Variational learning of inducing variables in sparse Gaussian
/// processes", AISTATS, eq. 9 (the collapsed bound), for thousands of training points.
///
/// Why VFE and not FITC (Snelson & Ghahramani 2006): VFE's objective is a lower bound on the exact
/// log marginal likelihood, so adding inducing inputs never makes the fit worse, the
/// hyper-parameters it learns converge to the exact GP's as M grows (with Z = X the bound *is*
/// log p(y | X, h)), and it does not underestimate the noise as FITC's heteroscedastic
/// approximation does (Bauer, van der Wilk & Rasmussen 2016, "Understanding probabilistic sparse
/// Gaussian process approximations"). GP-MI compares phi by the GPs' likelihood: a bound that
/// is tight where the data are explained is what it needs.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "drops/gp/gp.hpp"
#include "drops/gp/kernel.hpp"

namespace drops::gp {

/// Options of SparseGp.
struct SparseGpOptions {
  /// M, the number of inducing inputs (>= 1), chosen among the training inputs by
  /// greedy_inducing_rows when compute() is given no inducing inputs. With M >= N every training
  /// input is one (the exact GP's likelihood and predictions, up to round-off and the jitter).
  int inducing_points = 256;
  /// Jitter added to the diagonal of K_uu, relative to sigma_f^2 (>= 0): K_uu + jitter sigma_f^2 I
  /// is factorised. When that Cholesky fails it is retried with 10, 100, ... times the jitter
  /// (1e-10 sigma_f^2 as the base when jitter is 0), 6 times at most. Part of the model: the bound
  /// and the predictions use the jittered K_uu, and its gradient includes it.
  double jitter = 1e-8;
  /// greedy_inducing_rows stops before M inputs once no training input's latent variance given the
  /// inputs chosen exceeds selection_tolerance sigma_f^2 (>= 0): every training input is then
  /// explained to that level, and a duplicated input is never chosen twice.
  double selection_tolerance = 1e-6;
  /// Returns true when every field is in range; otherwise false and, if why != nullptr, the reason.
  bool IsValid(std::string* why) const;
};

/// The rows of X (N x D) to use as inducing inputs for `kernel`: greedy selection by the latent
/// variance given the rows chosen so far (a pivoted Cholesky factorisation of K_ff, without
/// noise: Burt, Rasmussen & van der Wilk 2020, "Convergence of sparse variational inference in
/// Gaussian process regression", JMLR, §6 greedy conditional-variance initialisation; Fine &
/// Scheinberg 2001). Each step adds the row with the largest variance (ties: the lowest row);
/// it stops at m rows or when no row's variance exceeds tolerance k(x, x). Deterministic (no
/// random stream). Returns increasing row indices; every row when m >= N. O(N m (m + D)) time,
/// O(N m) memory. Throws InvalidArgument when m < 1, tolerance < 0 or X.cols() differs from the
/// kernel's input dimension. Thread-safe.
std::vector<int> greedy_inducing_rows(const Eigen::MatrixXd& X, const SquaredExpArd& kernel, int m,
                                      double tolerance);

/// Scalar-output sparse GP regression (VFE; see the file comment) with the squared-exponential
/// ARD kernel, zero mean on its targets, with the hyper-parameter protocol of Gp:
///   h = [log l_1 .. log l_D, log sigma_f, log sigma_n]  (dim D + 2),
/// defaults l = 1, sigma_f^2 = 1, sigma_n^2 = 0.01. With u = f(Z) at M inducing inputs Z and
/// Q_ff = K_fu K_uu^-1 K_uf, it maximises the bound (Titsias 2009, eq. 9)
///   F(h) = log N(y | 0, Q_ff + sigma_n^2 I) - tr(K_ff - Q_ff) / (2 sigma_n^2)  <=  log p(y | X, h)
/// and predicts with the optimal q(u) (Titsias 2009, eq. 10-11):
///   mean(x) = k_u(x)^T Sigma^-1 K_uf y / sigma_n^2,
///   var(x)  = k(x, x) - k_u^T K_uu^-1 k_u + k_u^T Sigma^-1 k_u,   Sigma = K_uu + K_uf K_fu /
///   sigma_n^2,
/// in the Q_ff-free form: L = chol(K_uu), A = L^-1 K_uf / sigma_n, B = I + A A^T = L_B L_B^T
/// (GPflow's SGPR). Costs: compute() O(N M^2 + M^3), the bound O(N) after it, its gradient
/// O(N M^2 + M^3), a prediction O(M D + M^2). Memory O(N M).
///
/// Usage: compute(X, y) (inducing inputs chosen from X with the current kernel), optionally
/// optimize_h_params() (Z fixed), and compute(X, y) again to choose Z for the fitted kernel;
/// then predict(). After compute(), every const member is thread-safe.
class SparseGp {
 public:
  /// Sparse GP on inputs of dimension input_dim (>= 1). Throws InvalidArgument when input_dim < 1
  /// or options are invalid.
  explicit SparseGp(int input_dim = 1, const SparseGpOptions& options = {});

  int input_dim() const { return input_dim_; }
  /// N, the number of training points.
  int size() const { return static_cast<int>(X_.rows()); }
  /// M actually used (<= options().inducing_points; 0 before compute()).
  int inducing_size() const { return static_cast<int>(Z_.rows()); }
  const SparseGpOptions& options() const { return options_; }

  /// h (dim D + 2, log space; see the class comment), exactly as last set.
  Eigen::VectorXd h_params() const { return h_; }
  /// Sets h (dim D + 2, finite, |h_i| small enough that exp(2 h_i) is a normal double); if data is
  /// present, refactorises with the same inducing inputs. Throws InvalidArgument on a bad h,
  /// NumericalError when the factorisation fails (the GP is then unchanged).
  void set_h_params(const Eigen::VectorXd& h);
  const SquaredExpArd& kernel() const { return kernel_; }
  /// sigma_n^2 = exp(2 h[D + 1]).
  double noise_variance() const;

  /// Stores X (N x D, one input per row; N >= 1) and y (dim N), chooses the inducing inputs among
  /// the rows of X by greedy_inducing_rows with the current kernel, options().inducing_points and
  /// options().selection_tolerance, and factorises. Throws InvalidArgument on size mismatch,
  /// N = 0 or non-finite data; NumericalError when K_uu or B cannot be factorised (jitter
  /// retries: SparseGpOptions::jitter). On any throw the GP keeps its previous state.
  void compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
  /// As compute(X, y) with the inducing inputs Z (M x D, M >= 1, finite) given.
  void compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Eigen::MatrixXd& Z);
  /// Replaces the targets (dim N, finite) keeping X, Z and h: O(N M). Throws InvalidArgument on a
  /// size mismatch or non-finite values.
  void set_targets(const Eigen::VectorXd& y);

  /// The inducing inputs Z (M x D).
  const Eigen::MatrixXd& inducing_inputs() const { return Z_; }
  /// The rows of X that are the inducing inputs (increasing), empty when Z was given.
  const std::vector<int>& inducing_rows() const { return rows_; }

  /// The VFE bound F(h) (see the class comment; the name follows Gp's for generic code): <= the
  /// exact GP's log marginal likelihood for any Z, equal to it when Z = X (up to the jitter).
  /// O(N). Throws InvalidArgument before compute().
  double log_marginal_likelihood() const;
  /// dF/dh (dim D + 2), analytic (chain rule through K_uu, K_uf, diag K_ff and sigma_n^2; the
  /// derivation is in src/gp/sparse_gp.cpp). Z is held fixed. O(N M^2 + M^3). Throws
  /// InvalidArgument before compute().
  Eigen::VectorXd log_marginal_likelihood_gradient() const;
  /// Maximises F over h with iRprop- (the loop, box, soft walls and stopping rules of
  /// Gp::optimize_h_params), Z fixed, from the current h. On return h is the best iterate and the
  /// GP is refactorised with it. Throws InvalidArgument on invalid options or before compute().
  /// Not thread-safe.
  RpropSummary optimize_h_params(const RpropOptions& options = {}, RpropState* state = nullptr);

  /// Predictive mean and latent variance (without noise, clamped at >= 0) at x (dim D;
  /// InvalidArgument otherwise). Thread-safe.
  void predict(const Eigen::VectorXd& x, double& mean, double& variance) const;
  /// Batched: Xq B x D; mean and variance resized to B. Throws InvalidArgument when Xq.cols() != D.
  /// Thread-safe (per-thread scratch).
  void predict_batch(const Eigen::MatrixXd& Xq, Eigen::VectorXd& mean,
                     Eigen::VectorXd& variance) const;

 private:
  // Everything below is consistent with (kernel_, log_sigma_n_, X_, Z_, y_) after compute().
  int input_dim_;
  SparseGpOptions options_;
  SquaredExpArd kernel_;
  double log_sigma_n_;
  Eigen::VectorXd h_;
  Eigen::MatrixXd X_, Z_;    // N x D, M x D
  std::vector<int> rows_;    // Z's rows in X (when chosen from it)
  Eigen::RowVectorXd mu_;    // D, column means of X (centring)
  Eigen::MatrixXd Xs_, Zs_;  // centred inputs divided by the length scales
  Eigen::VectorXd y_;
  Eigen::MatrixXd Kuu_;      // M x M, with the jitter on the diagonal
  Eigen::MatrixXd Kuf_;      // M x N
  Eigen::MatrixXd L_;        // M x M lower: chol(Kuu_)
  Eigen::MatrixXd Linv_;     // M x M lower: L^-1
  Eigen::MatrixXd A_;        // M x N: L^-1 K_uf / sigma_n
  Eigen::MatrixXd LB_;       // M x M lower: chol(I + A A^T)
  Eigen::MatrixXd R_;        // M x M lower: LB^-1 L^-1 (predictive variance)
  double trace_aat_ = 0.0;   // tr(A A^T)
  double log_det_lb_ = 0.0;  // sum log diag LB
  double jitter_ = 0.0;      // absolute jitter on K_uu's diagonal
  Eigen::VectorXd c_;        // M: LB^-1 A y / sigma_n
  Eigen::VectorXd w_;        // M: L^-T LB^-T c (predictive mean weights)

  void factorise(const SquaredExpArd& kernel, double log_sigma_n, const Eigen::MatrixXd& X,
                 const Eigen::MatrixXd& Z, const Eigen::VectorXd& y, std::vector<int> rows);
  void update_targets();
  void require_data(const char* where) const;
};

}  // namespace drops::gp
