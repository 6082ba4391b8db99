// Tests of the MAP-Elites grid archive: the floor binning convention, cell arithmetic, the strict
// and epsilon insertion rules, and the archive file (round trip, rejection of bad files).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/ite/archive.hpp"
#include "drops/ite/archive_io.hpp"

namespace {

using drops::InvalidArgument;
using drops::Rng;
using drops::VectorXd;
using namespace drops::ite;

VectorXd Vec(std::initializer_list<double> v) {
  VectorXd x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double e : v) x[i++] = e;
  return x;
}

TEST(Binning, EqualWidthBinsWithTheUpperEdgeInTheLastBin) {
  // n = 5: [0, .2), [.2, .4), [.4, .6), [.6, .8), [.8, 1].
  EXPECT_EQ(bin_index(0.0, 5), 0);
  EXPECT_EQ(bin_index(0.199999, 5), 0);
  EXPECT_EQ(bin_index(0.2, 5), 1);
  EXPECT_EQ(bin_index(0.5, 5), 2);
  EXPECT_EQ(bin_index(0.799999, 5), 3);
  EXPECT_EQ(bin_index(0.8, 5), 4);
  EXPECT_EQ(bin_index(1.0, 5), 4);
  EXPECT_EQ(bin_index(1.0, 1), 0);
  // Interior points of bin i (i + u) / n, u in [0.01, 0.99], fall in bin i for many n.
  Rng rng(5);
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 40);
    const int i = static_cast<int>(rng() % static_cast<unsigned>(n));
    const double b = (i + rng.uniform(0.01, 0.99)) / n;
    EXPECT_EQ(bin_index(b, n), i) << "b = " << b << ", n = " << n;
  }
}

TEST(Binning, EveryCentreLiesInItsOwnBin) {
  for (int n = 1; n <= 60; ++n) {
    for (int i = 0; i < n; ++i) {
      EXPECT_DOUBLE_EQ(bin_centre(i, n), (i + 0.5) / n);
      EXPECT_EQ(bin_index(bin_centre(i, n), n), i);
    }
  }
}

TEST(Binning, RejectsValuesOutsideTheUnitIntervalAndBadCounts) {
  EXPECT_THROW(bin_index(-1e-12, 5), InvalidArgument);
  EXPECT_THROW(bin_index(1.0 + 1e-12, 5), InvalidArgument);
  EXPECT_THROW(bin_index(std::numeric_limits<double>::quiet_NaN(), 5), InvalidArgument);
  EXPECT_THROW(bin_index(0.5, 0), InvalidArgument);
  EXPECT_THROW(bin_centre(5, 5), InvalidArgument);
  EXPECT_THROW(bin_centre(-1, 5), InvalidArgument);
}

TEST(Archive, LinearIndexIsRowMajorAndInvertible) {
  Archive a({3, 4, 5}, 2);
  EXPECT_EQ(a.total_cells(), 60);
  EXPECT_EQ(a.linear_index({0, 0, 0}), 0);
  EXPECT_EQ(a.linear_index({0, 0, 1}), 1);
  EXPECT_EQ(a.linear_index({0, 1, 0}), 5);
  EXPECT_EQ(a.linear_index({1, 0, 0}), 20);
  EXPECT_EQ(a.linear_index({2, 3, 4}), 59);
  for (std::int64_t i = 0; i < a.total_cells(); ++i) {
    EXPECT_EQ(a.linear_index(a.cell_from_linear(i)), i);
    // the centre of every cell bins back into it
    EXPECT_EQ(a.cell_of(a.cell_centre(a.cell_from_linear(i))), a.cell_from_linear(i));
  }
  EXPECT_THROW(a.linear_index({3, 0, 0}), InvalidArgument);
  EXPECT_THROW(a.linear_index({0, 0}), InvalidArgument);
  EXPECT_THROW(a.cell_from_linear(60), InvalidArgument);
  EXPECT_THROW(Archive({}, 2), InvalidArgument);
  EXPECT_THROW(Archive({3, 0}, 2), InvalidArgument);
  EXPECT_THROW(Archive({3, 3}, 0), InvalidArgument);
}

