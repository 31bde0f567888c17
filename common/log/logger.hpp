// The one logger of every process: its lines start with the process's name ("fluid: ",
// "solid: ", "cosim-replay: "), carry a level, and one threshold decides which are shown
// (--quiet: no progress). The progress line is a level of its own with one format,
// "<process>: progress <text>" (launch/progress.py reads the coupled servers' lines); on a
// terminal ProgressLine rewrites it in place (common/run/progress.hpp).
//
// A Logger is a small value (the name and the threshold), not a global: each process names
// itself in one place (fluid/fluid_log.hpp, solid/solid_log.hpp, each tool's main). Each line
// is written whole under one lock, so that threads (the fluid's OpenMP region) never
// interleave within a line. Lines go to the stream the caller gives (stdout for the run's
// story, stderr for errors and progress), so that a test can hand in a string stream.
#pragma once

#include <iostream>
#include <sstream>
#include <string>
#include <string_view>

namespace cosim::log {

/// From the most to the least important; a threshold shows its level and those above it.
/// `progress` sits below `info`: --quiet is the threshold `info`.
enum class Level { error, warning, info, progress, debug };

/// printf into a string: the lines written with a printf format.
[[gnu::format(printf, 1, 2)]] std::string printf_text(const char* format, ...);

/// One line being written: collects `<<` and writes "<prefix><text>\n" when it ends (or
/// nothing where the level is below the threshold).
class Line {
 public:
  /// `head`: the prefix and the level's word; nothing is written where `shown` is false.
  Line(std::string head, bool shown, std::ostream& os);
  Line(Line&& other) noexcept;
  Line(const Line&) = delete;
  Line& operator=(const Line&) = delete;
  Line& operator=(Line&&) = delete;
  ~Line();

  template <class T>
  Line& operator<<(const T& value) {
    if (shown_) text_ << value;
    return *this;
  }

 private:
  std::string head_;
  std::ostream* os_;
  bool shown_;
  std::ostringstream text_;
};

class Logger {
 public:
  explicit Logger(std::string process, Level threshold = Level::progress);

  /// The same process with another threshold (--quiet: Level::info).
  Logger at(Level threshold) const { return Logger(process_, threshold); }
  bool shows(Level level) const { return level <= threshold_; }
  const std::string& process() const { return process_; }
  /// "fluid: "
  std::string prefix() const { return process_ + ": "; }

  /// "fluid: <text>" (errors carry no word of their own: the text says what went wrong).
  Line error(std::ostream& os = std::cerr) const { return line(Level::error, os); }
  /// "fluid: warning: <text>"
  Line warning(std::ostream& os = std::cout) const { return line(Level::warning, os); }
  Line info(std::ostream& os = std::cout) const { return line(Level::info, os); }
  Line debug(std::ostream& os = std::cerr) const { return line(Level::debug, os); }
  /// The progress line as a plain line: "fluid: progress <text>".
  Line progress(std::ostream& os = std::cerr) const { return line(Level::progress, os); }

  /// A line of that level on `os`.
  Line line(Level level, std::ostream& os) const { return Line(format(level, ""), shows(level), os); }
  /// The text of a line of that level, without the newline: the prefix, the level's word
  /// ("warning: ", "progress ") and `text`.
  std::string format(Level level, std::string_view text) const;
  /// Writes `text` (one or more whole lines, or a carriage-return line) to `os` at once,
  /// under the lock every Line takes, and flushes it.
  static void write(std::ostream& os, std::string_view text);

 private:
  std::string process_;
  Level threshold_;
};

}  // namespace cosim::log
