// The one TOML reader of scene files, used by both servers (DESIGN 2: "scene configuration
// has one reader"): it parses the file, checks every section and key against the reading
// process's schema and the ownership table (protocol/config/scene_sections.hpp), and reads
// typed values with one-line errors
//   FILE[:LINE]: KEY = VALUE: what is wrong and what is allowed
// naming a close known name when a key or section is misspelt ("did you mean ...").
// The parsers built on it (fluid/config/scene_config.cpp, solid/config/solid_scene.cpp, the solid models'
// options, protocol/config/coupling_config.cpp) turn a scene into plain typed structs: the
// physics never sees a TOML table (STYLE).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "protocol/config/scene_sections.hpp"

namespace cosim::protocol::config {

/// A scene file that cannot be run; what() is one line "FILE[:LINE]: ...". Each server turns
/// it into its own error type at its parser's boundary.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// When a process reads a section of its schema.
enum class Use {
  Always,
  Standalone,  ///< only in a scene without [coupling] (the solid's [run], [perturbation], [load])
  Coupled,     ///< only in a scene with [coupling]
};

/// A section of one process's schema: the keys it reads there.
struct SectionSchema {
  std::string_view name;
  /// Empty for a section both processes share whose keys scene_sections() lists.
  std::vector<std::string_view> keys = {};
  bool array = false;  ///< [[name]]
  Use use = Use::Always;
};

class SceneReader;

/// One table of the document and its name in messages: "solid" for [solid], "sheet[1]" for
/// the second [[sheet]]. An absent section is a Table that is not present(): its getters
/// return nothing, so optional keys need no test of their section.
class Table {
 public:
  Table(const SceneReader& reader, const toml::table* table, std::string name, std::uint32_t line)
      : reader_(&reader), table_(table), name_(std::move(name)), line_(line) {}

  bool present() const { return table_ != nullptr; }
  const std::string& name() const { return name_; }
  std::uint32_t line() const { return line_; }  ///< of the header; 0 if absent
  std::string key(std::string_view k) const { return name_ + "." + std::string(k); }
  const toml::node* node(std::string_view k) const { return table_ ? table_->get(k) : nullptr; }
  bool has(std::string_view k) const { return node(k) != nullptr; }

  /// Typed values; absent: nothing. A value of another type: "must be a number, not a
  /// string". Numbers are finite; an integer is written as one (16.5 is refused).
  std::optional<double> number(std::string_view k) const;
  std::optional<std::int64_t> integer(std::string_view k) const;
  std::optional<bool> boolean(std::string_view k) const;
  std::optional<std::string> string(std::string_view k) const;
  /// An integer in [lo, hi]: "must be an integer from LO to HI" + `why`.
  std::optional<int> integer_in(std::string_view k, std::int64_t lo, std::int64_t hi,
                                const std::string& why = "") const;
  /// A number > 0: "must be > 0 (WHAT)".
  std::optional<double> positive(std::string_view k, const std::string& what) const;
  /// A length in micrometres, > 0 ("must be > 0 (WHAT)") and within [length_min_um,
  /// length_max_um] ("must be in [1e-9, 1e6] micrometres (WHAT)"): a femtometre to a metre,
  /// so that every conversion (to bohr, to lattice cells) stays a positive finite number.
  std::optional<double> length_um(std::string_view k, const std::string& what) const;
  static constexpr double length_min_um = 1e-9;
  static constexpr double length_max_um = 1e6;
  /// A string from a closed list; its index. Else "must be one of ..." with did-you-mean.
  std::optional<std::size_t> choice(std::string_view k, const std::vector<const char*>& allowed) const;
  /// An array of n_min to n_max finite numbers; anything else is refused with `shape`.
  std::optional<std::vector<double>> numbers(std::string_view k, std::size_t n_min,
                                             std::size_t n_max, const std::string& shape) const;

  /// "NAME.K = VALUE: msg" at the value's line. @pre has(k)
  [[noreturn]] void bad(std::string_view k, const std::string& msg) const;
  /// "NAME.K: missing; what" at the section's line.
  [[noreturn]] void missing(std::string_view k, const std::string& what) const;
  /// `what` at the section's line.
  [[noreturn]] void fail(const std::string& what) const;
  /// The value of `k` as written (strings quoted). @pre has(k)
  std::string show(std::string_view k) const;
  /// The line of `k`'s value. @pre has(k)
  std::uint32_t line_of(std::string_view k) const;

 private:
  const SceneReader* reader_;
  const toml::table* table_;
  std::string name_;
  std::uint32_t line_;
};

/// A parsed scene file as one process reads it.
class SceneReader {
 public:
  /// Reads and parses `path`. A missing or unreadable file and a TOML syntax error throw
  /// ConfigError ("FILE:LINE:COLUMN: TOML syntax error: ...").
  SceneReader(std::string path, Process process);

  const std::string& path() const { return path_; }
  Process process() const { return process_; }
  /// A coupled scene: one with a [coupling] section.
  bool coupled() const { return root_.contains("coupling"); }

  /// Every section and key must be in `schema` (the sections of this process, in the order
  /// messages list them) or belong to the other process by scene_sections(): those are left
  /// unread in a coupled scene and refused in one without [coupling]. Anything else is
  /// refused, with a did-you-mean.
  void check_sections(const std::vector<SectionSchema>& schema) const;

  /// A single section ([name]); not present() if absent. @pre check_sections passed
  Table section(std::string_view name) const;
  /// The tables of an array section ([[name]]); empty if absent. @pre check_sections passed
  std::vector<Table> array_section(std::string_view name) const;
  std::uint32_t section_line(std::string_view name) const;

  /// "FILE[:LINE]: what" as a ConfigError (LINE 0: none).
  [[noreturn]] void fail(std::uint32_t line, const std::string& what) const;
  /// "FILE:LINE: KEY = VALUE: msg" at the node's line.
  [[noreturn]] void bad(const toml::node& n, const std::string& key, const std::string& msg) const;

 private:
  std::string path_;
  Process process_;
  toml::table root_;
};

/// `read()`, with a ConfigError turned into the caller's error type E (each server has its
/// own: fluid::SceneError, solid::SolidSceneError).
template <class E, class Read>
auto rethrow_as(Read&& read) {
  try {
    return read();
  } catch (const ConfigError& e) {
    throw E(e.what());
  }
}

// Text helpers of the one-line messages.

/// "command line: OPTION = VALUE: msg" on one line: a refused command-line override.
std::string command_line_problem(const std::string& option, const std::string& value,
                                 const std::string& msg);

/// Control characters become spaces, so that a message stays on one line.
std::string one_line(std::string s);
/// `"s"` on one line, cut to 60 characters: a value as the messages show it.
std::string quoted(const std::string& s);
/// The shortest text that reads back as `v` ("0.5", "1e-320").
std::string format_double(double v);
/// " (did you mean \"X\"?)" for the allowed name closest to `got` (at most 2 edits, 3 for
/// names of 8 or more characters, or `got` with its unit suffix left off: theta ->
/// theta_deg); "" if none is close.
std::string suggestion(std::string_view got, const std::vector<std::string_view>& allowed);
/// "a, b, c" with `prefix` and `suffix` around each.
std::string join(const std::vector<std::string_view>& items, std::string_view prefix = "",
                 std::string_view suffix = "");

}  // namespace cosim::protocol::config
