// Progress of a run, for the person watching it: the rate and ETA of its steps
// (ProgressClock) and the line that shows them (ProgressLine: a carriage-return line on a
// terminal, plain lines at a slower cadence in a log file). One implementation for the
// fluid-only and solid-only servers' progress lines and the coupled servers' "progress"
// lines, which launch/progress.py merges into the launcher's one line (README, "Coupled
// runs").
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "common/log/logger.hpp"

namespace cosim::protocol {

/// Rate and ETA of a run that goes from step `first` to step `total`, timed from its start.
class ProgressClock {
 public:
  using Clock = std::chrono::steady_clock;

  explicit ProgressClock(std::int64_t total, std::int64_t first = 0) : total_(total) { restart(first); }
  /// Times from now, from step `first` (a restart's).
  void restart(std::int64_t first) {
    first_ = first;
    start_ = last_ = Clock::now();
  }
  double elapsed_s() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  /// Steps per second since the start.
  double rate(std::int64_t step) const {
    const double t = elapsed_s();
    return t > 0.0 ? double(step - first_) / t : 0.0;
  }
  /// Seconds left at that rate; 0 before the first step.
  double eta_s(std::int64_t step) const {
    const double r = rate(step);
    return r > 0.0 ? double(total_ - step) / r : 0.0;
  }
  /// True at most once every `every_s` seconds (the first time after `every_s`).
  bool due(double every_s) {
    const Clock::time_point now = Clock::now();
    if (std::chrono::duration<double>(now - last_).count() < every_s) return false;
    last_ = now;
    return true;
  }
  std::int64_t total() const { return total_; }
  std::int64_t first() const { return first_; }

 private:
  std::int64_t total_, first_ = 0;
  Clock::time_point start_, last_;
};

/// The seconds between progress lines in a log file: `fallback`, or the environment's
/// COSIM_PROGRESS_EVERY_S (a number > 0; tests set a short one).
double progress_every_s(double fallback);

/// "42 s", "3 min 05 s", "2 h 07 min".
std::string format_duration(double seconds);

/// The progress line of a fluid-only or solid-only run on stderr, in the logger's format
/// ("fluid: progress <text>", log::Logger::progress): on a terminal rewritten in place with a
/// carriage return, at most twice a second; otherwise (a log file) one plain line every
/// progress_every_s(10) seconds. Shown where the logger's threshold shows progress (not
/// --quiet).
class ProgressLine {
 public:
  explicit ProgressLine(const log::Logger& logger);
  /// Whether a line is due now (the last step's always is).
  bool due(bool last);
  void show(const std::string& text);
  /// Clears a carriage-return line before something else is printed.
  void clear();

 private:
  log::Logger logger_;
  bool enabled_, tty_, shown_ = false;
  double every_s_;
  ProgressClock::Clock::time_point last_;
};

}  // namespace cosim::protocol
