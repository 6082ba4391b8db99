// Fault injection on `drops run` (slow; label "slow"): runs killed with SIGKILL at seeded random
// moments and resumed give the episodes of an uninterrupted run; a run directory damaged after
// its checkpoint (files cut, deleted or edited) is refused with an error naming the file, and
// nothing is appended to it; what a crash can leave after the checkpoint is repaired and said.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_test_util.hpp"

namespace fs = std::filesystem;
using drops::cli_test::episodes_without_timing;
using drops::cli_test::fresh_dir;
using drops::cli_test::read_file;
using drops::cli_test::run_drops;
using drops::cli_test::spawn_drops;
using drops::cli_test::write_file;

namespace {

// A 3-episode pendubot run with small budgets (about a second on an idle core): a prior-only
// episode, then GP-MI learning, warm starts and the policy search, each checkpointed.
const std::string kRun =
    "run episodes=3 seed=5 threads=1 optimizer.max_evaluations=400 optimizer.restarts=0 "
    "rollouts.predicted=2 optimizer.reevaluation_rollouts=4";

/// Runs `drops <args>` and SIGKILLs it after `delay` unless it ends first; returns its exit code,
/// or -1 when it was killed.
int run_and_kill_after(const std::string& args, std::chrono::milliseconds delay) {
  const pid_t pid = spawn_drops(args);
  const auto deadline = std::chrono::steady_clock::now() + delay;
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void expect_same_episodes(const fs::path& a, const fs::path& b, int episodes) {
  EXPECT_EQ(episodes_without_timing(a), episodes_without_timing(b));
  for (int e = 1; e <= episodes; ++e) {
    char ep[8];
    std::snprintf(ep, sizeof ep, "%03d", e);
    for (const char* f : {"real.csv", "predicted.csv", "policy.csv"}) {
      const fs::path pa = a / "episodes" / ep / f, pb = b / "episodes" / ep / f;
      ASSERT_TRUE(fs::exists(pb)) << pb;
      EXPECT_EQ(read_file(pa), read_file(pb)) << "episode " << ep << " " << f;
    }
  }
  const auto sb = nlohmann::json::parse(read_file(b / "summary.json"));
  EXPECT_EQ(sb["status"], "complete");
  EXPECT_EQ(sb["episodes_done"], episodes);
}

std::string cut(const std::string& text, std::size_t bytes_off_the_end) {
  return text.substr(0, text.size() - std::min(text.size(), bytes_off_the_end));
}

std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' not found";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace

// Six SIGKILLs at moments drawn from a seeded generator over the length of a run (so some land
// before the first checkpoint, some while files are written, some between episodes); each killed
// run is continued with --resume (and killed again, until one finishes), or started again when no
// episode had finished, as a user would. Every episode file then equals an uninterrupted run's.
TEST(Faults, RunsKilledAtRandomMomentsAndResumedGiveTheEpisodesOfAnUninterruptedRun) {
  const fs::path out = fresh_dir("faults", "kill");
  const auto t0 = std::chrono::steady_clock::now();
  std::string err;
  ASSERT_EQ(run_drops(kRun + " --output " + out.string() + " --name full -q", &err), 0) << err;
  const auto full_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0)
          .count();
  std::mt19937 rng(20261122);
  for (int trial = 0; trial < 6; ++trial) {
    const std::string name = "killed" + std::to_string(trial);
    const fs::path dir = out / name;
    std::uniform_int_distribution<long> delay(0, full_ms * 11 / 10);
    int kills = 0, restarts = 0, code = -1;
    for (int attempt = 0; attempt < 20 && code != 0; ++attempt) {
      // After three kills, let it finish.
      const auto ms = std::chrono::milliseconds(kills < 3 ? delay(rng) : 3600000L);
      const bool resumable = fs::exists(dir / "checkpoint.json");
      if (resumable) {
        code = run_and_kill_after("run --resume " + dir.string() + " -q", ms);
      } else {
        if (fs::exists(dir)) ++restarts;
        fs::remove_all(dir);  // no episode finished: start again
        code =
            run_and_kill_after(kRun + " --output " + out.string() + " --name " + name + " -q", ms);
      }
      if (code == -1) ++kills;
      ASSERT_TRUE(code == 0 || code == -1) << name << ": exit code " << code;
    }
    ASSERT_EQ(code, 0) << name;
    std::printf("[info] %s: killed %d times, started again %d times (no checkpoint yet)\n",
                name.c_str(), kills, restarts);
    SCOPED_TRACE(name + " (killed " + std::to_string(kills) + " times)");
    expect_same_episodes(out / "full", dir, 3);
  }
  fs::remove_all(out);
}

// Each damage a run directory can suffer after its checkpoint, applied to a copy of a finished
// 2-episode run that is then extended to 3 episodes: the resume is refused with the named file in
// the message, and episodes.csv, summary.json and checkpoint.json stay as they were.
TEST(Faults, ADamagedRunDirectoryIsRefusedWithAnErrorNamingTheFile) {
  const fs::path out = fresh_dir("faults", "damage");
  std::string err;
  ASSERT_EQ(run_drops(kRun + " episodes=2 --output " + out.string() + " --name base -q", &err), 0)
      << err;
  struct Damage {
    std::string name;
    std::function<void(const fs::path&)> apply;
    int exit_code;        // 0: 1 or 2
    std::string message;  // expected in the error, after the run directory's path
  };
  const std::vector<Damage> damages = {
      {"csv-cut-mid-line",
       [](const fs::path& d) {
         write_file(d / "episodes.csv", cut(read_file(d / "episodes.csv"), 12));
       },
       1, "/episodes.csv holds 1 complete rows, but checkpoint.json covers 2 episodes"},
      {"csv-deleted", [](const fs::path& d) { fs::remove(d / "episodes.csv"); }, 1,
       "/episodes.csv is missing"},
      {"csv-edited",
       [](const fs::path& d) {
         write_file(d / "episodes.csv",
                    replace_first(read_file(d / "episodes.csv"), "\n1,", "\n1,9"));
       },
       1, "/episodes.csv: its header and rows 1-2 differ from what drops recorded"},
      {"config-cut-mid-line",
       [](const fs::path& d) {
         write_file(d / "config.yaml", read_file(d / "config.yaml").substr(0, 100));
       },
       0, "/config.yaml"},  // where the cut lands depends on the path's length: exit 1 or 2
      {"config-cut-after-a-line",
       [](const fs::path& d) {
         const std::string text = read_file(d / "config.yaml");
         write_file(d / "config.yaml", text.substr(0, text.find("\noptimizer:") + 1));
       },
       1, "/config.yaml lacks the key"},
      {"config-edited",
       [](const fs::path& d) {
         write_file(d / "config.yaml",
                    replace_first(read_file(d / "config.yaml"), "max_evaluations: 400",
                                  "max_evaluations: 500"));
       },
       2,
       "/config.yaml: key 'optimizer.max_evaluations' is '500', but the run was started with "
       "'400'"},
      {"checkpoint-episodes-done-edited",
       [](const fs::path& d) {
         write_file(d / "checkpoint.json",
                    replace_first(read_file(d / "checkpoint.json"), "\"episodes_done\":2",
                                  "\"episodes_done\":3"));
       },
       1, "/checkpoint.json does not match its own checksum"},
      {"checkpoint-truncated",
       [](const fs::path& d) {
         write_file(d / "checkpoint.json", cut(read_file(d / "checkpoint.json"), 100));
       },
       1, "/checkpoint.json cannot be parsed"},
      {"summary-truncated",
       [](const fs::path& d) {
         write_file(d / "summary.json", cut(read_file(d / "summary.json"), 30));
       },
       1, "/summary.json cannot be parsed"},
      {"summary-deleted", [](const fs::path& d) { fs::remove(d / "summary.json"); }, 1,
       "/summary.json is missing"},
      {"summary-episode-edited",
       [](const fs::path& d) {
         auto s = nlohmann::json::parse(read_file(d / "summary.json"));
         s["episodes"][0]["real_return"] = 49.0;
         write_file(d / "summary.json", s.dump(2));
       },
       1, "/summary.json: the records of episodes 1-2 differ"},
      {"summary-episode-removed",
       [](const fs::path& d) {
         auto s = nlohmann::json::parse(read_file(d / "summary.json"));
         s["episodes"].erase(1);
         write_file(d / "summary.json", s.dump(2));
       },
       1, "/summary.json records 1 entry of episodes 1-2"},
      {"policy-edited",
       [](const fs::path& d) {
         write_file(d / "episodes/001/policy.csv",
                    "0.5\n" + read_file(d / "episodes/001/policy.csv"));
       },
       1, "/episodes/001/policy.csv differs from what drops recorded"},
      {"episode-folder-deleted", [](const fs::path& d) { fs::remove_all(d / "episodes/002"); }, 1,
       "/episodes/002/"},
  };
  for (const auto& damage : damages) {
    SCOPED_TRACE(damage.name);
    const fs::path dir = out / damage.name;
    fs::copy(out / "base", dir, fs::copy_options::recursive);
    damage.apply(dir);
    const std::string csv = read_file(dir / "episodes.csv"),
                      summary = read_file(dir / "summary.json"),
                      checkpoint = read_file(dir / "checkpoint.json");
    const int code = run_drops("run --resume " + dir.string() + " episodes=3 -q", &err);
    if (damage.exit_code == 0)
      EXPECT_TRUE(code == 1 || code == 2) << code << ": " << err;
    else
      EXPECT_EQ(code, damage.exit_code) << err;
    EXPECT_NE(err.find(dir.string() + damage.message), std::string::npos)
        << "expected '" << dir.string() + damage.message << "' in: " << err;
    EXPECT_EQ(read_file(dir / "episodes.csv"), csv);
    EXPECT_EQ(read_file(dir / "summary.json"), summary);
    EXPECT_EQ(read_file(dir / "checkpoint.json"), checkpoint);
  }
  // --resume with an empty path is an error, not a new run in the working directory's runs/.
  EXPECT_EQ(run_drops("run --resume \"\" -q", &err), 2);
  EXPECT_NE(err.find("--resume needs the run directory"), std::string::npos) << err;
  fs::remove_all(out);
}

// What a crash after the checkpoint leaves (a row of the next episode cut mid-line, its summary
// entry, a half-written episode folder) is removed, said on stderr, and the run continues to the
// episodes of an uninterrupted run.
TEST(Faults, WhatACrashLeavesAfterTheCheckpointIsRepaired) {
  const fs::path out = fresh_dir("faults", "repair");
  std::string err;
  ASSERT_EQ(run_drops(kRun + " --output " + out.string() + " --name full -q", &err), 0) << err;
  ASSERT_EQ(run_drops(kRun + " episodes=2 --output " + out.string() + " --name base -q", &err), 0)
      << err;

  const fs::path cut_row = out / "cut-row";
  fs::copy(out / "base", cut_row, fs::copy_options::recursive);
  {
    std::ofstream(cut_row / "episodes.csv", std::ios::app) << "3,7.500,12.3";  // no newline
    auto s = nlohmann::json::parse(read_file(cut_row / "summary.json"));
    s["episodes"].push_back({{"episode", 3}, {"solved", false}, {"real_return", 12.3}});
    write_file(cut_row / "summary.json", s.dump(2));
    fs::create_directories(cut_row / "episodes/003");
    write_file(cut_row / "episodes/003/real.csv.tmp", "t,th");
  }
  ASSERT_EQ(run_drops("run --resume " + cut_row.string() + " episodes=3", &err), 0) << err;
  EXPECT_NE(err.find("resume: removed 1 line of episodes.csv after episode 2"), std::string::npos)
      << err;
  EXPECT_NE(err.find("cut mid-line by a crash"), std::string::npos) << err;
  EXPECT_NE(err.find("resume: removed 1 episode entry of summary.json"), std::string::npos) << err;
  EXPECT_NE(err.find("resume: removed 1 folder of episodes/"), std::string::npos) << err;
  expect_same_episodes(out / "full", cut_row, 3);
  fs::remove_all(out);
}

// drops writes run-directory format version 1 (format_version in summary.json and
// checkpoint.json) and continues only that version: a directory whose checkpoint.json or
// summary.json holds another version, or none (written before the format was versioned), is
// refused with an error naming the file, the version found and the version this drops reads, and
// is left as it was; the same directory with version 1 restored resumes.
TEST(Faults, ARunDirectoryOfAnotherFormatVersionIsRefusedNamingTheFileAndTheVersions) {
  const fs::path out = fresh_dir("faults", "version");
  std::string err;
  ASSERT_EQ(run_drops(kRun + " episodes=2 --output " + out.string() + " --name base -q", &err), 0)
      << err;
  for (const char* f : {"summary.json", "checkpoint.json"})
    EXPECT_EQ(nlohmann::json::parse(read_file(out / "base" / f))["format_version"], 1) << f;
  struct Case {
    std::string name, file;
    nlohmann::json version;  // null: the key is removed
    std::string message;     // expected in the error, after the file's path
  };
  const std::vector<Case> cases = {
      {"checkpoint-v2", "checkpoint.json", 2,
       ": run-directory format version 2, but this drops reads version 1 only. Read or continue "
       "the run with a drops that reads version 2, or run it again with this one"},
      {"checkpoint-unversioned", "checkpoint.json", nullptr,
       " has no format_version: the run directory was written by a drops from before its format "
       "was versioned, and this drops reads run-directory format version 1 only"},
      {"summary-v0", "summary.json", 0,
       ": run-directory format version 0, but this drops reads version 1 only"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path dir = out / c.name;
    fs::copy(out / "base", dir, fs::copy_options::recursive);
    auto j = nlohmann::json::parse(read_file(dir / c.file));
    if (c.version.is_null())
      j.erase("format_version");
    else
      j["format_version"] = c.version;
    write_file(dir / c.file, j.dump());
    const std::string csv = read_file(dir / "episodes.csv"),
                      summary = read_file(dir / "summary.json"),
                      checkpoint = read_file(dir / "checkpoint.json");
    EXPECT_EQ(run_drops("run --resume " + dir.string() + " episodes=3 -q", &err), 1) << err;
    const std::string expected = (dir / c.file).string() + c.message;
    EXPECT_NE(err.find(expected), std::string::npos) << "expected '" << expected << "' in: " << err;
    EXPECT_EQ(read_file(dir / "episodes.csv"), csv);
    EXPECT_EQ(read_file(dir / "summary.json"), summary);
    EXPECT_EQ(read_file(dir / "checkpoint.json"), checkpoint);
    EXPECT_FALSE(fs::exists(dir / "episodes/003"));
  }
  // The refusal is the version's: with version 1 back (the file as drops wrote it), it resumes.
  const fs::path restored = out / "checkpoint-v2";
  auto cp = nlohmann::json::parse(read_file(restored / "checkpoint.json"));
  cp["format_version"] = 1;
  write_file(restored / "checkpoint.json", cp.dump() + "\n");
  ASSERT_EQ(read_file(restored / "checkpoint.json"), read_file(out / "base" / "checkpoint.json"));
  EXPECT_EQ(run_drops("run --resume " + restored.string() + " episodes=3 -q", &err), 0) << err;
  EXPECT_EQ(nlohmann::json::parse(read_file(restored / "summary.json"))["episodes_done"], 3);
  fs::remove_all(out);
}

// A "real" system that goes non-finite (issue 43): the pendubot with 1 cm links blows up within an
// episode. Each episode ends at its non-finite step, says so on stderr even with -q, records
// nonfinite_real_step in summary.json, and none is solved (the frozen state is not a success);
// whatever the run then does, it never reports the task solved and keeps what it recorded.
TEST(Faults, ARealSystemThatGoesNonFiniteIsCountedAndNeverSolved) {
  const fs::path out = fresh_dir("faults", "nonfinite-real");
  std::string err;
  const int code = run_drops("run episodes=3 threads=1 optimizer.max_evaluations=200 "
                             "rollouts.predicted=2 optimizer.reevaluation_rollouts=4 "
                             "system.l1=0.01 system.l2=0.01 -q --output " + out.string() +
                                 " --name run",
                             &err);
  EXPECT_NE(err.find("the real system returned a non-finite state at step"), std::string::npos)
      << err;
  EXPECT_EQ(err.find("first solved"), std::string::npos) << err;
  const auto s = nlohmann::json::parse(read_file(out / "run" / "summary.json"));
  ASSERT_FALSE(s["episodes"].empty()) << err;
  for (const auto& ep : s["episodes"]) {
    EXPECT_FALSE(ep["solved"].get<bool>()) << ep.dump();
    ASSERT_TRUE(ep.contains("nonfinite_real_step")) << ep.dump();
    EXPECT_GE(ep["nonfinite_real_step"].get<int>(), 0);
  }
  EXPECT_FALSE(s.contains("first_solved_episode") && s["first_solved_episode"].is_number() &&
               s["first_solved_episode"].get<int>() > 0)
      << s.dump();
  // Every episode in summary.json is also a row of episodes.csv (nothing recorded is lost).
  const std::string csv = read_file(out / "run" / "episodes.csv");
  EXPECT_EQ(static_cast<std::size_t>(std::count(csv.begin(), csv.end(), '\n')),
            s["episodes"].size() + 1);
  std::printf("[info] exit code %d, %zu episodes recorded\n", code, s["episodes"].size());
  fs::remove_all(out);
}
