// The command line of every executable of the project (fluid, solid, cosim-log,
// cosim-replay), parsed alike with CLI11: --help prints its text and exits 0; anything CLI11
// refuses (an unknown or mistyped flag, a missing value) is one line on stderr,
// "PROGRAM: WHAT (see PROGRAM --help)", and exit code 2 (bad input, protocol/README.md
// section 9). Header-only; the executables link CLI11.
#pragma once

#include <cstdio>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "protocol/session/exit_codes.hpp"
#include "protocol/text.hpp"

namespace cosim::protocol {

/// Parses argv into `app`. @return the exit code when the program ends here (--help, or a
/// command line CLI11 refuses), nothing when it goes on.
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const std::string& program) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::string what = one_line(e.what());
    if (what.empty()) what = e.get_name();
    std::fprintf(stderr, "%s: %s (see %s --help)\n", program.c_str(), what.c_str(), program.c_str());
    return exit_code::bad_input;
  }
  return std::nullopt;
}

}  // namespace cosim::protocol
