// Tests of MAP-Elites (run_map_elites): archive invariants after every batch, the toy planar arm
// (every reachable cell fills, no unreachable cell does), dead / invalid / out-of-range
// individuals, the evaluation budget, and identical archives whatever the thread count.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/ite/archive.hpp"
#include "drops/ite/archive_io.hpp"
#include "drops/ite/map_elites.hpp"

namespace {

using drops::InvalidArgument;
using drops::Rng;
using drops::VectorXd;
using namespace drops::ite;

// The planar arm of pymap_elites' example: n joints, links of length 1/n (reach 1), joint angles
// q_i = 2 pi (theta_i - 0.5) in [-pi, pi] (each relative to the previous link), theta in [0, 1]^n.
// Descriptor: the end effector p normalised to [0, 1]^2, b = (p + 1) / 2. Fitness: minus the
// variance of the joint angles (smooth arms are better).
Evaluation Arm(const VectorXd& theta) {
  const auto n = theta.size();
  const VectorXd q = (theta.array() - 0.5) * 2.0 * std::numbers::pi;
  double angle = 0, x = 0, y = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    angle += q[i];
    x += std::cos(angle) / static_cast<double>(n);
    y += std::sin(angle) / static_cast<double>(n);
  }
  Evaluation e;
  e.fitness = -(q.array() - q.mean()).square().mean();
  e.descriptor.resize(2);
  // Clamped against round-off: |p| <= 1 mathematically.
  e.descriptor << std::clamp((x + 1.0) / 2.0, 0.0, 1.0), std::clamp((y + 1.0) / 2.0, 0.0, 1.0);
  return e;
}

// The arm with evaluation noise drawn from the stream: the thread-count test must cover it.
Evaluation NoisyArm(const VectorXd& theta, std::uint64_t stream) {
  Evaluation e = Arm(theta);
  Rng rng(stream);
  e.fitness += 0.01 * rng.normal();
  return e;
}

TEST(MapElites, ArchiveInvariantsHoldAfterEveryBatch) {
  constexpr int kJoints = 8;
  Archive archive(2, 16, kJoints);
  MapElitesOptions o;
  o.max_evaluations = 30000;
  o.batch_size = 200;
  o.seed = 3;
  std::map<std::int64_t, double> previous;  // cell -> fitness after the last batch
  double previous_coverage = 0;
  int batches_checked = 0;
  long fitness_increases = 0;
  auto check = [&](const MapElitesProgress& p, const Archive& a) -> bool {
    EXPECT_GE(a.coverage(), previous_coverage) << "batch " << p.batch;
    EXPECT_EQ(p.filled, a.size());
    EXPECT_DOUBLE_EQ(p.coverage, a.coverage());
    std::map<std::int64_t, double> now;
    for (const Elite& e : a.elites()) {
      EXPECT_EQ(a.cell_of(e.descriptor), e.cell) << "an elite outside its cell";
      // The stored elite is what its parameters give (the archive pairs theta with its result).
      const Evaluation again = Arm(e.theta);
      EXPECT_EQ(again.fitness, e.fitness);
      EXPECT_EQ(again.descriptor, e.descriptor);
      now[a.linear_index(e.cell)] = e.fitness;
    }
    for (const auto& [cell, f] : previous) {
      if (!now.count(cell)) {
        ADD_FAILURE() << "a filled cell was emptied";
        continue;
      }
      EXPECT_GE(now[cell], f) << "strict elitism: a cell's fitness decreased";
      if (now[cell] > f) ++fitness_increases;
    }
    previous = std::move(now);
    previous_coverage = a.coverage();
    ++batches_checked;
    return true;
  };
  const MapElitesSummary s =
      run_map_elites([](const VectorXd& theta, std::uint64_t) { return Arm(theta); },
                     VectorXd::Zero(kJoints), VectorXd::Ones(kJoints), o, archive, check);
  EXPECT_EQ(batches_checked, s.batches);
  EXPECT_EQ(s.evaluations, 30000);
  EXPECT_EQ(s.batches, 1 + (30000 - 200) / 200);
  // Every evaluation is accounted for exactly once.
  EXPECT_EQ(s.new_cells + s.replacements + s.rejected + s.dead + s.invalid + s.out_of_range,
            s.evaluations);
  EXPECT_EQ(static_cast<std::size_t>(s.new_cells), archive.size());
  EXPECT_EQ(s.filled, archive.size());
  EXPECT_EQ(s.best_fitness, archive.best().fitness);
  // The run did improve elites (the invariant check is not vacuous).
  EXPECT_GT(fitness_increases, 100);
  EXPECT_GT(s.replacements, 100);
  EXPECT_EQ(s.termination, MapElitesTermination::kMaxEvaluations);
}

