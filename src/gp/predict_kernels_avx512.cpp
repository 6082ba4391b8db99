// predict_block for avx512 (compiled with the flags set in CMakeLists.txt); see predict_kernels.inc.
#define DROPS_KERNEL_FN predict_block_avx512
#include "predict_kernels.inc"
