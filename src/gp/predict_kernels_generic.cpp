// predict_block for baseline x86-64 (SSE2, no FMA); see predict_kernels.inc.
#define DROPS_KERNEL_FN predict_block_generic
#include "predict_kernels.inc"
