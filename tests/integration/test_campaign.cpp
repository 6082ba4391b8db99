// `drops campaign` end to end (label "slow"): the tiny campaign locally and under mpirun, a kill
// and restart, adoption of plain `drops run` directories, and campaign files with errors.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../fixtures.hpp"
#include "campaign.hpp"
#include "cli_test_util.hpp"
#include "drops/core/errors.hpp"

namespace fs = std::filesystem;
using drops::cli_test::episodes_without_timing;
using drops::cli_test::fresh_dir;
using drops::cli_test::read_file;
using drops::cli_test::run_drops;
using drops::cli_test::shell;
using drops::cli_test::Stdout;
using drops::cli_test::write_file;
extern char** environ;

namespace {

const std::string kTiny = std::string(DROPS_SOURCE_DIR) + "/configs/campaign-tiny.yaml";
const std::set<std::string> kTinyRuns = {"gp_mi-tunable-seed1", "gp_mi-tunable-seed2",
                                         "mi-tunable-seed1", "mi-tunable-seed2"};

/// Removes a test's directory unless the test failed (then it is kept for inspection).
void clean_up(const fs::path& d) {
  if (!::testing::Test::HasFailure()) fs::remove_all(d);
}

/// Starts `drops args...` in the background (stderr to a file); returns its pid.
pid_t drops_background(const std::vector<std::string>& args, const fs::path& stderr_file) {
  std::vector<std::string> all = {DROPS_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, stderr_file.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, DROPS_BINARY, &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

std::vector<nlohmann::json> read_log(const fs::path& campaign) {
  std::vector<nlohmann::json> events;
  std::ifstream in(campaign / "campaign.log");
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) events.push_back(nlohmann::json::parse(line));
  return events;
}

int count_events(const std::vector<nlohmann::json>& events, const std::string& event) {
  int n = 0;
  for (const auto& e : events) n += e.value("event", "") == event;
  return n;
}

std::string run_status(const fs::path& run_dir) {
  std::ifstream in(run_dir / "summary.json");
  if (!in) return "";
  return nlohmann::json::parse(in).value("status", "");
}

std::set<std::string> run_names(const fs::path& campaign) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(campaign / "runs"))
    if (e.is_directory()) names.insert(e.path().filename().string());
  return names;
}

/// True when some process holds the flock of a run directory.
bool any_run_locked(const fs::path& campaign) {
  for (const auto& e : fs::directory_iterator(campaign / "runs")) {
    const fs::path lock = e.path() / ".lock";
    const int fd = ::open(lock.c_str(), O_RDONLY);
    if (fd < 0) continue;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);
    if (held) return true;
  }
  return false;
}

bool have_mpirun() { return std::system("command -v mpirun > /dev/null 2>&1") == 0; }

/// `drops report` exists (not the placeholder of an unfinished build).
bool have_report() {
  const fs::path help_file =
      fs::temp_directory_path() / ("drops-campaign-report-help-" + std::to_string(getpid()));
  const int rc = shell(std::string(DROPS_BINARY) + " report --help > " + help_file.string());
  const std::string help = read_file(help_file);
  fs::remove(help_file);
  return rc == 0 && help.find("not yet available") == std::string::npos;
}

}  // namespace

// ---- the campaign file: naming, order, validation (library level, fast) ----

TEST(Campaign, PendubotCampaignNamesRunsLikeTheHandStartedCampaignAndRunsSeedsSlowest) {
  const auto spec = drops::experiment::load_campaign_file(
      drops::fixtures::registry(), std::string(DROPS_SOURCE_DIR) + "/configs/campaign-pendubot.yaml");
  EXPECT_EQ(spec.name, "pendubot");
  const auto runs = drops::experiment::expand_campaign(drops::fixtures::registry(), spec);
  ASSERT_EQ(runs.size(), 80u);
  EXPECT_EQ(runs[0].name, "gp_mi-tunable-useful-seed1");
  EXPECT_EQ(runs[1].name, "gp_mi-tunable-seed1");
  EXPECT_EQ(runs[4].name, "gp_prior-tunable-useful-seed1");
  EXPECT_EQ(runs[15].name, "gp-partially-tunable-seed1");
  EXPECT_EQ(runs[16].name, "gp_mi-tunable-useful-seed2");
  EXPECT_EQ(runs[79].name, "gp-partially-tunable-seed5");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].settings.at("seed"), std::to_string(i / 16 + 1)) << runs[i].name;
    EXPECT_EQ(runs[i].settings.at("episodes"), "15");
    EXPECT_EQ(runs[i].settings.at("threads"), "1");
    EXPECT_EQ(runs[i].settings.at("name"), runs[i].name);
  }
}

