// Sparse GP regression with the collapsed variational bound of Titsias (2009): factorisation,
// bound, analytic gradient, predictions; greedy inducing-input selection (Burt et al. 2020).
//
// The gradient. With K = K_uu (jitter included), U = K_uf, s = sigma_n^2, P = U U^T, b = U y,
// Sigma = K + P / s, v = Sigma^-1 b and the matrix inversion lemma,
//   F = -N/2 log 2 pi - 1/2 log|Sigma| + 1/2 log|K| - N/2 log s - y^T y / (2 s)
//       + b^T Sigma^-1 b / (2 s^2) - sum_i k(x_i, x_i) / (2 s) + tr(K^-1 P) / (2 s).
// Differentiating in K, U and s with the others fixed (dF = tr(G^T dM) for a matrix M):
//   G_K = 1/2 K^-1 - K^-1 P K^-1 / (2 s) - 1/2 Sigma^-1 - v v^T / (2 s^2),
//   G_P = (K^-1 - Sigma^-1) / (2 s) - v v^T / (2 s^3),   G_U = 2 G_P U + v y^T / s^2,
//   dF/ds = tr(Sigma^-1 P) / (2 s^2) + v^T P v / (2 s^4) - N / (2 s) + y^T y / (2 s^2)
//           - b^T v / s^3 + sum_i k(x_i, x_i) / (2 s^2) - tr(K^-1 P) / (2 s^2).
// In terms of the factors: K^-1 = L^-T L^-1, Sigma^-1 = L^-T B^-1 L^-1, K^-1 P K^-1 =
// s L^-T A A^T L^-1, tr(K^-1 P) = s tr(A A^T), tr(Sigma^-1 P) = s tr(B^-1 A A^T) and
// v = sigma_n L^-T B^-1 A y. The SE-ARD kernel then gives, with a = z_d / l_d, c = x_d / l_d,
//   dF/dlog l_d = sum_ij (G_K o K)_ij (a_i - a_j)^2 + sum_ij (G_U o U)_ij (a_i - c_j)^2,
//   dF/dlog sigma_f = 2 sum(G_K o K) + 2 sum(G_U o U) - N sigma_f^2 / s   (the jitter scales
//   with sigma_f^2, so K's derivative is 2 K),   dF/dlog sigma_n = 2 s dF/ds.
#include "drops/gp/sparse_gp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>

#include "drops/core/errors.hpp"
#include "rprop_loop.hpp"

namespace drops::gp {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kDefaultNoiseVariance = 0.01;  // as Gp (settings.md §3)
constexpr int kJitterRetries = 6;

// sf2 exp(-|a - b|^2 / 2) between the rows of As (n x D) and Bs (m x D), already centred and
// divided by the length scales; n x m.
MatrixXd se_gram(const MatrixXd& As, const MatrixXd& Bs, double sf2) {
  MatrixXd K(As.rows(), Bs.rows());
  K.noalias() = -2.0 * As * Bs.transpose();
  K.colwise() += As.rowwise().squaredNorm();
  K.rowwise() += Bs.rowwise().squaredNorm().transpose();
  return (K.array().max(0.0) * -0.5).exp().matrix() * sf2;
}

// Lower Cholesky factor of M (in place); false when it fails or is not strictly positive.
bool cholesky(MatrixXd& M) {
  Eigen::LLT<Eigen::Ref<MatrixXd>, Eigen::Lower> llt(M);
  if (llt.info() != Eigen::Success || !M.diagonal().allFinite() ||
      !(M.diagonal().array() > 0.0).all())
    return false;
  M.triangularView<Eigen::StrictlyUpper>().setZero();
  return true;
}

// L^-1 for a lower-triangular L.
MatrixXd lower_inverse(const MatrixXd& L) {
  MatrixXd I = MatrixXd::Identity(L.rows(), L.cols());
  L.triangularView<Eigen::Lower>().solveInPlace(I);
  return I;
}

template <typename Derived>
void check_finite(const Eigen::DenseBase<Derived>& m, const std::string& what) {
  if (!m.allFinite()) throw InvalidArgument(what + ": expected finite values");
}

}  // namespace

