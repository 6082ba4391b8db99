#include "drops/core/parallel.hpp"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#ifdef DROPS_TSAN
#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>
#endif

#ifdef DROPS_WITH_OPENBLAS
extern "C" void openblas_set_num_threads(int num_threads);
#endif

namespace drops {

#ifdef DROPS_TSAN
// ThreadSanitizer build (DROPS_SANITIZE=thread): Debian's oneTBB is not instrumented, so TSan
// cannot see its scheduler's synchronisation and would report every hand-over of data between the
// loop and its caller. The same loop on std::threads (whose start and join TSan sees), as many as
// TBB would use, each taking the next item: what TSan checks, that items running at the same time
// share no unsynchronised state, is unchanged.
void parallel_for(std::size_t n, const std::function<void(std::size_t)>& body) {
  if (n == 0) return;
  const std::size_t threads = std::min<std::size_t>(
      n, tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  if (threads <= 1) {
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  auto work = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < n;) {
      try {
        body(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}
#else
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
#endif

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
