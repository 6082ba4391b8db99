// `drops run --resume`: a run interrupted (SIGINT) or killed (SIGKILL) part-way and continued
// produces exactly the episodes of an uninterrupted run with the same seed (slow; label "slow").
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_test_util.hpp"

namespace fs = std::filesystem;
using drops::cli_test::episodes_without_timing;
using drops::cli_test::fresh_dir;
using drops::cli_test::read_file;
using drops::cli_test::read_json;
using drops::cli_test::run_drops;
using drops::cli_test::spawn_drops;

namespace {

/// archive_progress.csv's rows without the seconds and the time, which differ between runs:
/// "evaluations,coverage,best_fitness" per row.
std::vector<std::string> archive_progress_rows(const fs::path& run_dir) {
  std::istringstream in(read_file(run_dir / "archive_progress.csv"));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "evaluations,seconds,coverage,best_fitness,utc");
  std::vector<std::string> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    EXPECT_EQ(f.size(), 5u) << line;
    if (f.size() == 5) rows.push_back(f[0] + "," + f[2] + "," + f[3]);
  }
  return rows;
}

// Small budgets: a 4-episode run takes about a second, so the test stays fast while every part of
// Algorithm 1 (prior-only episode, GP-MI learning, warm starts, policy search) is exercised.
const std::string kRun =
    "run episodes=4 seed=3 threads=1 optimizer.max_evaluations=600 optimizer.restarts=0 "
    "rollouts.predicted=2";

int episodes_in_checkpoint(const fs::path& run_dir) {
  try {
    const auto j = nlohmann::json::parse(read_file(run_dir / "checkpoint.json"));
    return j.at("episodes_done").get<int>();
  } catch (...) {
    return 0;
  }
}

/// Waits until the run's checkpoint holds at least `episodes` episodes (or the process ended).
void wait_for_checkpoint(pid_t pid, const fs::path& run_dir, int episodes) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (episodes_in_checkpoint(run_dir) < episodes && std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// Every file of every episode, byte for byte, and the episode table.
void expect_same_episodes(const fs::path& a, const fs::path& b, int episodes) {
  EXPECT_EQ(episodes_without_timing(a), episodes_without_timing(b));
  for (int e = 1; e <= episodes; ++e) {
    char ep[8];
    std::snprintf(ep, sizeof ep, "%03d", e);
    for (const char* f : {"real.csv", "predicted.csv", "policy.csv"}) {
      const fs::path pa = a / "episodes" / ep / f, pb = b / "episodes" / ep / f;
      ASSERT_TRUE(fs::exists(pa)) << pa;
      ASSERT_TRUE(fs::exists(pb)) << pb;
      EXPECT_EQ(read_file(pa), read_file(pb)) << "episode " << ep << " " << f;
    }
  }
  const auto sa = nlohmann::json::parse(read_file(a / "summary.json"));
  const auto sb = nlohmann::json::parse(read_file(b / "summary.json"));
  EXPECT_EQ(sb["status"], "complete");
  EXPECT_EQ(sa["episodes_done"], sb["episodes_done"]);
  EXPECT_EQ(sa.value("first_solved_episode", 0), sb.value("first_solved_episode", 0));
  EXPECT_EQ(sa["best_real_return"], sb["best_real_return"]);
}

}  // namespace

TEST(Resume, InterruptedRunContinuesToTheSameEpisodesAsAnUninterruptedOne) {
  const fs::path out = fresh_dir("resume", "sigint");
  ASSERT_EQ(run_drops(kRun + " --output " + out.string() + " --name full -q"), 0);

  const pid_t pid = spawn_drops(kRun + " --output " + out.string() + " --name part -q");
  wait_for_checkpoint(pid, out / "part", 2);
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 130) << "the run ended before it could be interrupted";
  const auto s = nlohmann::json::parse(read_file(out / "part" / "summary.json"));
  EXPECT_EQ(s["status"], "interrupted");
  const int done = s["episodes_done"].get<int>();
  ASSERT_GE(done, 2);
  ASSERT_LT(done, 4);

  std::string err;
  ASSERT_EQ(run_drops("run --resume " + (out / "part").string() + " -q", &err), 0) << err;
  expect_same_episodes(out / "full", out / "part", 4);
  fs::remove_all(out);
}

