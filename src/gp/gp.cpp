// Gaussian-process regression: factorisation, likelihood, analytic gradient and prediction
// (Rasmussen & Williams 2006, Algorithm 2.1 and eq. 5.8-5.9; paper eq. 3-6).
#include "drops/gp/gp.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <memory>
#include <vector>

#include <Eigen/Cholesky>

#include "drops/core/errors.hpp"
#include "predict_kernels.hpp"


namespace drops::gp {
namespace {


using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kDefaultNoiseVariance = 0.01;  // settings.md §3
constexpr int kJitterRetries = 6;               // jitter 1e-9 * 10^k, k = 0..5
constexpr double kJitterBase = 1e-9;

// Grows a thread-local scratch buffer to at least n doubles (never shrinks, so repeated calls on GPs
// of the same or smaller size do not allocate) and returns its start, aligned to 64 bytes. The
// alignment matters for reproducibility: Eigen's vectorised kernels peel a different number of
// leading elements for differently aligned data, which changes round-off, so without it results
// would depend on which thread's buffer a prediction used.
double* scratch(std::vector<double>& buf, std::size_t n) {
  constexpr std::size_t kAlign = 64 / sizeof(double);
  if (buf.size() < n + kAlign) buf.resize(n + kAlign);
  void* p = buf.data();
  std::size_t space = buf.size() * sizeof(double);
  return static_cast<double*>(std::align(64, n * sizeof(double), p, space));
}

// The N x N matrices of the fitting path (factorise, the likelihood's gradient), kept per thread
// between calls: Rprop factorises K at every iteration, and matrices of this size allocated afresh
// each time made the allocator return memory to the system and fault it back in (15 % of the time
// in page faults for a GP-MI search over 48 output GPs at N = 400). factorise() swaps its result with the GP's members,
// so the GP's previous matrices become the thread's buffers. Matrices larger than
// kMaxKeptEntries doubles are allocated per call and not kept.
struct FitWorkspace {
  MatrixXd kf;  // factorise: noise-free kernel matrix
  MatrixXd l;   // factorise: Cholesky factor
  MatrixXd w;   // gradient: W = alpha alpha^T - K^-1
  MatrixXd linv;  // gradient: L^-1
};
constexpr Index kMaxKeptEntries = Index{1} << 22;  // 32 MB per matrix

FitWorkspace& fit_workspace() {
  thread_local FitWorkspace ws;
  return ws;
}

// Takes the thread's buffer into m (resized to rows x cols) when it is small enough to be kept.
void take(MatrixXd& m, MatrixXd& kept, Index rows, Index cols) {
  if (rows * cols <= kMaxKeptEntries) m.swap(kept);
  m.resize(rows, cols);
}

// Gives m's storage back to the thread's buffer (m is left with the buffer's previous storage).
void give(MatrixXd& m, MatrixXd& kept) {
  if (m.size() <= kMaxKeptEntries) kept.swap(m);
}

// "where" of the first non-finite entry of m, for error messages.
template <typename Derived>
std::string first_non_finite(const Eigen::DenseBase<Derived>& m) {
  for (Index j = 0; j < m.cols(); ++j)
    for (Index i = 0; i < m.rows(); ++i)
      if (!std::isfinite(m(i, j))) {
        std::ostringstream os;
        os << "(" << i << ", " << j << ") = " << m(i, j);
        return os.str();
      }
  return "none";
}

#ifndef EIGEN_USE_LAPACKE
// In-place inverse of a lower-triangular matrix whose strict upper part is zero. Recursive blocking
// [A 0; B C]^-1 = [A^-1 0; -C^-1 B A^-1  C^-1] so that the work (n^3/3 flops) runs in triangular
// matrix products.
void invert_lower(Eigen::Ref<MatrixXd> A) {
  const Index n = A.rows();
  if (n <= 48) {
    MatrixXd I = MatrixXd::Identity(n, n);
    A.triangularView<Eigen::Lower>().solveInPlace(I);
    A = I;
    return;
  }
  const Index h = n / 2;
  invert_lower(A.topLeftCorner(h, h));
  invert_lower(A.bottomRightCorner(n - h, n - h));
  MatrixXd T = A.bottomLeftCorner(n - h, h) * A.topLeftCorner(h, h).triangularView<Eigen::Lower>();
  auto B = A.bottomLeftCorner(n - h, h);
  B.setZero();
  B.noalias() -= A.bottomRightCorner(n - h, n - h).triangularView<Eigen::Lower>() * T;
}
#endif

// The lower triangle of K^-1 = L^-T L^-1 into Kinv (n x n; its strict upper triangle is left
// unspecified) from the Cholesky factor in the lower triangle of L. With LAPACK (DROPS_BLAS, the
// default build): dpotri, the triangular inverse and the product of a triangular matrix with its
// transpose, 2n^3/3 flops. Without: the blocked triangular inverse above into work, then a
// symmetric rank-n update (4n^3/3 flops).
void lower_inverse_covariance(const MatrixXd& L, MatrixXd& Kinv, MatrixXd& work) {
  const Index n = L.rows();
  if (Kinv.rows() != n || Kinv.cols() != n) Kinv.resize(n, n);
#ifdef EIGEN_USE_LAPACKE
  (void)work;
  Kinv.triangularView<Eigen::Lower>() = L.triangularView<Eigen::Lower>();
  const lapack_int info = LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', static_cast<lapack_int>(n),
                                         Kinv.data(), static_cast<lapack_int>(n));
  if (info != 0) {
    throw NumericalError("Gp: LAPACK dpotri failed (info " + std::to_string(info) + ") for N = " +
                         std::to_string(n) + " on a Cholesky factor with a positive diagonal");
  }
#else
  if (work.rows() != n || work.cols() != n) work.resize(n, n);
  work = L.triangularView<Eigen::Lower>();
  invert_lower(work);
  Kinv.setZero();
  Kinv.selfadjointView<Eigen::Lower>().rankUpdate(work.transpose(), 1.0);
#endif
}

}  // namespace

