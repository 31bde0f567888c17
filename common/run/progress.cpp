#include "common/run/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace cosim::protocol {

double progress_every_s(double fallback) {
  if (const char* env = std::getenv("COSIM_PROGRESS_EVERY_S")) {
    char* end = nullptr;
    const double v = std::strtod(env, &end);
    if (end != env && *end == '\0' && std::isfinite(v) && v > 0.0) return v;
  }
  return fallback;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return "?";
  const long long s = std::llround(seconds);
  char buf[48];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%lld s", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%lld min %02lld s", s / 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%lld h %02lld min", s / 3600, (s % 3600) / 60);
  return buf;
}

ProgressLine::ProgressLine(const log::Logger& logger)
    : logger_(logger), enabled_(logger.shows(log::Level::progress)), tty_(isatty(STDERR_FILENO) != 0),
      every_s_(tty_ ? 0.5 : progress_every_s(10.0)), last_(ProgressClock::Clock::now()) {}

bool ProgressLine::due(bool last) {
  if (!enabled_) return false;
  const auto now = ProgressClock::Clock::now();
  if (!last && std::chrono::duration<double>(now - last_).count() < every_s_) return false;
  last_ = now;
  return true;
}

void ProgressLine::show(const std::string& text) {
  if (!enabled_) return;
  const std::string line = logger_.format(log::Level::progress, text);
  log::Logger::write(std::cerr, tty_ ? "\r" + line + "    " : line + "\n");
  shown_ = tty_;
}

void ProgressLine::clear() {
  if (!shown_) return;
  log::Logger::write(std::cerr, "\r" + std::string(100, ' ') + "\r");
  shown_ = false;
}

}  // namespace cosim::protocol
