// predict_block and pair_weights for baseline x86-64 (SSE2, no FMA); see predict_kernels.inc.
#define DROPS_KERNEL_FN predict_block_generic
#define DROPS_VECTOR_DOUBLES 2
#define DROPS_PAIR_FN pair_weights_generic
#include "predict_kernels.inc"