Gp::Gp(int input_dim)
    : input_dim_(input_dim),
      kernel_(std::make_unique<SquaredExpArd>(input_dim > 0 ? input_dim : 0)),
      log_sigma_n_(0.5 * std::log(kDefaultNoiseVariance)) {
  if (input_dim < 1) {
    throw InvalidArgument("Gp: input dimension: expected >= 1, got " + std::to_string(input_dim));
  }
  bind_kernel();
  h_ = VectorXd::Zero(input_dim + 2);  // l = 1, sigma_f = 1
  h_[input_dim] = 0.5 * std::log(se_->signal_variance);
  h_[input_dim + 1] = log_sigma_n_;
}

Gp::Gp(const Kernel& kernel)
    : input_dim_(kernel.input_dim()),
      kernel_(kernel.clone()),
      log_sigma_n_(0.5 * std::log(kDefaultNoiseVariance)) {
  if (input_dim_ < 1) {
    throw InvalidArgument("Gp: kernel input dimension: expected >= 1, got " +
                          std::to_string(input_dim_));
  }
  bind_kernel();
  const VectorXd hk = kernel_->h_params();
  h_.resize(hk.size() + 1);
  h_.head(hk.size()) = hk;
  h_[hk.size()] = log_sigma_n_;
}

Gp::Gp(const Gp& o)
    : input_dim_(o.input_dim_),
      kernel_(o.kernel_->clone()),
      log_sigma_n_(o.log_sigma_n_),
      h_(o.h_),
      X_(o.X_),
      X_mean_(o.X_mean_),
      Xa_(o.Xa_),
      y_(o.y_),
      Kf_(o.Kf_),
      L_(o.L_),
      alpha_(o.alpha_),
      jitter_(o.jitter_),
      variance_points_(o.variance_points_),
      Lv_(o.Lv_),
      variance_pairs_(o.variance_pairs_),
      Lw_(o.Lw_) {
  bind_kernel();
}

Gp& Gp::operator=(const Gp& o) {
  if (this != &o) {
    Gp copy(o);
    *this = std::move(copy);
  }
  return *this;
}

Gp::~Gp() = default;

void Gp::bind_kernel() { se_ = dynamic_cast<const SquaredExpArd*>(kernel_.get()); }

int Gp::input_dim() const { return input_dim_; }
int Gp::size() const { return static_cast<int>(X_.rows()); }

Eigen::VectorXd Gp::h_params() const { return h_; }

void Gp::set_h_params(const Eigen::VectorXd& h) {
  check_size("Gp::set_h_params: h (kernel hyper-parameters + 1)", h_.size(), h.size());
  if (!h.allFinite()) {
    throw InvalidArgument("Gp::set_h_params: h: expected finite values, got non-finite entry " +
                          first_non_finite(h));
  }
  // exp(2 h) must stay a positive normal double: |h| < ~350.
  for (Index i = 0; i < h.size(); ++i) {
    const double v = std::exp(2.0 * h[i]);
    if (!std::isfinite(v) || !std::isnormal(v)) {
      std::ostringstream os;
      os << "Gp::set_h_params: h[" << i << "]: expected a log value with finite, non-zero exp(2 h), got "
         << h[i];
      throw InvalidArgument(os.str());
    }
  }
  apply_h(h);
}

