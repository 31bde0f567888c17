#include "common/run/progress.hpp"

#include <unistd.h>

#include <cmath>
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

ProgressLine::ProgressLine(bool enabled, std::FILE* stream)
    : enabled_(enabled), tty_(isatty(fileno(stream)) != 0), stream_(stream),
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
  std::fprintf(stream_, "%s%s%s", tty_ ? "\r" : "", text.c_str(), tty_ ? "    " : "\n");
  std::fflush(stream_);
  shown_ = tty_;
}

void ProgressLine::clear() {
  if (!shown_) return;
  std::fprintf(stream_, "\r%100s\r", "");
  std::fflush(stream_);
  shown_ = false;
}

}  // namespace cosim::protocol
