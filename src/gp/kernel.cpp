// Covariance functions (Rasmussen & Williams 2006, ch. 4-5).
#include "drops/gp/kernel.hpp"

#include <cmath>

#include "drops/core/errors.hpp"

namespace drops::gp {

Eigen::MatrixXd Kernel::gram(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) const {
  check_size("Kernel::gram: A columns", input_dim(), A.cols());
  check_size("Kernel::gram: B columns", input_dim(), B.cols());
  Eigen::MatrixXd K(A.rows(), B.rows());
  Eigen::VectorXd a, b;
  for (Eigen::Index i = 0; i < A.rows(); ++i) {
    a = A.row(i).transpose();
    for (Eigen::Index j = 0; j < B.rows(); ++j) {
      b = B.row(j).transpose();
      K(i, j) = (*this)(a, b);
    }
  }
  return K;
}

Eigen::VectorXd SquaredExpArd::h_params() const {
  Eigen::VectorXd h(h_dim());
  h.head(input_dim()) = length_scales.array().log().matrix();
  h[input_dim()] = 0.5 * std::log(signal_variance);
  return h;
}

void SquaredExpArd::set_h_params(const Eigen::VectorXd& h) {
  check_size("SquaredExpArd::set_h_params: h (D + 1)", h_dim(), h.size());
  if (!h.allFinite()) throw InvalidArgument("SquaredExpArd::set_h_params: h is not finite");
  length_scales = h.head(input_dim()).array().exp().matrix();
  signal_variance = std::exp(2.0 * h[input_dim()]);
}

double SquaredExpArd::operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  check_size("SquaredExpArd: first input", length_scales.size(), a.size());
  check_size("SquaredExpArd: second input", length_scales.size(), b.size());
  double s = 0.0;
  for (Eigen::Index d = 0; d < a.size(); ++d) {
    const double t = (a[d] - b[d]) / length_scales[d];
    s += t * t;
  }
  return signal_variance * std::exp(-0.5 * s);
}

Eigen::MatrixXd SquaredExpArd::gram(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) const {
  check_size("SquaredExpArd::gram: A columns", input_dim(), A.cols());
  check_size("SquaredExpArd::gram: B columns", input_dim(), B.cols());
  Eigen::MatrixXd K(A.rows(), B.rows());
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = 0; j < B.rows(); ++j) {
      const double s = ((A.row(i) - B.row(j)).transpose().array() / length_scales.array())
                           .square()
                           .sum();
      K(i, j) = signal_variance * std::exp(-0.5 * s);
    }
  return K;
}

Eigen::VectorXd SquaredExpArd::gram_gradient(const Eigen::MatrixXd& X,
                                             const Eigen::MatrixXd& W) const {
  check_size("SquaredExpArd::gram_gradient: X columns", input_dim(), X.cols());
  check_size("SquaredExpArd::gram_gradient: W rows", X.rows(), W.rows());
  check_size("SquaredExpArd::gram_gradient: W columns", X.rows(), W.cols());
  const Eigen::MatrixXd K = gram(X, X);
  const Eigen::MatrixXd M = W.cwiseProduct(K);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(h_dim());
  // dK_ik / dlog l_d = K_ik (x_id - x_kd)^2 / l_d^2; dK_ik / dlog sigma_f = 2 K_ik.
  for (Eigen::Index d = 0; d < X.cols(); ++d) {
    double s = 0;
    for (Eigen::Index i = 0; i < X.rows(); ++i)
      for (Eigen::Index k = 0; k < X.rows(); ++k) {
        const double t = (X(i, d) - X(k, d)) / length_scales[d];
        s += M(i, k) * t * t;
      }
    g[d] = 0.5 * s;
  }
  g[input_dim()] = M.sum();
  return g;
}

double Matern52::of_distance(double d) const {
  const double r = std::sqrt(5.0) * d / length_scale;
  return signal_variance * (1.0 + r + r * r / 3.0) * std::exp(-r);
}

double Matern52::operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  check_size("Matern52: second input", a.size(), b.size());
  if (dim > 0) check_size("Matern52: input", dim, a.size());
  return of_distance((a - b).norm());
}

Eigen::VectorXd Matern52::h_params() const {
  Eigen::VectorXd h(2);
  h << std::log(length_scale), 0.5 * std::log(signal_variance);
  return h;
}

void Matern52::set_h_params(const Eigen::VectorXd& h) {
  check_size("Matern52::set_h_params: h", 2, h.size());
  if (!h.allFinite()) throw InvalidArgument("Matern52::set_h_params: h is not finite");
  length_scale = std::exp(h[0]);
  signal_variance = std::exp(2.0 * h[1]);
}

Eigen::VectorXd Matern52::gram_gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& W) const {
  check_size("Matern52::gram_gradient: W rows", X.rows(), W.rows());
  check_size("Matern52::gram_gradient: W columns", X.rows(), W.cols());
  // With r = sqrt(5) d / l: k = s (1 + r + r^2/3) e^-r, dk/dlog l = s (r^2 / 3)(1 + r) e^-r,
  // dk/dlog sigma_f = 2 k.
  Eigen::VectorXd g = Eigen::VectorXd::Zero(2);
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.rows(); ++j) {
      const double r = std::sqrt(5.0) * (X.row(i) - X.row(j)).norm() / length_scale;
      const double e = std::exp(-r);
      g[0] += W(i, j) * signal_variance * (r * r / 3.0) * (1.0 + r) * e;
      g[1] += W(i, j) * 2.0 * signal_variance * (1.0 + r + r * r / 3.0) * e;
    }
  return 0.5 * g;
}

}  // namespace drops::gp