void Gp::apply_h(const Eigen::VectorXd& h, bool subset) {
  const Index K = h.size() - 1;
  std::unique_ptr<Kernel> k = kernel_->clone();
  k->set_h_params(h.head(K));
  const double log_sn = h[K];
  if (X_.rows() == 0) {
    kernel_ = std::move(k);
    bind_kernel();
    log_sigma_n_ = log_sn;
  } else {
    factorise(std::move(k), log_sn, X_, y_, subset);  // throws with the GP unchanged
  }
  // h itself, not log(exp(h)): set_h_params(h_params()) must restore the GP bit for bit (resume).
  h_ = h;
}

const Kernel& Gp::kernel() const { return *kernel_; }
double Gp::noise_variance() const { return std::exp(2.0 * log_sigma_n_); }

void Gp::compute(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  check_size("Gp::compute: X columns (input dimension)", input_dim_, X.cols());
  check_size("Gp::compute: y (one target per row of X)", X.rows(), y.size());
  if (!X.allFinite()) {
    throw InvalidArgument("Gp::compute: X: expected finite values, got " + first_non_finite(X));
  }
  if (!y.allFinite()) {
    throw InvalidArgument("Gp::compute: y: expected finite values, got " + first_non_finite(y));
  }
  factorise(kernel_->clone(), log_sigma_n_, X, y);
}

void Gp::factorise(std::unique_ptr<Kernel> kernel_ptr, double log_sigma_n,
                   const Eigen::MatrixXd& X, const Eigen::VectorXd& y, bool subset) {
  const Kernel& kernel = *kernel_ptr;
  const auto* se = dynamic_cast<const SquaredExpArd*>(&kernel);
  const Index n = X.rows();
  const double sf2 = kernel.variance();
  const double sn2 = std::exp(2.0 * log_sigma_n);

  // Centred inputs: the kernels are translation invariant and centring limits the cancellation
  // in |a|^2 + |b|^2 - 2 a.b for inputs far from the origin.
  Eigen::RowVectorXd mu = n > 0 ? Eigen::RowVectorXd(X.colwise().mean())
                                : Eigen::RowVectorXd(Eigen::RowVectorXd::Zero(X.cols()));
  MatrixXd Xs;  // SE-ARD: scaled inputs
  VectorXd sq;
  FitWorkspace& ws = fit_workspace();
  MatrixXd Kf, L;
  take(Kf, ws.kf, n, n);
  take(L, ws.l, n, n);
  if (se) {
    Xs = ((X.rowwise() - mu).array().rowwise() / se->length_scales.transpose().array()).matrix();
    sq = Xs.rowwise().squaredNorm();
    if (n > 0) {
      // Squared distances |a|^2 + |b|^2 - 2 a.b (clamped at 0), then the kernel, in the lower
      // triangle; the upper is its mirror image (exactly symmetric).
      Kf.setZero();  // (the strict upper triangle is overwritten below)
      Kf.selfadjointView<Eigen::Lower>().rankUpdate(Xs);
      for (Index j = 0; j + 1 < n; ++j) {
        const Index m = n - j - 1;
        auto c = Kf.col(j).tail(m).array();
        c = ((((c * -2.0) + sq.tail(m).array()) + sq[j]).max(0.0) * -0.5).exp() * sf2;
      }
      Kf.triangularView<Eigen::StrictlyUpper>() = Kf.transpose();
      Kf.diagonal().setConstant(sf2);
    }
  } else if (n > 0) {
    const MatrixXd Xc = X.rowwise() - mu;
    Kf = kernel.gram(Xc, Xc);
    Kf.triangularView<Eigen::StrictlyUpper>() = Kf.transpose();
    Kf.diagonal().setConstant(sf2);
  }

  double jitter = 0.0;
  bool ok = (n == 0);
  for (int k = -1; k < kJitterRetries && !ok; ++k) {
    jitter = k < 0 ? 0.0 : kJitterBase * std::pow(10.0, k);
    L = Kf;
    L.diagonal().array() += sn2 + jitter;
    Eigen::LLT<Eigen::Ref<MatrixXd>, Eigen::Lower> llt(L);
    ok = llt.info() == Eigen::Success && L.diagonal().allFinite() &&
         (L.diagonal().array() > 0.0).all();
  }
  if (!ok) {
    give(Kf, ws.kf);
    give(L, ws.l);
    std::ostringstream os;
    os << "Gp: Cholesky factorisation of K + sigma_n^2 I failed for N = " << n
       << " points (sigma_f^2 = " << sf2 << ", sigma_n^2 = " << sn2
       << ", kernel " << kernel.name() << " h = " << kernel.h_params().transpose()
       << ") even with a diagonal jitter up to " << kJitterBase * std::pow(10.0, kJitterRetries - 1)
       << "; the inputs are probably duplicated with near-zero noise or the hyper-parameters are "
          "extreme";
    throw NumericalError(os.str());
  }

  MatrixXd Lv, Lw;
  if (subset && variance_points_ > 0 && variance_points_ <= n &&
      (variance_points_ < n || variance_pairs_ > 0)) {
    try {
      if (variance_pairs_ > 0)
        pair_factors(Kf, sn2 + jitter, variance_pairs_, Lv, Lw);
      else
        Lv = subset_factor(Kf, sn2 + jitter, variance_points_);
    } catch (...) {
      give(Kf, ws.kf);
      give(L, ws.l);
      throw;
    }
  }
  L.triangularView<Eigen::StrictlyUpper>() = L.transpose();  // rows of L contiguous (predict_batch)
  VectorXd alpha = y;
  if (n > 0) {
    L.triangularView<Eigen::Lower>().solveInPlace(alpha);
    L.triangularView<Eigen::Lower>().transpose().solveInPlace(alpha);
  }

  // Commit (nothing below throws except on allocation failure).
  kernel_ = std::move(kernel_ptr);
  bind_kernel();
  log_sigma_n_ = log_sigma_n;
  if (&X != &X_) X_ = X;
  if (&y != &y_) y_ = y;
  X_mean_ = std::move(mu);
  if (se_) {
    Xa_.resize(n, X.cols() + 2);
    Xa_.leftCols(X.cols()) = Xs;
    Xa_.col(X.cols()) = -0.5 * sq;
    Xa_.col(X.cols() + 1).setOnes();
  } else {
    Xa_.resize(0, 0);
  }
  Kf_.swap(Kf);
  L_.swap(L);
  give(Kf, ws.kf);  // the previous factorisation's storage, for the next call on this thread
  give(L, ws.l);
  alpha_ = std::move(alpha);
  jitter_ = jitter;
  Lv_ = std::move(Lv);
  Lw_ = std::move(Lw);
}