TEST(Resume, KilledRunDropsItsUnfinishedEpisodeAndContinuesIdentically) {
  const fs::path out = fresh_dir("resume", "sigkill");
  ASSERT_EQ(run_drops(kRun + " --output " + out.string() + " --name full -q"), 0);
  const pid_t pid = spawn_drops(kRun + " --output " + out.string() + " --name part -q");
  wait_for_checkpoint(pid, out / "part", 1);
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before it could be killed";
  // A killed run leaves status "running"; simulate the worst case too: a row and an episode
  // folder written after the last checkpoint (killed between the two writes).
  const int done = episodes_in_checkpoint(out / "part");
  ASSERT_GE(done, 1);
  {
    std::ofstream csv(out / "part" / "episodes.csv", std::ios::app);
    csv << done + 1 << ",9.9,1.0,1.0,0,0.5 0.5 0.5 0.5,0.1,0.1,1\n";
    char ep[8];
    std::snprintf(ep, sizeof ep, "%03d", done + 1);
    fs::create_directories(out / "part" / "episodes" / ep);
    std::ofstream(out / "part" / "episodes" / ep / "real.csv") << "garbage\n";
  }
  std::string err;
  ASSERT_EQ(run_drops("run --resume " + (out / "part").string() + " -q", &err), 0) << err;
  expect_same_episodes(out / "full", out / "part", 4);
  fs::remove_all(out);
}

TEST(Resume, ACompleteRunCanBeExtendedWithMoreEpisodes) {
  const fs::path out = fresh_dir("resume", "extend");
  ASSERT_EQ(run_drops(kRun + " episodes=5 --output " + out.string() + " --name five -q"), 0);
  ASSERT_EQ(run_drops(kRun + " --output " + out.string() + " --name four -q"), 0);
  std::string err;
  ASSERT_EQ(run_drops("run --resume " + (out / "four").string() + " episodes=5 -q", &err), 0)
      << err;
  expect_same_episodes(out / "five", out / "four", 5);
  // config.yaml says what the run is now: 5 episodes, and `drops run` of it repeats the run.
  EXPECT_NE(read_file(out / "four" / "config.yaml").find("\nepisodes: 5\n"), std::string::npos)
      << read_file(out / "four" / "config.yaml");
  ASSERT_EQ(run_drops("run " + (out / "four" / "config.yaml").string() + " --output " +
                          out.string() + " --name again -q",
                      &err),
            0)
      << err;
  expect_same_episodes(out / "five", out / "again", 5);
  // Fewer episodes than are done is refused.
  EXPECT_EQ(run_drops("run --resume " + (out / "four").string() + " episodes=3", &err), 2);
  EXPECT_NE(err.find("episodes = 3, but the run has already done 5 episodes"), std::string::npos)
      << err;
  // Resuming a complete run is a no-op that says so.
  ASSERT_EQ(run_drops("run --resume " + (out / "four").string(), &err), 0) << err;
  EXPECT_NE(err.find("nothing to do"), std::string::npos) << err;
  fs::remove_all(out);
}