TEST(Campaign, RunNamesKeepDashesAndReplaceOtherCharacters) {
  EXPECT_EQ(drops::experiment::run_name_part("seed", "7"), "seed7");
  EXPECT_EQ(drops::experiment::run_name_part("prior.preset", "tunable-useful"), "tunable-useful");
  EXPECT_EQ(drops::experiment::run_name_part("prior.tunable", "[m1, m2]"), "m1_m2");
  EXPECT_EQ(drops::experiment::run_name_part("model.type", "a b/c"), "a_b_c");
}

TEST(Campaign, SeedRangeEqualsTheList) {
  const auto a = drops::experiment::parse_campaign(drops::fixtures::registry(), "grid: {seed: {first: 3, count: 2}}", "x");
  const auto b = drops::experiment::parse_campaign(drops::fixtures::registry(), "grid: {seed: [3, 4]}", "x");
  ASSERT_EQ(a.grid.size(), 1u);
  EXPECT_EQ(a.grid[0].values, b.grid[0].values);
}

// ---- end to end ----

TEST(Campaign, WrongKeysFailWithExitCode2NamingTheKeyAndWriteNothing) {
  const fs::path d = fresh_dir("campaign", "errors");
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"grid: {model.typ: [gp_mi, mi]}\n", {"model.typ", "did you mean 'model.type'"}},
      {"grid: {seed: [1]}\nsettings: {episode: 3}\n", {"episode", "did you mean 'episodes'"}},
      {"job: 2\ngrid: {seed: [1]}\n", {"'job'", "did you mean 'jobs'"}},
      {"grid: {model.type: [gp_mi, gp_mix]}\n", {"model.type", "gp_mix", "allowed values"}},
      {"grid: {seed: [1, 1]}\n", {"seed", "listed twice"}},
      {"episodes: 3\ngrid: {seed: [1]}\n", {"'episodes'", "settings:"}},
      {"grid: {seed: [1]}\nsettings: {output: x}\n", {"settings.output"}},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const fs::path file = d / ("bad" + std::to_string(i) + ".yaml");
    write_file(file, cases[i].first);
    std::string err;
    EXPECT_EQ(run_drops("campaign " + file.string() + " --output " + (d / "out").string(), &err,
                        Stdout::kDiscard),
              2)
        << cases[i].first << err;
    for (const auto& needle : cases[i].second)
      EXPECT_NE(err.find(needle), std::string::npos) << "'" << needle << "' not in: " << err;
  }
  EXPECT_FALSE(fs::exists(d / "out"));
  clean_up(d);
}

TEST(Campaign, TinyCampaignCompletesLocallyAndASecondInvocationRunsNothing) {
  const fs::path d = fresh_dir("campaign", "local");
  std::string err;
  ASSERT_EQ(
      run_drops("campaign " + kTiny + " --output " + d.string() + " -j 2", &err, Stdout::kDiscard),
      0)
      << err;
  const fs::path c = d / "tiny";
  EXPECT_EQ(run_names(c), kTinyRuns);
  for (const auto& r : kTinyRuns) {
    EXPECT_EQ(run_status(c / "runs" / r), "complete") << r;
    EXPECT_TRUE(fs::exists(c / "configs" / (r + ".yaml"))) << r;
    EXPECT_TRUE(fs::exists(c / "runs" / (r + ".log"))) << r;
  }
  EXPECT_EQ(read_file(c / "campaign.yaml"), read_file(kTiny));
  EXPECT_NE(err.find("[4/4]"), std::string::npos) << err;
  auto events = read_log(c);
  EXPECT_EQ(count_events(events, "start"), 4);
  EXPECT_EQ(count_events(events, "finish"), 4);

  ASSERT_EQ(
      run_drops("campaign " + kTiny + " --output " + d.string() + " -q", &err, Stdout::kDiscard), 0)
      << err;
  events = read_log(c);
  EXPECT_EQ(count_events(events, "start"), 4);
  EXPECT_EQ(count_events(events, "resume"), 0);
  EXPECT_EQ(count_events(events, "skip"), 4);

  // A kept run of another run-directory format version stops the campaign (exit code 2) naming
  // the run, the file and the versions, before anything runs.
  const std::string run = *kTinyRuns.begin();
  const fs::path summary = c / "runs" / run / "summary.json";
  auto s = nlohmann::json::parse(read_file(summary));
  s["format_version"] = 2;
  write_file(summary, s.dump());
  EXPECT_EQ(
      run_drops("campaign " + kTiny + " --output " + d.string() + " -q", &err, Stdout::kDiscard),
      2);
  EXPECT_NE(err.find("run " + run + " in "), std::string::npos) << err;
  EXPECT_NE(err.find(summary.string() +
                     ": run-directory format version 2, but this drops reads version 1 only"),
            std::string::npos)
      << err;
  EXPECT_EQ(count_events(read_log(c), "begin"), count_events(events, "begin"));
  clean_up(d);
}

