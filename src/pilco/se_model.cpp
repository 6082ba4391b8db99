// Exact moment matching through sums of SE centre sets (Deisenroth 2010 §2.3; gp0.m, gp0d.m, gp2.m
// described in baselines.md §1a, §2a), with derivatives with respect to the input moments and, for
// RBF networks, the centres, weights and length scales. Derivations: docs/pilco.md.
#include "drops/pilco/se_model.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../gp/predict_kernels.hpp"
#include "detail.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::RowVectorXd;
using Eigen::VectorXd;

namespace detail {

void check_gaussian(const char* who, Index dim, const VectorXd& mu, const MatrixXd& sigma) {
  const std::string w(who);
  check_size((w + ": mean").c_str(), dim, mu.size());
  check_size((w + ": covariance rows").c_str(), dim, sigma.rows());
  check_size((w + ": covariance columns").c_str(), dim, sigma.cols());
  if (!mu.allFinite()) throw InvalidArgument(w + ": mean: expected finite values, got non-finite");
  if (!sigma.allFinite()) {
    throw InvalidArgument(w + ": covariance: expected finite values, got non-finite");
  }
  if (dim == 0) return;
  const double scale = sigma.cwiseAbs().maxCoeff();
  const double asym = (sigma - sigma.transpose()).cwiseAbs().maxCoeff();
  if (asym > 1e-9 * scale) {
    std::ostringstream os;
    os << w << ": covariance: expected a symmetric matrix, got max |S - S^T| = " << asym
       << " (largest entry " << scale << ")";
    throw InvalidArgument(os.str());
  }
}

}  // namespace detail

