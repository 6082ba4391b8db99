// The 2N GP of N points and their mirror images, by its two blocks of N (reflected_pairs.hpp).
#include "drops/gp/reflected_pairs.hpp"

#include <cmath>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#ifdef EIGEN_USE_LAPACKE
#include <lapacke.h>
#endif

#include "drops/core/errors.hpp"
#include "rprop_loop.hpp"

namespace drops::gp {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kLog2Pi = 1.8378770664093454836;

void check(const VectorXd& h, const MatrixXd& X, const VectorXd& flip, const VectorXd& y,
           double sign) {
  const Index D = X.cols();
  if (X.rows() < 1 || D < 1)
    throw InvalidArgument("reflected pairs: X: expected N >= 1 rows and D >= 1 columns");
  if (flip.size() != D || y.size() != X.rows() || h.size() != D + 2)
    throw InvalidArgument("reflected pairs: expected flip of " + std::to_string(D) + ", y of " +
                          std::to_string(X.rows()) + " and h of " + std::to_string(D + 2) +
                          " entries, got " + std::to_string(flip.size()) + ", " +
                          std::to_string(y.size()) + " and " + std::to_string(h.size()));
  if (!((flip.array() == 1.0) || (flip.array() == -1.0)).all() || !(sign == 1.0 || sign == -1.0))
    throw InvalidArgument("reflected pairs: flip and sign must be +1 or -1");
  if (!X.allFinite() || !y.allFinite() || !h.allFinite())
    throw InvalidArgument("reflected pairs: X, y and h must be finite");
}

/// Per-thread buffers (N x N), resized only when N changes: an Rprop fit evaluates the same
/// shapes hundreds of times.
struct Buffers {
  MatrixXd A, B, Cp, Cm, Wp, Wm;
};
Buffers& buffers() {
  thread_local Buffers b;
  return b;
}

/// Factorises C (lower Cholesky, in place) and overwrites it with the lower triangle of C^-1,
/// copied to the upper one; returns log|C|. NumericalError when C is not positive definite.
double invert_spd(MatrixXd& C) {
  const Index n = C.rows();
  Eigen::LLT<Eigen::Ref<MatrixXd>> llt(C);
  if (llt.info() != Eigen::Success)
    throw NumericalError("reflected pairs: the covariance is not positive definite");
  const double logdet = 2 * C.diagonal().array().log().sum();
#ifdef EIGEN_USE_LAPACKE
  const lapack_int info = LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', static_cast<lapack_int>(n),
                                         C.data(), static_cast<lapack_int>(n));
  if (info != 0) throw NumericalError("reflected pairs: LAPACK dpotri failed");
#else
  const MatrixXd L = C.triangularView<Eigen::Lower>();
  C.setIdentity();
  L.triangularView<Eigen::Lower>().solveInPlace(C);
  L.triangularView<Eigen::Lower>().transpose().solveInPlace(C);
#endif
  C.triangularView<Eigen::StrictlyUpper>() = C.transpose();
  return logdet;
}

}  // namespace

