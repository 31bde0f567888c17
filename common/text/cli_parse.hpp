// The command line of every executable of the project (fluid, solid, cosim-log,
// cosim-replay, the benches), parsed alike with CLI11: --help prints its text and exits 0;
// --version prints "PROGRAM VERSION (git DESCRIBE, commit HASH)" and exits 0; anything CLI11
// refuses (an unknown or mistyped flag, a missing value) is one line on stderr,
// "PROGRAM: WHAT (see PROGRAM --help)", and exit code 2 (bad input, protocol/README.md
// section 9). Header-only; the executables link CLI11.
#pragma once

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/text/did_you_mean.hpp"
#include "common/run/provenance.hpp"
#include "common/run/exit_codes.hpp"
#include "common/text/text.hpp"
#include "common/run/version.hpp"

namespace cosim::protocol {

/// " (did you mean \"--steps\"?)" for the first --flag of argv that `app` does not know and
/// that is close to one it does (common/text/did_you_mean.hpp); "" if none.
inline std::string flag_suggestion(const CLI::App& app, int argc, char** argv) {
  std::vector<std::string> names;
  for (const CLI::Option* o : app.get_options())
    for (const std::string& n : o->get_lnames()) names.push_back("--" + n);
  const std::vector<std::string_view> known(names.begin(), names.end());
  for (int k = 1; k < argc; ++k) {
    const std::string_view a = argv[k];
    if (!a.starts_with("--")) continue;
    const std::string_view flag = a.substr(0, a.find('='));
    if (std::find(known.begin(), known.end(), flag) != known.end()) continue;
    if (std::string hint = did_you_mean(flag, known); !hint.empty()) return hint;
  }
  return "";
}

/// Parses argv into `app` (adding --version). @return the exit code when the program ends
/// here (--help, --version, or a command line CLI11 refuses), nothing when it goes on.
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const std::string& program) {
  record_invocation(program, argc, argv);  // the command line and start time of the outputs' provenance
  app.set_version_flag("--version", version_line(program), "print the version and git commit, and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::string what = one_line(e.what());
    if (what.empty()) what = e.get_name();
    what += flag_suggestion(app, argc, argv);
    std::fprintf(stderr, "%s: %s (see %s --help)\n", program.c_str(), what.c_str(), program.c_str());
    return exit_code::bad_input;
  }
  return std::nullopt;
}

}  // namespace cosim::protocol
