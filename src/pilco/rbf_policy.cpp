// PILCO's RBF-network policy (congp + gp2, baselines.md §1a): moments through se_moments and the
// parameter derivatives chained through beta = (K + sigma_n^2 I)^-1 t.
#include "drops/pilco/rbf_policy.hpp"

#include <cmath>
#include <string>

#include "detail.hpp"
#include "drops/core/errors.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

RbfPolicy::RbfPolicy(int input_dim, int num_centres, int output_dim)
    : input_dim_(input_dim), num_centres_(num_centres), output_dim_(output_dim) {
  if (input_dim < 1 || num_centres < 1 || output_dim < 1) {
    throw InvalidArgument("RbfPolicy: input_dim, num_centres, output_dim: expected >= 1, got " +
                          std::to_string(input_dim) + ", " + std::to_string(num_centres) + ", " +
                          std::to_string(output_dim));
  }
  set(MatrixXd::Zero(num_centres, input_dim), MatrixXd::Zero(num_centres, output_dim),
      MatrixXd::Zero(input_dim, output_dim));
}

int RbfPolicy::num_params() const {
  return num_centres_ * input_dim_ + num_centres_ * output_dim_ + input_dim_ * output_dim_;
}

Eigen::VectorXd RbfPolicy::params() const {
  const Index n = num_centres_, d = input_dim_, E = output_dim_;
  VectorXd theta(num_params());
  theta.head(n * d) = Eigen::Map<const VectorXd>(centres_.data(), n * d);
  theta.segment(n * d, n * E) = Eigen::Map<const VectorXd>(targets_.data(), n * E);
  theta.tail(d * E) = Eigen::Map<const VectorXd>(log_length_scales_.data(), d * E);
  return theta;
}

void RbfPolicy::set_params(const Eigen::VectorXd& theta) {
  check_size("RbfPolicy::set_params: theta (n d + n E + d E)", num_params(), theta.size());
  const Index n = num_centres_, d = input_dim_, E = output_dim_;
  set(Eigen::Map<const MatrixXd>(theta.data(), n, d),
      Eigen::Map<const MatrixXd>(theta.data() + n * d, n, E),
      Eigen::Map<const MatrixXd>(theta.data() + n * d + n * E, d, E));
}

void RbfPolicy::set(const Eigen::MatrixXd& centres, const Eigen::MatrixXd& targets,
                    const Eigen::MatrixXd& log_length_scales) {
  const Index n = num_centres_, d = input_dim_, E = output_dim_;
  check_size("RbfPolicy::set: centres rows (num_centres)", n, centres.rows());
  check_size("RbfPolicy::set: centres columns (input_dim)", d, centres.cols());
  check_size("RbfPolicy::set: targets rows (num_centres)", n, targets.rows());
  check_size("RbfPolicy::set: targets columns (output_dim)", E, targets.cols());
  check_size("RbfPolicy::set: log_length_scales rows (input_dim)", d, log_length_scales.rows());
  check_size("RbfPolicy::set: log_length_scales columns (output_dim)", E, log_length_scales.cols());
  if (!centres.allFinite() || !targets.allFinite() || !log_length_scales.allFinite()) {
    throw InvalidArgument("RbfPolicy::set: parameters: expected finite values, got non-finite");
  }
  if (log_length_scales.cwiseAbs().maxCoeff() >= 50.0) {
    throw InvalidArgument("RbfPolicy::set: log_length_scales: expected |log l| < 50, got " +
                          std::to_string(log_length_scales.cwiseAbs().maxCoeff()));
  }
  std::vector<MatrixXd> k(E);
  std::vector<Eigen::LLT<MatrixXd>> llt(E);
  MatrixXd beta(n, E);
  for (Index a = 0; a < E; ++a) {
    const VectorXd il = (-log_length_scales.col(a)).array().exp();
    const MatrixXd Xs = centres * il.asDiagonal();
    const VectorXd sq = Xs.rowwise().squaredNorm();
    MatrixXd D2 = (-2.0 * Xs * Xs.transpose()).colwise() + sq;
    D2.rowwise() += sq.transpose();
    k[a] = (-0.5 * D2.array().max(0.0)).exp().matrix() * kSignalVariance;
    k[a].diagonal().setConstant(kSignalVariance);
    MatrixXd Kn = k[a];
    Kn.diagonal().array() += kNoiseVariance;
    llt[a].compute(Kn);
    if (llt[a].info() != Eigen::Success) {
      throw NumericalError(
          "RbfPolicy::set: Cholesky factorisation of K + sigma_n^2 I failed for "
          "output " +
          std::to_string(a));
    }
    beta.col(a) = llt[a].solve(targets.col(a));
  }
  centres_ = centres;
  targets_ = targets;
  log_length_scales_ = log_length_scales;
  beta_ = std::move(beta);
  k_ = std::move(k);
  llt_ = std::move(llt);
}

