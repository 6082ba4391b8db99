// Tests of M-BOA: posterior against a naive dense solve, the oracles of baselines.md §3d, adaptation
// when the archive's best cell fails on the "real" system, independence of the archive's order.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/ite/archive.hpp"
#include "drops/ite/mboa.hpp"

namespace {

using drops::InvalidArgument;
using drops::MatrixXd;
using drops::Rng;
using drops::VectorXd;
using namespace drops::ite;

// A 2-D archive of n x n cells, every cell filled at a random point of the cell, fitness f(b).
template <class F>
Archive FullArchive(int n, F f, std::uint64_t seed = 1, bool reversed = false) {
  Archive a(2, n, 1);
  Rng rng(seed);
  std::vector<VectorXd> points;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      VectorXd b(2);
      b << (i + rng.uniform(0.05, 0.95)) / n, (j + rng.uniform(0.05, 0.95)) / n;
      points.push_back(b);
    }
  }
  if (reversed) std::reverse(points.begin(), points.end());
  for (std::size_t i = 0; i < points.size(); ++i) {
    a.insert(VectorXd::Constant(1, static_cast<double>(i)), f(points[i]), points[i]);
  }
  return a;
}

double Bump(const VectorXd& b, double cx, double cy, double width) {
  const double d2 = (b[0] - cx) * (b[0] - cx) + (b[1] - cy) * (b[1] - cy);
  return std::exp(-0.5 * d2 / (width * width));
}

TEST(Mboa, WithoutDataTheFirstTrialIsTheArchivesBestCell) {
  const Archive a = FullArchive(12, [](const VectorXd& b) { return 1.0 + Bump(b, 0.7, 0.2, 0.3); });
  const Mboa m(a);
  EXPECT_EQ(m.num_cells(), a.size());
  EXPECT_EQ(m.next_cell(), a.best().cell);
  for (const Elite& e : a.elites()) {
    EXPECT_EQ(m.mean(e.cell), e.fitness);
    EXPECT_EQ(m.prior_mean(e.cell), e.fitness);
    EXPECT_DOUBLE_EQ(m.variance(e.cell), 1.0);
  }
  EXPECT_FALSE(m.should_stop());
}

TEST(Mboa, PosteriorMatchesANaiveDenseSolve) {
  const Archive a = FullArchive(9, [](const VectorXd& b) { return std::sin(4 * b[0]) + b[1]; });
  for (bool centres : {false, true}) {
    MboaOptions o;
    o.length_scale = 0.25;
    o.signal_variance = 0.7;
    o.noise_variance = 0.01;
    o.kappa = 0.5;
    o.use_cell_centres = centres;
    Mboa m(a, o);
    Rng rng(4);
    std::vector<VectorXd> xs;
    std::vector<double> ys, ps;
    auto point = [&](const Elite& e) { return centres ? a.cell_centre(e.cell) : e.descriptor; };
    for (int t = 0; t < 6; ++t) {
      const Elite& e = a.elites()[rng() % a.size()];
      const double y = rng.uniform(-1, 2);
      m.observe(e.cell, y);
      xs.push_back(point(e));
      ys.push_back(y);
      ps.push_back(e.fitness);
    }
    // Naive GP: K + sigma_n^2 I inverted by LU, kernel written out here.
    auto kern = [&](const VectorXd& p, const VectorXd& q) {
      const double r = std::sqrt(5.0) * (p - q).norm() / o.length_scale;
      return o.signal_variance * (1 + r + r * r / 3) * std::exp(-r);
    };
    const int t = static_cast<int>(xs.size());
    MatrixXd K(t, t);
    VectorXd res(t);
    for (int i = 0; i < t; ++i) {
      res[i] = ys[i] - ps[i];
      for (int j = 0; j < t; ++j) K(i, j) = kern(xs[i], xs[j]) + (i == j ? o.noise_variance : 0);
    }
    const MatrixXd Kinv = K.fullPivLu().inverse();
    double best_ucb = -1e300;
    Cell best_cell;
    for (const Elite& e : a.elites()) {
      VectorXd ks(t);
      for (int i = 0; i < t; ++i) ks[i] = kern(point(e), xs[i]);
      const double mu = e.fitness + ks.dot(Kinv * res);
      const double var = o.signal_variance - ks.dot(Kinv * ks);
      EXPECT_NEAR(m.mean(e.cell), mu, 1e-9);
      EXPECT_NEAR(m.variance(e.cell), var, 1e-9);
      const double ucb = mu + o.kappa * std::sqrt(std::max(var, 0.0));
      if (ucb > best_ucb + 1e-12) {
        best_ucb = ucb;
        best_cell = e.cell;
      }
    }
    EXPECT_EQ(m.next_cell(), best_cell);
  }
}

