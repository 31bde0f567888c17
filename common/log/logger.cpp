#include "common/log/logger.hpp"

#include <cstdarg>
#include <cstdio>
#include <mutex>

namespace cosim::log {

namespace {
std::mutex& lines_lock() {
  static std::mutex m;
  return m;
}
}  // namespace

std::string printf_text(const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string text(n > 0 ? std::size_t(n) : 0, '\0');
  if (n > 0) std::vsnprintf(text.data(), text.size() + 1, format, again);
  va_end(again);
  return text;
}

Line::Line(std::string head, bool shown, std::ostream& os) : head_(std::move(head)), os_(&os), shown_(shown) {}

Line::Line(Line&& other) noexcept
    : head_(std::move(other.head_)), os_(other.os_), shown_(other.shown_),
      text_(std::move(other.text_)) {
  other.shown_ = false;
}

Line::~Line() {
  if (!shown_) return;
  Logger::write(*os_, head_ + text_.str() + "\n");
}

Logger::Logger(std::string process, Level threshold) : process_(std::move(process)), threshold_(threshold) {}

std::string Logger::format(Level level, std::string_view text) const {
  std::string line = prefix();
  if (level == Level::warning) line += "warning: ";
  if (level == Level::progress) line += "progress ";
  line += text;
  return line;
}

void Logger::write(std::ostream& os, std::string_view text) {
  const std::lock_guard<std::mutex> hold(lines_lock());
  os << text;
  os.flush();
}

}  // namespace cosim::log