TEST(Resume, RefusesWhatItCannotContinue) {
  const fs::path out = fresh_dir("resume", "refuse");
  std::string err;
  // Not a run directory.
  EXPECT_EQ(run_drops("run --resume " + (out / "nothing").string(), &err), 1);
  EXPECT_NE(err.find("not a run directory"), std::string::npos) << err;
  ASSERT_EQ(run_drops(kRun + " episodes=1 --output " + out.string() + " --name one -q"), 0);
  // Changing anything but episodes/threads would break the equivalence with an uninterrupted run.
  EXPECT_EQ(run_drops("run --resume " + (out / "one").string() + " seed=4", &err), 2);
  EXPECT_NE(err.find("'seed'"), std::string::npos) << err;
  // A directory whose process still holds the lock.
  {
    const int fd = ::open((out / "one" / ".lock").c_str(), O_RDWR);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
    EXPECT_EQ(run_drops("run --resume " + (out / "one").string() + " episodes=2", &err), 3);
    EXPECT_NE(err.find("in use"), std::string::npos) << err;
    ::close(fd);
  }
  // checkpoint.json deleted from a finished run: its recorded episode cannot be continued, and is
  // not started over (issue 43: the message said "no episode finished").
  fs::remove(out / "one" / "checkpoint.json");
  const std::string csv = read_file(out / "one" / "episodes.csv");
  const std::string summary = read_file(out / "one" / "summary.json");
  EXPECT_EQ(run_drops("run --resume " + (out / "one").string() + " episodes=2", &err), 1);
  EXPECT_NE(err.find((out / "one" / "checkpoint.json").string() +
                     " is missing, although 1 episode is recorded in " + (out / "one").string() +
                     ": the run cannot be continued"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("the recorded episodes are kept"), std::string::npos) << err;
  EXPECT_EQ(err.find("no episode finished"), std::string::npos) << err;
  EXPECT_EQ(read_file(out / "one" / "episodes.csv"), csv);
  EXPECT_EQ(read_file(out / "one" / "summary.json"), summary);
  EXPECT_TRUE(fs::exists(out / "one" / "episodes" / "001" / "real.csv"));
  fs::remove_all(out);
}

// A run started when an empty value stood for the task's choice (checkpoint.json's configuration
// holds "", config.yaml ~) resumes: left empty, the key takes its default now as then; given a
// value in config.yaml since, it is refused like any other change.
TEST(Resume, ARunStartedWithAKeyLeftEmptyResumes) {
  const fs::path out = fresh_dir("resume", "empty");
  ASSERT_EQ(run_drops(kRun + " episodes=1 --output " + out.string() + " --name one -q"), 0);
  const fs::path config = out / "one" / "config.yaml", checkpoint = out / "one" / "checkpoint.json";
  const std::string text = read_file(config);
  const std::string line = "\n  evaluations: 100000\n";
  const auto at = text.find(line);
  ASSERT_NE(at, std::string::npos) << text;
  nlohmann::json cp = read_json(checkpoint);
  ASSERT_EQ(cp["validation"]["config"]["ite.evaluations"], "100000");
  cp["validation"]["config"]["ite.evaluations"] = "";
  // Signed again as drops signs it: the sha256 of the document without its checksum.
  cp.erase("checksum");
  const fs::path unsigned_cp = out / "unsigned.json";
  drops::cli_test::write_file(unsigned_cp, cp.dump());
  std::string sum;
  {
    FILE* p = ::popen(("sha256sum " + unsigned_cp.string()).c_str(), "r");
    ASSERT_NE(p, nullptr);
    char hex[65] = {};
    ASSERT_EQ(std::fread(hex, 1, 64, p), 64u);
    ::pclose(p);
    sum = hex;
  }
  cp["checksum"] = sum;
  drops::cli_test::write_file(checkpoint, cp.dump() + "\n");
  const auto with = [&](const std::string& value) {
    drops::cli_test::write_file(config, text.substr(0, at) + "\n  evaluations: " + value + "\n" +
                                            text.substr(at + line.size()));
  };
  std::string err;
  with("5");
  EXPECT_EQ(run_drops("run --resume " + (out / "one").string() + " episodes=2 -q", &err), 2);
  EXPECT_NE(err.find("key 'ite.evaluations' is '5', but the run was started with ''"),
            std::string::npos)
      << err;
  with("~");
  EXPECT_EQ(run_drops("run --resume " + (out / "one").string() + " episodes=2 -q", &err), 0)
      << err;
  fs::remove_all(out);
}

// A run killed (SIGKILL) during its first episode recorded nothing and has no checkpoint:
// --resume starts it from its beginning in the same directory (from its config.yaml), and it ends
// with the episodes of a run that was never killed (issue 43).
TEST(Resume, RunKilledDuringItsFirstEpisodeStartsFromItsBeginning) {
  const fs::path out = fresh_dir("resume", "first");
  ASSERT_EQ(run_drops(kRun + " episodes=2 --output " + out.string() + " --name full -q"), 0);
  // The same run with a budget that keeps episode 1 busy until it is killed.
  const pid_t pid = spawn_drops(kRun + " episodes=2 optimizer.max_evaluations=200000 --output " +
                                out.string() + " --name killed -q");
  ASSERT_GE(pid, 0);
  const fs::path dir = out / "killed";
  for (int i = 0; i < 600 && !fs::exists(dir / "summary.json"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_FALSE(fs::exists(dir / "checkpoint.json"));
  ASSERT_EQ(read_file(dir / "episodes.csv").find("\n1,"), std::string::npos)
      << "episode 1 finished before the kill";
  EXPECT_EQ(read_json(dir / "summary.json")["status"], "running");
  // config.yaml is what the run starts from: that of the uninterrupted run, under this name.
  std::string yaml = read_file(out / "full" / "config.yaml");
  ASSERT_NE(yaml.find("\nname: full\n"), std::string::npos) << yaml;
  yaml.replace(yaml.find("\nname: full\n"), 12, "\nname: killed\n");
  drops::cli_test::write_file(dir / "config.yaml", yaml);
  std::string err;
  ASSERT_EQ(run_drops("run --resume " + dir.string(), &err), 0) << err;
  EXPECT_NE(err.find("resume: no checkpoint.json and no finished episode: nothing was recorded"),
            std::string::npos)
      << err;
  expect_same_episodes(out / "full", dir, 2);
  EXPECT_EQ(read_file(dir / "config.yaml"), yaml);
  fs::remove_all(out);
}

// IT&E killed in the middle of its archive's generation: the archive so far (archive.csv, with its
// MAP-Elites cursor) and checkpoint.json (no episode yet) continue it to the same archive and the
// same trials as an uninterrupted run.
TEST(Resume, IteKilledWhileBuildingItsArchiveContinuesToTheSameArchiveAndTrials) {
  const fs::path out = fresh_dir("resume", "ite");
  const std::string ite =
      "run algorithm=ite episodes=4 seed=2 threads=2 ite.evaluations=60000 ite.bins=4 "
      "ite.stop_ratio=0 ite.checkpoint_minutes=0 --output " + out.string();
  ASSERT_EQ(run_drops(ite + " --name full -q"), 0);
  const pid_t pid = spawn_drops(ite + " --name part -q");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out / "part" / "checkpoint.json") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before it could be killed";
  ASSERT_EQ(episodes_in_checkpoint(out / "part"), 0) << "killed after its archive was complete";
  EXPECT_NE(read_file(out / "part" / "archive.csv").find("# map_elites complete 0"),
            std::string::npos);
  std::string err;
  ASSERT_EQ(run_drops("run --resume " + (out / "part").string() + " -q", &err), 0) << err;
  expect_same_episodes(out / "full", out / "part", 4);
  EXPECT_EQ(read_file(out / "full" / "archive.csv"), read_file(out / "part" / "archive.csv"));
  // The progress of the archive: one row per generation, evaluations rising to the budget,
  // coverage never falling and ending at the archive's; the resumed run's rows (those written
  // past the cursor before the kill dropped) are the uninterrupted run's.
  const std::vector<std::string> full = archive_progress_rows(out / "full");
  ASSERT_GE(full.size(), 60000u / 400);
  long last_evaluations = 0;
  double last_coverage = 0;
  for (const std::string& row : full) {
    const long evaluations = std::atol(row.c_str());
    const double coverage = std::atof(row.c_str() + row.find(',') + 1);
    EXPECT_GT(evaluations, last_evaluations) << row;
    EXPECT_GE(coverage, last_coverage) << row;
    last_evaluations = evaluations;
    last_coverage = coverage;
  }
  EXPECT_EQ(last_evaluations, 60000);
  const auto summary = read_json(out / "full" / "summary.json");
  EXPECT_NEAR(last_coverage, summary["archive"]["coverage"].get<double>(), 1e-9);
  EXPECT_EQ(archive_progress_rows(out / "part"), full);
  fs::remove_all(out);
}

#ifdef DROPS_WITH_HEXAPOD
// The hexapod through `drops run`: its run directory (48-D states with named columns, foot heights,
// walking speed and state-guard counts per episode), bit-identical results with 1 and 2 threads
// (DART prior copies leased from a pool, GP-MI over the 7 priors, rollouts and CMA-ES), and resume.
TEST(Resume, HexapodRunIsIdenticalWithOneAndTwoThreadsAndResumes) {
  const fs::path out = fresh_dir("resume", "hexapod");
  const std::string small =
      "run task=hexapod seed=4 hexapod.horizon=10 optimizer.max_evaluations=80 "
      "optimizer.restarts=0 optimizer.prior_optimizations=1 rollouts.predicted=2 "
      "model.rprop.iterations=40 --output " + out.string();
  ASSERT_EQ(run_drops(small + " episodes=3 threads=1 --name one -q"), 0);
  ASSERT_EQ(run_drops(small + " episodes=3 threads=2 --name two -q"), 0);
  expect_same_episodes(out / "one", out / "two", 3);

  ASSERT_EQ(run_drops(small + " episodes=2 threads=2 --name part -q"), 0);
  ASSERT_EQ(run_drops("run --resume " + (out / "part").string() + " episodes=3 -q"), 0);
  expect_same_episodes(out / "one", out / "part", 3);

  // What the run directory holds for the hexapod.
  std::istringstream real(read_file(out / "one" / "episodes" / "002" / "real.csv"));
  std::string header, line;
  std::getline(real, header);
  int rows = 0, columns = 1;
  for (char c : header) columns += c == ',';
  while (std::getline(real, line)) ++rows;
  EXPECT_EQ(rows, 11);                           // x_0 .. x_H, H = 10
  EXPECT_EQ(columns, 1 + 48 + 18 + 1 + 6);       // t, state, action, reward, foot heights
  EXPECT_EQ(header.rfind("t,q_leg0_hip,q_leg0_femur,q_leg0_tibia,", 0), 0u) << header;
  EXPECT_NE(header.find(",x,y,z,roll,pitch,yaw,vx,vy,vz,wx,wy,wz,u_leg0_hip,"), std::string::npos);
  EXPECT_NE(header.find(",reward,foot0_height,"), std::string::npos);
  const std::string table = read_file(out / "one" / "episodes.csv");
  EXPECT_NE(table.find(",walking_speed_m_s,predicted_speed_m_s,guard_evaluations,guard_stopped,"
                       "guard_clamped\n"),
            std::string::npos)
      << table;
  const auto s = nlohmann::json::parse(read_file(out / "one" / "summary.json"));
  EXPECT_EQ(s["task"], "hexapod");
  EXPECT_EQ(s["prior"], "intact");
  EXPECT_EQ(s["phi_names"], nlohmann::json::array({"removed_leg"}));
  ASSERT_EQ(s["episodes"].size(), 3u);
  for (const auto& e : s["episodes"]) {
    EXPECT_TRUE(e["walking_speed_m_s"].is_number());
    EXPECT_GT(e["guard_evaluations"].get<double>(), 0);  // every model step passes the guard
  }

  // drops plot on a hexapod run: the speed, the path from above and the gait diagram.
  const fs::path plots = out / "plots";
  ASSERT_EQ(
      run_drops("plot " + (out / "one").string() + " --episodes 2 --output " + plots.string()), 0);
  for (const char* f : {"returns.png", "phi.png", "speed.png", "trajectories-002.png",
                        "path-002.png", "gait-002.png"})
    EXPECT_GT(fs::exists(plots / f) ? fs::file_size(plots / f) : 0u, 10000u) << f;
}
#endif

// A run that starts from recorded data (data.logs): killed after its first episode and resumed,
// it continues to the episodes of an uninterrupted run; a log whose bytes changed since is
// refused on resume, naming its digest.
TEST(Resume, RunFromRecordedLogsResumesExactlyAndRefusesAChangedLog) {
  const fs::path out = fresh_dir("resume", "logs");
  // The log: the real trajectory of another seed's first episode (its last row has no action:
  // dropped with identify.bad_rows=drop).
  ASSERT_EQ(run_drops(kRun + " episodes=1 seed=11 --output " + out.string() + " --name src -q"), 0);
  const fs::path log = out / "data.csv";
  fs::copy_file(out / "src" / "episodes" / "001" / "real.csv", log);
  const std::string with_logs =
      kRun + " data.logs=[" + log.string() + "] identify.columns.time=t identify.bad_rows=drop";
  ASSERT_EQ(run_drops(with_logs + " --output " + out.string() + " --name full -q"), 0);
  const auto cp = nlohmann::json::parse(read_file(out / "full" / "checkpoint.json"));
  // The checkpoint's data start with the log's transitions.
  const auto& decl = cp["validation"]["task"]["declaration"];
  ASSERT_TRUE(decl.contains("data.transitions")) << decl.dump();
  const int recorded = std::stoi(decl["data.transitions"].get<std::string>());
  EXPECT_GT(recorded, 10);
  EXPECT_EQ(decl["data.log.1"], log.string());
  EXPECT_GT(cp["data"]["x"].size(), static_cast<std::size_t>(recorded));

  const pid_t pid = spawn_drops(with_logs + " --output " + out.string() + " --name part -q");
  wait_for_checkpoint(pid, out / "part", 1);
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before it could be killed";
  std::string err;
  ASSERT_EQ(run_drops("run --resume " + (out / "part").string() + " -q", &err), 0) << err;
  expect_same_episodes(out / "full", out / "part", 4);

  // The log changed: a resume is refused, naming the digest.
  std::ofstream(log, std::ios::app) << "# a comment changes the bytes\n";
  EXPECT_NE(run_drops("run --resume " + (out / "part").string() + " episodes=5", &err), 0);
  EXPECT_NE(err.find("data.log.1.sha256"), std::string::npos) << err;
  fs::remove_all(out);
}
