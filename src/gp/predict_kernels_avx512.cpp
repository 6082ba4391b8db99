// predict_block and pair_weights for avx512 (compiled with the flags set in CMakeLists.txt); see predict_kernels.inc.
#define DROPS_KERNEL_FN predict_block_avx512
#define DROPS_VECTOR_DOUBLES 8
#define DROPS_PAIR_FN pair_weights_avx512
#include "predict_kernels.inc"
