// Running a command from a test: the shell line, its exit status and what it printed
// (stdout and stderr captured in files of a scratch folder), and the small text helpers the
// executables' tests share.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <system_error>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>

namespace cosim::test {

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `s` quoted for sh.
inline std::string quoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

inline bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

/// An empty folder `name` under GoogleTest's temporary directory (what was there is removed).
inline std::filesystem::path fresh_scratch(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// The build folder whose executables the launch scripts run (launch/folders.sh):
/// $COSIM_BUILD_DIR (CTest sets it to the test's own build, tests/CMakeLists.txt), else
/// SOURCE/build.
inline std::filesystem::path launcher_build(const std::filesystem::path& source) {
  const char* dir = std::getenv("COSIM_BUILD_DIR");
  return dir != nullptr && *dir != '\0' ? std::filesystem::path(dir) : source / "build";
}

/// Empty when the launch scripts run `fluid` and `solid` (this build's executables), else
/// why they run others: a test comparing against this build would check another one.
inline std::string launcher_build_problem(const std::filesystem::path& source, const std::filesystem::path& fluid,
                                          const std::filesystem::path& solid) {
  const std::filesystem::path b = launcher_build(source);
  std::error_code ec;
  if (std::filesystem::equivalent(b / "fluid" / "fluid", fluid, ec) &&
      std::filesystem::equivalent(b / "solid" / "solid", solid, ec))
    return "";
  return "the launch scripts run " + b.string() + "/{fluid/fluid,solid/solid}, which are not this build's " +
         fluid.string() + " and " + solid.string() + ": set COSIM_BUILD_DIR to this build's folder (ctest does)";
}

inline std::size_t lines(const std::string& s) { return std::size_t(std::count(s.begin(), s.end(), '\n')); }

struct RunResult {
  int status = -1;
  std::string out, err;
};

/// Runs the shell command line `command` (stdin from /dev/null), stdout and stderr captured
/// in files of `scratch` (created if missing).
inline RunResult run_command(const std::string& command, const std::filesystem::path& scratch) {
  std::filesystem::create_directories(scratch);
  const std::filesystem::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string cmd = command + " >" + quoted(out.string()) + " 2>" + quoted(err.string()) + " </dev/null";
  const int raw = std::system(cmd.c_str());
  RunResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

/// Runs the study script `script` (a launch/*.py that prints "NAME: check WHERE: KEY ...: ok"
/// per checked quantity and exits non-zero when one fails) with `args` and `--out` a fresh
/// scratch folder `name`, prints its lines, and expects exit 0 and a check line
/// "WHERE: KEY" for each of `keys` (a study that measured nothing passes no check).
inline void expect_study_passes(const std::filesystem::path& script, const std::string& name,
                                const std::string& args, const std::string& where,
                                std::initializer_list<const char*> keys) {
  const std::filesystem::path out = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(out);
  const RunResult r = run_command("/usr/bin/python3 " + quoted(script.string()) + " --out " +
                                      quoted(out.string()) + " " + args,
                                  out / "logs");
  std::printf("%s%s", r.out.c_str(), r.err.c_str());
  EXPECT_EQ(r.status, 0) << r.err;
  for (const char* k : keys)
    EXPECT_TRUE(contains(r.out, where + ": " + k + " ")) << k << " not checked";
}

}  // namespace cosim::test