TEST(Campaign, ADifferentCampaignFileIsRefusedButOtherJobsAndThreadsAreAccepted) {
  const fs::path d = fresh_dir("campaign", "changed");
  const fs::path file = d / "tiny.yaml";
  write_file(file, read_file(kTiny));
  std::string err;
  ASSERT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " -q", &err,
                      Stdout::kDiscard),
            0)
      << err;

  write_file(file, read_file(kTiny) + "jobs: 1\n");
  EXPECT_EQ(
      run_drops("campaign " + file.string() + " --output " + d.string() + " --threads 2 --dry-run",
                &err, Stdout::kDiscard),
      0)
      << err;

  std::string text = read_file(kTiny);
  text.replace(text.find("episodes: 2"), 11, "episodes: 3");
  write_file(file, text);
  EXPECT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " -q", &err,
                      Stdout::kDiscard),
            2);
  EXPECT_NE(err.find("episodes"), std::string::npos) << err;
  EXPECT_NE(err.find("different campaign"), std::string::npos) << err;
  clean_up(d);
}

// A default that changed after a campaign was made: the file then pins the old value, which the
// runs were made with. That is the same campaign; another value is refused by the runs made.
TEST(Campaign, PinningTheOldValueOfAChangedDefaultKeepsTheCampaign) {
  const fs::path d = fresh_dir("campaign", "pinned");
  const fs::path file = d / "tiny.yaml";
  const std::string pinned = read_file(kTiny) + "  model.gp_mi.candidate_start: initial\n";
  write_file(file, pinned);
  std::string err;
  ASSERT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " -q", &err,
                      Stdout::kDiscard),
            0)
      << err;
  // Make the campaign's copy of its file leave the key to its default, as if that default had
  // been initial when the runs were made (it is best_so_far today).
  write_file(d / "tiny" / "campaign.yaml", read_file(kTiny));
  EXPECT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " --dry-run", &err,
                      Stdout::kDiscard),
            0)
      << err;
  write_file(file, read_file(kTiny) + "  model.gp_mi.candidate_start: best_so_far\n");
  EXPECT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " --dry-run", &err,
                      Stdout::kDiscard),
            2);
  EXPECT_NE(err.find("different settings: key 'model.gp_mi.candidate_start'"), std::string::npos)
      << err;
  // Unpinned, the file means today's default, which the runs were not made with.
  write_file(file, read_file(kTiny));
  EXPECT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " --dry-run", &err,
                      Stdout::kDiscard),
            2);
  EXPECT_NE(err.find("model.gp_mi.candidate_start"), std::string::npos) << err;
  clean_up(d);
}

TEST(Campaign, AdoptsARunStartedByPlainDropsRunAndRefusesOneWithOtherSettings) {
  const fs::path d = fresh_dir("campaign", "adopt");
  const std::string budget =
      " task=pendubot episodes=2 optimizer.max_evaluations=300 optimizer.restarts=0 "
      "model.gp_mi.max_evaluations=100 model.mi.max_evaluations=100 rollouts.predicted=2 "
      "threads=1";
  std::string err;
  ASSERT_EQ(run_drops("run model.type=gp_mi prior.preset=tunable seed=1" + budget + " --output " +
                          (d / "tiny" / "runs").string() + " --name gp_mi-tunable-seed1 -q",
                      &err, Stdout::kDiscard),
            0)
      << err;
  ASSERT_EQ(run_drops("campaign " + kTiny + " --output " + d.string() + " -j 2 -q", &err,
                      Stdout::kDiscard),
            0)
      << err;
  const auto events = read_log(d / "tiny");
  EXPECT_EQ(count_events(events, "start"), 3);
  for (const auto& e : events)
    if (e.value("run", "") == "gp_mi-tunable-seed1") EXPECT_EQ(e.value("event", ""), "skip");

  // A run directory made with other settings: error naming the run and the key, nothing started.
  const fs::path d2 = fresh_dir("campaign", "adopt-mismatch");
  ASSERT_EQ(
      run_drops("run model.type=mi prior.preset=tunable seed=2" + budget + " episodes=3 --output " +
                    (d2 / "tiny" / "runs").string() + " --name mi-tunable-seed2 -q",
                &err, Stdout::kDiscard),
      0)
      << err;
  EXPECT_EQ(
      run_drops("campaign " + kTiny + " --output " + d2.string() + " -q", &err, Stdout::kDiscard),
      2);
  EXPECT_NE(err.find("mi-tunable-seed2"), std::string::npos) << err;
  EXPECT_NE(err.find("'episodes'"), std::string::npos) << err;
  EXPECT_EQ(run_names(d2 / "tiny"), std::set<std::string>{"mi-tunable-seed2"});
  clean_up(d);
  clean_up(d2);
}

