// `drops campaign FILE.yaml`: parsing and expanding the campaign file, planning (skip, resume or
// start each run), the campaign directory, child processes and the local pool, progress display.
// MPI lives in campaign_mpi.cpp. Format and semantics: docs/campaigns.md.

#include "campaign.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "drops/core/errors.hpp"
#include "drops/experiment/campaign.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::app {
namespace fs = std::filesystem;
using experiment::CampaignRun;
using experiment::CampaignSpec;
using experiment::now_iso;
using experiment::write_file_atomically;

namespace {

using Clock = std::chrono::steady_clock;


// ---- small helpers ----

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "?";
  return buf;
}

/// "45s", "2m31s", "1h10m".
std::string human_duration(double s) {
  const long t = std::lround(std::max(0.0, s));
  if (t < 60) return fmt::format("{}s", t);
  if (t < 3600) return fmt::format("{}m{:02d}s", t / 60, t % 60);
  return fmt::format("{}h{:02d}m", t / 3600, (t % 3600) / 60);
}

/// True when another process holds an flock on `path` (probes with LOCK_EX|LOCK_NB, then releases).
bool lock_held(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

// ---- signals ----

std::atomic<int> g_interrupts{0};

extern "C" void on_campaign_signal(int) {
  if (g_interrupts.fetch_add(1) >= 2) {
    ::signal(SIGINT, SIG_DFL);
    ::raise(SIGINT);
  }
}

}  // namespace

// ---- public: processes, signals, local pool ----

bool campaign_interrupted() { return g_interrupts.load() > 0; }
int campaign_interrupt_count() { return g_interrupts.load(); }

void install_campaign_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_campaign_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

