// Tests of the Matern 5/2 kernel (used by M-BOA): closed values from baselines.md §3d, the general
// Matern formula with a Bessel function, the derivative against finite differences, positive
// definiteness.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/gp/kernel.hpp"

namespace {

using drops::InvalidArgument;
using drops::Rng;
using drops::gp::Matern52;
using Eigen::MatrixXd;
using Eigen::VectorXd;

TEST(Matern52, ValueAtZeroAndAtOneLengthScale) {
  for (double sf2 : {1.0, 2.5}) {
    for (double l : {0.4, 3.0}) {
      Matern52 k{l, sf2};
      EXPECT_DOUBLE_EQ(k.of_distance(0.0), sf2);
      // baselines.md §3d: k(l) = 0.52399 sigma_f^2.
      EXPECT_NEAR(k.of_distance(l) / sf2, 0.52399, 5e-6);
      VectorXd a(3), b(3);
      a << 0.1, 0.2, 0.3;
      b = a;
      b[1] += l;
      EXPECT_NEAR(k(a, b) / sf2, 0.52399, 5e-6);
      EXPECT_DOUBLE_EQ(k(a, a), sf2);
    }
  }
}

TEST(Matern52, MatchesTheGeneralMaternFormulaWithNuFiveHalves) {
  // k(r) = sigma_f^2 2^(1 - nu) / Gamma(nu) (sqrt(2 nu) r / l)^nu K_nu(sqrt(2 nu) r / l).
  const double nu = 2.5, l = 0.7, sf2 = 1.3;
  const Matern52 k{l, sf2};
  for (double r = 0.01; r < 5.0; r += 0.0731) {
    const double z = std::sqrt(2 * nu) * r / l;
    const double general =
        sf2 * std::pow(2.0, 1 - nu) / std::tgamma(nu) * std::pow(z, nu) * std::cyl_bessel_k(nu, z);
    EXPECT_NEAR(k.of_distance(r), general, 1e-10 * sf2) << "r = " << r;
  }
}

TEST(Matern52, DerivativeMatchesFiniteDifferencesAndVanishesAtZero) {
  const double l = 0.4, sf2 = 2.0;
  const Matern52 k{l, sf2};
  // Closed form: dk/dd = -sigma_f^2 (5 d / (3 l^2)) (1 + sqrt(5) d / l) exp(-sqrt(5) d / l).
  auto dk = [&](double d) {
    return -sf2 * (5.0 * d / (3.0 * l * l)) * (1.0 + std::sqrt(5.0) * d / l) *
           std::exp(-std::sqrt(5.0) * d / l);
  };
  const double h = 1e-6;
  for (double d = 0.02; d < 2.0; d += 0.05) {
    const double fd = (k.of_distance(d + h) - k.of_distance(d - h)) / (2 * h);
    EXPECT_NEAR(fd, dk(d), 1e-7) << "d = " << d;
  }
  EXPECT_NEAR((k.of_distance(h) - k.of_distance(0.0)) / h, 0.0, 1e-4);
}

TEST(Matern52, KernelMatricesArePositiveDefiniteAndInputsAreChecked) {
  Rng rng(1);
  const Matern52 k{0.3, 1.0};
  MatrixXd X(40, 3);
  for (Eigen::Index i = 0; i < X.size(); ++i) X.data()[i] = rng.uniform();
  MatrixXd K(40, 40);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) K(i, j) = k(X.row(i).transpose(), X.row(j).transpose());
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff(), 1e-15);
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(K);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  EXPECT_THROW(k(VectorXd::Zero(2), VectorXd::Zero(3)), InvalidArgument);
}

}  // namespace