TEST(Archive, StrictElitismReplacesOnlyAStrictlyFitterCandidate) {
  Archive a(2, 4, 1);
  EXPECT_EQ(a.insert(Vec({1}), 1.0, Vec({0.3, 0.9})), InsertOutcome::kNewCell);
  ASSERT_NE(a.find({1, 3}), nullptr);
  EXPECT_EQ(a.find({1, 2}), nullptr);
  EXPECT_EQ(a.insert(Vec({2}), 1.0, Vec({0.26, 0.76})), InsertOutcome::kRejected);  // tie
  EXPECT_EQ(a.insert(Vec({3}), 0.5, Vec({0.3, 0.9})), InsertOutcome::kRejected);
  EXPECT_EQ(a.find({1, 3})->theta[0], 1.0);
  EXPECT_EQ(a.insert(Vec({4}), 1.5, Vec({0.49, 0.75})), InsertOutcome::kReplaced);
  const Elite* e = a.find({1, 3});
  EXPECT_EQ(e->theta[0], 4.0);
  EXPECT_EQ(e->fitness, 1.5);
  EXPECT_EQ(e->descriptor, Vec({0.49, 0.75}));
  EXPECT_EQ(a.size(), 1u);
  EXPECT_DOUBLE_EQ(a.coverage(), 1.0 / 16.0);
  EXPECT_EQ(a.insert(Vec({5}), -3.0, Vec({1.0, 0.0})), InsertOutcome::kNewCell);
  EXPECT_EQ(a.elites()[1].cell, (Cell{3, 0}));
  EXPECT_EQ(a.best().theta[0], 4.0);
}

TEST(Archive, EpsilonRulePrefersTheCandidateNearerTheCentreWithinEpsilon) {
  // Cell (1, 1) of a 4 x 4 grid: [0.25, 0.5)^2, centre (0.375, 0.375).
  const double eps = 0.05;
  Archive a(2, 4, 1);
  ASSERT_EQ(a.insert(Vec({1}), 1.0, Vec({0.30, 0.30}), InsertionRule::kEpsilon, eps),
            InsertOutcome::kNewCell);
  // Within epsilon and farther from the centre: kept.
  EXPECT_EQ(a.insert(Vec({2}), 1.04, Vec({0.26, 0.26}), InsertionRule::kEpsilon, eps),
            InsertOutcome::kRejected);
  // Within epsilon, slightly worse but nearer the centre: replaced (fitness decreases).
  EXPECT_EQ(a.insert(Vec({3}), 0.96, Vec({0.37, 0.38}), InsertionRule::kEpsilon, eps),
            InsertOutcome::kReplaced);
  EXPECT_EQ(a.find({1, 1})->fitness, 0.96);
  // Worse by more than epsilon, even at the centre: kept.
  EXPECT_EQ(a.insert(Vec({4}), 0.90, Vec({0.375, 0.375}), InsertionRule::kEpsilon, eps),
            InsertOutcome::kRejected);
  // Better by more than epsilon, even far from the centre: replaced.
  EXPECT_EQ(a.insert(Vec({5}), 1.02, Vec({0.26, 0.49}), InsertionRule::kEpsilon, eps),
            InsertOutcome::kReplaced);
  EXPECT_EQ(a.find({1, 1})->theta[0], 5.0);
  // The same sequence under strict elitism keeps whatever is fitter.
  Archive s(2, 4, 1);
  s.insert(Vec({1}), 1.0, Vec({0.30, 0.30}));
  EXPECT_EQ(s.insert(Vec({2}), 1.04, Vec({0.26, 0.26})), InsertOutcome::kReplaced);
  EXPECT_EQ(s.insert(Vec({3}), 0.96, Vec({0.37, 0.38})), InsertOutcome::kRejected);
}

TEST(Archive, InsertRejectsInvalidCandidatesWithoutChangingTheArchive) {
  Archive a(2, 4, 2);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(a.insert(Vec({0, 0}), nan, Vec({0.5, 0.5})), InvalidArgument);
  EXPECT_THROW(a.insert(Vec({0, 0}), 1.0, Vec({0.5, nan})), InvalidArgument);
  EXPECT_THROW(a.insert(Vec({0, 0}), 1.0, Vec({0.5, 1.5})), InvalidArgument);
  EXPECT_THROW(a.insert(Vec({0, 0}), 1.0, Vec({0.5})), InvalidArgument);
  EXPECT_THROW(a.insert(Vec({0}), 1.0, Vec({0.5, 0.5})), InvalidArgument);
  EXPECT_THROW(a.insert(Vec({0, nan}), 1.0, Vec({0.5, 0.5})), InvalidArgument);
  EXPECT_TRUE(a.empty());
}

// An archive with awkward values: thirds, tiny and huge magnitudes, negative fitness.
Archive AwkwardArchive(std::uint64_t seed) {
  Archive a({7, 5, 3}, 4);
  Rng rng(seed);
  for (int i = 0; i < 300; ++i) {
    VectorXd d(3), theta(4);
    for (int j = 0; j < 3; ++j) d[j] = (i % 17 == 0) ? (j == 0 ? 1.0 : 0.0) : rng.uniform();
    theta << rng.uniform(-1, 1) / 3.0, 1e-300 * rng.uniform(), 1e300 * rng.uniform(-1, 1),
        std::nextafter(1.0, 2.0);
    a.insert(theta, -std::exp(rng.uniform(-30, 30)), d);
  }
  return a;
}

