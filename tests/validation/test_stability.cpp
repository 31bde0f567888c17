// The stability matrix and the watchdog end to end (DESIGN 6; issue 7 items 2 and 3): two
// processes through launch/run-coupled.sh (a private network namespace as root), or the
// matrix script. Every HDF5 file a run leaves is read back and checked finite.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/run_compare.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::logs;
using cosim::test::quoted;
using cosim::test::run_launcher;
using cosim::test::scratch;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;

/// `text` with "key = ..." of [section] set to `value` (the first such line after the header).
std::string set_key(std::string text, const std::string& section, const std::string& key,
                    const std::string& value) {
  const std::string header = "\n[" + section + "]\n";
  const std::size_t at = text.find(header);
  if (at == std::string::npos) throw std::runtime_error("no section [" + section + "]");
  const std::size_t end = std::min(text.find("\n[", at + 1), text.size());
  const std::size_t k = text.find("\n" + key + " = ", at);
  if (k == std::string::npos || k > end) {
    text.insert(at + header.size(), key + " = " + value + "\n");
  } else {
    const std::size_t eol = text.find('\n', k + 1);
    text.replace(k + 1, eol - k - 1, key + " = " + value);
  }
  return text;
}

/// A scene of scenes/stability/ (or any) with settings changed, written into `dir`.
fs::path scene_from(const fs::path& source, const fs::path& dir, const std::string& name,
                    const std::vector<std::array<std::string, 3>>& settings) {
  std::string s = slurp(source);
  for (const auto& [section, key, value] : settings) s = set_key(s, section, key, value);
  const fs::path p = dir / (name + ".toml");
  std::ofstream(p) << s;
  return p;
}

/// Every float of every HDF5 file under `dir` (checkpoints included); the names of the
/// datasets with a non-finite value, and how many files were read.
std::vector<std::string> non_finite(const fs::path& dir, int& files) {
  std::vector<std::string> bad;
  files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() != ".h5") continue;
    ++files;
    for (const auto& [name, d] : cosim::test::read_datasets(e.path()))
      if (d.cls == H5T_FLOAT)
        for (const double v : d.values)
          if (!std::isfinite(v)) {
            bad.push_back(e.path().string() + ":" + name);
            break;
          }
  }
  return bad;
}

/// The last line of `log` that contains `what`, or "".
std::string line_with(const std::string& log, const std::string& what) {
  std::string found, line;
  std::istringstream in(log);
  while (std::getline(in, line))
    if (line.find(what) != std::string::npos) found = line;
  return found;
}

/// The short matrix: every case ends stable, or stopped with a diagnosis naming step, place
/// and cause, and no file it leaves holds a NaN (the script checks each; the test reads its
/// per-case lines).
TEST(Stability, StabilityMatrixShort) {
  const fs::path dir = scratch("stability_matrix_short");
  const std::string cmd = "bash " + quoted((kSource / "launch" / "stability-matrix.sh").string()) +
                          " --short --no-build --output " + quoted((dir / "runs").string()) + " --doc " +
                          quoted((dir / "stability.md").string()) + " >" + quoted((dir / "matrix.log").string()) +
                          " 2>&1";
  const int s = std::system(cmd.c_str());
  const std::string out = slurp(dir / "matrix.log");
  ASSERT_TRUE(WIFEXITED(s)) << out;
  EXPECT_EQ(WEXITSTATUS(s), 0) << out;
  std::printf("%s", out.c_str());
  static const std::regex row(R"(stability-matrix: (\w+) +(stable|stopped|no end) *(.*) \(([0-9.]+) s\))");
  int cases = 0, stable = 0, stopped = 0;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, row)) continue;
    ++cases;
    EXPECT_EQ(line.find("VIOLATION"), std::string::npos) << line;
    if (m[2] == "stable") ++stable;
    if (m[2] == "stopped") {
      ++stopped;
      // "step N, cause: place"
      EXPECT_TRUE(std::regex_search(m[3].str(), std::regex(R"(^(after .* )?step (\d+|start-up), [a-z_]+.*: .+)"))) << line;
    }
  }
  EXPECT_GE(cases, 9) << out;
  EXPECT_GE(stable, 3) << out;
  EXPECT_GE(stopped, 4) << out;
  EXPECT_NE(out.find(", 0 violation(s)"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir / "stability.md"));
  if (!HasFailure()) fs::remove_all(dir);
}