namespace {

// Per-call state of one block at the input mean mu.
struct BlockState {
  const SeBlock* block = nullptr;
  int output = 0;
  int index = 0;  // position in the flat block list
  VectorXd lam;   // D, 1 / l^2
  MatrixXd nu;    // n x D, rows c_i - mu
  MatrixXd y;     // n x D, rows Lambda^-1 nu_i
  VectorXd logk;  // n, log k(c_i, mu) = log alpha^2 - 1/2 nu_i^T Lambda^-1 nu_i
};

// B = I + diag(sq) Sigma diag(sq): its inverse and log-determinant. Every (Sigma + Lambda)^-1 and
// R^-1 below is written through B, which stays well conditioned for Sigma -> 0 or singular Sigma.
struct ScaledFactor {
  MatrixXd inv;
  double logdet = 0.0;
};

ScaledFactor factor_scaled(const MatrixXd& sigma, const VectorXd& sq) {
  const Index D = sigma.rows();
  MatrixXd B = sq.asDiagonal() * sigma * sq.asDiagonal();
  B.diagonal().array() += 1.0;
  Eigen::LLT<MatrixXd> llt(B);
  if (llt.info() != Eigen::Success) {
    throw NumericalError(
        "se_moments: I + Lambda^-1/2 Sigma Lambda^-1/2 is not positive definite; the input "
        "covariance Sigma is probably not positive semi-definite");
  }
  ScaledFactor f;
  f.logdet = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  f.inv = llt.solve(MatrixXd::Identity(D, D));
  f.inv = 0.5 * (f.inv + f.inv.transpose());
  return f;
}

// Adds the contribution of the block pair (A, B) of outputs (a, b) to S_ab (and S_ba), with
// multiplicity `mult` (2 for A != B of the same output: the pair (B, A) is the transpose).
// Includes alpha^2 - tr(K^-1 Q) when A is B and has gp_variance.
void add_pair(const BlockState& A, const BlockState& B, double mult, const MatrixXd& sigma, Index E,
              bool input_derivatives, Moments& out,
              std::vector<detail::BlockParamGradient>* params) {
  const Index D = sigma.rows();
  const Index a = A.output, b = B.output;
  const Index nA = A.nu.rows(), nB = B.nu.rows();
  const bool variance = (&A == &B) && A.block->gp_variance;
  if (nA == 0 || nB == 0) {
    if (variance) {
      out.cov(a, a) += A.block->signal_variance;  // no data: the prior variance
    }
    return;
  }
  const VectorXd lam = A.lam + B.lam;
  const VectorXd sq = lam.array().sqrt();
  const VectorXd isq = sq.cwiseInverse();
  const ScaledFactor f = factor_scaled(sigma, sq);
  // T = (Sigma^-1 + Lambda_A^-1 + Lambda_B^-1)^-1 = R^-1 Sigma, written without Sigma^-1.
  MatrixXd T = sigma * sq.asDiagonal() * f.inv * isq.asDiagonal();
  T = 0.5 * (T + T.transpose());
  const MatrixXd AT = A.y * T;  // rows a_i = T Lambda_A^-1 nu_i
  const MatrixXd BT = B.y * T;  // rows b_j = T Lambda_B^-1 nu_j
  const VectorXd lA =
      A.logk.array() - 0.25 * f.logdet + 0.5 * (A.y.array() * AT.array()).rowwise().sum();
  const VectorXd lB =
      B.logk.array() - 0.25 * f.logdet + 0.5 * (B.y.array() * BT.array()).rowwise().sum();
  // Q and W are n_A x n_B (up to 300 x 300 for the swing-up of paper §V-A): per-thread buffers
  // reused across pairs and calls, since allocating them for every pair (and faulting their pages
  // in) cost more than the arithmetic. They only grow: a resize to each pair's size (blocks of 50,
  // 200 and 300 centres alternate in a PILCO step) freed and mapped them again every time, which
  // made some objective evaluations 2-4 times slower than others (bench_pilco,
  // BM_PilcoObjectiveAsDataGrow).
  thread_local std::vector<double> q_buffer, w_buffer;
  const auto size = static_cast<std::size_t>(nA * nB);
  if (q_buffer.size() < size) q_buffer.resize(size);
  if (w_buffer.size() < size) w_buffer.resize(size);
  Eigen::Map<MatrixXd> Q(q_buffer.data(), nA, nB), W(w_buffer.data(), nA, nB);
  Q.noalias() = AT * B.y.transpose();
  const VectorXd& wA = A.block->weights;
  const VectorXd& wB = B.block->weights;
  VectorXd r(nA), c(nB);  // W's row and column sums
  // Q = exp(AT B.y^T + lA 1^T + 1 lB^T) and W = (mult wA wB^T - [K^-1]) .* Q with the sums in one
  // pass of the SIMD kernel (the exp of the n_A x n_B entries was over half of a step's work).
  gp::kernels::PairArgs args;
  args.g = Q.data();
  args.la = lA.data();
  args.lb = lB.data();
  args.wa = wA.data();
  args.wb = wB.data();
  args.mult = mult;
  args.kinv = variance ? A.block->k_inverse.data() : nullptr;
  args.na = nA;
  args.nb = nB;
  args.q = Q.data();
  args.w = W.data();
  args.row_sums = r.data();
  args.col_sums = c.data();
  gp::kernels::pair_weights(args);
  if (variance) out.cov(a, a) += A.block->signal_variance;
  const double total = c.sum();
  out.cov(a, b) += total;
  if (a != b) out.cov(b, a) += total;

  if (input_derivatives) {
    // d log Q_ij / dmu = s_ij = e_i + f_j with e_i = (I + Lambda^-1 Sigma)^-1 Lambda_A^-1 nu_i;
    // d log Q_ij / dSigma = 1/2 (s_ij s_ij^T - (Sigma + Lambda_AB)^-1), Lambda_AB^-1 = lam.
    const MatrixXd Rp = isq.asDiagonal() * f.inv * sq.asDiagonal();
    const MatrixXd Pab = sq.asDiagonal() * f.inv * sq.asDiagonal();
    const MatrixXd EA = A.y * Rp;
    const MatrixXd FB = B.y * Rp;
    const VectorXd dmu = EA.transpose() * r + FB.transpose() * c;
    const MatrixXd X = EA.transpose() * (W * FB);
    MatrixXd G = EA.transpose() * r.asDiagonal() * EA + FB.transpose() * c.asDiagonal() * FB + X +
                 X.transpose() - total * Pab;
    G *= 0.5;
    out.dcov_dmu.row(a + E * b) += dmu.transpose();
    out.dcov_dsigma.row(a + E * b) += detail::as_row(G);
    if (a != b) {
      out.dcov_dmu.row(b + E * a) += dmu.transpose();
      out.dcov_dsigma.row(b + E * a) += detail::as_row(G);
    }
  }

  if (params != nullptr) {
    // d log Q_ij / dc_i = -Lambda_A^-1 (nu_i - a_i - b_j), d log Q_ij / dc_j = -Lambda_B^-1 (nu_j -
    // a_i - b_j), d log Q_ij / d(Lambda_A^-1)_d = -1/2 (nu_id - a_id - b_jd)^2 - 1/2 T_dd.
    const MatrixXd gA = A.nu - AT;
    const MatrixXd hB = B.nu - BT;
    const MatrixXd WB = W * BT;
    const MatrixXd WtA = W.transpose() * AT;
    const MatrixXd dXA =
        -((gA.array().colwise() * r.array() - WB.array()).rowwise() * A.lam.transpose().array())
             .matrix();
    const MatrixXd dXB =
        -((hB.array().colwise() * c.array() - WtA.array()).rowwise() * B.lam.transpose().array())
             .matrix();
    VectorXd dlamA(D), dlamB(D);
    for (Index d = 0; d < D; ++d) {
      dlamA[d] =
          -0.5 * ((gA.col(d).array().square() * r.array()).sum() - 2.0 * gA.col(d).dot(WB.col(d)) +
                  (BT.col(d).array().square() * c.array()).sum()) -
          0.5 * T(d, d) * total;
      dlamB[d] =
          -0.5 * ((hB.col(d).array().square() * c.array()).sum() - 2.0 * hB.col(d).dot(WtA.col(d)) +
                  (AT.col(d).array().square() * r.array()).sum()) -
          0.5 * T(d, d) * total;
    }
    const VectorXd dlogl_A = -2.0 * A.lam.cwiseProduct(dlamA);
    const VectorXd dlogl_B = -2.0 * B.lam.cwiseProduct(dlamB);
    const VectorXd dwA = mult * (Q * wB);
    const VectorXd dwB = mult * (Q.transpose() * wA);
    auto add = [&](detail::BlockParamGradient& g, Index row, const MatrixXd& dX, const VectorXd& dw,
                   const VectorXd& dl) {
      g.d_centres.row(row) += detail::as_row(dX);
      g.d_weights.row(row) += dw.transpose();
      g.d_log_length_scales.row(row) += dl.transpose();
    };
    add((*params)[A.index], E + a + E * b, dXA, dwA, dlogl_A);
    add((*params)[B.index], E + a + E * b, dXB, dwB, dlogl_B);
    if (a != b) {
      add((*params)[A.index], E + b + E * a, dXA, dwA, dlogl_A);
      add((*params)[B.index], E + b + E * a, dXB, dwB, dlogl_B);
    }
  }
}

}  // namespace