TEST(ArchiveFile, WriteThenReadGivesAnIdenticalArchive) {
  const Archive a = AwkwardArchive(11);
  ASSERT_GT(a.size(), 50u);
  std::stringstream file;
  write_archive(file, a);
  const std::string text = file.str();
  const Archive b = read_archive(file);
  EXPECT_TRUE(b == a);
  EXPECT_EQ(b.bins(), a.bins());
  EXPECT_EQ(b.param_dim(), 4);
  // Writing the reloaded archive reproduces the file byte for byte.
  std::stringstream again;
  write_archive(again, b);
  EXPECT_EQ(again.str(), text);
  // And a different archive is not equal (the comparison can fail).
  EXPECT_FALSE(AwkwardArchive(12) == a);
}

TEST(ArchiveFile, HasTheDocumentedPreambleAndColumns) {
  Archive a(2, 4, 1);
  a.insert(Vec({0.5}), -1.25, Vec({0.3, 0.9}));
  std::stringstream file;
  write_archive(file, a);
  const std::string expected =
      "# drops-map-elites-archive 1\n"
      "# bins 4 4\n"
      "# param_dim 1\n"
      "# binning floor: cell_d = min(floor(descriptor_d * bins_d), bins_d - 1)\n"
      "cell_0,cell_1,descriptor_0,descriptor_1,fitness,theta_0\n"
      "1,3,0.3,0.9,-1.25,0.5\n";
  EXPECT_EQ(file.str(), expected);
}

TEST(ArchiveFile, CommentsAreWrittenAfterTheBinningLineAndReadBack) {
  Archive a(2, 4, 1);
  a.insert(Vec({0.5}), -1.25, Vec({0.3, 0.9}));
  std::stringstream file;
  write_archive(file, a, {"task arm", "descriptor x y"});
  EXPECT_NE(file.str().find("bins_d - 1)\n# task arm\n# descriptor x y\ncell_0"),
            std::string::npos)
      << file.str();
  std::vector<std::string> comments;
  const Archive b = read_archive(file, &comments);
  EXPECT_TRUE(b == a);
  EXPECT_EQ(comments, (std::vector<std::string>{"task arm", "descriptor x y"}));
  std::stringstream bad;
  EXPECT_THROW(write_archive(bad, a, {"two\nlines"}), InvalidArgument);
}

std::string ReadError(const std::string& text) {
  std::istringstream in(text);
  try {
    read_archive(in);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "";
}

TEST(ArchiveFile, RejectsBadFilesNamingTheLine) {
  const std::string head =
      "# drops-map-elites-archive 1\n# bins 5\n# param_dim 1\n"
      "cell_0,descriptor_0,fitness,theta_0\n";
  EXPECT_EQ(ReadError(head + "2,0.5,1,0\n"), "");  // a valid file, for contrast
  EXPECT_NE(ReadError("cell_0\n").find("line 1"), std::string::npos);
  EXPECT_NE(ReadError("# drops-map-elites-archive 1\n# param_dim 1\ncell_0\n").find("bins"),
            std::string::npos);
  EXPECT_NE(ReadError(head + "2,0.5,1\n").find("line 5: expected 4 fields, got 3"),
            std::string::npos);
  EXPECT_NE(ReadError(head + "2,0.5,nan,0\n").find("line 5"), std::string::npos);
  EXPECT_NE(ReadError(head + "2,0.5,1,0\n2,0.45,2,0\n").find("line 6"), std::string::npos);
  EXPECT_NE(ReadError(head + "5,0.99,1,0\n").find("line 5"), std::string::npos);
  EXPECT_NE(ReadError(head + "x,0.5,1,0\n").find("integer cell index"), std::string::npos);
  // A cell keyed by another convention: sferes2's min(round(5 b), 4) puts 0.35 in cell 2,
  // the floor convention in cell 1.
  EXPECT_NE(ReadError(head + "2,0.35,1,0\n").find("bin into its cell"), std::string::npos);
  // Wrong column header.
  EXPECT_NE(ReadError("# drops-map-elites-archive 1\n# bins 5\n# param_dim 1\n"
                      "cell_0,fitness,descriptor_0,theta_0\n")
                .find("column header"),
            std::string::npos);
}

}  // namespace