double reflected_pairs_log_likelihood(const VectorXd& h, const MatrixXd& X, const VectorXd& flip,
                                      const VectorXd& y, double sign, VectorXd* grad) {
  check(h, X, flip, y, sign);
  const Index N = X.rows(), D = X.cols();
  const double sn2 = std::exp(2 * h[D + 1]);
  const double sf2 = std::exp(2 * h[D]);
  const VectorXd inv_l = (-h.head(D)).array().exp();
  const MatrixXd S = X * inv_l.asDiagonal();  // scaled inputs; their reflections S P
  const VectorXd sq = S.rowwise().squaredNorm();
  Buffers& b = buffers();
  // A = k(X, X), B = k(X, X P): sf2 exp(-|s_i - s_j|^2 / 2), |s_i - P s_j|^2 likewise.
  b.A.resize(N, N);
  b.B.resize(N, N);
  b.A.noalias() = S * S.transpose();
  b.B.noalias() = S * flip.asDiagonal() * S.transpose();
  b.A = (((b.A * 2).colwise() - sq).rowwise() - sq.transpose()).array().min(0.0).matrix();
  b.B = (((b.B * 2).colwise() - sq).rowwise() - sq.transpose()).array().min(0.0).matrix();
  b.A = ((b.A * 0.5).array().exp() * sf2).matrix();
  b.B = ((b.B * 0.5).array().exp() * sf2).matrix();
  // C+ = A + B + sn2 I, C- = A - B + sn2 I, both inverted in place.
  b.Cp = b.A + b.B;
  b.Cm = b.A - b.B;
  b.Cp.diagonal().array() += sn2;
  b.Cm.diagonal().array() += sn2;
  const double logdet = invert_spd(b.Cp) + invert_spd(b.Cm);
  const MatrixXd& Cs_inv = sign > 0 ? b.Cp : b.Cm;
  const VectorXd a = Cs_inv * y;
  const double ll = -y.dot(a) - 0.5 * logdet - static_cast<double>(N) * kLog2Pi;
  if (grad == nullptr) return ll;
  // d log p / d theta = sum over the blocks of tr(W dC): W_s = a a^T - C_s^-1 / 2,
  // W_-s = -C_-s^-1 / 2; dC+- = dA +- dB, so with G = W+ + W- and H = W+ - W- (symmetric):
  // d log p = sum_ij G_ij dA_ij + H_ij dB_ij.
  b.Wp = b.Cp * -0.5;
  b.Wm = b.Cm * -0.5;
  (sign > 0 ? b.Wp : b.Wm).noalias() += a * a.transpose();
  // GA = (W+ + W-) o A into Cp, HB = (W+ - W-) o B into Cm (the inverses are no longer needed).
  b.Cp = (b.Wp + b.Wm).cwiseProduct(b.A);
  b.Cm = (b.Wp - b.Wm).cwiseProduct(b.B);
  // dk/dlog l_d = k (s_id - s'_jd)^2 with s' = s (A) or P s (B); for a symmetric M,
  // sum_ij M_ij (s_i - f s_j)^2 = 2 sum_i s_i^2 (M 1)_i - 2 f s^T M s.
  const VectorXd rA = b.Cp.rowwise().sum(), rB = b.Cm.rowwise().sum();
  const MatrixXd TA = b.Cp * S, TB = b.Cm * S;
  grad->resize(D + 2);
  for (Index d = 0; d < D; ++d) {
    const auto s = S.col(d);
    (*grad)[d] = 2 * (s.cwiseAbs2().dot(rA + rB)) - 2 * s.dot(TA.col(d)) -
                 2 * flip[d] * s.dot(TB.col(d));
  }
  (*grad)[D] = 2 * (rA.sum() + rB.sum());                      // d/dlog sigma_f: 2 k
  (*grad)[D + 1] = 2 * sn2 * (b.Wp.trace() + b.Wm.trace());    // d/dlog sigma_n: 2 sn2 I
  return ll;
}

RpropSummary fit_reflected_pairs(VectorXd& h, const MatrixXd& X, const VectorXd& flip,
                                 const VectorXd& y, double sign, const RpropOptions& options) {
  check(h, X, flip, y, sign);
  std::string why;
  if (!options.IsValid(&why))
    throw InvalidArgument("fit_reflected_pairs: invalid RpropOptions: " + why);
  // The soft walls' input spread: the 2N points.
  MatrixXd X2(2 * X.rows(), X.cols());
  X2.topRows(X.rows()) = X;
  X2.bottomRows(X.rows()) = X * flip.asDiagonal();
  // apply evaluates the likelihood and its gradient together (one factorisation per iterate);
  // evaluate and value hand them out.
  double value = 0;
  VectorXd gradient;
  detail::RpropTarget target;
  target.apply = [&](const VectorXd& hh) {
    VectorXd g;
    const double v = reflected_pairs_log_likelihood(hh, X, flip, y, sign, &g);  // may throw
    value = v;
    gradient = std::move(g);
  };
  target.evaluate = [&](VectorXd& grad) {
    grad = gradient;
    return value;
  };
  target.value = [&] { return value; };
  VectorXd best = h;
  target.keep = [&](const VectorXd& hh) { best = hh; };
  target.apply(h);  // the start (NumericalError when it cannot be factorised)
  const RpropSummary s = detail::run_irprop(options, X2, h, nullptr, target);
  h = best;
  return s;
}

}  // namespace drops::gp