// Cells of an n x n grid whose centre lies within the arm's reach (|p| <= 1, i.e. the disc of
// radius 0.5 around (0.5, 0.5) in descriptor space), and cells that lie entirely outside it.
struct Reach {
  std::vector<Cell> reachable, unreachable;
};
Reach ArmReach(int n) {
  Reach r;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double cx = (i + 0.5) / n - 0.5, cy = (j + 0.5) / n - 0.5;
      if (std::hypot(cx, cy) <= 0.5) r.reachable.push_back({i, j});
      // Nearest point of the cell [i/n, (i+1)/n] x [j/n, (j+1)/n] to the disc centre.
      const double nx = std::clamp(0.5, 1.0 * i / n, (i + 1.0) / n) - 0.5;
      const double ny = std::clamp(0.5, 1.0 * j / n, (j + 1.0) / n) - 0.5;
      if (std::hypot(nx, ny) > 0.5) r.unreachable.push_back({i, j});
    }
  }
  return r;
}

TEST(MapElites, ToyArmFillsEveryReachableCellAndNoUnreachableOne) {
  // 8 joints, 20 x 20 grid, 100,000 evaluations (200 random + batches of 400), seeds 1-3.
  constexpr int kJoints = 8, kBins = 20;
  const Reach reach = ArmReach(kBins);
  // Geometry sanity: about pi/4 of the 400 cells have their centre in the disc.
  ASSERT_GT(reach.reachable.size(), 300u);
  ASSERT_LT(reach.reachable.size(), 330u);
  for (std::uint64_t seed : {1, 2, 3}) {
    Archive archive(2, kBins, kJoints);
    MapElitesOptions o;
    o.max_evaluations = 100000;
    o.seed = seed;
    const MapElitesSummary s =
        run_map_elites([](const VectorXd& theta, std::uint64_t) { return Arm(theta); },
                       VectorXd::Zero(kJoints), VectorXd::Ones(kJoints), o, archive);
    int missing = 0;
    for (const Cell& c : reach.reachable) {
      if (archive.find(c) == nullptr) {
        ++missing;
        ADD_FAILURE() << "seed " << seed << ": reachable cell (" << c[0] << ", " << c[1]
                      << ") is empty";
      }
    }
    for (const Cell& c : reach.unreachable) {
      EXPECT_EQ(archive.find(c), nullptr) << "unreachable cell (" << c[0] << ", " << c[1] << ")";
    }
    EXPECT_EQ(missing, 0) << s.BriefReport();
    // The straightest arms reach the rim; the best elite is (nearly) a straight arm: all joints
    // but the first at 0 has variance (q_1^2 (n - 1) / n^2), 0 when pointing along +x.
    EXPECT_GT(archive.best().fitness, -1e-2);
  }
}