Eigen::MatrixXd Gp::subset_factor(const Eigen::MatrixXd& Kf, double diagonal, int m) {
  const Index n = Kf.rows();
  if (m <= 0 || m >= n) return MatrixXd();
  MatrixXd Lv = Kf.bottomRightCorner(m, m);
  Lv.diagonal().array() += diagonal;
  Eigen::LLT<Eigen::Ref<MatrixXd>, Eigen::Lower> llt(Lv);
  if (llt.info() != Eigen::Success || !Lv.diagonal().allFinite() ||
      !(Lv.diagonal().array() > 0.0).all()) {
    std::ostringstream os;
    os << "Gp: Cholesky factorisation of the last " << m << " of " << n
       << " points' K + sigma_n^2 I (set_variance_points) failed although the whole K's succeeded";
    throw NumericalError(os.str());
  }
  Lv.triangularView<Eigen::StrictlyUpper>() = Lv.transpose();
  return Lv;
}

void Gp::set_variance_points(int m) {
  if (m < 0) {
    throw InvalidArgument("Gp::set_variance_points: expected m >= 0 (0: every point), got " +
                          std::to_string(m));
  }
  MatrixXd Lv = subset_factor(Kf_, noise_variance() + jitter_, m);  // throws with the GP unchanged
  variance_points_ = m;
  variance_pairs_ = 0;
  Lv_ = std::move(Lv);
  Lw_.resize(0, 0);
}