bool SparseGpOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (inducing_points < 1)
    return fail("inducing_points: expected >= 1, got " + std::to_string(inducing_points));
  if (!(std::isfinite(jitter) && jitter >= 0.0))
    return fail("jitter: expected a finite value >= 0, got " + std::to_string(jitter));
  if (!(std::isfinite(selection_tolerance) && selection_tolerance >= 0.0))
    return fail("selection_tolerance: expected a finite value >= 0, got " +
                std::to_string(selection_tolerance));
  if (why) why->clear();
  return true;
}

std::vector<int> greedy_inducing_rows(const Eigen::MatrixXd& X, const SquaredExpArd& kernel, int m,
                                      double tolerance) {
  if (m < 1)
    throw InvalidArgument("greedy_inducing_rows: m: expected >= 1, got " + std::to_string(m));
  if (!(tolerance >= 0.0))
    throw InvalidArgument("greedy_inducing_rows: tolerance: expected >= 0, got " +
                          std::to_string(tolerance));
  check_size("greedy_inducing_rows: X columns (kernel input dimension)", kernel.input_dim(),
             X.cols());
  const Index N = X.rows();
  std::vector<int> out;
  if (N <= m) {
    for (Index i = 0; i < N; ++i) out.push_back(static_cast<int>(i));
    return out;
  }
  const double sf2 = kernel.signal_variance;
  const MatrixXd Xs = (X.rowwise() - X.colwise().mean()).array().rowwise() /
                      kernel.length_scales.transpose().array();
  MatrixXd F(N, m);  // columns of the pivoted Cholesky factor of K_ff
  VectorXd var = VectorXd::Constant(N, sf2);
  std::vector<char> chosen(static_cast<std::size_t>(N), 0);
  for (int k = 0; k < m; ++k) {
    Index best = -1;
    for (Index i = 0; i < N; ++i)
      if (!chosen[static_cast<std::size_t>(i)] && (best < 0 || var[i] > var[best])) best = i;
    if (best < 0 || !(var[best] > tolerance * sf2)) break;
    VectorXd col = se_gram(Xs, Xs.row(best), sf2);
    if (k > 0) col.noalias() -= F.leftCols(k) * F.row(best).head(k).transpose();
    const double pivot = var[best];
    F.col(k) = col / std::sqrt(pivot);
    var -= F.col(k).cwiseAbs2();
    var = var.cwiseMax(0.0);
    chosen[static_cast<std::size_t>(best)] = 1;
    out.push_back(static_cast<int>(best));
  }
  std::sort(out.begin(), out.end());
  return out;
}

SparseGp::SparseGp(int input_dim, const SparseGpOptions& options)
    : input_dim_(input_dim),
      options_(options),
      kernel_(input_dim > 0 ? input_dim : 0),
      log_sigma_n_(0.5 * std::log(kDefaultNoiseVariance)) {
  if (input_dim < 1)
    throw InvalidArgument("SparseGp: input dimension: expected >= 1, got " +
                          std::to_string(input_dim));
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("SparseGp: invalid options: " + why);
  h_ = VectorXd::Zero(input_dim + 2);
  h_[input_dim + 1] = log_sigma_n_;
}

double SparseGp::noise_variance() const { return std::exp(2.0 * log_sigma_n_); }

void SparseGp::set_h_params(const Eigen::VectorXd& h) {
  check_size("SparseGp::set_h_params: h (D + 2)", h_.size(), h.size());
  for (Index i = 0; i < h.size(); ++i) {
    const double v = std::exp(2.0 * h[i]);
    if (!std::isfinite(h[i]) || !std::isfinite(v) || !std::isnormal(v)) {
      std::ostringstream os;
      os << "SparseGp::set_h_params: h[" << i
         << "]: expected a finite log value with finite, non-zero exp(2 h), got " << h[i];
      throw InvalidArgument(os.str());
    }
  }
  SquaredExpArd k = kernel_;
  k.set_h_params(h.head(input_dim_ + 1));
  if (X_.rows() > 0) factorise(k, h[input_dim_ + 1], X_, Z_, y_, rows_);
  kernel_ = k;
  log_sigma_n_ = h[input_dim_ + 1];
  h_ = h;
}

