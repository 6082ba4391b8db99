// `mpirun -np K drops campaign FILE --mpi`: rank 0 plans the campaign and hands out runs one at a
// time; ranks 1..K-1 execute each as a `drops run` child process (exactly as a local campaign
// does) and report how it ended. Every wait polls (MPI_Iprobe / MPI_Test and short sleeps): a
// blocking receive in Open MPI spins a core that the runs need.
//
// Messages (payload: JSON text, MPI_CHAR):
//   rank 0 -> worker  kTagRun        {"run", "event", "argv", "log"}
//   rank 0 -> worker  kTagInterrupt  {"level"}: forward SIGINT to the run (once per level)
//   rank 0 -> worker  kTagStop       {}: stop the run if any, answer kTagStopped, leave
//   worker -> rank 0  kTagResult     {"run", "exit_code", "seconds", "host", "retired"}
//   worker -> rank 0  kTagStopped    {}

#include "campaign.hpp"
#include "drops/core/errors.hpp"

#ifdef DROPS_WITH_MPI

// The C API only: without these, Open MPI's and MPICH's mpi.h pull in the deprecated C++ bindings.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <fmt/format.h>
#include <mpi.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <iostream>
#include <list>
#include <nlohmann/json.hpp>
#include <thread>

namespace drops::app {
namespace {

using Clock = std::chrono::steady_clock;

constexpr int kTagRun = 1;
constexpr int kTagInterrupt = 2;
constexpr int kTagStop = 3;
constexpr int kTagResult = 4;
constexpr int kTagStopped = 5;
constexpr auto kPoll = std::chrono::milliseconds(50);

struct Message {
  int source = 0;
  int tag = 0;
  std::string text;
};

/// A message that has arrived, if any (never waits).
std::optional<Message> try_receive(int source, int tag) {
  int flag = 0;
  MPI_Status st;
  MPI_Iprobe(source, tag, MPI_COMM_WORLD, &flag, &st);
  if (!flag) return std::nullopt;
  int count = 0;
  MPI_Get_count(&st, MPI_CHAR, &count);
  Message m{st.MPI_SOURCE, st.MPI_TAG, std::string(static_cast<std::size_t>(count), '\0')};
  MPI_Recv(m.text.data(), count, MPI_CHAR, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD,
           MPI_STATUS_IGNORE);
  return m;
}

/// Non-blocking sends whose buffers live until MPI_Test reports them complete; both sides keep
/// receiving meanwhile, so two ranks sending to each other never wait on each other.
class Outbox {
 public:
  void send(std::string text, int dest, int tag) {
    pending_.push_back({std::move(text), MPI_REQUEST_NULL});
    Pending& p = pending_.back();
    MPI_Isend(p.text.data(), static_cast<int>(p.text.size()), MPI_CHAR, dest, tag, MPI_COMM_WORLD,
              &p.request);
  }
  /// Completes what can be completed; true when nothing is pending.
  bool progress() {
    for (auto it = pending_.begin(); it != pending_.end();) {
      int done = 0;
      MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
      it = done ? pending_.erase(it) : std::next(it);
    }
    return pending_.empty();
  }
  void flush() {
    while (!progress()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }

 private:
  struct Pending {
    std::string text;
    MPI_Request request;
  };
  std::list<Pending> pending_;
};

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "?";
  return buf;
}

/// Rank 0's view of ranks 1..K-1.
class MpiPool : public WorkerPool {
 public:
  explicit MpiPool(int size) : busy_(static_cast<std::size_t>(size - 1), false) {}
  ~MpiPool() override {
    try {
      shutdown();
    } catch (...) {
    }
  }
  int slots() const override { return static_cast<int>(busy_.size()); }
  std::string describe() const override {
    return fmt::format("{} MPI worker rank{}", busy_.size(), busy_.size() == 1 ? "" : "s");
  }
  std::string worker_name(int slot) const override { return fmt::format("mpi:{}", slot + 1); }
  void launch(int slot, const RunLaunch& l) override {
    const nlohmann::json j = {{"run", l.run}, {"event", l.event}, {"argv", l.argv}, {"log", l.log}};
    outbox_.send(j.dump(), slot + 1, kTagRun);
    busy_.at(static_cast<std::size_t>(slot)) = true;
  }
  std::vector<RunOutcome> poll() override {
    outbox_.progress();
    std::vector<RunOutcome> done;
    while (auto m = try_receive(MPI_ANY_SOURCE, kTagResult)) {
      const nlohmann::json j = nlohmann::json::parse(m->text);
      RunOutcome r;
      r.slot = m->source - 1;
      r.run = j.at("run").get<std::string>();
      r.exit_code = j.at("exit_code").get<int>();
      r.seconds = j.at("seconds").get<double>();
      r.host = j.value("host", "?");
      r.retired = j.value("retired", false);
      busy_.at(static_cast<std::size_t>(r.slot)) = false;
      done.push_back(r);
    }
    return done;
  }
  void interrupt() override {
    const std::string level = nlohmann::json{{"level", campaign_interrupt_count()}}.dump();
    for (std::size_t s = 0; s < busy_.size(); ++s)
      if (busy_[s]) outbox_.send(level, static_cast<int>(s) + 1, kTagInterrupt);
  }
  /// Tells every worker to leave and waits (polling) until each has answered; results that
  /// still arrive are dropped (only reached early when the coordinator throws).
  void shutdown() {
    if (stopped_) return;
    stopped_ = true;
    for (std::size_t s = 0; s < busy_.size(); ++s)
      outbox_.send("{}", static_cast<int>(s) + 1, kTagStop);
    std::size_t answered = 0;
    while (answered < busy_.size()) {
      outbox_.progress();
      bool any = false;
      while (auto m = try_receive(MPI_ANY_SOURCE, MPI_ANY_TAG)) {
        any = true;
        if (m->tag == kTagStopped) ++answered;
      }
      if (!any) std::this_thread::sleep_for(kPoll);
    }
    outbox_.flush();
  }