void Gp::pair_factors(const Eigen::MatrixXd& Kf, double diagonal, int h, Eigen::MatrixXd& Lv,
                      Eigen::MatrixXd& Lw) {
  const Index n = Kf.rows();
  Lv.resize(0, 0);
  Lw.resize(0, 0);
  if (h <= 0 || 2 * static_cast<Index>(h) > n) return;
  const Index f = n - 2 * static_cast<Index>(h);
  // K of the last 2h points: [[A, B'], [B, A']]; mirror pairs make A' = A and B symmetric.
  const auto A = Kf.block(f, f, h, h);
  const auto A2 = Kf.block(f + h, f + h, h, h);
  const auto B = Kf.block(f + h, f, h, h);
  const double scale = std::max(Kf.diagonal().maxCoeff(), 0.0);
  const double mismatch =
      std::max((A2 - A).cwiseAbs().maxCoeff(), (B - B.transpose()).cwiseAbs().maxCoeff());
  if (!(mismatch <= 1e-8 * scale)) {
    std::ostringstream os;
    os << "Gp::set_variance_pairs: the last " << 2 * h << " of " << n
       << " points are not " << h << " points followed by their mirror images (their kernel "
       << "matrix is not [[A, B], [B, A]]: entries differ by " << mismatch << ", sigma_f^2 = "
       << scale << ")";
    throw InvalidArgument(os.str());
  }
  const MatrixXd Bs = 0.5 * (B + B.transpose());
  auto factor = [&](MatrixXd& out, double sign, const char* which) {
    out = A + sign * Bs;
    out.diagonal().array() += diagonal;
    Eigen::LLT<Eigen::Ref<MatrixXd>, Eigen::Lower> llt(out);
    if (llt.info() != Eigen::Success || !out.diagonal().allFinite() ||
        !(out.diagonal().array() > 0.0).all()) {
      std::ostringstream os;
      os << "Gp: Cholesky factorisation of the " << which << " block of the last " << 2 * h
         << " of " << n
         << " points' K + sigma_n^2 I (set_variance_pairs) failed although the whole K's succeeded";
      throw NumericalError(os.str());
    }
    out.triangularView<Eigen::StrictlyUpper>() = out.transpose();
  };
  factor(Lv, 1.0, "A + B");
  factor(Lw, -1.0, "A - B");
}

void Gp::set_variance_pairs(int h) {
  if (h < 0) {
    throw InvalidArgument("Gp::set_variance_pairs: expected h >= 0 (0: every point), got " +
                          std::to_string(h));
  }
  MatrixXd Lv, Lw;
  pair_factors(Kf_, noise_variance() + jitter_, h, Lv, Lw);  // throws with the GP unchanged
  variance_points_ = 2 * h;
  variance_pairs_ = h;
  Lv_ = std::move(Lv);
  Lw_ = std::move(Lw);
}

Index Gp::variance_first() const {
  if (Lv_.rows() == 0) return 0;
  return L_.rows() - (Lw_.rows() > 0 ? 2 * Lv_.rows() : Lv_.rows());
}

void Gp::variance_terms(Eigen::Ref<Eigen::MatrixXd> kv, Eigen::Ref<Eigen::VectorXd> ss) const {
  if (Lw_.rows() > 0) {
    const Index h = Lv_.rows();
    constexpr double kHalfSqrt2 = 0.70710678118654752440;  // 1 / sqrt(2)
    for (Index c = 0; c < kv.cols(); ++c) {
      for (Index r = 0; r < h; ++r) {
        const double k1 = kv(r, c), k2 = kv(h + r, c);
        kv(r, c) = (k1 + k2) * kHalfSqrt2;
        kv(h + r, c) = (k1 - k2) * kHalfSqrt2;
      }
    }
    auto u = kv.topRows(h);
    auto w = kv.bottomRows(h);
    Lv_.triangularView<Eigen::Lower>().solveInPlace(u);
    Lw_.triangularView<Eigen::Lower>().solveInPlace(w);
  } else {
    (Lv_.rows() > 0 ? Lv_ : L_).triangularView<Eigen::Lower>().solveInPlace(kv);
  }
  ss = kv.colwise().squaredNorm().transpose();
}

void Gp::set_targets(const Eigen::VectorXd& y) {
  check_size("Gp::set_targets: y (one target per training point)", X_.rows(), y.size());
  if (!y.allFinite()) {
    throw InvalidArgument("Gp::set_targets: y: expected finite values, got " + first_non_finite(y));
  }
  y_ = y;
  alpha_ = y;
  if (alpha_.size() > 0) {
    L_.triangularView<Eigen::Lower>().solveInPlace(alpha_);
    L_.triangularView<Eigen::Lower>().transpose().solveInPlace(alpha_);
  }
}

double Gp::log_marginal_likelihood() const {
  const Index n = X_.rows();
  if (n == 0) return 0.0;
  return -0.5 * y_.dot(alpha_) - L_.diagonal().array().log().sum() -
         0.5 * static_cast<double>(n) * std::log(2.0 * std::numbers::pi);
}