void SparseGp::compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  check_size("SparseGp::compute: X columns (input dimension)", input_dim_, X.cols());
  if (X.rows() == 0) throw InvalidArgument("SparseGp::compute: X: expected N >= 1 rows, got 0");
  check_finite(X, "SparseGp::compute: X");
  std::vector<int> rows =
      greedy_inducing_rows(X, kernel_, options_.inducing_points, options_.selection_tolerance);
  MatrixXd Z(static_cast<Index>(rows.size()), X.cols());
  for (std::size_t r = 0; r < rows.size(); ++r) Z.row(static_cast<Index>(r)) = X.row(rows[r]);
  check_size("SparseGp::compute: y (one target per row of X)", X.rows(), y.size());
  check_finite(y, "SparseGp::compute: y");
  factorise(kernel_, log_sigma_n_, X, Z, y, std::move(rows));
}

void SparseGp::compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                       const Eigen::MatrixXd& Z) {
  check_size("SparseGp::compute: X columns (input dimension)", input_dim_, X.cols());
  check_size("SparseGp::compute: Z columns (input dimension)", input_dim_, Z.cols());
  check_size("SparseGp::compute: y (one target per row of X)", X.rows(), y.size());
  if (X.rows() == 0 || Z.rows() == 0)
    throw InvalidArgument("SparseGp::compute: expected N >= 1 inputs and M >= 1 inducing inputs");
  check_finite(X, "SparseGp::compute: X");
  check_finite(Z, "SparseGp::compute: Z");
  check_finite(y, "SparseGp::compute: y");
  factorise(kernel_, log_sigma_n_, X, Z, y, {});
}

void SparseGp::factorise(const SquaredExpArd& kernel, double log_sigma_n, const Eigen::MatrixXd& X,
                         const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                         std::vector<int> rows) {
  const double sf2 = kernel.signal_variance;
  const double sn = std::exp(log_sigma_n);
  const Eigen::RowVectorXd mu = X.colwise().mean();
  const Eigen::RowVectorXd inv_l = kernel.length_scales.cwiseInverse().transpose();
  MatrixXd Xs = (X.rowwise() - mu).array().rowwise() * inv_l.array();
  MatrixXd Zs = (Z.rowwise() - mu).array().rowwise() * inv_l.array();
  MatrixXd Kuu = se_gram(Zs, Zs, sf2);
  Kuu.diagonal().setConstant(sf2);
  MatrixXd Kuf = se_gram(Zs, Xs, sf2);
  const Index M = Z.rows();

  MatrixXd L;
  double jitter = options_.jitter * sf2;
  bool ok = false;
  for (int k = -1; k < kJitterRetries && !ok; ++k) {
    if (k >= 0)
      jitter = (options_.jitter > 0 ? options_.jitter : 1e-10) * sf2 * std::pow(10.0, k + 1);
    L = Kuu;
    L.diagonal().array() += jitter;
    ok = cholesky(L);
  }
  if (!ok) {
    std::ostringstream os;
    os << "SparseGp: Cholesky factorisation of K_uu failed for M = " << M
       << " inducing inputs (sigma_f^2 = " << sf2 << ", length scales "
       << kernel.length_scales.transpose() << ") even with a jitter of " << jitter
       << "; the inducing inputs are probably duplicated";
    throw NumericalError(os.str());
  }
  Kuu.diagonal().array() += jitter;
  MatrixXd A = Kuf / sn;
  L.triangularView<Eigen::Lower>().solveInPlace(A);
  MatrixXd LB = MatrixXd::Identity(M, M);
  LB.selfadjointView<Eigen::Lower>().rankUpdate(A);
  const double trace_aat = LB.diagonal().sum() - static_cast<double>(M);
  if (!cholesky(LB)) {
    std::ostringstream os;
    os << "SparseGp: Cholesky factorisation of I + A A^T failed (M = " << M << ", N = " << X.rows()
       << ", sigma_n^2 = " << sn * sn << "): the inputs or hyper-parameters are not finite";
    throw NumericalError(os.str());
  }
  MatrixXd Linv = lower_inverse(L);
  MatrixXd R = Linv;
  LB.triangularView<Eigen::Lower>().solveInPlace(R);

  // Commit.
  if (&X != &X_) X_ = X;
  if (&Z != &Z_) Z_ = Z;
  if (&y != &y_) y_ = y;
  if (&rows != &rows_) rows_ = std::move(rows);
  mu_ = mu;
  Xs_ = std::move(Xs);
  Zs_ = std::move(Zs);
  Kuu_ = std::move(Kuu);
  Kuf_ = std::move(Kuf);
  L_ = std::move(L);
  Linv_ = std::move(Linv);
  A_ = std::move(A);
  LB_ = std::move(LB);
  R_ = std::move(R);
  trace_aat_ = trace_aat;
  log_det_lb_ = LB_.diagonal().array().log().sum();
  jitter_ = jitter;
  kernel_ = kernel;
  log_sigma_n_ = log_sigma_n;  // h_ is set by the caller (exactly the h given, for resume)
  update_targets();
}