void SeModel::validate() const {
  if (input_dim < 1) {
    throw InvalidArgument("SeModel: input_dim: expected >= 1, got " + std::to_string(input_dim));
  }
  if (outputs.empty()) throw InvalidArgument("SeModel: outputs: expected >= 1, got 0");
  for (std::size_t a = 0; a < outputs.size(); ++a) {
    for (std::size_t k = 0; k < outputs[a].blocks.size(); ++k) {
      const SeBlock& b = outputs[a].blocks[k];
      const std::string who =
          "SeModel: output " + std::to_string(a) + ", block " + std::to_string(k) + ": ";
      check_size((who + "centres columns (input_dim)").c_str(), input_dim, b.centres.cols());
      check_size((who + "weights (one per centre)").c_str(), b.centres.rows(), b.weights.size());
      check_size((who + "length_scales (input_dim)").c_str(), input_dim, b.length_scales.size());
      if (!(b.length_scales.array() > 0.0).all() || !b.length_scales.allFinite()) {
        throw InvalidArgument(who + "length_scales: expected finite values > 0");
      }
      if (!(b.signal_variance > 0.0) || !std::isfinite(b.signal_variance)) {
        throw InvalidArgument(who + "signal_variance: expected a finite value > 0, got " +
                              std::to_string(b.signal_variance));
      }
      if (b.gp_variance) {
        check_size((who + "k_inverse rows").c_str(), b.centres.rows(), b.k_inverse.rows());
        check_size((who + "k_inverse columns").c_str(), b.centres.rows(), b.k_inverse.cols());
      }
    }
  }
}

