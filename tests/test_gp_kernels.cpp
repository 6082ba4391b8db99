// The GP prediction kernel variants (src/gp/predict_kernels*.cpp): each supported instruction set
// agrees with the baseline one at round-off, and within a variant a query's results do not depend
// on the batch it came in (bit for bit).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <string>
#include <vector>

#include "drops/core/rng.hpp"
#include "gp/predict_kernels.hpp"

namespace {

using drops::Rng;
using drops::gp::kernels::Isa;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// PredictArgs for `count` queries (qa: bp rows, padded) on n training points, every variance
// from every point (lt); v, mean and ss sized by the caller.
drops::gp::kernels::PredictArgs Args(const MatrixXd& xa, const MatrixXd& lt, const VectorXd& alpha,
                                     const MatrixXd& qa, int count, int bp, double sf2,
                                     std::vector<double>& v, std::vector<double>& mean,
                                     std::vector<double>& ss) {
  drops::gp::kernels::PredictArgs a;
  a.xa = xa.data();
  a.lt = lt.data();
  a.alpha = alpha.data();
  a.n = xa.rows();
  a.d2 = xa.cols();
  a.qa = qa.data();
  a.used = count;
  a.bp = bp;
  a.sf2 = sf2;
  a.v = v.data();
  a.mean = mean.data();
  a.ss = ss.data();
  return a;
}

// A positive definite problem in the layout predict_block expects (see PredictArgs).
struct Problem {
  int n = 60, d2 = 6, queries = 20;
  MatrixXd xa, lt, qa;  // qa: padded to 24 rows
  VectorXd alpha;
  explicit Problem(Rng& rng) {
    const int D = d2 - 2;
    MatrixXd X(n, D), Q(queries, D);
    for (int i = 0; i < n; ++i)
      for (int d = 0; d < D; ++d) X(i, d) = rng.uniform(-1.0, 1.0);
    for (int i = 0; i < queries; ++i)
      for (int d = 0; d < D; ++d) Q(i, d) = rng.uniform(-1.5, 1.5);
    xa.resize(n, d2);
    xa << X, -0.5 * X.rowwise().squaredNorm(), VectorXd::Ones(n);
    qa = MatrixXd::Zero(24, d2);
    qa.topRows(queries) << Q, VectorXd::Ones(queries), -0.5 * Q.rowwise().squaredNorm();
    MatrixXd K(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) K(i, j) = std::exp(-0.5 * (X.row(i) - X.row(j)).squaredNorm());
    K.diagonal().array() += 0.01;
    MatrixXd L = K.llt().matrixL();
    L.triangularView<Eigen::StrictlyUpper>() = L.transpose();
    lt = L;
    alpha.resize(n);
    for (int i = 0; i < n; ++i) alpha[i] = rng.uniform(-1.0, 1.0);
  }
  // Queries [first, first + count) through `isa`.
  void run(Isa isa, int first, int count, std::vector<double>& mean,
           std::vector<double>& ss) const {
    const int bp = (count + 7) / 8 * 8;
    MatrixXd q = MatrixXd::Zero(bp, d2);
    q.topRows(count) = qa.middleRows(first, count);
    std::vector<double> v(static_cast<std::size_t>(n * bp));
    mean.assign(static_cast<std::size_t>(count), 0.0);
    ss.assign(static_cast<std::size_t>(count), 0.0);
    drops::gp::kernels::predict_block(isa, Args(xa, lt, alpha, q, count, bp, 1.3, v, mean, ss));
  }
};

TEST(GpKernels, EverySupportedVariantMatchesBaselineAndIgnoresTheBatchSplit) {
  Rng rng(3);
  const Problem p(rng);
  std::vector<double> ref_m, ref_s;
  p.run(Isa::kGeneric, 0, p.queries, ref_m, ref_s);
  for (const Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kGeneric}) {
    if (!drops::gp::kernels::supported(isa)) continue;
    SCOPED_TRACE(drops::gp::kernels::isa_name(isa));
    std::vector<double> all_m, all_s, m, s;
    p.run(isa, 0, p.queries, all_m, all_s);
    for (int q = 0; q < p.queries; ++q) {
      EXPECT_NEAR(all_m[q], ref_m[q], 1e-12 * (1.0 + std::abs(ref_m[q]))) << "q=" << q;
      EXPECT_NEAR(all_s[q], ref_s[q], 1e-12 * (1.0 + std::abs(ref_s[q]))) << "q=" << q;
    }
    // Every split into a first query and a count (packs of 8, 4, 2 and a lone query) gives the same
    // bits as the whole batch.
    for (int first = 0; first < p.queries; ++first)
      for (int count = 1; first + count <= p.queries; ++count) {
        p.run(isa, first, count, m, s);
        for (int q = 0; q < count; ++q) {
          ASSERT_EQ(m[q], all_m[first + q])
              << "first=" << first << " count=" << count << " q=" << q;
          ASSERT_EQ(s[q], all_s[first + q])
              << "first=" << first << " count=" << count << " q=" << q;
        }
      }
  }
}

