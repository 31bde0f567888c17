// The project's version and the git commit it was built from (generated at build time by
// cmake/version.cmake from `git describe`; never committed): what every executable answers
// to --version (common/text/cli_parse.hpp) and what every output folder records
// (common/run/provenance.hpp).
#pragma once

#include <string>

namespace cosim::protocol {

/// The project's version, e.g. "0.1.0" (CMakeLists.txt's project(VERSION)).
const char* version();
/// `git describe --always --dirty --tags` at build time, e.g. "90af1b0-dirty"; "unknown"
/// outside a git checkout.
const char* git_describe();
/// The full commit hash at build time; "unknown" outside a git checkout.
const char* git_commit();
/// "PROGRAM 0.1.0 (git 90af1b0, commit 90af1b0...)": the --version line.
std::string version_line(const std::string& program);

}  // namespace cosim::protocol