void SparseGp::update_targets() {
  const double sn = std::exp(log_sigma_n_);
  c_.noalias() = A_ * y_;
  c_ /= sn;
  LB_.triangularView<Eigen::Lower>().solveInPlace(c_);
  w_ = c_;
  LB_.triangularView<Eigen::Lower>().transpose().solveInPlace(w_);
  L_.triangularView<Eigen::Lower>().transpose().solveInPlace(w_);
}

void SparseGp::set_targets(const Eigen::VectorXd& y) {
  require_data("SparseGp::set_targets");
  check_size("SparseGp::set_targets: y (one target per training point)", X_.rows(), y.size());
  check_finite(y, "SparseGp::set_targets: y");
  y_ = y;
  update_targets();
}

void SparseGp::require_data(const char* where) const {
  if (X_.rows() == 0)
    throw InvalidArgument(std::string(where) + ": no training data (call compute first)");
}

double SparseGp::log_marginal_likelihood() const {
  require_data("SparseGp::log_marginal_likelihood");
  const auto n = static_cast<double>(X_.rows());
  const double s = noise_variance();
  return -0.5 * n * std::log(2.0 * std::numbers::pi) - log_det_lb_ - n * log_sigma_n_ -
         0.5 * y_.squaredNorm() / s + 0.5 * c_.squaredNorm() -
         0.5 * n * kernel_.signal_variance / s + 0.5 * trace_aat_;
}

Eigen::VectorXd SparseGp::log_marginal_likelihood_gradient() const {
  require_data("SparseGp::log_marginal_likelihood_gradient");
  const Index M = Z_.rows(), N = X_.rows(), D = input_dim_;
  const double s = noise_variance();
  const double sf2 = kernel_.signal_variance;
  const MatrixXd LBinv = lower_inverse(LB_);
  MatrixXd Binv(M, M);
  Binv.noalias() = LBinv.transpose() * LBinv;
  MatrixXd AAT = MatrixXd::Zero(M, M);
  AAT.selfadjointView<Eigen::Lower>().rankUpdate(A_);
  AAT.triangularView<Eigen::StrictlyUpper>() = AAT.transpose();
  // v = Sigma^-1 b with b = U y = sigma_n L A y and Sigma^-1 = L^-T B^-1 L^-1:
  // v = sigma_n L^-T B^-1 A y = s w, w = L^-T LB^-T c the mean weights.
  const VectorXd v = s * w_;
  const VectorXd Utv = Kuf_.transpose() * v;  // U^T v (N)
  // G_K = 1/2 L^-T (I - A A^T - B^-1) L^-1 - v v^T / (2 s^2).
  MatrixXd inner = -AAT - Binv;
  inner.diagonal().array() += 1.0;
  MatrixXd GK = 0.5 * Linv_.transpose() * inner * Linv_;
  GK.noalias() -= (0.5 / (s * s)) * v * v.transpose();
  // G_P = L^-T (I - B^-1) L^-1 / (2 s) - v v^T / (2 s^3);  G_U = 2 G_P U + v y^T / s^2.
  MatrixXd ib = -Binv;
  ib.diagonal().array() += 1.0;
  MatrixXd GP = (0.5 / s) * Linv_.transpose() * ib * Linv_;
  GP.noalias() -= (0.5 / (s * s * s)) * v * v.transpose();
  MatrixXd GU(M, N);
  GU.noalias() = 2.0 * GP * Kuf_;
  GU.noalias() += (1.0 / (s * s)) * v * y_.transpose();
  // dF/ds.
  const double tr_binv_aat = (Binv.cwiseProduct(AAT)).sum();
  const double vPv = Utv.squaredNorm();
  const double btv = y_.dot(Utv);
  const double dFds = 0.5 * tr_binv_aat / s + 0.5 * vPv / (s * s * s * s) -
                      0.5 * static_cast<double>(N) / s + 0.5 * y_.squaredNorm() / (s * s) -
                      btv / (s * s * s) + 0.5 * static_cast<double>(N) * sf2 / (s * s) -
                      0.5 * trace_aat_ / s;
  // Kernel hyper-parameters.
  const MatrixXd WK = GK.cwiseProduct(Kuu_);  // includes the jitter (scales with sigma_f^2)
  MatrixXd WKl = WK;                          // without it for the length scales (no effect
  WKl.diagonal().setZero();                   // there: (a_i - a_i)^2 = 0)
  const MatrixXd WU = GU.cwiseProduct(Kuf_);
  VectorXd g(D + 2);
  const VectorXd rk = WKl.rowwise().sum();
  const VectorXd ru = WU.rowwise().sum();
  const VectorXd cu = WU.colwise().sum().transpose();
  for (Index d = 0; d < D; ++d) {
    const auto a = Zs_.col(d);
    const auto c = Xs_.col(d);
    const double sym = 2.0 * (a.array().square() * rk.array()).sum() - 2.0 * a.dot(WKl * a);
    const double cross = (a.array().square() * ru.array()).sum() +
                         (c.array().square() * cu.array()).sum() - 2.0 * a.dot(WU * c);
    g[d] = sym + cross;
  }
  g[D] = 2.0 * WK.sum() + 2.0 * WU.sum() - static_cast<double>(N) * sf2 / s;
  g[D + 1] = 2.0 * s * dFds;
  return g;
}