SeBlock gp_mean_block(const gp::Gp& gp) {
  SeBlock b;
  b.centres = gp.training_inputs();
  if (b.centres.cols() != gp.input_dim()) b.centres.resize(0, gp.input_dim());
  b.weights = gp.size() > 0 ? gp.alpha() : VectorXd(0);
  const auto* se = dynamic_cast<const gp::SquaredExpArd*>(&gp.kernel());
  if (!se)
    throw InvalidArgument("pilco: moment matching needs GPs with the SE-ARD kernel, got '" +
                          gp.kernel().name() + "'");
  b.length_scales = se->length_scales;
  b.signal_variance = se->signal_variance;
  return b;
}

SeBlock gp_block(const gp::Gp& gp) {
  SeBlock b = gp_mean_block(gp);
  b.gp_variance = true;
  b.k_inverse = gp.inverse_covariance();
  return b;
}

SeModel gp_model(const std::vector<gp::Gp>& gps) {
  if (gps.empty()) throw InvalidArgument("gp_model: gps: expected at least 1 GP, got 0");
  SeModel m;
  m.input_dim = gps[0].input_dim();
  for (std::size_t a = 0; a < gps.size(); ++a) {
    check_size(("gp_model: input dimension of GP " + std::to_string(a)).c_str(), m.input_dim,
               gps[a].input_dim());
    m.outputs.push_back(SeOutput{{gp_block(gps[a])}});
  }
  return m;
}

SeModel gp_model_with_prior_mean(const std::vector<gp::Gp>& prior,
                                 const std::vector<gp::Gp>& residual) {
  check_size("gp_model_with_prior_mean: prior GPs (one per residual GP)",
             static_cast<long>(residual.size()), static_cast<long>(prior.size()));
  SeModel m = gp_model(residual);
  for (std::size_t a = 0; a < prior.size(); ++a) {
    check_size(
        ("gp_model_with_prior_mean: input dimension of prior GP " + std::to_string(a)).c_str(),
        m.input_dim, prior[a].input_dim());
    m.outputs[a].blocks.insert(m.outputs[a].blocks.begin(), gp_mean_block(prior[a]));
  }
  return m;
}

namespace {

// sigma_f^2 exp(-1/2 |(a_i - b_j) / l|^2) for the rows of A (na x D) and B (nb x D).
MatrixXd se_cross(const MatrixXd& A, const MatrixXd& B, const VectorXd& length_scales,
                  double signal_variance) {
  const VectorXd il = length_scales.cwiseInverse();
  const MatrixXd As = A * il.asDiagonal(), Bs = B * il.asDiagonal();
  MatrixXd D2 = (-2.0 * As * Bs.transpose()).colwise() + As.rowwise().squaredNorm();
  D2.rowwise() += Bs.rowwise().squaredNorm().transpose();
  return signal_variance * (-0.5 * D2.array().max(0.0)).exp().matrix();
}

}  // namespace

