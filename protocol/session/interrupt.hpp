// SIGINT and SIGTERM to a server: noted, not fatal. catch_interrupts() blocks both in every
// thread (call it before any thread starts: OpenMP's, LCM's) and lets one thread of its own
// take them with sigwait, so no system call of the run is interrupted (LCM's select()
// would read EINTR as a failure). The run loops ask interrupted() and end the run cleanly
// at the next step: a checkpoint, stop_t naming the signal, the outputs closed, exit code 1
// (protocol/README.md section 9). run-coupled.sh relies on it when it is interrupted itself
// (InterruptStopsBothWithCheckpoint).
#pragma once

#include <pthread.h>

#include <atomic>
#include <csignal>
#include <string>
#include <thread>

namespace cosim::protocol {

namespace detail {
inline std::atomic<int> g_interrupt_signal{0};
}  // namespace detail

/// Blocks SIGINT and SIGTERM and takes them on a thread of its own (once per process).
inline void catch_interrupts() {
  static std::atomic<bool> installed{false};
  if (installed.exchange(true)) return;
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  // A process started in the background by a non-interactive shell has SIGINT ignored, and
  // an ignored signal is discarded, blocked or not: back to the default, so sigwait sees it.
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::thread([set] {
    for (;;) {
      int sig = 0;
      if (sigwait(&set, &sig) == 0) detail::g_interrupt_signal.store(sig);
    }
  }).detach();
}

/// The signal received (SIGINT or SIGTERM), 0 if none.
inline int interrupted() { return detail::g_interrupt_signal.load(); }

/// "interrupted by SIGTERM" for the reasons.
inline std::string interrupt_reason() {
  return std::string("interrupted by ") + (interrupted() == SIGINT ? "SIGINT" : "SIGTERM");
}

}  // namespace cosim::protocol
