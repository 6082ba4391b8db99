// The main() of every test program: OpenBLAS on the calling thread, as in the drops command line
// (drops::use_single_threaded_blas), then GoogleTest.
#include <gtest/gtest.h>

#include "drops/core/parallel.hpp"

int main(int argc, char** argv) {
  drops::use_single_threaded_blas();
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