SeBlock fitc_block(const MatrixXd& X, const VectorXd& y, const MatrixXd& Z,
                   const VectorXd& length_scales, double signal_variance, double noise_variance,
                   double jitter) {
  const Index D = Z.cols(), N = X.rows(), M = Z.rows();
  if (M < 1) throw InvalidArgument("fitc_block: Z: expected at least 1 inducing input, got 0");
  check_size("fitc_block: X columns (input dimension of Z)", D, X.cols());
  check_size("fitc_block: y (rows of X)", N, y.size());
  check_size("fitc_block: length_scales (input dimension)", D, length_scales.size());
  if (!X.allFinite() || !y.allFinite() || !Z.allFinite())
    throw InvalidArgument("fitc_block: X, y and Z: expected finite values");
  if (!(length_scales.array() > 0).all() || !length_scales.allFinite())
    throw InvalidArgument("fitc_block: length_scales: expected finite values > 0");
  if (!(signal_variance > 0) || !std::isfinite(signal_variance) || !(noise_variance > 0) ||
      !std::isfinite(noise_variance) || !(jitter >= 0))
    throw InvalidArgument(
        "fitc_block: expected finite signal and noise variances > 0 and a jitter >= 0, got " +
        std::to_string(signal_variance) + ", " + std::to_string(noise_variance) + ", " +
        std::to_string(jitter));
  MatrixXd Kmm = se_cross(Z, Z, length_scales, signal_variance);
  Kmm.diagonal().setConstant(signal_variance);
  Eigen::LLT<MatrixXd> L;
  double j = jitter;
  for (;;) {
    MatrixXd K = Kmm;
    K.diagonal().array() += j * signal_variance;
    L.compute(K);
    if (L.info() == Eigen::Success) break;
    j = j > 0 ? 10 * j : 1e-10;
    if (j > 1e-2)
      throw NumericalError(
          "fitc_block: K(Z, Z) is not positive definite even with a jitter of "
          "1e-2 sigma_f^2 (repeated inducing inputs?)");
  }
  // V = L^-1 Kmn; Q_ii = |V_:i|^2; Lambda = diag(sigma_f^2 - Q_ii) + sigma_n^2 (>= sigma_n^2).
  MatrixXd V = se_cross(Z, X, length_scales, signal_variance);
  L.matrixL().solveInPlace(V);
  const VectorXd lam =
      (signal_variance - V.colwise().squaredNorm().transpose().array()).max(0.0) + noise_variance;
  const VectorXd isl = lam.array().rsqrt();
  const MatrixXd Vl = V * isl.asDiagonal();
  MatrixXd A = Vl * Vl.transpose();
  A.diagonal().array() += 1.0;
  Eigen::LLT<MatrixXd> LA(A);
  if (LA.info() != Eigen::Success)
    throw NumericalError("fitc_block: I + V Lambda^-1 V^T is not positive definite");
  // w = Sigma_m Kmn Lambda^-1 y = L^-T A^-1 Vl (y ./ sqrt(lam)); Kmm^-1 - Sigma_m = L^-T (I - A^-1)
  // L^-1.
  VectorXd w = LA.solve(Vl * y.cwiseProduct(isl));
  L.matrixU().solveInPlace(w);
  MatrixXd W = MatrixXd::Identity(M, M) - LA.solve(MatrixXd::Identity(M, M));
  L.matrixU().solveInPlace(W);  // L^-T (I - A^-1)
  W.transposeInPlace();         // (I - A^-1) L^-1
  L.matrixU().solveInPlace(W);  // L^-T (I - A^-1) L^-1
  SeBlock b;
  b.centres = Z;
  b.weights = std::move(w);
  b.length_scales = length_scales;
  b.signal_variance = signal_variance;
  b.gp_variance = true;
  b.k_inverse = 0.5 * (W + W.transpose());
  return b;
}

VectorXd block_values(const SeBlock& block, const MatrixXd& X) {
  check_size("block_values: X columns (the block's input dimension)", block.centres.cols(),
             X.cols());
  check_size("block_values: weights (centres)", block.centres.rows(), block.weights.size());
  check_size("block_values: length_scales (input dimension)", block.centres.cols(),
             block.length_scales.size());
  if (block.centres.rows() == 0) return VectorXd::Zero(X.rows());
  return se_cross(X, block.centres, block.length_scales, block.signal_variance) * block.weights;
}

Moments se_moments(const SeModel& model, const VectorXd& mu, const MatrixXd& sigma,
                   bool derivatives) {
  return detail::se_moments_impl(model, mu, sigma, derivatives, nullptr);
}