// The forward substitution L v = k* does, per lane, exactly the operations predict_kernels.inc
// documents (four accumulators a_(k mod 4) for k < 4 floor(i / 4), then a_0 for the rest in
// order, v_i = ((a_0 + a_2) + (a_1 + a_3)) / L(i, i), ss += v_i^2), whatever blocks of rows the
// variant runs side by side: checked bit for bit against a scalar loop, with std::fma where the AVX
// variants contract (-ffp-contract=fast) and plain operations for the generic one. k* comes from
// the same kernel with L = I (then v = k* exactly). n = 61 leaves rows outside every block;
// counts 1..20 take every pack path (8, padded rest, 4, 2, a lone query).
TEST(GpKernels, ForwardSubstitutionIsTheDocumentedLoopBitForBitInEveryVariant) {
  Rng rng(9);
  const int n = 61, D = 5, d2 = D + 2, queries = 20, bp = 24;
  MatrixXd X(n, D), Q(queries, D);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < D; ++d) X(i, d) = rng.uniform(-1.0, 1.0);
  for (int i = 0; i < queries; ++i)
    for (int d = 0; d < D; ++d) Q(i, d) = rng.uniform(-1.0, 1.0);
  MatrixXd xa(n, d2), qa = MatrixXd::Zero(bp, d2);
  xa << X, -0.5 * X.rowwise().squaredNorm(), VectorXd::Ones(n);
  VectorXd alpha(n);
  for (int i = 0; i < n; ++i) alpha[i] = rng.uniform(-1.0, 1.0);
  // L: lower triangular, diagonal in [1, 2]; lt holds row i of L in its column i.
  MatrixXd L = MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < i; ++k) L(i, k) = rng.uniform(-0.3, 0.3);
    L(i, i) = rng.uniform(1.0, 2.0);
  }
  const MatrixXd lt = L.transpose(), eye = MatrixXd::Identity(n, n);
  for (const Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kGeneric}) {
    if (!drops::gp::kernels::supported(isa)) continue;
    SCOPED_TRACE(drops::gp::kernels::isa_name(isa));
    const bool fused = isa != Isa::kGeneric;
    auto sub = [fused](double a, double l, double v) { return fused ? std::fma(-l, v, a) : a - l * v; };
    for (int count = 1; count <= queries; ++count) {
      qa.setZero();
      qa.topRows(count) << Q.topRows(count), VectorXd::Ones(count),
          -0.5 * Q.topRows(count).rowwise().squaredNorm();
      auto run = [&](const MatrixXd& factor, std::vector<double>& v, std::vector<double>& ss) {
        std::vector<double> mean(static_cast<std::size_t>(count));
        v.assign(static_cast<std::size_t>(n * bp), 0.0);
        ss.assign(static_cast<std::size_t>(count), 0.0);
        drops::gp::kernels::PredictArgs a;
        a.xa = xa.data();
        a.lt = factor.data();
        a.alpha = alpha.data();
        a.n = n;
        a.d2 = d2;
        a.qa = qa.data();
        a.used = count;
        a.bp = bp;
        a.sf2 = 1.7;
        a.v = v.data();
        a.mean = mean.data();
        a.ss = ss.data();
        drops::gp::kernels::predict_block(isa, a);
      };
      std::vector<double> k, ss_eye, v, ss;
      run(eye, k, ss_eye);
      run(lt, v, ss);
      for (int q = 0; q < count; ++q) {
        std::vector<double> ref(static_cast<std::size_t>(n));
        double ss_ref = 0.0;
        for (int i = 0; i < n; ++i) {
          double a0 = k[static_cast<std::size_t>(i * bp + q)], a1 = 0.0, a2 = 0.0, a3 = 0.0;
          const int g = i / 4 * 4;
          for (int j = 0; j < g; j += 4) {
            a0 = sub(a0, L(i, j), ref[static_cast<std::size_t>(j)]);
            a1 = sub(a1, L(i, j + 1), ref[static_cast<std::size_t>(j + 1)]);
            a2 = sub(a2, L(i, j + 2), ref[static_cast<std::size_t>(j + 2)]);
            a3 = sub(a3, L(i, j + 3), ref[static_cast<std::size_t>(j + 3)]);
          }
          for (int j = g; j < i; ++j) a0 = sub(a0, L(i, j), ref[static_cast<std::size_t>(j)]);
          a0 = a0 + a2;
          a1 = a1 + a3;
          const double vi = (a0 + a1) / L(i, i);
          ref[static_cast<std::size_t>(i)] = vi;
          ss_ref = fused ? std::fma(vi, vi, ss_ref) : ss_ref + vi * vi;
          ASSERT_EQ(v[static_cast<std::size_t>(i * bp + q)], vi)
              << "count=" << count << " q=" << q << " row " << i;
        }
        ASSERT_EQ(ss[static_cast<std::size_t>(q)], ss_ref) << "count=" << count << " q=" << q;
      }
    }
  }
}

