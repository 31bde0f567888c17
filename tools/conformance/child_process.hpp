// A candidate solid as a child process of the conformance kit: started through /bin/sh -c
// (the command as a user writes it, e.g. "python3 my_solid.py --k 2") in its own process
// group, its output into a file, watched without blocking, and ended by its own id.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <map>
#include <optional>
#include <string>

namespace cosim::conformance {

class ChildProcess {
 public:
  /// Starts `/bin/sh -c command` with `env` added to the environment, stdout and stderr to
  /// `log_path`. @throws std::runtime_error naming the command if it cannot be started.
  ChildProcess(const std::string& command, const std::map<std::string, std::string>& env, const std::string& log_path);
  /// Ends it (SIGTERM, then SIGKILL) if it still runs.
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// Its exit status once it ended (128 + signal for a signal), else nothing. Never blocks.
  std::optional<int> poll();
  /// Waits up to `timeout` for it to end; its exit status, or nothing.
  std::optional<int> wait_for(std::chrono::milliseconds timeout);
  /// SIGTERM to its process group, SIGKILL after a second; its status.
  int kill();
  /// The last non-empty line of its output (for a one-line reason).
  std::string last_line() const;

 private:
  pid_t pid_ = -1;
  std::optional<int> status_;
  std::string log_path_;
};

}  // namespace cosim::conformance
