// The main() of every Google Benchmark program here. As in the drops command line, OpenBLAS runs
// each call on the calling thread (drops parallelises with TBB); otherwise OpenBLAS's own threads
// compete with TBB's workers and spin in sched_yield (measured: GP-MI learning at N = 500 on the
// pendubot twice as slow on 2 cores, half of its time in the kernel).
#include <benchmark/benchmark.h>

#include "drops/core/parallel.hpp"

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  drops::use_single_threaded_blas();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
