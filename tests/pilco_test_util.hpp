#pragma once
// Shared oracles of the drops::pilco tests: random problems, Monte-Carlo moments with standard
// errors, and central finite differences with PILCO's covariance-derivative convention.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <string>

#include "drops/core/rng.hpp"
#include "drops/pilco/moments.hpp"

namespace pilco_test {

using drops::Rng;
using Eigen::MatrixXd;
using Eigen::VectorXd;

inline MatrixXd RandomMatrix(Rng& rng, int rows, int cols, double lo, double hi) {
  MatrixXd m(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) m(i, j) = rng.uniform(lo, hi);
  return m;
}

inline VectorXd RandomVector(Rng& rng, int n, double lo, double hi) {
  return RandomMatrix(rng, n, 1, lo, hi).col(0);
}

// A covariance with standard deviations in [sd_lo, sd_hi] and correlations up to ~0.7.
inline MatrixXd RandomCovariance(Rng& rng, int D, double sd_lo, double sd_hi) {
  MatrixXd A = RandomMatrix(rng, D, D, -1.0, 1.0);
  MatrixXd C = A * A.transpose() + 0.5 * MatrixXd::Identity(D, D);
  VectorXd d = C.diagonal().cwiseSqrt().cwiseInverse();
  C = d.asDiagonal() * C * d.asDiagonal();  // correlation matrix
  VectorXd sd = RandomVector(rng, D, sd_lo, sd_hi);
  MatrixXd S = sd.asDiagonal() * C * sd.asDiagonal();
  return 0.5 * (S + S.transpose());
}

// N samples of N(mu, sigma), one per row (sigma positive semi-definite).
inline MatrixXd SampleGaussian(Rng& rng, const VectorXd& mu, const MatrixXd& sigma, int N) {
  const int D = static_cast<int>(mu.size());
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(sigma);
  const MatrixXd L = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  MatrixXd Z(N, D);
  for (int i = 0; i < N; ++i)
    for (int d = 0; d < D; ++d) Z(i, d) = rng.normal();
  MatrixXd X = Z * L.transpose();
  X.rowwise() += mu.transpose();
  return X;
}

// Sample means, covariances and their standard errors (SE of a covariance entry: the standard
// deviation of the centred products over sqrt(N)).
struct McStats {
  VectorXd mean, mean_se;
  MatrixXd cov, cov_se;      // Cov[Y] (E x E)
  MatrixXd cross, cross_se;  // Cov[X, Y] (D x E)
};

inline McStats MonteCarloStats(const MatrixXd& X, const MatrixXd& Y) {
  const double N = static_cast<double>(Y.rows());
  McStats s;
  s.mean = Y.colwise().mean().transpose();
  const MatrixXd Yc = Y.rowwise() - s.mean.transpose();
  const MatrixXd Xc = X.rowwise() - X.colwise().mean();
  s.mean_se = (Yc.array().square().colwise().sum() / (N - 1)).sqrt().transpose() / std::sqrt(N);
  auto cov_and_se = [N](const MatrixXd& A, const MatrixXd& B, MatrixXd& cov, MatrixXd& se) {
    cov.resize(A.cols(), B.cols());
    se.resize(A.cols(), B.cols());
    for (int a = 0; a < A.cols(); ++a) {
      for (int b = 0; b < B.cols(); ++b) {
        const VectorXd p = A.col(a).cwiseProduct(B.col(b));
        const double m = p.sum() / (N - 1);
        cov(a, b) = m;
        se(a, b) = std::sqrt((p.array() - p.mean()).square().sum() / (N - 1) / N);
      }
    }
  };
  cov_and_se(Yc, Yc, s.cov, s.cov_se);
  cov_and_se(Xc, Yc, s.cross, s.cross_se);
  return s;
}

// Largest |analytic - mc| / se over the entries (se floored at `floor`), for reporting.
inline double MaxZ(const MatrixXd& analytic, const MatrixXd& mc, const MatrixXd& se,
                   double floor = 1e-12) {
  return ((analytic - mc).array().abs() / se.array().max(floor)).maxCoeff();
}

// Expects |analytic - mc| <= z * se + abs_tol entry by entry, and prints the largest z-score.
inline void ExpectWithinSe(const std::string& what, const MatrixXd& analytic, const MatrixXd& mc,
                           const MatrixXd& se, double z, double abs_tol = 1e-9) {
  ASSERT_EQ(analytic.rows(), mc.rows()) << what;
  ASSERT_EQ(analytic.cols(), mc.cols()) << what;
  for (int j = 0; j < analytic.cols(); ++j)
    for (int i = 0; i < analytic.rows(); ++i)
      EXPECT_LE(std::abs(analytic(i, j) - mc(i, j)), z * se(i, j) + abs_tol)
          << what << " (" << i << ", " << j << "): analytic " << analytic(i, j) << ", MC "
          << mc(i, j) << " +- " << se(i, j);
  std::cout << "[ measured ] " << what
            << ": max |analytic - MC| / SE = " << MaxZ(analytic, mc, se, 1e-300)
            << ", max |analytic - MC| = " << (analytic - mc).cwiseAbs().maxCoeff() << "\n";
}

// Derivative along a direction from a function of the step t: central differences of order 2
// ((f(h) - f(-h)) / 2h, truncation O(h^2)) or 4 ((8 (f(h) - f(-h)) - (f(2h) - f(-2h))) / 12h,
// truncation O(h^4), which allows a larger h and so less round-off for long computations).
inline VectorXd CentralDifference(const std::function<VectorXd(double)>& f, double h, int order) {
  if (order == 4) return (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h);
  return (f(h) - f(-h)) / (2.0 * h);
}

// Central differences of f (returns a flat vector) at x along each coordinate, step h.
inline MatrixXd FdJacobian(const std::function<VectorXd(const VectorXd&)>& f, const VectorXd& x,
                           double h, int order = 2) {
  const VectorXd f0 = f(x);
  MatrixXd J(f0.size(), x.size());
  for (int k = 0; k < x.size(); ++k) {
    J.col(k) = CentralDifference(
        [&](double t) {
          VectorXd xt = x;
          xt[k] += t;
          return f(xt);
        },
        h, order);
  }
  return J;
}

// Central differences with respect to a symmetric matrix S (D x D) in PILCO's convention: column
// k + D l is half the derivative along the symmetric perturbation E_kl + E_lk for k != l (so the
// columns (k, l) and (l, k) are equal and sum to it), and the derivative along E_kk for k = l.
inline MatrixXd FdJacobianSym(const std::function<VectorXd(const MatrixXd&)>& f, const MatrixXd& S,
                              double h, int order = 2) {
  const int D = static_cast<int>(S.rows());
  const VectorXd f0 = f(S);
  MatrixXd J(f0.size(), D * D);
  for (int l = 0; l < D; ++l) {
    for (int k = 0; k <= l; ++k) {
      VectorXd d = CentralDifference(
          [&](double t) {
            MatrixXd St = S;
            St(k, l) += t;
            if (k != l) St(l, k) += t;
            return f(St);
          },
          h, order);
      if (k != l) d *= 0.5;
      J.col(k + D * l) = d;
      J.col(l + D * k) = d;
    }
  }
  return J;
}

// Relative error max|A - B| / max(max|B|, 1e-300), the reported derivative metric.
inline double RelErr(const MatrixXd& A, const MatrixXd& B) {
  return (A - B).cwiseAbs().maxCoeff() / std::max(B.cwiseAbs().maxCoeff(), 1e-300);
}

inline void ExpectJacobian(const std::string& what, const MatrixXd& analytic, const MatrixXd& fd,
                           double rel_tol) {
  ASSERT_EQ(analytic.rows(), fd.rows()) << what;
  ASSERT_EQ(analytic.cols(), fd.cols()) << what;
  const double err = RelErr(analytic, fd);
  EXPECT_LE(err, rel_tol) << what << ": analytic\n" << analytic << "\nfinite differences\n" << fd;
  EXPECT_GT(fd.cwiseAbs().maxCoeff(), 0.0) << what << ": trivial (all-zero) derivative";
  std::cout << "[ measured ] " << what << ": max |analytic - FD| / max |FD| = " << err << "\n";
}

// Flattened moments [mean; vec(cov); vec(cross)] of a Moments-valued function.
inline VectorXd FlatMoments(const drops::pilco::Moments& m) {
  VectorXd v(m.mean.size() + m.cov.size() + m.cross.size());
  v << m.mean, Eigen::Map<const VectorXd>(m.cov.data(), m.cov.size()),
      Eigen::Map<const VectorXd>(m.cross.data(), m.cross.size());
  return v;
}

// Checks the six input derivatives of a Moments-valued function of (mu, sigma) by central
// differences (step h), relative tolerance rel_tol.
inline void CheckInputDerivatives(
    const std::string& what,
    const std::function<drops::pilco::Moments(const VectorXd&, const MatrixXd&, bool)>& f,
    const VectorXd& mu, const MatrixXd& sigma, double h, double rel_tol) {
  const drops::pilco::Moments m = f(mu, sigma, true);
  const int E = static_cast<int>(m.mean.size());
  const int D = static_cast<int>(mu.size());
  const MatrixXd Jm =
      FdJacobian([&](const VectorXd& x) { return FlatMoments(f(x, sigma, false)); }, mu, h);
  const MatrixXd Js =
      FdJacobianSym([&](const MatrixXd& S) { return FlatMoments(f(mu, S, false)); }, sigma, h);
  ExpectJacobian(what + " dmean/dmu", m.dmean_dmu, Jm.topRows(E), rel_tol);
  ExpectJacobian(what + " dmean/dsigma", m.dmean_dsigma, Js.topRows(E), rel_tol);
  ExpectJacobian(what + " dcov/dmu", m.dcov_dmu, Jm.middleRows(E, E * E), rel_tol);
  ExpectJacobian(what + " dcov/dsigma", m.dcov_dsigma, Js.middleRows(E, E * E), rel_tol);
  ExpectJacobian(what + " dcross/dmu", m.dcross_dmu, Jm.bottomRows(D * E), rel_tol);
  ExpectJacobian(what + " dcross/dsigma", m.dcross_dsigma, Js.bottomRows(D * E), rel_tol);
}

}  // namespace pilco_test