Eigen::VectorXd Gp::log_marginal_likelihood_gradient() const {
  const Index n = X_.rows();
  const Index D = input_dim_;
  const Index K = h_.size() - 1;  // kernel hyper-parameters
  VectorXd g = VectorXd::Zero(K + 1);
  if (n == 0) return g;

  // K^-1 = L^-T L^-1 (lower triangle), then W = alpha alpha^T - K^-1.
  FitWorkspace& ws = fit_workspace();
  MatrixXd Linv, W;
  take(Linv, ws.linv, n, n);
  take(W, ws.w, n, n);
  struct Give {  // back to the thread's buffers on every exit
    FitWorkspace& ws;
    MatrixXd& linv;
    MatrixXd& w;
    ~Give() {
      give(linv, ws.linv);
      give(w, ws.w);
    }
  } give_back{ws, Linv, W};
  lower_inverse_covariance(L_, W, Linv);
  W.triangularView<Eigen::Lower>() = -W;
  W.selfadjointView<Eigen::Lower>().rankUpdate(alpha_, 1.0);
  W.triangularView<Eigen::StrictlyUpper>() = W.transpose();
  const double trace_w = W.trace();

  if (!se_) {
    // dK/dlog sigma_n = 2 sigma_n^2 I gives g_n = sigma_n^2 tr(W); the kernel gives the rest.
    const MatrixXd Xc = X_.rowwise() - X_mean_;
    g.head(K) = kernel_->gram_gradient(Xc, W);
    g[K] = noise_variance() * trace_w;
    return g;
  }
  // With M = W o Kf (element-wise), dK/dlog l_d = Kf o (a_i - a_j)^2 (a = x_d / l_d):
  //   g_d = 1/2 sum_ij M_ij (a_i - a_j)^2 = sum_i a_i^2 r_i - a^T M a,  r = M 1,
  // with a centred (translation invariance) to limit cancellation. dK/dlog sigma_f = 2 Kf and
  // dK/dlog sigma_n = 2 sigma_n^2 I give g_f = sum_ij M_ij and g_n = sigma_n^2 tr(W).
  W.array() *= Kf_.array();
  const VectorXd r = W.rowwise().sum();
  const auto Xc = Xa_.leftCols(D);  // scaled inputs, already centred (translation invariance)
  MatrixXd MX(n, D);
  MX.noalias() = W * Xc;
  for (Index d = 0; d < D; ++d) {
    g[d] = (Xc.col(d).array().square() * r.array()).sum() - Xc.col(d).dot(MX.col(d));
  }
  g[D] = r.sum();
  g[D + 1] = noise_variance() * trace_w;
  return g;
}

void Gp::predict(const Eigen::VectorXd& x, double& mean, double& variance) const {
  check_size("Gp::predict: x (input dimension)", input_dim_, x.size());
  const double sf2 = kernel_->variance();
  const Index n = X_.rows();
  const Index D = input_dim_;
  if (n == 0) {
    mean = 0.0;
    variance = sf2;
    return;
  }
  VectorXd k_other;  // the kernel with x for a kernel other than SE-ARD
  double* kp = nullptr;
  if (!se_) {
    k_other = kernel_->gram((x.transpose() - X_mean_), X_.rowwise() - X_mean_).transpose();
    mean = k_other.dot(alpha_);
    kp = k_other.data();
  } else {
    thread_local std::vector<double> buf;
    double* p = scratch(buf, static_cast<std::size_t>(n + D + 2));
    Eigen::Map<VectorXd> qa(p, D + 2);  // [q, 1, -|q|^2 / 2]
    Eigen::Map<VectorXd> k(p + D + 2, n);
    qa.head(D) = (x - X_mean_.transpose()).cwiseQuotient(se_->length_scales);
    qa[D] = 1.0;
    qa[D + 1] = -0.5 * qa.head(D).squaredNorm();
    k.noalias() = Xa_ * qa;  // -1/2 squared scaled distances
    k = k.array().min(0.0).exp() * sf2;
    mean = k.dot(alpha_);
    kp = k.data();
  }
  const Index first = variance_first();
  double ss = 0.0;
  Eigen::Map<MatrixXd> kv(kp + first, n - first, 1);
  Eigen::Map<VectorXd> ssv(&ss, 1);
  variance_terms(kv, ssv);
  variance = std::max(0.0, sf2 - ss);
}

void Gp::predict_batch(const Eigen::MatrixXd& Xq, Eigen::VectorXd& mean,
                       Eigen::VectorXd& variance) const {
  predict_rows(Xq, nullptr, nullptr, mean, variance);
}

void Gp::predict_batch(const Eigen::MatrixXd& Xq, const Eigen::MatrixXd& weights,
                       const std::vector<int>& columns, Eigen::VectorXd& mean,
                       Eigen::VectorXd& variance) const {
  check_size("Gp::predict_batch: weights rows (one per training point)", X_.rows(),
             weights.rows());
  check_size("Gp::predict_batch: columns (one per query)", Xq.rows(),
             static_cast<Index>(columns.size()));
  for (const int c : columns) {
    if (c < 0 || c >= weights.cols()) {
      throw InvalidArgument("Gp::predict_batch: column " + std::to_string(c) +
                            " of weights out of range [0, " + std::to_string(weights.cols()) +
                            ")");
    }
  }
  predict_rows(Xq, &weights, &columns, mean, variance);
}

