// The error-against-run-time study (DESIGN 6, docs/error-vs-runtime.md): its short version,
// `launch/error-study.sh --short`, runs every knob on cheap settings (fluid alone, solid alone,
// and coupled runs of two processes through launch/run-coupled.sh) and must finish, write its
// tables, leave docs/ alone, and show the errors of both grid-resolution rows falling with
// resolution: strictly smaller on each finer grid.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;
using cosim::test::quoted;
using cosim::test::launcher_build_problem;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kFluid = FLUID_EXE;
const fs::path kSolid = SOLID_EXE;
const char* const kPython = "/usr/bin/python3";  // Debian's, with h5py, numpy and matplotlib

int run(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, sep)) out.push_back(cell);
  return out;
}

struct Row {
  std::string knob, kind, setting;
  double error = NAN;
  bool reference = false;
};

/// OUT/results.tsv: a header, then knob, kind, setting, value, error, wall_s, peak_rss_mib,
/// reference, front, note.
std::vector<Row> read_results(const fs::path& p) {
  std::vector<Row> rows;
  std::istringstream in(slurp(p));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto c = split(line, '\t');
    if (c.size() < 9) {
      ADD_FAILURE() << p << ": short line: " << line;
      continue;
    }
    Row r;
    r.knob = c[0];
    r.kind = c[1];
    r.setting = c[2];
    r.error = c[4] == "nan" ? NAN : std::strtod(c[4].c_str(), nullptr);
    r.reference = c[7] == "1";
    rows.push_back(r);
  }
  return rows;
}

TEST(ErrorStudy, ErrorStudyShortRuns) {
  if (!fs::exists(kPython)) GTEST_SKIP() << kPython << " missing (launch/bootstrap.sh installs it)";
  // The study runs the launch scripts' build (as launch/run-coupled.sh does): it must be
  // this one, or the test would check another build.
  const std::string problem = launcher_build_problem(kSource, kFluid, kSolid);
  ASSERT_TRUE(problem.empty()) << problem;

  const fs::path dir = fs::path(::testing::TempDir()) / ("cosim_error_study_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / "study";
  const fs::path doc = kSource / "docs" / "error-vs-runtime.md";
  const bool doc_existed = fs::exists(doc);
  const auto doc_time = doc_existed ? fs::last_write_time(doc) : fs::file_time_type{};

  const int status = run("bash " + quoted((kSource / "launch" / "error-study.sh").string()) +
                         " --short --no-build --out " + quoted(out.string()) + " >" +
                         quoted((dir / "study.log").string()) + " 2>&1");
  const std::string log = slurp(dir / "study.log");
  ASSERT_EQ(status, 0) << log;

  // The tables and the machine-readable results.
  const fs::path table = out / "error-vs-runtime.md";
  ASSERT_TRUE(fs::exists(table)) << log;
  const std::string md = slurp(table);
  EXPECT_NE(md.find("# Error against run time"), std::string::npos) << md;
  EXPECT_NE(md.find("| setting |"), std::string::npos) << md;
  ASSERT_TRUE(fs::exists(out / "results.tsv")) << log;
  EXPECT_TRUE(fs::exists(out / "results.json")) << log;
  EXPECT_TRUE(fs::exists(out / "figures" / "resolution_fluid.png")) << log;
  EXPECT_TRUE(fs::exists(out / "figures" / "resolution_coupled.png")) << log;

  // --short writes only into --out.
  EXPECT_EQ(fs::exists(doc), doc_existed);
  if (doc_existed) {
    EXPECT_TRUE(fs::last_write_time(doc) == doc_time) << doc << " was rewritten by --short";
  }

  const std::vector<Row> rows = read_results(out / "results.tsv");
  std::map<std::string, std::vector<Row>> by_knob;
  for (const Row& r : rows) by_knob[r.knob].push_back(r);
  for (const char* knob : {"resolution_fluid", "resolution_coupled", "time_ratio", "truncation_range",
                           "coupling_scheme", "precision"})
    EXPECT_TRUE(by_knob.count(knob)) << knob << " missing from results.tsv:\n" << slurp(out / "results.tsv");

  // Every knob of kind "resolution" lists its grids from coarse to fine; the errors (against
  // the analytic solution, or against the finest grid, which is the reference row and has
  // none) must fall strictly from each grid to the next finer one.
  int resolution_knobs = 0;
  for (const auto& [knob, list] : by_knob) {
    if (list.front().kind != "resolution") continue;
    ++resolution_knobs;
    std::vector<double> errors;
    std::string shown;
    for (const Row& r : list) {
      shown += "  " + r.setting + ": " + (r.reference ? std::string("reference") : std::to_string(r.error)) + "\n";
      if (r.reference) continue;
      ASSERT_TRUE(std::isfinite(r.error) && r.error > 0.0) << knob << " " << r.setting << ": error " << r.error;
      errors.push_back(r.error);
    }
    std::printf("%s:\n%s", knob.c_str(), shown.c_str());
    ASSERT_GE(errors.size(), 2u) << knob << ":\n" << shown;
    for (std::size_t i = 1; i < errors.size(); ++i)
      EXPECT_LT(errors[i], errors[i - 1]) << knob << ": the error does not fall from one grid to the next finer "
                                          << "one:\n" << shown;
  }
  EXPECT_EQ(resolution_knobs, 2) << slurp(out / "results.tsv");

  fs::remove_all(dir);
}

}  // namespace