TEST(Mboa, AnObservationMovesTheMeanThereAndLeavesFarCellsAtThePrior) {
  const Archive a = FullArchive(20, [](const VectorXd& b) { return 1.0 + b[0]; });
  MboaOptions o;
  o.length_scale = 0.05;  // so that most of [0, 1]^2 is many length scales away
  o.noise_variance = 1e-3;
  Mboa m(a, o);
  const Elite& target = *a.find({3, 3});
  const double y = target.fitness - 0.8;
  m.observe(target.cell, y);
  // mu(b) = P(b) + sigma_f^2 / (sigma_f^2 + sigma_n^2) (y - P(b)): within 1e-3 |y - P| of y.
  EXPECT_NEAR(m.mean(target.cell), y, 1.01e-3 * 0.8);
  EXPECT_NE(m.mean(target.cell), y);  // a noisy GP does not interpolate exactly
  EXPECT_LT(m.variance(target.cell), 1.01e-3);
  int far = 0;
  for (const Elite& e : a.elites()) {
    const double d = (e.descriptor - target.descriptor).norm();
    if (d > 10 * o.length_scale) {
      ++far;
      EXPECT_NEAR(m.mean(e.cell), e.fitness, 1e-6 * 0.8);
      EXPECT_NEAR(m.variance(e.cell), 1.0, 1e-6);
    }
  }
  EXPECT_GT(far, 200);
  // The failed cell is not proposed again.
  EXPECT_NE(m.next_cell(), target.cell);
}

TEST(Mboa, StopsAfterOneTrialWhenRealityEqualsThePrior) {
  const Archive a =
      FullArchive(15, [](const VectorXd& b) { return 0.5 + Bump(b, 0.3, 0.6, 0.25); });
  Mboa m(a);
  int trials = 0;
  const MboaSummary s = run_mboa(m, [&](const Elite& e) {
    ++trials;
    return e.fitness;  // the real system is the prior, no noise
  });
  EXPECT_EQ(trials, 1);
  EXPECT_EQ(s.trials, 1);
  EXPECT_EQ(s.stop, MboaStop::kMaxPredictedValue);
  EXPECT_EQ(s.best_cell, a.best().cell);
  EXPECT_EQ(s.best_value, a.best().fitness);
  EXPECT_DOUBLE_EQ(s.max_predicted_mean, a.best().fitness);
}

