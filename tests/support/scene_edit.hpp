// Scene writers of the tests: a shipped scene (a template) with some of its text replaced,
// written where the test wants it. Each replacement is of the first occurrence, in order, and
// one that finds nothing throws (the template changed under the test).
#pragma once

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/run_command.hpp"

namespace cosim::test {

/// `text` with the first `from` replaced by `to` (a scene template edited for a test);
/// throws when `text` lacks `from`.
inline void replace_in(std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("scene template lacks " + from);
  text.replace(at, from.size(), to);
}

/// The text replacements (from -> to, applied in order) that make a test's scene.
using SceneEdits = std::vector<std::pair<std::string, std::string>>;

/// The scene file `from` with `edits` applied, written as `to` (its folder created); `to`.
inline std::filesystem::path write_edited_scene(const std::filesystem::path& from, const SceneEdits& edits,
                                                const std::filesystem::path& to) {
  std::string s = slurp(from);
  for (const auto& [a, b] : edits) replace_in(s, a, b);
  std::filesystem::create_directories(to.parent_path());
  std::ofstream(to) << s;
  return to;
}

}  // namespace cosim::test