Eigen::VectorXd Gp::solve(const Eigen::VectorXd& y) const {
  check_size("Gp::solve: y (one target per training point)", X_.rows(), y.size());
  VectorXd x = y;
  if (x.size() > 0) {
    L_.triangularView<Eigen::Lower>().solveInPlace(x);
    L_.triangularView<Eigen::Lower>().transpose().solveInPlace(x);
  }
  return x;
}

void Gp::predict_rows(const Eigen::MatrixXd& Xq, const Eigen::MatrixXd* weights,
                      const std::vector<int>* columns, Eigen::VectorXd& mean,
                      Eigen::VectorXd& variance) const {
  check_size("Gp::predict_batch: Xq columns (input dimension)", input_dim_, Xq.cols());
  const Index B = Xq.rows();
  const Index n = X_.rows();
  const Index D = input_dim_;
  const double sf2 = kernel_->variance();
  mean.resize(B);
  variance.resize(B);
  if (B == 0) return;
  if (n == 0) {
    mean.setZero();
    variance.setConstant(sf2);
    return;
  }
  if (!se_) {
    MatrixXd KT = kernel_->gram(Xq.rowwise() - X_mean_, X_.rowwise() - X_mean_).transpose();
    if (weights) {
      for (Index q = 0; q < B; ++q)
        mean[q] = KT.col(q).dot(weights->col((*columns)[static_cast<std::size_t>(q)]));
    } else {
      mean = KT.transpose() * alpha_;
    }
    const Index first = variance_first();
    VectorXd ss(B);
    auto KTv = KT.bottomRows(n - first);
    variance_terms(KTv, ss);
    variance = (sf2 - ss.array()).max(0.0).matrix();
    return;
  }
  const Index Bp = (B + 7) / 8 * 8;  // queries padded to a multiple of 8 (padding rows are 0)
  thread_local std::vector<double> buf;
  // Qa, ss, KT and, with weights, the queries' own weights (n x Bp each).
  const Index panels = weights ? 2 : 1;
  double* p = scratch(buf, static_cast<std::size_t>(Bp * (D + 2) + Bp + panels * n * Bp));
  Eigen::Map<MatrixXd> Qa(p, Bp, D + 2);          // rows [q, 1, -|q|^2 / 2]
  Eigen::Map<VectorXd> ss(p + Bp * (D + 2), Bp);  // column sums of squares of L^-1 Kq^T
  double* KT = p + Bp * (D + 2) + Bp;             // n x Bp row-major: Kq^T, one query per column
  Qa.topLeftCorner(B, D) =
      ((Xq.rowwise() - X_mean_).array().rowwise() / se_->length_scales.transpose().array())
          .matrix();
  Qa.col(D).head(B).setOnes();
  Qa.col(D + 1).head(B) = -0.5 * Qa.topLeftCorner(B, D).rowwise().squaredNorm();
  Qa.bottomRows(Bp - B).setZero();
  // Kernel, mean and forward substitution: src/gp/predict_kernels.inc, compiled for AVX-512, AVX2
  // and baseline x86-64 and chosen at run time (results differ at round-off between the variants,
  // so between machines with different instruction sets, never between runs or thread counts).
  kernels::PredictArgs args;
  args.xa = Xa_.data();
  args.lt = L_.data();
  args.alpha = alpha_.data();
  if (weights) {  // n x Bp row-major: query q's weights in column q (padding columns: q = 0's)
    double* lanes = KT + n * Bp;
    for (Index q = 0; q < Bp; ++q) {
      const double* w =
          weights->col((*columns)[static_cast<std::size_t>(q < B ? q : 0)]).data();
      for (Index i = 0; i < n; ++i) lanes[i * Bp + q] = w[i];
    }
    args.alpha_lanes = lanes;
  }
  const Index first = variance_first();
  if (Lv_.rows() > 0) {
    args.lv = Lv_.data();
    args.var_first = first;
    args.nv = n - first;
    if (Lw_.rows() > 0) args.lw = Lw_.data();
  }
  args.n = n;
  args.d2 = D + 2;
  args.qa = Qa.data();
  args.used = B;
  args.bp = Bp;
  args.sf2 = sf2;
  args.v = KT;
  args.mean = mean.data();
  args.ss = ss.data();
  kernels::predict_block(args);
  variance = (sf2 - ss.head(B).array()).max(0.0).matrix();
}

const Eigen::VectorXd& Gp::alpha() const { return alpha_; }