// The variance subset in mirror pairs (PredictArgs::lw): the last 2h training points are h
// points and their reflections (signs flipped on some inputs), so the subset's K is
// [[A, B], [B, A]] and the factors of A + B and A - B must give the ss of the dense subset
// factor, to round-off, in every variant; and, as everywhere, the same bits whatever the split.
TEST(GpKernels, MirrorPairSubsetGivesTheDenseSubsetsVariancesInEveryVariant) {
  Rng rng(17);
  const int r = 13, h = 9, n = r + 2 * h, D = 4, d2 = D + 2, queries = 19, bp = 24;
  MatrixXd X(n, D), Q(queries, D);
  for (int i = 0; i < r + h; ++i)
    for (int d = 0; d < D; ++d) X(i, d) = rng.uniform(-1.0, 1.0);
  for (int i = 0; i < h; ++i)
    for (int d = 0; d < D; ++d) X(r + h + i, d) = (d % 2 == 0 ? -1.0 : 1.0) * X(r + i, d);
  for (int i = 0; i < queries; ++i)
    for (int d = 0; d < D; ++d) Q(i, d) = rng.uniform(-1.5, 1.5);
  MatrixXd xa(n, d2), qa = MatrixXd::Zero(bp, d2);
  xa << X, -0.5 * X.rowwise().squaredNorm(), VectorXd::Ones(n);
  qa.topRows(queries) << Q, VectorXd::Ones(queries), -0.5 * Q.rowwise().squaredNorm();
  MatrixXd K(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) K(i, j) = std::exp(-0.5 * (X.row(i) - X.row(j)).squaredNorm());
  K.diagonal().array() += 0.01;
  auto laid_out = [](const MatrixXd& M) {  // lower Cholesky factor, rows contiguous (as lt)
    MatrixXd L = M.llt().matrixL();
    L.triangularView<Eigen::StrictlyUpper>() = L.transpose();
    return L;
  };
  const MatrixXd lt = laid_out(K), lv = laid_out(K.bottomRightCorner(2 * h, 2 * h));
  const MatrixXd A = K.block(r, r, h, h), B = K.block(r + h, r, h, h);
  const MatrixXd lp = laid_out(A + B), lm = laid_out(A - B);
  VectorXd alpha(n);
  for (int i = 0; i < n; ++i) alpha[i] = rng.uniform(-1.0, 1.0);
  auto run = [&](Isa isa, bool paired, int first, int count, std::vector<double>& mean,
                 std::vector<double>& ss) {
    MatrixXd q = MatrixXd::Zero(bp, d2);
    q.topRows(count) = qa.middleRows(first, count);
    std::vector<double> v(static_cast<std::size_t>(n * bp));
    mean.assign(static_cast<std::size_t>(count), 0.0);
    ss.assign(static_cast<std::size_t>(count), 0.0);
    drops::gp::kernels::PredictArgs a = Args(xa, lt, alpha, q, count, bp, 1.0, v, mean, ss);
    a.lv = paired ? lp.data() : lv.data();
    a.lw = paired ? lm.data() : nullptr;
    a.var_first = r;
    a.nv = 2 * h;
    drops::gp::kernels::predict_block(isa, a);
  };
  for (const Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kGeneric}) {
    if (!drops::gp::kernels::supported(isa)) continue;
    SCOPED_TRACE(drops::gp::kernels::isa_name(isa));
    std::vector<double> dm, ds, pm, ps, m, s;
    run(isa, false, 0, queries, dm, ds);
    run(isa, true, 0, queries, pm, ps);
    double smallest = 1.0;
    for (int q = 0; q < queries; ++q) {
      EXPECT_EQ(pm[q], dm[q]) << "q=" << q;
      EXPECT_NEAR(ps[q], ds[q], 1e-12) << "q=" << q;
      smallest = std::min(smallest, 1.0 - ds[q]);
    }
    EXPECT_GT(smallest, -1e-12);
    for (int first = 0; first < queries; first += 3)
      for (int count = 1; first + count <= queries; count += 2) {
        run(isa, true, first, count, m, s);
        for (int q = 0; q < count; ++q) ASSERT_EQ(s[q], ps[first + q]) << first << " " << count;
      }
  }
}