TEST(MapElites, DeadInvalidAndOutOfRangeIndividualsAreCountedAndNeverInserted) {
  constexpr int kJoints = 6;
  std::atomic<long> dead{0}, invalid{0}, out_of_range{0}, calls{0};
  auto evaluate = [&](const VectorXd& theta, std::uint64_t) {
    ++calls;
    Evaluation e = Arm(theta);
    if (theta[0] < 0.1) {
      e.alive = false;  // the descriptor stays valid: only the flag excludes it
      ++dead;
    } else if (theta[1] < 0.1) {
      e.fitness = std::numeric_limits<double>::quiet_NaN();
      ++invalid;
    } else if (theta[2] < 0.1) {
      e.descriptor[1] = std::numeric_limits<double>::infinity();
      ++invalid;
    } else if (theta[3] < 0.1) {
      e.descriptor[0] = 1.0 + 1e-9;
      ++out_of_range;
    }
    return e;
  };
  Archive archive(2, 10, kJoints);
  MapElitesOptions o;
  o.max_evaluations = 1234;  // not a multiple of anything below
  o.initial_population = 150;
  o.batch_size = 100;
  o.mutation = Mutation::kGaussian;
  o.mutation_rate = 0.5;
  o.gaussian_sigma = 0.3;
  const MapElitesSummary s =
      run_map_elites(evaluate, VectorXd::Zero(kJoints), VectorXd::Ones(kJoints), o, archive);
  EXPECT_EQ(calls.load(), 1234);
  EXPECT_EQ(s.evaluations, 1234);
  EXPECT_EQ(s.batches, 2 + 11);  // 100 + 50 initial, 10 x 100 + 84
  EXPECT_EQ(s.dead, dead.load());
  EXPECT_EQ(s.invalid, invalid.load());
  EXPECT_EQ(s.out_of_range, out_of_range.load());
  EXPECT_GT(s.dead, 20);
  EXPECT_GT(s.invalid, 20);
  EXPECT_GT(s.out_of_range, 10);
  EXPECT_EQ(s.new_cells + s.replacements + s.rejected + s.dead + s.invalid + s.out_of_range,
            s.evaluations);
  for (const Elite& e : archive.elites()) {
    EXPECT_GE(e.theta[0], 0.1);
    EXPECT_GE(e.theta[1], 0.1);
    EXPECT_GE(e.theta[2], 0.1);
    EXPECT_GE(e.theta[3], 0.1);
  }
}

TEST(MapElites, AWrongDescriptorSizeIsAnError) {
  Archive archive(2, 4, 3);
  MapElitesOptions o;
  o.max_evaluations = 10;
  auto evaluate = [](const VectorXd&, std::uint64_t) {
    Evaluation e;
    e.fitness = 1;
    e.descriptor = VectorXd::Constant(3, 0.5);
    return e;
  };
  EXPECT_THROW(run_map_elites(evaluate, VectorXd::Zero(3), VectorXd::Ones(3), o, archive),
               InvalidArgument);
  o.mutation_rate = 1.5;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("mutation_rate"), std::string::npos);
  EXPECT_THROW(run_map_elites(evaluate, VectorXd::Zero(3), VectorXd::Ones(3), o, archive),
               InvalidArgument);
  o = MapElitesOptions{};
  EXPECT_THROW(run_map_elites(evaluate, VectorXd::Zero(2), VectorXd::Ones(2), o, archive),
               InvalidArgument);  // bounds of the wrong size
  EXPECT_THROW(run_map_elites(evaluate, VectorXd::Ones(3), VectorXd::Ones(3), o, archive),
               InvalidArgument);  // empty box
}

TEST(MapElites, CallbackStopsTheRun) {
  Archive archive(2, 8, 4);
  MapElitesOptions o;
  o.batch_size = 50;
  o.initial_population = 50;
  const MapElitesSummary s =
      run_map_elites([](const VectorXd& theta, std::uint64_t) { return Arm(theta); },
                     VectorXd::Zero(4), VectorXd::Ones(4), o, archive,
                     [](const MapElitesProgress& p, const Archive&) { return p.batch < 3; });
  EXPECT_EQ(s.termination, MapElitesTermination::kCallback);
  EXPECT_EQ(s.batches, 3);
  EXPECT_EQ(s.evaluations, 150);
}

Archive RunArm(const MapElitesOptions& o, int threads, int joints = 6) {
  drops::ThreadLimit limit(threads);
  Archive archive(2, 12, joints);
  run_map_elites(NoisyArm, VectorXd::Zero(joints), VectorXd::Ones(joints), o, archive);
  return archive;
}

TEST(MapElites, SameSeedGivesTheSameArchiveWithOneAndTwoThreads) {
  for (Mutation m : {Mutation::kPolynomial, Mutation::kGaussian, Mutation::kResample}) {
    MapElitesOptions o;
    o.max_evaluations = 8000;
    o.batch_size = 100;
    o.mutation = m;
    o.crossover_rate = 0.3;
    o.seed = 17;
    const Archive one = RunArm(o, 1);
    const Archive two = RunArm(o, 2);
    EXPECT_GT(one.size(), 50u);
    EXPECT_TRUE(one == two) << "mutation " << static_cast<int>(m);
    o.parallel = false;
    EXPECT_TRUE(RunArm(o, 2) == one) << "mutation " << static_cast<int>(m);
    o.parallel = true;
    o.seed = 18;
    EXPECT_FALSE(RunArm(o, 2) == one) << "another seed gives another archive";
    if (m == Mutation::kResample) {
      // Every gene on the 21-level grid of [0, 1] (mutation, initial draw and crossover snapping).
      for (const Elite& e : one.elites()) {
        for (Eigen::Index i = 0; i < e.theta.size(); ++i) {
          EXPECT_NEAR(e.theta[i] * 20.0, std::round(e.theta[i] * 20.0), 1e-9);
        }
      }
    }
  }
}