const Eigen::MatrixXd& Gp::training_inputs() const { return X_; }

Eigen::MatrixXd Gp::inverse_covariance() const {
  const Index n = X_.rows();
  if (n == 0) return MatrixXd(0, 0);
  MatrixXd Kinv, Linv;
  lower_inverse_covariance(L_, Kinv, Linv);
  Kinv.triangularView<Eigen::StrictlyUpper>() = Kinv.transpose();
  return Kinv;
}

namespace {

// greedy_variance_subset (pairs = 0) and greedy_variance_pairs (pairs = n: row n + i is row i's
// image; each step adds a recorded row and its image, and the result lists the recorded rows).
std::vector<int> greedy_rows(const Eigen::MatrixXd& X, const std::vector<Gp>& gps, int m,
                             double tolerance, Index pairs, const char* who) {
  const Index N = X.rows();
  std::vector<int> out;
  const Index candidates = pairs > 0 ? pairs : N;
  if (m <= 0 || candidates <= m) {
    for (Index i = 0; i < candidates; ++i) out.push_back(static_cast<int>(i));
    return out;
  }
  if (!(tolerance >= 0.0))
    throw InvalidArgument(std::string(who) + ": tolerance must be >= 0, got " +
                          std::to_string(tolerance));
  const auto G = static_cast<Index>(gps.size());
  for (const Gp& g : gps)
    if (g.input_dim() != X.cols())
      throw InvalidArgument(std::string(who) + ": a GP has input dimension " +
                            std::to_string(g.input_dim()) + ", X has " + std::to_string(X.cols()));
  // Per GP: the columns of the pivoted Cholesky factor so far (N x steps) and every row's latent
  // variance given the chosen rows' observations, k(x,x) - sum of the squared factor entries.
  const Index steps = pairs > 0 ? 2 * static_cast<Index>(m) : m;
  std::vector<MatrixXd> L(static_cast<std::size_t>(G), MatrixXd(N, steps));
  MatrixXd var(N, G);
  VectorXd scale(G), noise(G);
  for (Index g = 0; g < G; ++g) {
    const Gp& gp = gps[static_cast<std::size_t>(g)];
    const double sf2 = gp.kernel().variance();
    var.col(g).setConstant(sf2);
    scale[g] = sf2 > 0.0 ? 1.0 / sf2 : 0.0;
    noise[g] = gp.noise_variance();
  }
  std::vector<char> chosen(static_cast<std::size_t>(candidates), 0);
  VectorXd score(N), col(N);
  Index k = 0;  // pivots so far
  auto pivot = [&](Index row) {
    for (Index g = 0; g < G; ++g) {
      auto& Lg = L[static_cast<std::size_t>(g)];
      col = gps[static_cast<std::size_t>(g)].kernel().gram(X, X.row(row));
      if (k > 0) col.noalias() -= Lg.leftCols(k) * Lg.row(row).head(k).transpose();
      col[row] = var(row, g);  // the same quantity, without the round-off of the difference
      const double p = var(row, g) + noise[g];
      Lg.col(k) = col / std::sqrt(p);
      var.col(g) -= Lg.col(k).cwiseAbs2();
    }
    var = var.cwiseMax(0.0);
    ++k;
  };
  const double per_row = pairs > 0 ? 2.0 : 1.0;
  for (int step = 0; step < m; ++step) {
    score.noalias() = var * scale;
    Index best = -1;
    for (Index i = 0; i < candidates; ++i) {
      if (chosen[static_cast<std::size_t>(i)]) continue;
      if (pairs > 0) score[i] += score[pairs + i];
      if (best < 0 || score[i] > score[best]) best = i;
    }
    if (best < 0 || !(score[best] > per_row * tolerance * static_cast<double>(G))) break;
    pivot(best);
    if (pairs > 0) pivot(pairs + best);
    chosen[static_cast<std::size_t>(best)] = 1;
    out.push_back(static_cast<int>(best));
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::vector<int> greedy_variance_subset(const Eigen::MatrixXd& X, const std::vector<Gp>& gps,
                                        int m, double tolerance) {
  return greedy_rows(X, gps, m, tolerance, 0, "greedy_variance_subset");
}

std::vector<int> greedy_variance_pairs(const Eigen::MatrixXd& X, const std::vector<Gp>& gps,
                                       int h, double tolerance) {
  if (X.rows() % 2 != 0)
    throw InvalidArgument("greedy_variance_pairs: X must hold 2 n rows (n rows and their images), "
                          "got " + std::to_string(X.rows()));
  return greedy_rows(X, gps, h, tolerance, X.rows() / 2, "greedy_variance_pairs");
}

}  // namespace drops::gp
