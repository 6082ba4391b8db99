// Writes the reference trajectories of test_hexapod_prior_reference.cpp to stdout (issue 14, item
// 1: the prior's trajectories must stay what they were before the prior was made faster):
//
//   cd tasks/hexapod/tests/data
//   ../../../../build/tasks/hexapod/make_prior_reference $(git rev-parse HEAD) >
//   prior_reference.txt
//
// The checked-in data file was written by this program built from the commit named in its first
// line (main's code before the speed-ups, plus this program); the test reads it back and compares
// the current code with it. The cases are those of prior_reference_cases.hpp; each is written as a
// line "<name> <rows> 48" and its rows, every number with 17 significant digits.
#include <cstdio>

#include "prior_reference_cases.hpp"

int main(int argc, char** argv) {
  const char* commit = argc > 1 ? argv[1] : "unknown";
  std::printf("# prior reference, written by make_prior_reference built from commit %s\n", commit);
  for (const auto& c : drops::hexapod::testing::prior_reference_cases()) {
    std::printf("%s %d 48\n", c.name.c_str(), static_cast<int>(c.rows.rows()));
    for (Eigen::Index r = 0; r < c.rows.rows(); ++r) {
      for (Eigen::Index k = 0; k < c.rows.cols(); ++k)
        std::printf(k ? " %.17g" : "%.17g", c.rows(r, k));
      std::printf("\n");
    }
  }
  return 0;
}