TEST(MapElites, EpsilonRuleRunsAndKeepsElitesInTheirCells) {
  MapElitesOptions o;
  o.max_evaluations = 8000;
  o.batch_size = 100;
  o.insertion = InsertionRule::kEpsilon;
  o.epsilon = 0.05;
  const Archive a = RunArm(o, 2);
  for (const Elite& e : a.elites()) EXPECT_EQ(a.cell_of(e.descriptor), e.cell);
  o.insertion = InsertionRule::kStrict;
  EXPECT_FALSE(RunArm(o, 2) == a) << "the rule changes the archive";
}

TEST(MapElites, AReloadedArchiveContinuesExactlyLikeTheOriginal) {
  MapElitesOptions o;
  o.max_evaluations = 3000;
  o.batch_size = 100;
  Archive original = RunArm(o, 2);
  std::stringstream file;
  write_archive(file, original);
  Archive reloaded = read_archive(file);
  o.seed = 99;  // the continuation's own streams
  run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, original);
  const auto s = run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, reloaded);
  EXPECT_EQ(s.evaluations, 3000);  // no initial population: the archive was not empty
  EXPECT_TRUE(original == reloaded);
}

TEST(MapElites, AStoppedRunContinuedFromItsCursorAndSavedArchiveEqualsAnUninterruptedRun) {
  MapElitesOptions o;
  o.max_evaluations = 3000;
  o.batch_size = 100;
  o.initial_population = 250;  // the stop below falls inside the initial population
  o.crossover_rate = 0.3;
  for (const int stop_after : {2, 9}) {
    const Archive uninterrupted = RunArm(o, 2);
    Archive first(2, 12, 6);
    MapElitesCursor cursor;
    std::stringstream file;
    const auto s1 = run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, first,
                                   [&](const MapElitesProgress& p, const Archive& a) {
                                     if (p.batch < stop_after) return true;
                                     cursor = p.cursor;
                                     write_archive(file, a);
                                     return false;
                                   });
    EXPECT_EQ(s1.cursor.batches, stop_after);
    EXPECT_EQ(s1.cursor.evaluations, cursor.evaluations);
    Archive reloaded = read_archive(file);
    const auto s2 =
        run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, reloaded, {}, &cursor);
    EXPECT_EQ(s2.cursor.evaluations, 3000) << "the budget counts both calls";
    EXPECT_EQ(s1.evaluations + s2.evaluations, 3000);
    EXPECT_TRUE(reloaded == uninterrupted) << "stopped after batch " << stop_after;
  }
  MapElitesCursor bad;
  bad.generations = -1;
  Archive archive(2, 12, 6);
  EXPECT_THROW(
      run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, archive, {}, &bad),
      InvalidArgument);
}

}  // namespace

// MAP-Elites is an anytime algorithm: the archive of a run with budget N is the archive of a run
// with a larger budget as it stood after N evaluations (bench/ite_archive's --save-at relies on
// it to give the archives of several budgets from one run).
TEST(MapElites, ASmallerBudgetsArchiveIsALongerRunsArchiveAtThatBudget) {
  MapElitesOptions o;
  o.initial_population = 200;
  o.batch_size = 200;
  o.seed = 11;
  o.max_evaluations = 2000;
  Archive small(2, 10, 6);
  run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, small);
  o.max_evaluations = 6000;
  Archive longer(2, 10, 6), at_budget(2, 10, 6);
  long seen = 0;
  run_map_elites(NoisyArm, VectorXd::Zero(6), VectorXd::Ones(6), o, longer,
                 [&](const MapElitesProgress& p, const Archive& a) {
                   if (p.cursor.evaluations == 2000) at_budget = a;
                   seen = p.cursor.evaluations;
                   return true;
                 });
  EXPECT_EQ(seen, 6000);
  EXPECT_GT(small.size(), 20u);
  EXPECT_TRUE(at_budget == small);
  EXPECT_FALSE(longer == small);  // the longer run went on
}