int child_exit_code(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

pid_t spawn_run(const RunLaunch& launch, const std::string& worker) {
  const int log_fd = ::open(launch.log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) throw Error("cannot open " + launch.log + ": " + std::strerror(errno));
  std::string header = fmt::format("==== drops campaign: {} {} on {} ({}) at {}\n==== drops",
                                   launch.event, launch.run, worker, host_name(), now_iso());
  for (const auto& a : launch.argv) header += " " + a;
  header += "\n";
  if (::write(log_fd, header.data(), header.size()) < 0) { /* the run still starts */
  }

  // Everything the child needs is prepared before fork: only async-signal-safe calls after it.
  std::vector<std::string> args;
  args.push_back("drops");
  args.insert(args.end(), launch.argv.begin(), launch.argv.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();

  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(log_fd);
    throw Error(std::string("cannot start a run (fork): ") + std::strerror(err));
  }
  if (pid == 0) {
    // Own process group: a terminal's Ctrl-C reaches the campaign only, which forwards exactly
    // one SIGINT per run; a campaign killed outright still stops its runs through PDEATHSIG.
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGINT);
    if (::getppid() != parent) ::_exit(130);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    ::dup2(log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    ::close_range(3, ~0U, 0);
    ::execv("/proc/self/exe", argv.data());
    const char msg[] = "drops campaign: cannot execute /proc/self/exe\n";
    if (::write(STDERR_FILENO, msg, sizeof msg - 1) < 0) { /* nothing left to report to */
    }
    ::_exit(127);
  }
  ::close(log_fd);
  return pid;
}

namespace {

class LocalPool : public WorkerPool {
 public:
  explicit LocalPool(int jobs) : slots_(static_cast<std::size_t>(jobs)) {}
  ~LocalPool() override {
    // Only reached with runs still going when the coordinator throws: stop them cleanly.
    for (auto& s : slots_)
      if (s.pid > 0) ::kill(s.pid, SIGINT);
    for (auto& s : slots_)
      if (s.pid > 0) ::waitpid(s.pid, nullptr, 0);
  }
  int slots() const override { return static_cast<int>(slots_.size()); }
  std::string describe() const override {
    return fmt::format("{} local job{}", slots_.size(), slots_.size() == 1 ? "" : "s");
  }
  std::string worker_name(int slot) const override { return fmt::format("local:{}", slot); }
  void launch(int slot, const RunLaunch& l) override {
    Slot& s = slots_.at(static_cast<std::size_t>(slot));
    s.pid = spawn_run(l, worker_name(slot));
    s.run = l.run;
    s.started = Clock::now();
  }
  std::vector<RunOutcome> poll() override {
    std::vector<RunOutcome> done;
    for (std::size_t i = 0; i < slots_.size(); ++i) {
      Slot& s = slots_[i];
      if (s.pid <= 0) continue;
      int status = 0;
      const pid_t r = ::waitpid(s.pid, &status, WNOHANG);
      if (r == 0 || (r < 0 && errno == EINTR)) continue;
      RunOutcome res;
      res.slot = static_cast<int>(i);
      res.run = s.run;
      res.exit_code = r == s.pid ? child_exit_code(status) : 1;
      res.seconds = std::chrono::duration<double>(Clock::now() - s.started).count();
      res.host = host_name();
      s.pid = 0;
      done.push_back(res);
    }
    return done;
  }
  void interrupt() override {
    for (auto& s : slots_)
      if (s.pid > 0) ::kill(s.pid, SIGINT);
  }

 private:
  struct Slot {
    pid_t pid = 0;
    std::string run;
    Clock::time_point started;
  };
  std::vector<Slot> slots_;
};

// ---- the coordinator ----

enum class Plan { kStart, kRestart, kResume, kSkipComplete, kSkipFailed, kSkipBusy };

const char* plan_word(Plan p) {
  switch (p) {
    case Plan::kStart:
      return "start";
    case Plan::kRestart:
      return "restart";
    case Plan::kResume:
      return "resume";
    case Plan::kSkipComplete:
      return "complete";
    case Plan::kSkipFailed:
      return "failed";
    case Plan::kSkipBusy:
      return "in-use";
  }
  return "?";
}

Plan classify(const experiment::Registry& registry, const experiment::CampaignDirectory& campaign,
              const CampaignRun& run, bool retry_failed) {
  if (!fs::exists(campaign.run(run.name))) return Plan::kStart;
  if (lock_held(campaign.run(run.name) / ".lock")) return Plan::kSkipBusy;
  const std::string status = campaign.run_status(run.name);
  if (status == "complete") {
    campaign.check_kept_run(registry, run);
    return Plan::kSkipComplete;
  }
  if (status == "failed" && !retry_failed) {
    campaign.check_kept_run(registry, run);
    return Plan::kSkipFailed;
  }
  if (campaign.run_has_checkpoint(run.name) &&
      (status == "failed" || status == "interrupted" || status == "running")) {
    campaign.check_kept_run(registry, run);
    return Plan::kResume;
  }
  return Plan::kRestart;
}

/// The campaign's flock; held for the coordinator's lifetime.
class DirectoryLock {
 public:
  explicit DirectoryLock(const fs::path& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error("cannot open " + path.string() + ": " + std::strerror(errno));
    acquired_ = ::flock(fd_, LOCK_EX | LOCK_NB) == 0;
  }
  ~DirectoryLock() {
    if (fd_ >= 0) ::close(fd_);
  }
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;
  bool acquired() const { return acquired_; }

 private:
  int fd_ = -1;
  bool acquired_ = false;
};

/// campaign.log: one JSON object per line, appended with one write() each.
class EventLog {
 public:
  explicit EventLog(const fs::path& path) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error("cannot open " + path.string() + ": " + std::strerror(errno));
  }
  ~EventLog() { ::close(fd_); }
  EventLog(const EventLog&) = delete;
  EventLog& operator=(const EventLog&) = delete;
  void write(const std::string& event, nlohmann::ordered_json fields) {
    nlohmann::ordered_json j;
    j["time"] = now_iso();
    j["event"] = event;
    for (auto it = fields.begin(); it != fields.end(); ++it) j[it.key()] = it.value();
    const std::string line = j.dump() + "\n";
    if (::write(fd_, line.data(), line.size()) < 0)
      std::cerr << "drops campaign: cannot append to campaign.log: " << std::strerror(errno)
                << "\n";
  }

 private:
  int fd_ = -1;
};

std::string status_of(int exit_code, const experiment::CampaignDirectory& campaign,
                      const std::string& run) {
  if (exit_code == 0) return campaign.run_status(run) == "complete" ? "complete" : "failed";
  if (exit_code == 130 || exit_code == 128 + SIGINT || exit_code == 128 + SIGTERM)
    return "interrupted";
  if (exit_code == 3) return "in use";
  return "failed";
}

std::string describe_grid(const CampaignSpec& spec) {
  std::vector<std::string> axes;
  for (const auto& a : spec.grid) axes.push_back(fmt::format("{} {}", a.values.size(), a.key));
  return join(axes, " x ");
}

/// A resolved campaign: the file with the command line's overrides, its runs and its directory.
struct Campaign {
  CampaignSpec spec;
  std::vector<CampaignRun> runs;
  fs::path dir;           ///< absolute <output>/<name>
  experiment::CampaignDirectory directory{fs::path()};  ///< its layout (at dir)
  std::string shown;      ///< <output>/<name> as the user gave it (messages)
  std::string file_text;  ///< the campaign file, copied to campaign.yaml
};

Campaign resolve_campaign(const CampaignOptions& opt) {
  Campaign c;
  c.spec = experiment::load_campaign_file(*opt.registry, opt.file);
  c.file_text = experiment::read_file_text(opt.file);
  if (opt.output) c.spec.output = *opt.output;
  if (opt.threads) c.spec.threads = *opt.threads;
  if (opt.jobs) c.spec.jobs = *opt.jobs;
  if (c.spec.jobs == 0) {
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    c.spec.jobs = std::max(1, cores / c.spec.threads);
  }
  c.runs = experiment::expand_campaign(*opt.registry, c.spec);
  c.dir = fs::absolute(fs::path(c.spec.output) / c.spec.name).lexically_normal();
  c.directory = experiment::CampaignDirectory(c.dir);
  c.shown = (fs::path(c.spec.output) / c.spec.name).string();
  return c;
}

/// Throws ConfigError when the directory already holds another campaign.
void check_same_campaign(const experiment::Registry& registry, const Campaign& c) {
  std::optional<CampaignSpec> old_spec;
  try {
    old_spec = c.directory.read_spec(registry, c.spec.name, true);
  } catch (const ConfigError& e) {
    throw ConfigError(std::string(e.what()) +
                      "; use a new campaign name (key 'name') or another --output");
  }
  if (!old_spec) return;
  const std::string diff = experiment::campaign_difference(registry, *old_spec, c.spec);
  if (!diff.empty())
    throw ConfigError(c.shown + " holds a different campaign: " + diff +
                      " (only jobs and threads may change); use a new campaign name (key "
                      "'name') or another --output, or restore the file");
}

void print_dry_run(const Campaign& c, const std::vector<Plan>& plans) {
  std::map<Plan, int> n;
  for (std::size_t i = 0; i < c.runs.size(); ++i) {
    std::cout << fmt::format("{:<9} {}\n", plan_word(plans[i]), c.runs[i].name);
    ++n[plans[i]];
  }
  std::cout << "(restart: the run directory holds no finished episode and is started again; "
               "failed: skipped unless --retry-failed; in-use: another process holds its lock)\n";
  std::cout << fmt::format(
      "{}: {} runs ({}): {} complete, {} to resume, {} to start, {} failed, {} in use; "
      "{} thread{} per run\n",
      c.shown, c.runs.size(), describe_grid(c.spec), n[Plan::kSkipComplete], n[Plan::kResume],
      n[Plan::kStart] + n[Plan::kRestart], n[Plan::kSkipFailed], n[Plan::kSkipBusy], c.spec.threads,
      c.spec.threads == 1 ? "" : "s");
}

/// Runs the planned runs on a pool: launches them in order on free slots, records how each
/// ended (campaign.log, progress lines, status line), forwards interrupts.
class Dispatcher {
 public:
  Dispatcher(const Campaign& c, std::vector<Plan> plans, WorkerPool& pool, EventLog& log,
             bool quiet)
      : c_(c),
        plans_(std::move(plans)),
        pool_(pool),
        log_(log),
        quiet_(quiet),
        live_(!quiet && ::isatty(STDERR_FILENO)),
        slots_(static_cast<std::size_t>(pool.slots())),
        retired_(static_cast<std::size_t>(pool.slots()), false) {}

  /// Until every run has ended, or the campaign was interrupted and its runs have stopped.
  /// Returns the exit code (see campaign_main).
  int run(const CampaignOptions& opt) {
    start();
    const auto t0 = Clock::now();
    while (true) {
      for (const auto& res : pool_.poll()) on_outcome(res);
      forward_interrupts();
      if (!campaign_interrupted()) launch_on_free_slots();
      if (running() == 0 && (queue_.empty() || campaign_interrupted() || usable_slots() == 0))
        break;
      show_status();
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    clear_status();
    return finish(opt, std::chrono::duration<double>(Clock::now() - t0).count());
  }

 private:
  struct Running {
    std::size_t run = 0;
    Clock::time_point started;
  };

  /// Logs the invocation and the skipped runs, prints the plan, fills the queue.
  void start() {
    std::map<Plan, int> n;
    for (const auto p : plans_) ++n[p];
    log_.write("begin", {{"runs", c_.runs.size()},
                         {"to_run", n[Plan::kStart] + n[Plan::kRestart] + n[Plan::kResume]},
                         {"workers", pool_.describe()},
                         {"threads", c_.spec.threads},
                         {"host", host_name()},
                         {"pid", static_cast<long>(::getpid())}});
    complete_ = n[Plan::kSkipComplete];
    for (std::size_t i = 0; i < c_.runs.size(); ++i) {
      const std::string& name = c_.runs[i].name;
      switch (plans_[i]) {
        case Plan::kSkipComplete:
          log_.write("skip", {{"run", name}, {"status", "complete"}});
          break;
        case Plan::kSkipFailed:
          log_.write("skip", {{"run", name}, {"status", "failed"}});
          failed_.push_back(name);
          break;
        case Plan::kSkipBusy:
          log_.write("skip", {{"run", name}, {"status", "in use"}});
          busy_.push_back(name);
          break;
        default:
          queue_.push_back(i);
      }
    }
    if (quiet_) return;
    std::cerr << fmt::format(
        "drops campaign: {} ({} runs: {}) in {}\n"
        "  {} complete, {} to resume, {} to start{}{}; {}, {} thread{} per run\n",
        c_.spec.name, c_.runs.size(), describe_grid(c_.spec), c_.shown, complete_, n[Plan::kResume],
        n[Plan::kStart] + n[Plan::kRestart],
        failed_.empty() ? "" : fmt::format(", {} failed (skipped: --retry-failed)", failed_.size()),
        busy_.empty() ? "" : fmt::format(", {} in use by another process", busy_.size()),
        pool_.describe(), c_.spec.threads, c_.spec.threads == 1 ? "" : "s");
    for (const auto& f : failed_)
      std::cerr << fmt::format("  failed earlier: {} (see {}/runs/{}.log)\n", f, c_.shown, f);
    for (const auto& b : busy_) std::cerr << fmt::format("  in use by another process: {}\n", b);
  }

  void launch_on_free_slots() {
    for (std::size_t s = 0; s < slots_.size() && !queue_.empty(); ++s) {
      if (slots_[s] || retired_[s]) continue;
      const std::size_t i = queue_.front();
      queue_.pop_front();
      const CampaignRun& run = c_.runs[i];
      const fs::path run_dir = c_.directory.run(run.name);
      if (lock_held(run_dir / ".lock")) {
        log_.write("skip", {{"run", run.name}, {"status", "in use"}});
        busy_.push_back(run.name);
        print_line(run.name + " in use by another process (skipped)");
        continue;
      }
      RunLaunch l;
      l.run = run.name;
      l.log = c_.directory.run_log(run.name).string();
      const std::string threads = std::to_string(c_.spec.threads);
      if (plans_[i] == Plan::kResume) {
        l.event = "resume";
        l.argv = {"run", "--resume", run_dir.string(), "--threads", threads, "-q"};
      } else {
        l.event = "start";
        fs::remove_all(run_dir);  // nothing finished in it (see classify)
        l.argv = {"run",       c_.directory.run_config(run.name).string(),
                  "--output",  c_.directory.runs().string(),
                  "--name",    run.name,
                  "--threads", threads,
                  "-q"};
      }
      const int slot = static_cast<int>(s);
      log_.write(l.event, {{"run", run.name}, {"worker", pool_.worker_name(slot)}});
      slots_[s] = Running{i, Clock::now()};
      try {
        pool_.launch(slot, l);
      } catch (const std::exception& e) {
        slots_[s].reset();
        failed_.push_back(run.name);
        log_.write("finish", {{"run", run.name},
                              {"status", "failed"},
                              {"exit_code", 1},
                              {"seconds", 0},
                              {"worker", pool_.worker_name(slot)}});
        print_line(run.name + " could not be started: " + e.what());
      }
    }
  }

  void on_outcome(const RunOutcome& res) {
    auto& slot = slots_.at(static_cast<std::size_t>(res.slot));
    if (!slot) return;
    const CampaignRun& run = c_.runs[slot->run];
    slot.reset();
    if (res.retired) retired_[static_cast<std::size_t>(res.slot)] = true;
    const std::string status = status_of(res.exit_code, c_.directory, run.name);
    log_.write(status == "in use" ? "skip" : "finish",
               {{"run", run.name},
                {"status", status},
                {"exit_code", res.exit_code},
                {"seconds", std::round(res.seconds * 1000) / 1000},
                {"worker", pool_.worker_name(res.slot)},
                {"host", res.host}});
    const std::string took = human_duration(res.seconds);
    if (status == "complete") {
      ++complete_;
      ++completed_here_;
      completed_seconds_ += res.seconds;
      print_line(run.name + " complete in " + took);
    } else if (status == "interrupted") {
      stopped_.push_back(run.name);
      print_line(run.name + " interrupted after " + took + " (resumable)");
    } else if (status == "in use") {
      busy_.push_back(run.name);
      print_line(run.name + " in use by another process (skipped)");
    } else {
      failed_.push_back(run.name);
      print_line(fmt::format("{} failed (exit code {}) after {}; see {}/runs/{}.log", run.name,
                             res.exit_code, took, c_.shown, run.name));
    }
  }

  /// One SIGINT to every running run per interrupt of the campaign.
  void forward_interrupts() {
    if (campaign_interrupt_count() <= forwarded_) return;
    forwarded_ = campaign_interrupt_count();
    pool_.interrupt();
    if (quiet_) return;
    clear_status();
    std::cerr << (forwarded_ == 1 ? "drops campaign: interrupted; stopping the running runs "
                                    "cleanly (Ctrl-C again stops them at once)\n"
                                  : "drops campaign: stopping the running runs at once\n");
  }

  /// `done 12 · running 2 · left 66 · ETA 1h10m` on a terminal, once a second.
  void show_status() {
    if (!live_ || Clock::now() - last_status_ < std::chrono::seconds(1)) return;
    last_status_ = Clock::now();
    std::string eta = "?";
    if (completed_here_ > 0) {
      const double mean = completed_seconds_ / completed_here_;
      double remaining = mean * static_cast<double>(queue_.size());
      for (const auto& s : slots_)
        if (s)
          remaining += std::max(
              0.0, mean - std::chrono::duration<double>(Clock::now() - s->started).count());
      const int parallel =
          std::max(1, std::min(usable_slots(), static_cast<int>(queue_.size()) + running()));
      eta = human_duration(remaining / parallel);
    }
    std::cerr << fmt::format(
                     "\r\033[Kdone {} \u00b7 running {} \u00b7 left {}{} \u00b7 ETA {}", complete_,
                     running(), queue_.size(),
                     failed_.empty() ? "" : fmt::format(" \u00b7 failed {}", failed_.size()), eta)
              << std::flush;
    status_shown_ = true;
  }

  void clear_status() {
    if (status_shown_) std::cerr << "\r\033[K" << std::flush;
    status_shown_ = false;
  }

  /// `[12/80] <text>` (not with -q).
  void print_line(const std::string& text) {
    if (quiet_) return;
    clear_status();
    std::cerr << fmt::format("[{}/{}] {}\n", complete_, c_.runs.size(), text);
  }

  int running() const {
    int n = 0;
    for (const auto& s : slots_) n += s.has_value();
    return n;
  }

  int usable_slots() const {
    int n = 0;
    for (const bool r : retired_) n += !r;
    return n;
  }

  /// Logs the end, prints the final line, returns the exit code.
  int finish(const CampaignOptions& opt, double seconds) {
    // Interrupted (130) when runs are left to do: not started, or stopped by a signal.
    int code = 0;
    if (!queue_.empty() || (!stopped_.empty() && failed_.empty() && busy_.empty()))
      code = 130;
    else if (!failed_.empty() || !busy_.empty())
      code = 1;
    log_.write("end", {{"complete", complete_},
                       {"failed", failed_.size()},
                       {"in_use", busy_.size()},
                       {"interrupted", stopped_.size()},
                       {"left", queue_.size()},
                       {"seconds", std::round(seconds * 1000) / 1000},
                       {"exit_code", code}});
    const std::string& name = c_.spec.name;
    const std::size_t total = c_.runs.size();
    if (code == 0) {
      std::cerr << fmt::format("campaign {} complete: {}/{} runs ({} in this invocation, {}); {}\n",
                               name, complete_, total, completed_here_, human_duration(seconds),
                               c_.shown);
    } else if (code == 130) {
      std::string resume = "drops campaign " + opt.file;
      if (opt.output) resume += " --output " + *opt.output;
      if (opt.mpi) resume = "mpirun ... " + resume + " --mpi";
      std::cerr << fmt::format(
          "campaign {} interrupted: {}/{} runs complete{}; resume with: {}\n", name, complete_,
          total, failed_.empty() ? "" : fmt::format(", {} failed", failed_.size()), resume);
    } else {
      std::cerr << fmt::format("campaign {}: {}/{} runs complete", name, complete_, total);
      if (!failed_.empty())
        std::cerr << fmt::format(
            ", {} failed ({}; logs in {}/runs/<run>.log; --retry-failed resumes them)",
            failed_.size(), join(failed_, ", "), c_.shown);
      if (!busy_.empty())
        std::cerr << fmt::format(
            ", {} in use by another process ({}; run the campaign again when they are done)",
            busy_.size(), join(busy_, ", "));
      std::cerr << "\n";
    }
    return code;
  }

  const Campaign& c_;
  const std::vector<Plan> plans_;
  WorkerPool& pool_;
  EventLog& log_;
  const bool quiet_, live_;
  std::vector<std::optional<Running>> slots_;
  std::vector<bool> retired_;  ///< slots whose worker was interrupted (MPI)
  std::deque<std::size_t> queue_;
  std::vector<std::string> failed_, busy_, stopped_;
  int complete_ = 0;        ///< complete runs, including those complete before
  int completed_here_ = 0;  ///< completed in this invocation (for the ETA)
  double completed_seconds_ = 0;
  int forwarded_ = 0;
  Clock::time_point last_status_ = Clock::now() - std::chrono::seconds(10);
  bool status_shown_ = false;
};

}  // namespace

std::unique_ptr<WorkerPool> make_local_pool(int jobs) { return std::make_unique<LocalPool>(jobs); }

int coordinate_campaign(const CampaignOptions& opt, WorkerPool* external_pool) {
  const Campaign c = resolve_campaign(opt);  // every run validated
  check_same_campaign(*opt.registry, c);

  std::optional<DirectoryLock> lock;
  if (!opt.dry_run) {
    std::error_code ec;
    fs::create_directories(c.dir, ec);  // for the lock; the rest with campaign.yaml, below
    if (ec) throw Error("cannot create " + c.shown + ": " + ec.message());
    lock.emplace(c.directory.lock_file());
    if (!lock->acquired()) {
      std::cerr << "drops campaign: " << c.shown
                << " is in use by another process (a drops campaign is running it)\n";
      return 3;
    }
  } else if (lock_held(c.directory.lock_file())) {
    std::cerr << "drops campaign: note: " << c.shown << " is in use by another process\n";
  }

  // Plan every run before anything starts (a mismatching run directory stops here).
  std::vector<Plan> plans;
  for (const auto& r : c.runs)
    plans.push_back(classify(*opt.registry, c.directory, r, opt.retry_failed));
  if (opt.dry_run) {
    print_dry_run(c, plans);
    return 0;
  }

  c.directory.write(*opt.registry, c.file_text, c.runs);
  EventLog log(c.directory.log_file());
  std::unique_ptr<WorkerPool> local;
  if (!external_pool) local = make_local_pool(c.spec.jobs);
  Dispatcher dispatcher(c, std::move(plans), external_pool ? *external_pool : *local, log,
                        opt.quiet);
  return dispatcher.run(opt);
}

int campaign_main(const CampaignOptions& options) {
  if (options.mpi) return campaign_mpi_main(options);
  // Started by mpirun without --mpi, every rank would run the whole campaign on its own.
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    const char* v = std::getenv(var);
    if (v && std::atoi(v) > 1)
      throw ConfigError(fmt::format(
          "started by mpirun with {} processes but without --mpi (each process would run the "
          "whole campaign); add --mpi, or run it without mpirun",
          v));
  }
  install_campaign_signal_handlers();
  return coordinate_campaign(options, nullptr);
}