RpropSummary SparseGp::optimize_h_params(const RpropOptions& options, RpropState* state) {
  std::string why;
  if (!options.IsValid(&why))
    throw InvalidArgument("SparseGp::optimize_h_params: invalid RpropOptions: " + why);
  require_data("SparseGp::optimize_h_params");
  if (state != nullptr && state->started && state->h.size() != h_.size())
    throw InvalidArgument("SparseGp::optimize_h_params: state: expected " +
                          std::to_string(h_.size()) + " hyper-parameters, got " +
                          std::to_string(state->h.size()));
  detail::RpropTarget target;
  auto apply = [this](const Eigen::VectorXd& h) {
    SquaredExpArd k = kernel_;
    k.set_h_params(h.head(input_dim_ + 1));
    factorise(k, h[input_dim_ + 1], X_, Z_, y_, rows_);
    h_ = h;
  };
  target.apply = apply;
  target.keep = apply;
  target.evaluate = [this](Eigen::VectorXd& grad) {
    grad = log_marginal_likelihood_gradient();
    return log_marginal_likelihood();
  };
  target.value = [this] { return log_marginal_likelihood(); };
  return detail::run_irprop(options, X_, h_, state, target);
}

void SparseGp::predict(const Eigen::VectorXd& x, double& mean, double& variance) const {
  check_size("SparseGp::predict: x (input dimension)", input_dim_, x.size());
  thread_local Eigen::MatrixXd q;
  thread_local Eigen::VectorXd m, v;
  q = x.transpose();
  predict_batch(q, m, v);
  mean = m[0];
  variance = v[0];
}

void SparseGp::predict_batch(const Eigen::MatrixXd& Xq, Eigen::VectorXd& mean,
                             Eigen::VectorXd& variance) const {
  check_size("SparseGp::predict_batch: Xq columns (input dimension)", input_dim_, Xq.cols());
  require_data("SparseGp::predict_batch");
  const Index B = Xq.rows();
  const double sf2 = kernel_.signal_variance;
  thread_local MatrixXd Qs, Ks, T1, T2;
  Qs = (Xq.rowwise() - mu_).array().rowwise() / kernel_.length_scales.transpose().array();
  Ks = se_gram(Zs_, Qs, sf2);  // M x B
  mean.noalias() = Ks.transpose() * w_;
  T1.noalias() = Linv_.triangularView<Eigen::Lower>() * Ks;
  T2.noalias() = R_.triangularView<Eigen::Lower>() * Ks;
  variance = (sf2 - T1.colwise().squaredNorm().transpose().array() +
              T2.colwise().squaredNorm().transpose().array())
                 .max(0.0)
                 .matrix();
  (void)B;
}

}  // namespace drops::gp