/// Runs that would blow up stop with exit 3 and a sentinel's diagnosis, write no NaN, and
/// leave a checkpoint. The solid's side: a sheet lighter than its substeps can hold
/// (scenes/stability/light_sheet.toml, dt_CG / T = 2.7): before the watchdog, its first
/// dynamic interval ended with a non-finite CGP state. The fluid's side: a flow past Mach 0.3
/// around a sheet (mach_local.toml).
TEST(Stability, WatchdogStopsBeforeNaN) {
  const fs::path dir = scratch("watchdog_stops");
  const fs::path light = scene_from(kSource / "scenes" / "stability" / "light_sheet.toml", dir, "light",
                                    {{{"run", "steps", "14"}, {"coupling", "rigid_steps", "10"},
                                      {"coupling", "checkpoint_every", "5"}}});
  const fs::path out = dir / "light";
  EXPECT_EQ(run_launcher(kSource, light, out), 3) << logs(out);
  EXPECT_EQ(slurp(out / "solid.exit"), "3\n") << logs(out);
  EXPECT_EQ(slurp(out / "fluid.exit"), "4\n") << logs(out);
  const std::string solid_line = line_with(slurp(out / "solid.log"), "watchdog cgp_speed");
  EXPECT_TRUE(std::regex_search(solid_line, std::regex(R"(watchdog cgp_speed at step 10 \(substep \d+ of 4000\): )"
                                                       R"(CGP \d+ \(sheet 0, i = \d, j = \d\) moves at [0-9.]+ c)")))
      << logs(out);
  EXPECT_NE(solid_line.find("dt_CG / T = 2.74"), std::string::npos) << solid_line;
  // The fluid names its checkpoint of step 10; the pair of step 5 is the one a retry takes.
  const std::string fluid_line = line_with(slurp(out / "fluid.log"), "coupled run stopped");
  EXPECT_NE(fluid_line.find("checkpoint " + (out / "checkpoints" / "fluid_00000010.h5").string()), std::string::npos)
      << fluid_line;
  EXPECT_TRUE(fs::exists(out / "checkpoints" / "fluid_00000010.h5"));
  EXPECT_TRUE(fs::exists(out / "checkpoints" / "fluid_00000005.h5"));
  EXPECT_TRUE(fs::exists(out / "checkpoints" / "solid_00000005.h5"));
  int files = 0;
  EXPECT_EQ(non_finite(out, files), std::vector<std::string>{}) << logs(out);
  EXPECT_GE(files, 5);  // monitor.h5, solid.h5 and three checkpoints at least

  const fs::path mach = scene_from(kSource / "scenes" / "stability" / "mach_local.toml", dir, "mach",
                                   {{{"run", "steps", "60"}, {"coupling", "checkpoint_every", "4"}}});
  const fs::path out2 = dir / "mach";
  EXPECT_EQ(run_launcher(kSource, mach, out2), 3) << logs(out2);
  EXPECT_EQ(slurp(out2 / "fluid.exit"), "3\n") << logs(out2);
  const std::string reason = line_with(slurp(out2 / "fluid.log"), "coupled run stopped");
  EXPECT_TRUE(std::regex_search(reason, std::regex(R"(watchdog (flow_health|marker_mach) at step \d+: .*(cell \(\d+, \d+, \d+\)|CGP \d+).*Mach [0-9.]+ above)")))
      << reason;
  EXPECT_NE(slurp(out2 / "solid.log").find("checkpoint"), std::string::npos) << logs(out2);
  EXPECT_FALSE(fs::is_empty(out2 / "checkpoints"));
  EXPECT_EQ(non_finite(out2, files), std::vector<std::string>{}) << logs(out2);
  std::printf("solid's sentinel: %s\nfluid's sentinel: %s\n", solid_line.c_str(), reason.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

/// The coordinator prints the added-mass warning at start-up for a sheet too light for its
/// substeps (200 atoms per CGP at A_T = 4000: the fluid's reaction relaxes a CGP in 0.36
/// substeps), naming the ratio, its threshold and what to do; for the paper's scene
/// (scenes/paper/single_theta90_re40.toml: 2e6 atoms on 0.24 x 0.22 um, A_T = 150) it prints the
/// numbers and no warning.
TEST(Stability, AddedMassWarningAtStartUp) {
  const fs::path dir = scratch("added_mass");
  const fs::path light = scene_from(kSource / "scenes" / "stability" / "light_sheet.toml", dir, "light",
                                    {{{"run", "steps", "3"}, {"coupling", "rigid_steps", "3"}}});
  const fs::path out = dir / "light";
  EXPECT_EQ(run_launcher(kSource, light, out), 0) << logs(out);  // held rigid: nothing to blow up
  const std::string warning = line_with(slurp(out / "fluid.log"), "warning: added mass");
  EXPECT_TRUE(std::regex_search(warning, std::regex(R"(^fluid: warning: added mass: the lightest CGP has )"
                                                    R"(m / \(rho_air dA dx\) = 0\.000182\d?, below 2 x )"
                                                    R"(relaxation_substeps_min / A_T = 0\.0005: )")))
      << logs(out);
  EXPECT_NE(warning.find("T = m / (2 rho_air dA c) = 0.364 substeps"), std::string::npos) << warning;
  EXPECT_NE(warning.find("raise coupling.time_ratio to at least 10978 or make the CGPs heavier"), std::string::npos)
      << warning;

  const fs::path paper = scene_from(kSource / "scenes" / "paper" / "single_theta90_re40.toml", dir, "paper",
                                    {{{"run", "steps", "2"}, {"output", "planes_every", "0"},
                                      {"output", "sheets_every", "0"}}});
  const fs::path out2 = dir / "paper";
  EXPECT_EQ(run_launcher(kSource, paper, out2), 0) << logs(out2);
  const std::string log = slurp(out2 / "fluid.log");
  EXPECT_EQ(log.find("warning: added mass"), std::string::npos) << log;
  const std::string numbers = line_with(log, "fluid: added mass: the lightest CGP has");
  // m = 3.989e-20 kg, dA = 0.24 x 0.22 um^2, dx = 0.2561 um: 2.26, T = 1.13 LB steps.
  EXPECT_TRUE(std::regex_search(numbers, std::regex(R"(m / \(rho_air dA dx\) = 2\.26\d*; the fluid's reaction )"
                                                    R"(relaxes it in 169\.\d+ substeps)")))
      << log;
  std::printf("light: %s\npaper: %s\n", warning.c_str(), numbers.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace

// Issue 7 item 4: the sheet of `light_sheet` (m / (rho_air dA dx) = 1.8e-4) at A_T = 4000,
// where the serial scheme's held reaction diverges within the first free interval
// (dt_CG / T = 2.7 > 2; the watchdog stops it), runs to the end with coupling.scheme =
// "implicit": every step's sub-iterations converge (protocol/README.md 13) and no file holds
// a NaN.
TEST(Stability, ImplicitCouplingExtendsMassRatio) {
  const fs::path dir = scratch("implicit_mass_ratio");
  const fs::path source = kSource / "scenes" / "stability" / "light_sheet.toml";
  const fs::path serial = scene_from(source, dir, "serial", {});
  const fs::path out_serial = dir / "serial";
  EXPECT_EQ(run_launcher(kSource, serial, out_serial), 3) << logs(out_serial);
  const std::string serial_log = slurp(out_serial / "solid.log");
  EXPECT_NE(serial_log.find("watchdog cgp_speed at step 20"), std::string::npos) << serial_log;
  EXPECT_NE(serial_log.find("explicit substeps diverge above 2: the cause"), std::string::npos) << serial_log;

  const fs::path implicit = scene_from(source, dir, "implicit", {{{"coupling", "scheme", "\"implicit\""}}});
  const fs::path out = dir / "implicit";
  ASSERT_EQ(run_launcher(kSource, implicit, out), 0) << logs(out);
  const std::string log = slurp(out / "solid.log");
  const std::string line = line_with(log, "solid: implicit scheme:");
  EXPECT_NE(line.find("20 steps iterated"), std::string::npos) << log;
  EXPECT_NE(line.find("; 0 steps not converged"), std::string::npos) << log;
  int files = 0;
  const std::vector<std::string> bad = non_finite(out, files);
  EXPECT_TRUE(bad.empty()) << bad.front();
  EXPECT_GE(files, 2);
  std::printf("serial: %s\nimplicit: %s\n", line_with(serial_log, "watchdog cgp_speed").c_str(), line.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}
