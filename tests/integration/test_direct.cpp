// `drops direct` (= `drops run algorithm=direct`): the policy optimized directly on the real system
// (no model). On the pendubot (fast real episodes): every evaluation is an episode of the run
// directory, the recorded best episode is the one scored, the search beats the zero policy, the
// result does not depend on the thread count, and bad input is refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../fixtures.hpp"
#include "cli_test_util.hpp"
#include "drops/core/rng.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/rollout/rollout.hpp"

namespace fs = std::filesystem;
using drops::cli_test::fresh_dir;
using drops::cli_test::read_json;
using drops::cli_test::run_drops;

namespace {

/// Rows of a CSV file with a header: the named column as numbers (empty cells skipped).
std::vector<double> column(const fs::path& p, const std::string& name) {
  std::ifstream in(p);
  std::string line, cell;
  std::getline(in, line);
  std::stringstream h(line);
  int index = -1;
  for (int i = 0; std::getline(h, cell, ','); ++i)
    if (cell == name) index = i;
  EXPECT_GE(index, 0) << name << " not in " << p;
  std::vector<double> v;
  while (std::getline(in, line)) {
    std::stringstream s(line);
    for (int i = 0; std::getline(s, cell, ','); ++i)
      if (i == index && !cell.empty()) v.push_back(std::stod(cell));
  }
  return v;
}

std::string fmt_double(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace

TEST(Direct, PendubotSearchRecordsItsBestEpisodeBeatsTheZeroPolicyAndIgnoresTheThreadCount) {
  const fs::path out = fresh_dir("direct", "pendubot");
  std::string err;
  ASSERT_EQ(run_drops("direct --evaluations 600 --seed 3 --threads 1 --output " + out.string() +
                          " --name t1 -q",
                      &err),
            0)
      << err;
  ASSERT_EQ(run_drops("direct --evaluations 600 --seed 3 --threads 2 --output " + out.string() +
                          " --name t2 -q",
                      &err),
            0)
      << err;
  const auto s1 = read_json(out / "t1" / "summary.json");
  const auto s2 = read_json(out / "t2" / "summary.json");
  EXPECT_EQ(s1["status"], "complete");
  EXPECT_EQ(s1["algorithm"], "direct");
  EXPECT_LE(s1["episodes_done"].get<long>(), 600);
  // one seed, one result, whatever the thread count
  EXPECT_EQ(s1["best_real_return"].get<double>(), s2["best_real_return"].get<double>());
  EXPECT_EQ(s1["search"]["best_theta"], s2["search"]["best_theta"]);
  EXPECT_EQ(read_json(out / "t1" / "summary.json")["episodes"].size(),
            s2["episodes"].size());

  // the best episode's trajectory is the scored one: its rewards add up to the best return
  const double best = s1["best_real_return"].get<double>();
  const int k = s1["best_episode"].get<int>();
  char folder[16];
  std::snprintf(folder, sizeof folder, "%03d", k);
  double sum = 0;
  for (double r : column(out / "t1" / "episodes" / folder / "real.csv", "reward")) sum += r;
  EXPECT_NEAR(sum, best, 1e-6 * std::max(1.0, std::abs(best)));

  // every evaluation is a row of episodes.csv; each improvement keeps its trajectory and the
  // running best ends at the summary's
  const std::vector<double> returns = column(out / "t1" / "episodes.csv", "real_return");
  ASSERT_EQ(static_cast<long>(returns.size()), s1["episodes_done"].get<long>());
  double running = -1e300;
  for (std::size_t i = 0; i < returns.size(); ++i) {
    if (returns[i] > running) {
      running = returns[i];
      std::snprintf(folder, sizeof folder, "%03d", static_cast<int>(i + 1));
      EXPECT_TRUE(fs::exists(out / "t1" / "episodes" / folder / "real.csv")) << i + 1;
    }
  }
  EXPECT_NEAR(running, best, 1e-5 * std::max(1.0, std::abs(best)));

  // the search beats the policy at the centre of the box it starts from (theta = 0: no torque)
  const auto e = drops::fixtures::experiment();
  const auto& setup = e.setup;
  setup.policy->set_params(drops::VectorXd::Zero(setup.policy->param_dim()));
  drops::Rng rng(1);
  const double zero = drops::rollout::run_episode(*setup.task, *setup.real, *setup.policy, rng)
                          .total_return();
  EXPECT_GT(best, zero + 1.0) << "zero policy " << zero;
  const double bound = std::stod(e.settings.at("policy.bound"));
  for (const auto& t : s1["search"]["best_theta"]) EXPECT_LE(std::abs(t.get<double>()), bound);

  // --start from that best policy: evaluated (the pendubot is noise-free: the same return) and
  // kept unless the search beats it, within the same budget
  {
    std::ofstream f(out / "start.csv");
    for (const auto& t : s1["search"]["best_theta"]) f << fmt_double(t.get<double>()) << "\n";
  }
  ASSERT_EQ(run_drops("direct --evaluations 30 --seed 4 --start " + (out / "start.csv").string() +
                          " --output " + out.string() + " --name s -q",
                      &err),
            0)
      << err;
  const auto s3 = read_json(out / "s" / "summary.json");
  const double start = s3["search"]["start_return"].get<double>();
  EXPECT_NEAR(start, best, 1e-9 * std::max(1.0, std::abs(best)));
  EXPECT_NEAR(s3["episodes"][0]["real_return"].get<double>(), start, 1e-6);  // evaluated first
  EXPECT_GE(s3["best_real_return"].get<double>(), start);
  EXPECT_LE(s3["episodes_done"].get<long>(), 30);
  EXPECT_GT(s3["episodes_done"].get<long>(), 17);  // the start and at least a generation (issue 18)
  fs::remove_all(out);
}

TEST(Direct, RefusesABadConfigAndAnExistingResultDirectory) {
  const fs::path out = fresh_dir("direct", "bad");
  std::string err;
  EXPECT_EQ(run_drops("direct optimizer.max_evalutions=10 --output " + out.string(), &err), 2);
  EXPECT_NE(err.find("max_evalutions"), std::string::npos) << err;
  ASSERT_EQ(run_drops("direct --evaluations 20 --output " + out.string() + " --name a -q", &err), 0)
      << err;
  const std::string before = read_json(out / "a" / "summary.json").dump();
  EXPECT_EQ(run_drops("direct --evaluations 20 --output " + out.string() + " --name a -q", &err),
            1);
  EXPECT_NE(err.find("already holds"), std::string::npos) << err;
  EXPECT_EQ(read_json(out / "a" / "summary.json").dump(), before);  // nothing overwritten
  {
    std::ofstream f(out / "short.csv");
    f << "0.1\n0.2\n";
  }
  EXPECT_EQ(run_drops("direct --start " + (out / "short.csv").string() + " --output " +
                          out.string() + " --name b -q",
                      &err),
            2);
  EXPECT_NE(err.find("holds 2 values; the policy has 81"), std::string::npos) << err;
  EXPECT_NE(err.find("direct.start"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out / "b"));  // refused before anything was written
  fs::remove_all(out);
}

// --evaluations sets optimizer.max_evaluations: a count below its range (0, a negative one) is
// refused with that range and the option's name, not with CLI11's bound of a double (issue 43).
TEST(Direct, EvaluationsOutsideTheRangeAreRefusedNamingTheOptionAndTheRange) {
  const fs::path out = fresh_dir("direct", "evaluations");
  for (const std::string n : {"0", "-3", "5"}) {
    SCOPED_TRACE(n);
    std::string err;
    EXPECT_EQ(run_drops("direct --evaluations " + n + " --output " + out.string() + " -q", &err),
              2);
    EXPECT_NE(err.find("--evaluations " + n + " sets config key 'optimizer.max_evaluations'"),
              std::string::npos)
        << err;
    EXPECT_NE(err.find("allowed [10, 1e+08]"), std::string::npos) << err;
    EXPECT_LT(err.size(), 200u) << err;
  }
  EXPECT_TRUE(fs::is_empty(out));
  fs::remove_all(out);
}