TEST(Campaign, MpiCampaignGivesTheSameRunsAndEpisodesAsLocal) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (scripts/install-deps)";
  ASSERT_TRUE(drops::app::mpi_built())
      << "mpirun is installed but drops was built without MPI (cmake -DDROPS_WITH_MPI=ON)";
  const fs::path d = fresh_dir("campaign", "mpi");
  std::string err;
  ASSERT_EQ(run_drops("campaign " + kTiny + " --output " + (d / "local").string() + " -j 2 -q",
                      &err, Stdout::kDiscard),
            0)
      << err;
  ASSERT_EQ(shell("mpirun --allow-run-as-root --oversubscribe -np 2 " + std::string(DROPS_BINARY) +
                      " campaign " + kTiny + " --output " + (d / "mpi").string() +
                      " --mpi -q > /dev/null",
                  &err),
            0)
      << err;
  const fs::path local = d / "local" / "tiny", mpi = d / "mpi" / "tiny";
  ASSERT_EQ(run_names(mpi), run_names(local));
  for (const auto& r : run_names(local)) {
    EXPECT_EQ(run_status(mpi / "runs" / r), "complete") << r;
    EXPECT_EQ(episodes_without_timing(mpi / "runs" / r),
              episodes_without_timing(local / "runs" / r))
        << r;
  }
  for (const auto& e : read_log(mpi))
    if (e.value("event", "") == "start") EXPECT_EQ(e.value("worker", ""), "mpi:1");

  if (have_report()) {
    ASSERT_EQ(run_drops("report " + local.string() + " --no-figures", &err, Stdout::kDiscard), 0)
        << err;
    ASSERT_EQ(run_drops("report " + mpi.string() + " --no-figures", &err, Stdout::kDiscard), 0)
        << err;
    for (const char* f : {"summary.csv", "returns.csv"})
      EXPECT_EQ(read_file(mpi / "report" / f), read_file(local / "report" / f)) << f;
  }

  // One process is not enough: rank 0 only coordinates.
  EXPECT_EQ(shell("mpirun --allow-run-as-root -np 1 " + std::string(DROPS_BINARY) + " campaign " +
                      kTiny + " --output " + (d / "one").string() + " --mpi",
                  &err),
            2)
      << err;
  EXPECT_NE(err.find("at least 2"), std::string::npos) << err;
  clean_up(d);
}

