// predict_block and pair_weights for avx2 (compiled with the flags set in CMakeLists.txt); see predict_kernels.inc.
#define DROPS_KERNEL_FN predict_block_avx2
#define DROPS_VECTOR_DOUBLES 4
#define DROPS_PAIR_FN pair_weights_avx2
#include "predict_kernels.inc"