// pair_weights (PILCO's block-pair second moments) against a plain loop with std::exp, for every
// supported variant: odd sizes that use packs of 8, 4, 2 and a lone row, with and without K^-1,
// log Q from -800 (underflow to 0) through 0 to 720 (overflow to +inf).
TEST(GpKernels, PairWeightsMatchAPlainLoopInEveryVariant) {
  Rng rng(5);
  for (const bool with_kinv : {false, true}) {
    const int na = 15, nb = with_kinv ? na : 13;
    MatrixXd g(na, nb), kinv(na, na);
    VectorXd la(na), lb(nb), wa(na), wb(nb);
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < nb; ++j) g(i, j) = rng.uniform(-30.0, 8.0);
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < na; ++j) kinv(i, j) = rng.uniform(-1.0, 1.0);
    for (int i = 0; i < na; ++i) la[i] = rng.uniform(-2.0, 2.0), wa[i] = rng.uniform(-1.0, 1.0);
    for (int j = 0; j < nb; ++j) lb[j] = rng.uniform(-2.0, 2.0), wb[j] = rng.uniform(-1.0, 1.0);
    g(1, 0) = -800.0;   // exp -> 0
    g(14, 2) = -705.0;  // just inside the range
    g(3, 4) = 0.0;
    g(5, 6) = 700.0;  // large but finite
    g(7, 7) = 720.0;  // exp -> +inf
    const double mult = 2.0;
    MatrixXd q_ref(na, nb), w_ref(na, nb);
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < nb; ++j) {
        const double x = g(i, j) + la[i] + lb[j];
        q_ref(i, j) = x < -708.0 ? 0.0 : std::exp(x);
        w_ref(i, j) =
            q_ref(i, j) * (wa[i] * mult) * wb[j] - (with_kinv ? kinv(i, j) * q_ref(i, j) : 0.0);
      }
    for (const Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kGeneric}) {
      if (!drops::gp::kernels::supported(isa)) continue;
      SCOPED_TRACE(std::string(drops::gp::kernels::isa_name(isa)) + (with_kinv ? " K^-1" : ""));
      MatrixXd q = g, w(na, nb);  // q overwrites g, as in se_model.cpp
      VectorXd r(na), c(nb);
      drops::gp::kernels::PairArgs a;
      a.g = q.data();
      a.la = la.data();
      a.lb = lb.data();
      a.wa = wa.data();
      a.wb = wb.data();
      a.mult = mult;
      a.kinv = with_kinv ? kinv.data() : nullptr;
      a.na = na;
      a.nb = nb;
      a.q = q.data();
      a.w = w.data();
      a.row_sums = r.data();
      a.col_sums = c.data();
      drops::gp::kernels::pair_weights(isa, a);
      EXPECT_EQ(q(1, 0), 0.0);
      EXPECT_TRUE(std::isinf(q(7, 7)) && q(7, 7) > 0);
      for (int i = 0; i < na; ++i)
        for (int j = 0; j < nb; ++j) {
          if (i == 7 && j == 7) continue;
          ASSERT_NEAR(q(i, j), q_ref(i, j), 1e-15 * q_ref(i, j)) << i << "," << j;
          ASSERT_NEAR(w(i, j), w_ref(i, j), 1e-15 * (std::abs(w_ref(i, j)) + q_ref(i, j)))
              << i << "," << j;
        }
      // The sums, on the finite part (column 7 and row 7 hold the +inf entry).
      for (int i = 0; i < na; ++i) {
        if (i == 7) continue;
        const double ref = w_ref.row(i).sum();
        EXPECT_NEAR(r[i], ref, 1e-14 * w_ref.row(i).cwiseAbs().sum()) << i;
      }
      for (int j = 0; j < nb; ++j) {
        if (j == 7) continue;
        const double ref = w_ref.col(j).sum();
        EXPECT_NEAR(c[j], ref, 1e-14 * w_ref.col(j).cwiseAbs().sum()) << j;
      }
    }
  }
}

TEST(GpKernels, SelectedVariantIsSupported) {
  EXPECT_TRUE(drops::gp::kernels::supported(drops::gp::kernels::selected_isa()));
  EXPECT_TRUE(drops::gp::kernels::supported(Isa::kGeneric));
}

}  // namespace