void add_campaign_command(CLI::App& app, Action& action, const experiment::Registry& registry) {
  auto* sub = app.add_subcommand(
      "campaign",
      "Run a grid of experiments (a campaign file, see docs/campaigns.md) as parallel local "
      "processes or over MPI; run it again to resume");
  auto opt = std::make_shared<CampaignOptions>();
  opt->registry = &registry;
  sub->add_option("FILE", opt->file, "campaign file (YAML; see docs/campaigns.md)")->required();
  sub->add_option("-j,--jobs", opt->jobs,
                  "runs at once (default: the file's jobs, else cores / threads)")
      ->check(CLI::Range(1, 4096));
  sub->add_option("--threads", opt->threads,
                  "threads per run (default: the file's threads, else 1)")
      ->check(CLI::Range(1, 1024));
  sub->add_option("--output", opt->output,
                  "parent directory of the campaign directory (default: the file's output)");
  sub->add_flag("--retry-failed", opt->retry_failed, "resume (or restart) runs that failed");
  sub->add_flag("--mpi", opt->mpi,
                "under mpirun: rank 0 hands out runs, ranks 1..K-1 execute them (K >= 2)");
  sub->add_flag("--dry-run", opt->dry_run, "print what each run would do; change nothing");
  sub->add_flag("-q,--quiet", opt->quiet, "only the final line on stderr");
  sub->callback([&action, opt] { action = [opt] { return campaign_main(*opt); }; });
}

}  // namespace drops::app