Moments detail::se_moments_impl(const SeModel& model, const VectorXd& mu, const MatrixXd& sigma,
                                bool input_derivatives,
                                std::vector<detail::BlockParamGradient>* params) {
  model.validate();
  detail::check_gaussian("se_moments", model.input_dim, mu, sigma);
  const Index D = model.input_dim;
  const Index E = model.output_dim();

  // Flat list of blocks with their state at mu.
  std::vector<BlockState> blocks;
  for (Index a = 0; a < E; ++a) {
    for (const SeBlock& blk : model.outputs[a].blocks) {
      if (params != nullptr && blk.gp_variance) {
        throw InvalidArgument(
            "se_moments: parameter derivatives: expected blocks without gp_variance, got one with");
      }
      BlockState st;
      st.block = &blk;
      st.output = static_cast<int>(a);
      st.index = static_cast<int>(blocks.size());
      st.lam = blk.length_scales.array().square().inverse();
      st.nu = blk.centres.rowwise() - mu.transpose();
      st.y = st.nu * st.lam.asDiagonal();
      st.logk =
          std::log(blk.signal_variance) - 0.5 * (st.nu.array() * st.y.array()).rowwise().sum();
      blocks.push_back(std::move(st));
    }
  }

  Moments out;
  out.mean = VectorXd::Zero(E);
  out.cov = MatrixXd::Zero(E, E);
  out.cross = MatrixXd::Zero(D, E);
  if (input_derivatives) {
    out.dmean_dmu = MatrixXd::Zero(E, D);
    out.dmean_dsigma = MatrixXd::Zero(E, D * D);
    out.dcov_dmu = MatrixXd::Zero(E * E, D);
    out.dcov_dsigma = MatrixXd::Zero(E * E, D * D);
    out.dcross_dmu = MatrixXd::Zero(D * E, D);
    out.dcross_dsigma = MatrixXd::Zero(D * E, D * D);
  }
  const Index F = E + E * E + D * E;  // rows of the parameter gradients
  if (params != nullptr) {
    params->clear();
    for (const BlockState& st : blocks) {
      const Index n = st.nu.rows();
      params->push_back({MatrixXd::Zero(F, n * D), MatrixXd::Zero(F, n), MatrixXd::Zero(F, D)});
    }
  }

  // The blocks of each output (their flat indices, in order): the unit of parallel work below, as
  // blocks of one output add into the same rows of `out`, blocks of different outputs into disjoint
  // ones (and each block into its own parameter gradient).
  std::vector<std::vector<int>> by_output(static_cast<std::size_t>(E));
  for (const BlockState& st : blocks) by_output[st.output].push_back(st.index);

  // First moments and cross-covariances: outputs in parallel, the blocks of an output in order.
  parallel_for(static_cast<std::size_t>(E), [&](std::size_t output) {
    for (const int index : by_output[output]) {
      const BlockState& st = blocks[index];
      const Index n = st.nu.rows();
      if (n == 0) continue;
      const SeBlock& blk = *st.block;
      const Index a = st.output;
      const VectorXd sq = st.lam.array().sqrt();
      const ScaledFactor f = factor_scaled(sigma, sq);
      const MatrixXd P = sq.asDiagonal() * f.inv * sq.asDiagonal();  // (Sigma + Lambda)^-1
      const MatrixXd s = st.nu * P;                                  // rows P nu_i
      const VectorXd q = (std::log(blk.signal_variance) - 0.5 * f.logdet -
                          0.5 * (s.array() * st.nu.array()).rowwise().sum())
                             .exp()
                             .matrix();
      const VectorXd wq = blk.weights.cwiseProduct(q);
      const double M = wq.sum();
      const VectorXd V = s.transpose() * wq;
      out.mean[a] += M;
      out.cross.col(a) += V;

      // dM/dSigma = 1/2 sum_i w_i q_i (s_i s_i^T - P); dV/dmu = 2 dM/dSigma.
      MatrixXd G = s.transpose() * wq.asDiagonal() * s - M * P;
      G *= 0.5;
      if (input_derivatives) {
        out.dmean_dmu.row(a) += V.transpose();
        out.dmean_dsigma.row(a) += detail::as_row(G);
        out.dcross_dmu.middleRows(D * a, D) += 2.0 * G;
        // dV_r/dSigma_kl = 1/2 sum_i w_i q_i s_ir s_ik s_il - 1/2 V_r P_kl - 1/2 (P_rk V_l + P_rl
        // V_k)
        for (Index r = 0; r < D; ++r) {
          MatrixXd H = s.transpose() * (wq.cwiseProduct(s.col(r))).asDiagonal() * s - V[r] * P -
                       P.col(r) * V.transpose() - V * P.row(r);
          H *= 0.5;
          out.dcross_dsigma.row(r + D * a) += detail::as_row(H);
        }
      }
      if (params != nullptr) {
        detail::BlockParamGradient& g = (*params)[st.index];
        const VectorXd Lam = blk.length_scales.array().square();
        // Mean: dM/dw = q, dM/dc_i = -w_i q_i s_i, dM/dlog l_d = sum_i w_i q_i (1 - L_d P_dd + L_d
        // s_id^2).
        g.d_weights.row(a) = q.transpose();
        const MatrixXd dX = -(s.array().colwise() * wq.array()).matrix();
        g.d_centres.row(a) = detail::as_row(dX);
        VectorXd dl(D);
        for (Index d = 0; d < D; ++d) {
          dl[d] =
              (wq.array() * (1.0 - Lam[d] * P(d, d) + Lam[d] * s.col(d).array().square())).sum();
        }
        g.d_log_length_scales.row(a) = dl.transpose();
        // Cross: dV/dw_i = q_i s_i, dV_r/dc_id = w_i q_i (P_rd - s_ir s_id),
        // dV/dLambda_dd = 1/2 sum_i w_i q_i s_id^2 s_i - 1/2 (P_dd - 1/Lambda_dd) V - P_:d V_d.
        MatrixXd dVl(D, D);  // column d: dV/dlog l_d
        for (Index d = 0; d < D; ++d) {
          const VectorXd t = s.transpose() * wq.cwiseProduct(s.col(d).cwiseAbs2());
          dVl.col(d) = 2.0 * Lam[d] * (0.5 * t - 0.5 * (P(d, d) - st.lam[d]) * V - P.col(d) * V[d]);
        }
        for (Index r = 0; r < D; ++r) {
          const Index row = E + E * E + r + D * a;
          g.d_weights.row(row) = q.cwiseProduct(s.col(r)).transpose();
          const MatrixXd dXr =
              wq * P.row(r) - (s.array().colwise() * wq.cwiseProduct(s.col(r)).array()).matrix();
          g.d_centres.row(row) = detail::as_row(dXr);
          g.d_log_length_scales.row(row) = dVl.row(r);
        }
      }
    }
  });

  // Second moments: every pair of blocks of outputs a <= b. The pairs of one output pair (a, b) add
  // into the same entries (S_ab, its derivative rows, rows E + a + E b of the blocks' parameter
  // gradients), those of different output pairs into disjoint ones: output pairs run in parallel,
  // the block pairs of each in the order of the serial loop, so the sums are the same bits for any
  // thread count (with E = 4 outputs, the 10 pairs dominate a PILCO step).
  std::vector<std::vector<std::pair<int, int>>> pairs;
  std::vector<int> pair_of(static_cast<std::size_t>(E * E), -1);
  for (const BlockState& A : blocks) {
    for (const BlockState& B : blocks) {
      if (B.output < A.output) continue;
      if (B.output == A.output && B.index < A.index) continue;
      int& k = pair_of[static_cast<std::size_t>(A.output + E * B.output)];
      if (k < 0) {
        k = static_cast<int>(pairs.size());
        pairs.emplace_back();
      }
      pairs[static_cast<std::size_t>(k)].emplace_back(A.index, B.index);
    }
  }
  parallel_for(pairs.size(), [&](std::size_t k) {
    for (const auto& [ia, ib] : pairs[k]) {
      const BlockState& A = blocks[static_cast<std::size_t>(ia)];
      const BlockState& B = blocks[static_cast<std::size_t>(ib)];
      const double mult = (A.output == B.output && A.index != B.index) ? 2.0 : 1.0;
      add_pair(A, B, mult, sigma, E, input_derivatives, out, params);
    }
  });

  // - M_a M_b and its derivatives.
  for (Index a = 0; a < E; ++a) {
    for (Index b = 0; b < E; ++b) {
      out.cov(a, b) -= out.mean[a] * out.mean[b];
      if (input_derivatives) {
        out.dcov_dmu.row(a + E * b) -=
            out.mean[b] * out.dmean_dmu.row(a) + out.mean[a] * out.dmean_dmu.row(b);
        out.dcov_dsigma.row(a + E * b) -=
            out.mean[b] * out.dmean_dsigma.row(a) + out.mean[a] * out.dmean_dsigma.row(b);
      }
    }
  }
  if (params != nullptr) {
    for (const BlockState& st : blocks) {
      detail::BlockParamGradient& g = (*params)[st.index];
      const Index a = st.output;
      for (Index b = 0; b < E; ++b) {
        // d(M_a M_b) through this block's parameters (which only move M_a): M_b dM_a, twice if b =
        // a.
        const double factor = (b == a) ? 2.0 * out.mean[a] : out.mean[b];
        auto subtract = [&](Index row) {
          g.d_centres.row(row) -= factor * g.d_centres.row(a);
          g.d_weights.row(row) -= factor * g.d_weights.row(a);
          g.d_log_length_scales.row(row) -= factor * g.d_log_length_scales.row(a);
        };
        subtract(E + a + E * b);
        if (b != a) subtract(E + b + E * a);
      }
    }
  }
  out.cov = 0.5 * (out.cov + out.cov.transpose());
  return out;
}

}  // namespace drops::pilco
