#pragma once
/// \file The one helper through which drops runs parallel loops (oneTBB). The number of threads is
/// set by the application with ThreadLimit; the library never spawns threads elsewhere.

#include <cstddef>
#include <functional>
#include <memory>

namespace drops {

/// Calls body(i) for every i in [0, n), in parallel over the TBB arena. body must only write state
/// owned by index i (results are reduced by the caller after the loop). Exceptions thrown by body are
/// rethrown in the caller (the first one). Thread-safe.
void parallel_for(std::size_t n, const std::function<void(std::size_t)>& body);

/// RAII limit on the number of worker threads used by parallel_for while the object lives
/// (tbb::global_control). threads >= 1; 0 means "all hardware threads". Create on the main thread.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Number of hardware threads TBB would use by default.
int hardware_threads();

/// Makes OpenBLAS (Eigen's backend for large products and the Cholesky factorization, when drops
/// was built with it, DROPS_BLAS) run each of its calls on the calling thread: drops parallelises
/// over GPs, rollouts and candidates with parallel_for, and one thread per BLAS call keeps results
/// independent of the machine's core count. This changes a process-wide OpenBLAS setting, so the
/// library never calls it by itself: applications call it once from main() (the drops command
/// line and the test programs do). Does nothing in a build without OpenBLAS. Not thread-safe.
void use_single_threaded_blas();

}  // namespace drops