 private:
  std::vector<bool> busy_;
  Outbox outbox_;
  bool stopped_ = false;
};

/// Ranks 1..K-1: run what rank 0 sends, one run at a time, until told to stop.
int worker_loop(int rank) {
  Outbox outbox;
  const std::string host = host_name();
  const std::string worker = fmt::format("mpi:{}", rank);
  pid_t child = 0;
  std::string run;
  Clock::time_point started;
  int level_sent = 0;   // SIGINTs forwarded to the current run
  int level_asked = 0;  // interrupt level requested by rank 0
  bool stop = false;

  auto send_result = [&](const std::string& name, int exit_code, double seconds) {
    const nlohmann::json j = {{"run", name},
                              {"exit_code", exit_code},
                              {"seconds", seconds},
                              {"host", host},
                              {"retired", campaign_interrupted()}};
    outbox.send(j.dump(), 0, kTagResult);
  };

  while (true) {
    outbox.progress();
    while (auto m = try_receive(0, MPI_ANY_TAG)) {
      if (m->tag == kTagRun) {
        const nlohmann::json j = nlohmann::json::parse(m->text);
        RunLaunch l;
        l.run = j.at("run").get<std::string>();
        l.event = j.at("event").get<std::string>();
        l.argv = j.at("argv").get<std::vector<std::string>>();
        l.log = j.at("log").get<std::string>();
        if (child != 0 || campaign_interrupted() || stop) {
          send_result(l.run, 130, 0);  // not started: the run stays pending for the next time
          continue;
        }
        try {
          child = spawn_run(l, worker);
          run = l.run;
          started = Clock::now();
          level_sent = 0;
        } catch (const std::exception& e) {
          std::cerr << fmt::format("drops campaign ({} on {}): {}\n", worker, host, e.what());
          send_result(l.run, 1, 0);
        }
      } else if (m->tag == kTagInterrupt) {
        level_asked = std::max(level_asked, nlohmann::json::parse(m->text).value("level", 1));
      } else if (m->tag == kTagStop) {
        stop = true;
        level_asked = std::max(level_asked, 1);
      }
    }
    // One SIGINT per interrupt, whether it reached this rank (mpirun forwards signals to every
    // rank) or rank 0 asked: a second SIGINT stops a run at once instead of cleanly.
    const int level = std::max(level_asked, campaign_interrupt_count());
    if (child != 0 && level > level_sent) {
      ::kill(child, SIGINT);
      level_sent = level;
    }
    if (child != 0) {
      int status = 0;
      const pid_t r = ::waitpid(child, &status, WNOHANG);
      if (r == child || (r < 0 && errno != EINTR)) {
        const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
        if (!stop) send_result(run, r == child ? child_exit_code(status) : 1, seconds);
        child = 0;
      }
    }
    if (stop && child == 0) break;
    std::this_thread::sleep_for(kPoll);
  }
  outbox.send("{}", 0, kTagStopped);
  outbox.flush();
  return 0;
}

class MpiSession {
 public:
  MpiSession() {
    if (MPI_Init(nullptr, nullptr) != MPI_SUCCESS) throw Error("MPI_Init failed");
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiSession() { MPI_Finalize(); }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  int rank_ = 0, size_ = 1;
};

}  // namespace

bool mpi_built() { return true; }

int campaign_mpi_main(const CampaignOptions& options) {
  MpiSession mpi;
  install_campaign_signal_handlers();
  if (mpi.size() < 2)
    throw ConfigError(
        "--mpi needs at least 2 MPI processes (rank 0 hands out the runs, ranks 1..K-1 run them); "
        "start it as: mpirun -np K drops campaign " +
        options.file + " --mpi, with K >= 2");
  if (mpi.rank() != 0) return worker_loop(mpi.rank());
  MpiPool pool(mpi.size());
  const int code = coordinate_campaign(options, &pool);
  pool.shutdown();
  return code;
}

}  // namespace drops::app

#else  // !DROPS_WITH_MPI

namespace drops::app {

bool mpi_built() { return false; }

int campaign_mpi_main(const CampaignOptions&) {
  throw ConfigError(
      "--mpi: this drops was built without MPI; install one (scripts/install-deps installs "
      "libopenmpi-dev and openmpi-bin), reconfigure with cmake -DDROPS_WITH_MPI=ON and rebuild, "
      "or run the campaign locally without --mpi");
}

}  // namespace drops::app

#endif  // DROPS_WITH_MPI
