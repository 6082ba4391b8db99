#pragma once
// `drops campaign FILE.yaml`: a grid of `drops run` experiments, each in its own child process,
// run by a pool of local job slots or by the ranks of an MPI job, resumable at any time.
// The file format, the directory layout and the resume rules are documented in docs/campaigns.md;
// the directory is read and written through experiment::CampaignDirectory.

#include <sys/types.h>

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "command.hpp"
#include "drops/experiment/campaign.hpp"
#include "drops/experiment/registry.hpp"

namespace drops::app {

/// Command-line options of `drops campaign`.
struct CampaignOptions {
  std::string file;                   ///< the campaign file
  std::optional<int> jobs;            ///< -j: overrides the file's `jobs`
  std::optional<int> threads;         ///< --threads: overrides the file's `threads`
  std::optional<std::string> output;  ///< --output: overrides the file's `output`
  bool retry_failed = false;          ///< --retry-failed: resume (or restart) failed runs
  bool mpi = false;                   ///< --mpi: rank 0 coordinates, ranks 1..K-1 run
  bool quiet = false;                 ///< -q: only the final line on stderr
  bool dry_run = false;               ///< --dry-run: print the plan, write nothing
  const experiment::Registry* registry = nullptr;  ///< the tasks and algorithms (required)
};

/// `drops campaign`: returns the exit code (0 every run complete, 1 a run failed or was in use by
/// another process, 3 the campaign directory is in use, 130 interrupted). Throws
/// drops::ConfigError for an invalid campaign file or one that does not match the campaign
/// directory, drops::Error for other failures. Not reentrant (installs SIGINT/SIGTERM handlers).
int campaign_main(const CampaignOptions& options);

// ---- the worker side, shared by the local pool (campaign.cpp) and MPI (campaign_mpi.cpp) ----

/// What a worker slot starts: `drops <argv...>` as a child process of this binary.
struct RunLaunch {
  std::string run;                ///< run name
  std::string event;              ///< "start" or "resume"
  std::vector<std::string> argv;  ///< arguments after the program name, e.g. {"run", ...}
  std::string log;                ///< file that receives the child's stdout and stderr (appended)
};

/// How a launched run ended.
struct RunOutcome {
  int slot = -1;         ///< worker slot that ran it
  std::string run;       ///< run name
  int exit_code = 1;     ///< the child's exit code, or 128 + signal when killed
  double seconds = 0;    ///< wall time of the child
  std::string host;      ///< host name of the worker
  bool retired = false;  ///< the worker was interrupted and takes no more runs
};

/// Starts `/proc/self/exe argv...` in its own process group, with stdin from /dev/null, stdout
/// and stderr appended to launch.log, and SIGINT as parent-death signal (a killed campaign stops
/// its runs cleanly). Returns the child's pid. Throws drops::Error when the log cannot be opened
/// or fork fails. worker: the slot's name, written with the command line into the log.
/// Call from the main thread only (the parent-death signal follows the thread that forks).
pid_t spawn_run(const RunLaunch& launch, const std::string& worker);

/// The exit code of a waitpid status (128 + signal for a killed child).
int child_exit_code(int wait_status);

/// True once SIGINT or SIGTERM reached this process after install_campaign_signal_handlers();
/// campaign_interrupt_count() counts them. Async-signal-safe.
bool campaign_interrupted();
int campaign_interrupt_count();
/// Installs the campaign's SIGINT/SIGTERM handlers (count the signal; a third one kills).
void install_campaign_signal_handlers();

/// The places where runs execute: local job slots or MPI ranks. Used by one thread (the
/// coordinator); not thread-safe.
class WorkerPool {
 public:
  virtual ~WorkerPool() = default;
  /// Number of slots (runs at once).
  virtual int slots() const = 0;
  /// One-line description, e.g. "2 local jobs" or "3 MPI worker ranks".
  virtual std::string describe() const = 0;
  /// The name of a slot in campaign.log, e.g. "local:0" or "mpi:3" (MPI rank 3).
  virtual std::string worker_name(int slot) const = 0;
  /// Starts a run on a free slot. Throws drops::Error when it cannot be started.
  virtual void launch(int slot, const RunLaunch& launch) = 0;
  /// Non-blocking: the runs that ended since the last call.
  virtual std::vector<RunOutcome> poll() = 0;
  /// Asks every running run to stop cleanly (SIGINT); call once per campaign interrupt.
  virtual void interrupt() = 0;
};

/// `jobs` local slots, each a child process.
std::unique_ptr<WorkerPool> make_local_pool(int jobs);

/// The coordinator: plans the campaign, writes its directory and runs it on `pool` (or, when
/// pool is null, on a local pool of the campaign's `jobs`). Same results and errors as
/// campaign_main.
int coordinate_campaign(const CampaignOptions& options, WorkerPool* pool);

/// True when this binary was built with MPI (DROPS_WITH_MPI).
bool mpi_built();

/// `drops campaign --mpi`: MPI_Init; rank 0 calls coordinate_campaign with a pool of ranks
/// 1..K-1, the other ranks run what rank 0 hands them; MPI_Finalize. Throws drops::ConfigError
/// when K < 2 or the binary was built without MPI.
int campaign_mpi_main(const CampaignOptions& options);

}  // namespace drops::app