// Interrupt (SIGINT) after the first run, kill (SIGKILL) after the next, then finish: every run
// completes and no run that had finished is started or resumed again.
TEST(Campaign, InterruptedAndKilledCampaignsResumeWithoutRepeatingFinishedRuns) {
  const fs::path d = fresh_dir("campaign", "kill");
  const fs::path file = d / "kill.yaml";
  write_file(file,
             "name: kill\n"
             "grid:\n"
             "  model.type: [gp_mi]\n"
             "  seed: {first: 1, count: 4}\n"
             "settings:\n"
             "  prior.preset: tunable\n"
             "  episodes: 5\n"
             "  optimizer: {max_evaluations: 1000, restarts: 0}\n"
             "  model.gp_mi.max_evaluations: 200\n"
             "  rollouts.predicted: 2\n");
  const fs::path c = d / "kill";
  const std::vector<std::string> args = {"campaign", file.string(), "--output",
                                         d.string(), "-j",          "1"};
  std::set<std::string> finished;  // complete before an interruption
  std::size_t events_before = 0;

  for (const int sig : {SIGINT, SIGKILL}) {
    const pid_t pid = drops_background(args, d / "stderr.txt");
    ASSERT_GT(pid, 0);
    // Wait for one more run to finish in this invocation, then stop the campaign.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    bool one_more = false;
    while (!one_more && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      const auto events = read_log(c);
      for (std::size_t i = events_before; i < events.size(); ++i)
        one_more = one_more || events[i].value("event", "") == "finish";
    }
    ASSERT_TRUE(one_more) << read_file(d / "stderr.txt");
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // into the next run
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (sig == SIGINT) {
      ASSERT_TRUE(WIFEXITED(status));
      EXPECT_EQ(WEXITSTATUS(status), 130);
      EXPECT_NE(read_file(d / "stderr.txt").find("resume with"), std::string::npos);
    }
    // A killed campaign's runs stop on their own (parent-death SIGINT): wait for their locks.
    const auto unlock_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (any_run_locked(c) && std::chrono::steady_clock::now() < unlock_deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ASSERT_FALSE(any_run_locked(c));
    const auto events = read_log(c);
    for (std::size_t i = events_before; i < events.size(); ++i)
      if (events[i].value("event", "") == "finish" && events[i].value("status", "") == "complete")
        finished.insert(events[i].value("run", ""));
    events_before = events.size();
  }
  ASSERT_FALSE(finished.empty());

  std::set<std::string> resumable;  // runs left with a checkpoint: must be resumed, not restarted
  for (const auto& r : run_names(c))
    if (run_status(c / "runs" / r) != "complete" && fs::exists(c / "runs" / r / "checkpoint.json"))
      resumable.insert(r);

  std::string err;
  ASSERT_EQ(run_drops("campaign " + file.string() + " --output " + d.string() + " -j 1", &err,
                      Stdout::kDiscard),
            0)
      << err;
  EXPECT_EQ(run_names(c).size(), 4u);
  for (const auto& r : run_names(c)) {
    EXPECT_EQ(run_status(c / "runs" / r), "complete") << r;
    // Every episode exactly once, in order.
    std::ifstream in(c / "runs" / r / "episodes.csv");
    std::string line;
    std::getline(in, line);
    int expected = 1;
    while (std::getline(in, line)) EXPECT_EQ(std::stoi(line), expected++) << r;
    EXPECT_EQ(expected, 6) << r;
  }
  // Over the three invocations: no run is started or resumed after it completed.
  const auto events = read_log(c);
  std::set<std::string> done;
  for (std::size_t i = 0; i < events.size(); ++i) {
    const std::string ev = events[i].value("event", ""), run = events[i].value("run", "");
    if (ev == "start" || ev == "resume") {
      EXPECT_EQ(done.count(run), 0u) << run << " had completed and was " << ev << "d again";
      if (i >= events_before && resumable.count(run)) EXPECT_EQ(ev, "resume") << run;
    }
    // A run whose last episode ends after its campaign was killed completes with no one left to
    // log it; the next invocation logs it as skipped, complete.
    if ((ev == "finish" || ev == "skip") && events[i].value("status", "") == "complete")
      done.insert(run);
  }
  EXPECT_EQ(done.size(), 4u);
  EXPECT_EQ(count_events(events, "begin"), 3);
  clean_up(d);
}

// A campaign whose runs take a description file by a relative prior.model (resolved by each run
// to an absolute path) keeps its finished runs when invoked again from the same place.
TEST(Campaign, ARelativePriorModelIsTheSameOnTheSecondInvocation) {
  const fs::path d = fresh_dir("campaign", "relative-prior-model");
  const fs::path file = d / "file-prior.yaml";
  // Relative to this file's directory: the source tree's pendubot file, by a path from d.
  const fs::path xml = fs::path(DROPS_SOURCE_DIR) / "tasks/pendubot/data/pendubot.xml";
  fs::copy_file(xml, d / "pendubot.xml");
  write_file(file,
             "name: rel\nthreads: 1\ngrid:\n  seed: [1]\nsettings:\n  task: pendubot\n"
             "  episodes: 1\n  optimizer.max_evaluations: 20\n  optimizer.prior_optimizations: 1\n"
             "  prior:\n    model: pendubot.xml\n    parameters:\n"
             "      - {name: Link2.mass, bounds: [0.05, 1], value: 0.5}\n");
  const std::string args = "campaign " + file.string() + " --output " + (d / "out").string();
  std::string err;
  const std::string cwd = fs::current_path().string();
  fs::current_path(d);  // the run resolves pendubot.xml beside its own config, then here
  const int first = run_drops(args, &err, Stdout::kDiscard);
  const int second = run_drops(args, &err, Stdout::kDiscard);
  fs::current_path(cwd);
  if (first != 0 && err.find("without MuJoCo") != std::string::npos) {
    clean_up(d);
    GTEST_SKIP() << "this drops was built without MuJoCo";
  }
  EXPECT_EQ(first, 0) << err;
  EXPECT_EQ(second, 0) << err;
  EXPECT_EQ(err.find("different settings"), std::string::npos) << err;
  clean_up(d);
}
