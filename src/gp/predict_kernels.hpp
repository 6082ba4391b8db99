#pragma once
// Hot kernel of Gp::predict_batch, kept free of Eigen types so that it can be compiled for several
// instruction sets in one binary (src/gp/predict_kernels_*.cpp) while everything else, Eigen
// included, is compiled for baseline x86-64 (16-byte Eigen alignment, the same as Debian's DART).
// Internal header (not installed).
#include <cstddef>

namespace drops::gp::kernels {

/// Instruction-set variants of predict_block, best first.
enum class Isa { kAvx512, kAvx2, kGeneric };

/// Arguments of predict_block (all pointers non-null; raw column-major / row-major storage).
struct PredictArgs {
  const double* xa;     ///< n x d2 column-major (leading dimension n): rows [xs, -|xs|^2 / 2, 1]
  const double* lt;     ///< n x n column-major: column i = row i of the Cholesky factor L (i entries)
                        ///< followed by L(i, i) at index i
  const double* alpha;  ///< n: K^-1 y
  std::ptrdiff_t n;     ///< training points, >= 1
  std::ptrdiff_t d2;    ///< D + 2
  const double* qa;     ///< bp x d2 column-major (leading dimension bp): rows [q, 1, -|q|^2 / 2]
  std::ptrdiff_t used;  ///< queries to compute, the first `used` rows of qa (<= bp)
  std::ptrdiff_t bp;    ///< padded query count, a multiple of 8 (padding rows of qa are read)
  double sf2;           ///< signal variance sigma_f^2
  double* v;            ///< n x bp row-major scratch (overwritten: L^-1 k*, one query per column)
  double* mean;         ///< used: posterior means k*^T alpha
  double* ss;           ///< used: |L^-1 k*|^2 (the variance is sf2 - ss)
};

/// For the first args.used queries: k* = sf2 exp(min(xa qa^T, 0)) (squared-exponential kernel
/// with the query), mean = k*^T alpha, forward substitution L v = k* and ss = |v|^2.
/// Queries are processed in packs of 8, 4 and 2 lanes; every lane performs the same operations in
/// the same order in every pack width, so a query's results do not depend on the batch it came in
/// or its position in it. Results of different Isa variants differ at round-off (FMA or not).
void predict_block(const PredictArgs& args);

/// The variant predict_block uses on this CPU (chosen once, by __builtin_cpu_supports).
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

}  // namespace drops::gp::kernels
