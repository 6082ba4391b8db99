#pragma once
// Hot kernels of Gp::predict_batch and of PILCO's moment matching (pair_weights), kept free of
// Eigen types so that it can be compiled for several instruction sets in one binary
// (src/gp/predict_kernels_*.cpp) while everything else, Eigen included, is compiled for baseline
// x86-64 (16-byte Eigen alignment, the same as Debian's DART). Internal header (not installed).
#include <cstddef>

namespace drops::gp::kernels {

/// Instruction-set variants of predict_block, best first.
enum class Isa { kAvx512, kAvx2, kGeneric };

/// Arguments of predict_block (all pointers non-null; raw column-major / row-major storage).
struct PredictArgs {
  const double* xa;  ///< n x d2 column-major (leading dimension n): rows [xs, -|xs|^2 / 2, 1]
  const double* lt;  ///< n x n column-major: column i = row i of the Cholesky factor L (i entries)
                     ///< followed by L(i, i) at index i
  const double* alpha;  ///< n: K^-1 y
  /// nullptr (every query uses alpha), or n x bp row-major: query c's own weights at column c
  /// (another right-hand side K^-1 y' on the same factorisation; padding columns are read)
  const double* alpha_lanes = nullptr;
  std::ptrdiff_t n;     ///< training points, >= 1
  std::ptrdiff_t d2;    ///< D + 2
  const double* qa;     ///< bp x d2 column-major (leading dimension bp): rows [q, 1, -|q|^2 / 2]
  std::ptrdiff_t used;  ///< queries to compute, the first `used` rows of qa (<= bp)
  std::ptrdiff_t bp;    ///< padded query count, a multiple of 8 (padding rows of qa are read)
  double sf2;           ///< signal variance sigma_f^2
  double* v;            ///< n x bp row-major scratch (overwritten: L^-1 k*, one query per column)
  double* mean;         ///< used: posterior means k*^T alpha
  double* ss;           ///< used: |L^-1 k*|^2 (the variance is sf2 - ss)
  /// nullptr (variances from every point, with lt), or the nv x nv factor of the last nv
  /// training points (rows var_first .. n - 1, var_first = n - nv), laid out as lt: ss is then
  /// |Lv^-1 k*_v|^2 (subset-of-data variance; Gp::set_variance_points)
  const double* lv = nullptr;
  std::ptrdiff_t var_first = 0;
  std::ptrdiff_t nv = 0;
  /// With lv: nullptr, or the subset in mirror pairs (Gp::set_variance_pairs, nv even): lv is
  /// then the nv / 2 x nv / 2 factor of A + B and lw that of A - B (laid out as lt), and ss is
  /// |Lv^-1 u|^2 + |Lw^-1 w|^2 with u, w = (k_1 +- k_2) / sqrt(2), k_1 and k_2 the two halves of
  /// the subset's kernel entries.
  const double* lw = nullptr;
};

/// For the first args.used queries: k* = sf2 exp(min(xa qa^T, 0)) (squared-exponential kernel
/// with the query), mean = k*^T alpha (or k*^T the query's column of alpha_lanes), forward
/// substitution L v = k* and ss = |v|^2 (with lv: Lv v = the last nv entries of k*; with lw as
/// well, the two half-size substitutions of the mirror pairs).
/// Queries are processed in packs of 8, 4 and 2 lanes (the rest after the packs of 8 padded to a
/// pack of 8 where that costs no more registers); every lane performs the same operations in
/// the same order in every pack width, so a query's results do not depend on the batch it came in
/// or its position in it. Results of different Isa variants differ at round-off (FMA or not).
void predict_block(const PredictArgs& args);

/// Arguments of pair_weights (PILCO's second moments of two SE blocks, src/pilco/se_model.cpp).
/// Column-major n_a x n_b matrices with leading dimension n_a.
struct PairArgs {
  const double* g;     ///< n_a x n_b: the bilinear part of log Q, a_i^T Lambda_B^-1 nu_j
  const double* la;    ///< n_a: the row terms of log Q
  const double* lb;    ///< n_b: the column terms of log Q
  const double* wa;    ///< n_a: block A's weights
  const double* wb;    ///< n_b: block B's weights
  double mult;         ///< multiplicity of the pair (1 or 2)
  const double* kinv;  ///< n_a x n_a: K^-1 when A is B with a variance term, else nullptr
  std::ptrdiff_t na;   ///< >= 1
  std::ptrdiff_t nb;   ///< >= 1
  double* q;           ///< n_a x n_b out: Q_ij = exp(g_ij + la_i + lb_j) (may be g)
  double* w;           ///< n_a x n_b out: W_ij = (mult wa_i) wb_j Q_ij [- kinv_ij Q_ij]
  double* row_sums;    ///< n_a out: sum_j W_ij
  double* col_sums;    ///< n_b out: sum_i W_ij
};

/// Q, W and W's row and column sums of one block pair in one pass (PILCO's second moments,
/// baselines.md §1a). Each column runs rows in packs of 8, 4, 2 and 1 in a fixed order, so the
/// results depend only on the inputs and the Isa variant (not on threads). exp overflows to +inf
/// above 709.78 and underflows to 0 below -708 (as a log Q that low contributes nothing).
void pair_weights(const PairArgs& args);
/// pair_weights with a given variant (tests). Precondition: supported(isa).
void pair_weights(Isa isa, const PairArgs& args);

/// The variant predict_block uses on this CPU (chosen once, by __builtin_cpu_supports: the
/// widest one, or the one the environment variable DROPS_GP_KERNEL names if the CPU runs it).
Isa selected_isa();
/// True when this CPU can run variant `isa`.
bool supported(Isa isa);
/// predict_block with a given variant (tests and benchmarks). Precondition: supported(isa).
void predict_block(Isa isa, const PredictArgs& args);
/// "avx512", "avx2" or "generic".
const char* isa_name(Isa isa);

// The variants (src/gp/predict_kernels_{avx512,avx2,generic}.cpp).
void predict_block_avx512(const PredictArgs& args);
void predict_block_avx2(const PredictArgs& args);
void predict_block_generic(const PredictArgs& args);
void pair_weights_avx512(const PairArgs& args);
void pair_weights_avx2(const PairArgs& args);
void pair_weights_generic(const PairArgs& args);

}  // namespace drops::gp::kernels
