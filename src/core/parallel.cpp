#include "drops/core/parallel.hpp"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#ifdef DROPS_WITH_OPENBLAS
extern "C" void openblas_set_num_threads(int num_threads);
#endif

namespace drops {

void parallel_for(std::size_t n, const std::function<void(std::size_t)>& body) {
  if (n == 0) return;
  if (n == 1) {
    body(0);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
                    },
                    // Items are coarse (a batch of rollouts, one output GP): split down to single
                    // items so that few items still spread over every thread.
                    tbb::simple_partitioner());
}

struct ThreadLimit::Impl {
  tbb::global_control control;
  explicit Impl(int threads)
      : control(tbb::global_control::max_allowed_parallelism,
                static_cast<std::size_t>(threads > 0 ? threads : hardware_threads())) {}
};

ThreadLimit::ThreadLimit(int threads) : impl_(std::make_unique<Impl>(threads)) {}
ThreadLimit::~ThreadLimit() = default;

int hardware_threads() { return tbb::info::default_concurrency(); }

void use_single_threaded_blas() {
#ifdef DROPS_WITH_OPENBLAS
  openblas_set_num_threads(1);
#endif
}

}  // namespace drops