TEST(Mboa, FindsABetterCellWhenTheArchivesBestFailsOnTheRealSystem) {
  // Prior: two hills, A at (0.25, 0.3) (the archive's best) and the lower B at (0.75, 0.7). Real
  // system: hill A is mostly gone (damage at the scale of the kernel) and everything is 0.1 lower
  // (a reality gap), so the best real cells are on hill B.
  auto prior = [](const VectorXd& b) {
    return 0.3 + 2.0 * Bump(b, 0.25, 0.3, 0.15) + 1.6 * Bump(b, 0.75, 0.7, 0.15);
  };
  auto real = [&](const VectorXd& b) { return prior(b) - 1.6 * Bump(b, 0.25, 0.3, 0.15) - 0.1; };
  const Archive a = FullArchive(15, prior);
  double real_max = -1e300;
  for (const Elite& e : a.elites()) real_max = std::max(real_max, real(e.descriptor));
  const double first_real = real(a.best().descriptor);
  ASSERT_LT(first_real, 0.5 * real_max) << "the scenario: the prior's best is bad in reality";

  Mboa m(a);  // Nature settings: l = 0.4, sigma_f^2 = 1, sigma_n^2 = 1e-3, kappa = 0.05
  std::vector<double> values;
  const MboaSummary s = run_mboa(m, [&](const Elite& e) {
    values.push_back(real(e.descriptor));
    return values.back();
  });
  ASSERT_FALSE(values.empty());
  EXPECT_EQ(values.front(), first_real);  // trial 1: the archive's best
  EXPECT_EQ(s.stop, MboaStop::kMaxPredictedValue) << s.BriefReport();
  EXPECT_LE(s.trials, 6) << s.BriefReport();
  EXPECT_GE(s.best_value, 0.9 * real_max) << s.BriefReport() << ", real max " << real_max;
  EXPECT_GT(s.best_value, first_real + 0.5);
  // Deterministic (the paper's premise): the same archive gives the same trials.
  Mboa again(a);
  std::vector<double> values2;
  run_mboa(again, [&](const Elite& e) {
    values2.push_back(real(e.descriptor));
    return values2.back();
  });
  EXPECT_EQ(values2, values);
}

TEST(Mboa, TrialsDependOnCellsNotOnTheArchivesFillOrder) {
  auto f = [](const VectorXd& b) { return 1.0 + Bump(b, 0.4, 0.4, 0.2) + 0.3 * b[1]; };
  const Archive forward = FullArchive(10, f, 7, false);
  const Archive backward = FullArchive(10, f, 7, true);
  ASSERT_FALSE(forward == backward);  // same elites, other order (and other theta labels)
  auto real = [](const VectorXd& b) { return 1.0 + 0.8 * b[0]; };
  MboaOptions o;
  o.stop_ratio = 0;  // run all trials
  o.max_trials = 8;
  Mboa m1(forward, o), m2(backward, o);
  const MboaSummary s1 = run_mboa(m1, [&](const Elite& e) { return real(e.descriptor); });
  const MboaSummary s2 = run_mboa(m2, [&](const Elite& e) { return real(e.descriptor); });
  EXPECT_EQ(s1.trials, 8);
  EXPECT_EQ(s1.stop, MboaStop::kMaxTrials);
  ASSERT_EQ(m1.observations().size(), m2.observations().size());
  for (std::size_t i = 0; i < m1.observations().size(); ++i) {
    EXPECT_EQ(m1.observations()[i].cell, m2.observations()[i].cell);
    EXPECT_EQ(m1.observations()[i].value, m2.observations()[i].value);
  }
}

TEST(Mboa, RejectsUnknownCellsBadValuesAndBadOptions) {
  Archive a(2, 4, 1);
  EXPECT_THROW(Mboa{a}, InvalidArgument);  // empty archive
  VectorXd b(2);
  b << 0.1, 0.1;
  a.insert(VectorXd::Zero(1), 1.0, b);
  Mboa m(a);
  EXPECT_THROW(m.observe({1, 1}, 1.0), InvalidArgument);  // empty cell
  EXPECT_THROW(m.observe({4, 0}, 1.0), InvalidArgument);  // out of range
  EXPECT_THROW(m.observe({0, 0}, std::numeric_limits<double>::quiet_NaN()), InvalidArgument);
  EXPECT_TRUE(m.observations().empty());
  // The same cell observed twice with a tiny noise: the jittered solve still works.
  MboaOptions o;
  o.noise_variance = 1e-14;
  o.stop_ratio = 0;
  Mboa tiny(a, o);
  tiny.observe({0, 0}, 0.5);
  tiny.observe({0, 0}, 0.5);
  EXPECT_NEAR(tiny.mean({0, 0}), 0.5, 1e-6);
  o.length_scale = 0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("length_scale"), std::string::npos);
  EXPECT_THROW(Mboa(a, o), InvalidArgument);
}

}  // namespace
