#pragma once
// What the integration tests of the `drops` command line share: fresh temporary directories, whole
// files read and written, the episodes of a run directory without their timing, and the drops
// binary (DROPS_BINARY, defined for every integration test by tests/CMakeLists.txt) run through the
// shell with its stderr captured.
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace drops::cli_test {

namespace fs = std::filesystem;

/// A fresh, empty directory `<temp>/drops-<suite>-<name>-<pid>`: removed first if it exists, then
/// created. `suite` names the test file (e.g. "campaign"), `name` the test; the pid keeps test
/// processes running side by side apart. Returns its path.
inline fs::path fresh_dir(const std::string& suite, const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("drops-" + suite + "-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// The whole content of file `p`, byte for byte; "" when it cannot be read.
inline std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Writes `text` to file `p`, byte for byte, replacing what it held (the folder must exist).
inline void write_file(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
}

/// The JSON document in file `p` (throws nlohmann::json::parse_error when it is missing or not
/// JSON).
inline nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

/// The episodes.csv of run directory `run_dir` without its wall-clock columns (model_learning_s,
/// policy_optimization_s, found by the header): what runs with the same seed must repeat to the
/// byte. Every kept cell ends with ',' and every row with '\n'; "" when there is no episodes.csv.
inline std::string episodes_without_timing(const fs::path& run_dir) {
  std::ifstream in(run_dir / "episodes.csv");
  std::string line, out;
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (keep.empty())
      for (const auto& name : cells)
        keep.push_back(name != "model_learning_s" && name != "policy_optimization_s");
    for (std::size_t i = 0; i < cells.size(); ++i)
      if (i >= keep.size() || keep[i]) out += cells[i] + ",";
    out += "\n";
  }
  return out;
}

/// The exit code of a wait status (std::system, waitpid): the process's own code when it exited,
/// 128 + the signal's number when a signal ended it (as a shell reports it).
inline int exit_code(int status) {
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// Runs the shell command line `command` (std::system) with its stderr sent to a temporary file,
/// and puts that text in *stderr_text unless it is null. Returns the exit code (exit_code: 128 +
/// the signal's number when killed).
inline int shell(const std::string& command, std::string* stderr_text = nullptr) {
  const fs::path err =
      fs::temp_directory_path() / ("drops-test-stderr-" + std::to_string(getpid()));
  const int status = std::system((command + " 2> " + err.string()).c_str());
  if (stderr_text) *stderr_text = read_file(err);
  fs::remove(err);
  return exit_code(status);
}

/// Where run_drops sends the binary's stdout: to the test's own stdout, or to /dev/null.
enum class Stdout { kKeep, kDiscard };

/// Runs `drops <args>` (the DROPS_BINARY; `args` is shell text, so it may hold quotes and
/// redirections of stdout) through `shell`: its stderr in *stderr_text unless null, its stdout
/// kept or discarded as `stdout_to` says. Returns the exit code (128 + the signal's number when
/// killed).
inline int run_drops(const std::string& args, std::string* stderr_text = nullptr,
                     Stdout stdout_to = Stdout::kKeep) {
  return shell(std::string(DROPS_BINARY) + " " + args +
                   (stdout_to == Stdout::kDiscard ? " > /dev/null" : ""),
               stderr_text);
}

/// Starts `drops <args>` in the background (/bin/sh -c "exec drops <args> 2> <stderr_file>", so
/// the pid is drops's own and a signal sent to it reaches drops). `args` is shell text. Returns
/// the child's pid (-1 when fork failed); the caller waits for it with waitpid.
inline pid_t spawn_drops(const std::string& args, const fs::path& stderr_file = "/dev/null") {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string cmd =
        std::string("exec ") + DROPS_BINARY + " " + args + " 2>" + stderr_file.string();
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

}  // namespace drops::cli_test
