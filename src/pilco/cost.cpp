// PILCO's saturating cost and its Gaussian expectation (lossSat; baselines.md §1a).
#include "drops/pilco/cost.hpp"

#include <Eigen/LU>
#include <cmath>

#include "detail.hpp"
#include "drops/core/errors.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

void SaturatingCost::validate(int dim) const {
  check_size("SaturatingCost: weight rows", dim, weight.rows());
  check_size("SaturatingCost: weight columns", dim, weight.cols());
  check_size("SaturatingCost: target", dim, target.size());
  if (!weight.allFinite() || !target.allFinite()) {
    throw InvalidArgument("SaturatingCost: weight, target: expected finite values");
  }
  if (dim > 0 &&
      (weight - weight.transpose()).cwiseAbs().maxCoeff() > 1e-12 * weight.cwiseAbs().maxCoeff()) {
    throw InvalidArgument("SaturatingCost: weight: expected a symmetric matrix");
  }
}

double SaturatingCost::operator()(const VectorXd& x) const {
  check_size("SaturatingCost: x", target.size(), x.size());
  const VectorXd d = x - target;
  return 1.0 - std::exp(-0.5 * d.dot(weight * d));
}

CostMoments expected_cost(const SaturatingCost& cost, const VectorXd& mu, const MatrixXd& sigma,
                          bool derivatives) {
  const Index p = mu.size();
  cost.validate(static_cast<int>(p));
  detail::check_gaussian("expected_cost", p, mu, sigma);
  const MatrixXd I = MatrixXd::Identity(p, p);
  const VectorXd d = mu - cost.target;

  // S = W (I + Sigma W)^-1 = ((I + W Sigma)^-1 W)^T (W, Sigma symmetric), symmetric; and
  // |I + Sigma W| = |I + W Sigma|.
  const Eigen::PartialPivLU<MatrixXd> lu(I + cost.weight * sigma);
  const double det = lu.determinant();
  if (!(det > 0.0) || !std::isfinite(det)) {
    throw NumericalError(
        "expected_cost: I + Sigma W is singular or has a negative determinant; "
        "Sigma is probably not positive semi-definite");
  }
  MatrixXd S = lu.solve(cost.weight).transpose();
  S = 0.5 * (S + S.transpose());
  const double L = std::exp(-0.5 * d.dot(S * d)) / std::sqrt(det);

  CostMoments out;
  out.mean = 1.0 - L;

  const Eigen::PartialPivLU<MatrixXd> lu2(I + 2.0 * cost.weight * sigma);
  const double det2 = lu2.determinant();
  MatrixXd S2 = lu2.solve(cost.weight).transpose();
  S2 = 0.5 * (S2 + S2.transpose());
  const double second = std::exp(-d.dot(S2 * d)) / std::sqrt(det2);
  out.variance = second - L * L;
  if (out.variance < 1e-12) out.variance = 0.0;  // as lossSat

  if (derivatives) {
    const VectorXd Sd = S * d;
    out.dmean_dmu = L * Sd;
    out.dmean_dsigma = 0.5 * L * (S - Sd * Sd.transpose());
  }
  return out;
}

}  // namespace drops::pilco
