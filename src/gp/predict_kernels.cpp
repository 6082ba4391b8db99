// Run-time choice of the predict_block variant (compiled for baseline x86-64).
#include "predict_kernels.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>

namespace drops::gp::kernels {

bool supported(Isa isa) {
  switch (isa) {
    case Isa::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") &&
             __builtin_cpu_supports("fma");
    case Isa::kAvx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::kGeneric:
      return true;
  }
  return false;
}

namespace {

/// The widest variant this CPU runs, or the one DROPS_GP_KERNEL names (avx512, avx2, generic)
/// when the CPU runs it: a way to measure on an AVX-512 host what an AVX2-only one gets. A value
/// that is not a variant, or one the CPU cannot run, is reported on stderr once and ignored.
Isa choose_isa() {
  const Isa widest = supported(Isa::kAvx512) ? Isa::kAvx512
                     : supported(Isa::kAvx2) ? Isa::kAvx2
                                             : Isa::kGeneric;
  const char* env = std::getenv("DROPS_GP_KERNEL");
  if (env == nullptr || *env == '\0') return widest;
  for (Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kGeneric}) {
    if (std::strcmp(env, isa_name(isa)) != 0) continue;
    if (supported(isa)) return isa;
    std::fprintf(stderr, "drops: DROPS_GP_KERNEL=%s: this CPU cannot run it; using %s\n", env,
                 isa_name(widest));
    return widest;
  }
  std::fprintf(stderr,
               "drops: DROPS_GP_KERNEL=%s is not avx512, avx2 or generic; using %s\n", env,
               isa_name(widest));
  return widest;
}

}  // namespace

Isa selected_isa() {
  static const Isa isa = choose_isa();
  return isa;
}

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::kAvx512: return "avx512";
    case Isa::kAvx2: return "avx2";
    case Isa::kGeneric: return "generic";
  }
  return "?";
}

void predict_block(Isa isa, const PredictArgs& args) {
  switch (isa) {
    case Isa::kAvx512: predict_block_avx512(args); return;
    case Isa::kAvx2: predict_block_avx2(args); return;
    case Isa::kGeneric: predict_block_generic(args); return;
  }
}

void predict_block(const PredictArgs& args) { predict_block(selected_isa(), args); }

void pair_weights(Isa isa, const PairArgs& args) {
  switch (isa) {
    case Isa::kAvx512: pair_weights_avx512(args); return;
    case Isa::kAvx2: pair_weights_avx2(args); return;
    case Isa::kGeneric: pair_weights_generic(args); return;
  }
}

void pair_weights(const PairArgs& args) { pair_weights(selected_isa(), args); }

}  // namespace drops::gp::kernels