Eigen::VectorXd RbfPolicy::action(const Eigen::VectorXd& x) const {
  check_size("RbfPolicy::action: x (input_dim)", input_dim_, x.size());
  VectorXd u(output_dim_);
  const MatrixXd diff = centres_.rowwise() - x.transpose();
  for (Index a = 0; a < output_dim_; ++a) {
    const VectorXd il2 = (-2.0 * log_length_scales_.col(a)).array().exp();
    const VectorXd k = (-0.5 * (diff.array().square().matrix() * il2).array()).exp();
    u[a] = k.dot(beta_.col(a)) * kSignalVariance;
  }
  return u;
}

SeModel RbfPolicy::as_se_model() const {
  SeModel m;
  m.input_dim = input_dim_;
  for (Index a = 0; a < output_dim_; ++a) {
    SeBlock b;
    b.centres = centres_;
    b.weights = beta_.col(a);
    b.length_scales = log_length_scales_.col(a).array().exp();
    b.signal_variance = kSignalVariance;
    m.outputs.push_back(SeOutput{{std::move(b)}});
  }
  return m;
}

Moments RbfPolicy::moments(const Eigen::VectorXd& mu, const Eigen::MatrixXd& sigma,
                           bool input_derivatives, bool param_derivatives) const {
  const Index n = num_centres_, d = input_dim_, E = output_dim_;
  std::vector<detail::BlockParamGradient> pg;
  Moments m = detail::se_moments_impl(as_se_model(), mu, sigma, input_derivatives,
                                      param_derivatives ? &pg : nullptr);
  m.cov.diagonal().array() += kOutputJitter;
  if (!param_derivatives) return m;

  // Rows: [mean (E) | cov (E^2) | cross (d E)], columns: theta.
  const Index F = E + E * E + d * E;
  const Index off_t = n * d, off_l = n * d + n * E;
  MatrixXd J = MatrixXd::Zero(F, num_params());
  for (Index a = 0; a < E; ++a) {
    const detail::BlockParamGradient& g = pg[a];
    J.leftCols(n * d) += g.d_centres;
    J.middleCols(off_l + d * a, d) += g.d_log_length_scales;
    // Through beta_a = (K_a + sigma_n^2 I)^-1 t_a: dF = h^T dt_a - h^T dK_a beta_a, h = (K_a +
    // sigma_n^2 I)^-1 dF/dbeta_a.
    const MatrixXd H = llt_[a].solve(g.d_weights.transpose());  // n x F
    J.middleCols(off_t + n * a, n) += H.transpose();
    const VectorXd beta = beta_.col(a);
    const VectorXd lam = (-2.0 * log_length_scales_.col(a)).array().exp();
    const MatrixXd& K = k_[a];
    // For each row f with h = H.col(f), G = (h beta^T + beta h^T) o K (never formed, K symmetric):
    //   G 1 = h o K beta + beta o K h,   G C = h o K (beta o C) + beta o K (h o C).
    // dK_ij/dc_i = -K_ij Lambda^-1 (c_i - c_j) makes -h^T dK beta over centre k equal to
    // Lambda^-1 ((G 1)_k c_k - (G C)_k); dK_ij/dlog l_k = K_ij (c_ik - c_jk)^2 / l_k^2 makes
    // -h^T dK beta over log l_k equal to -(sum_i ((h o K beta)_i + (beta o K h)_i) c_ik^2 -
    // 2 (h o c_k)^T K (beta o c_k)) / l_k^2.
    const VectorXd Kb = K * beta;
    const MatrixXd bC = centres_.array().colwise() * beta.array();
    const MatrixXd KbC = K * bC;
    const MatrixXd KH = K * H;
    MatrixXd HC(n, d * F);  // block f: h_f o C
    for (Index f = 0; f < F; ++f) {
      HC.middleCols(d * f, d) = centres_.array().colwise() * H.col(f).array();
    }
    const MatrixXd KHC = K * HC;
    const MatrixXd C2 = centres_.array().square();
    for (Index f = 0; f < F; ++f) {
      if (g.d_weights.row(f).isZero(0.0)) continue;
      const auto h = H.col(f);
      const auto Kh = KH.col(f);
      const VectorXd rs = h.cwiseProduct(Kb);     // (h beta^T o K) 1
      const VectorXd cs = beta.cwiseProduct(Kh);  // (h beta^T o K)^T 1
      const VectorXd s = rs + cs;                 // G 1
      const MatrixXd GC = (KbC.array().colwise() * h.array() +
                           KHC.middleCols(d * f, d).array().colwise() * beta.array())
                              .matrix();
      const MatrixXd dC = ((centres_.array().colwise() * s.array() - GC.array()).rowwise() *
                           lam.transpose().array())
                              .matrix();
      J.row(f).head(n * d) += detail::as_row(dC);
      for (Index k = 0; k < d; ++k) {
        const double v = C2.col(k).dot(s) - 2.0 * HC.col(d * f + k).dot(KbC.col(k));
        J(f, off_l + d * a + k) -= lam[k] * v;
      }
    }
  }
  m.dmean_dtheta = J.topRows(E);
  m.dcov_dtheta = J.middleRows(E, E * E);
  m.dcross_dtheta = J.bottomRows(d * E);
  return m;
}

}  // namespace drops::pilco
