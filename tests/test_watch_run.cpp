// A run a physicist can watch, check, cite and plot (issue 19): every launch script answers
// --help without installing or building, every executable --version; one check of both
// sides of a coupled scene with did-you-mean; scene keys in physical units; the coupled
// launcher's one progress line; provenance and units in every output; XDMF geometry of the
// fluid and the sheets in one frame.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::quoted;
using cosim::test::run_command;
using cosim::test::RunResult;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cosim_watch_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// `base` with some keys replaced or removed ("key" -> value; an empty value removes the
/// line), and lines added after a section header ("[section]" -> lines).
fs::path edited_scene(const fs::path& base, const fs::path& out,
                      const std::vector<std::pair<std::string, std::string>>& edits,
                      const std::vector<std::pair<std::string, std::string>>& additions = {}) {
  std::istringstream in(slurp(base));
  std::ostringstream o;
  for (std::string line; std::getline(in, line);) {
    bool drop = false;
    for (const auto& [key, value] : edits)
      if (line.rfind(key + " ", 0) == 0 || line.rfind(key + "=", 0) == 0) {
        if (value.empty()) drop = true;
        else line = key + " = " + value;
      }
    if (!drop) o << line << "\n";
    for (const auto& [section, text] : additions)
      if (line == section) o << text << "\n";
  }
  std::ofstream(out) << o.str();
  return out;
}

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

// ---- --help and --version ----

TEST(WatchRun, ScriptsAnswerHelpWithoutBuilding) {
  const fs::path dir = scratch("help");
  // Anything that would install or build leaves a mark and fails.
  const fs::path bin = dir / "bin", mark = dir / "built";
  fs::create_directories(bin);
  for (const char* tool : {"cmake", "make", "gmake", "ninja", "ctest", "apt-get", "dpkg-query", "sudo", "lcm-gen",
                           "javac", "git", "unshare"}) {
    std::ofstream(bin / tool) << "#!/bin/sh\necho \"$0 $*\" >> " << quoted(mark.string()) << "\nexit 1\n";
    fs::permissions(bin / tool, fs::perms::owner_all);
  }
  int scripts = 0;
  for (const auto& e : fs::directory_iterator(kSource / "launch")) {
    const std::string name = e.path().filename().string();
    const std::string ext = e.path().extension().string();
    if (name == "help.sh" || (ext != ".sh" && ext != ".py")) continue;
    ++scripts;
    const std::string runner = ext == ".sh" ? "bash " : "/usr/bin/python3 ";
    const auto t0 = std::chrono::steady_clock::now();
    const RunResult r = run_command("PATH=" + quoted(bin.string()) + ":$PATH timeout 20 " + runner +
                                        quoted(e.path().string()) + " --help",
                                    dir / "run");
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.status, 0) << name << ": " << r.err;
    EXPECT_FALSE(r.out.empty()) << name;
    if (ext == ".sh") {
      // The usage line names the script as it is run.
      EXPECT_TRUE(contains(r.out, "launch/" + name)) << name << " --help:\n" << r.out;
    }
    EXPECT_LT(s, 10.0) << name;
    EXPECT_FALSE(fs::exists(mark)) << name << " --help installed or built: " << slurp(mark);
    fs::remove(mark);
  }
  EXPECT_GE(scripts, 20);
  fs::remove_all(dir);
}

TEST(WatchRun, ToolsAnswerVersion) {
  const fs::path dir = scratch("version");
  const RunResult git = run_command("git -C " + quoted(kSource.string()) + " rev-parse HEAD", dir);
  for (const auto& [name, exe] : std::vector<std::pair<std::string, std::string>>{{"fluid", FLUID_EXE},
                                                                                 {"solid", SOLID_EXE},
                                                                                 {"cosim-log", COSIM_LOG_EXE},
                                                                                 {"cosim-replay", REPLAY_EXE},
                                                                                 {"bench", FLUID_BENCH_EXE},
                                                                                 {"solid_bench", SOLID_BENCH_EXE}}) {
    const RunResult r = run_command(quoted(exe) + " --version", dir);
    EXPECT_EQ(r.status, 0) << name << ": " << r.err;
    // "NAME 0.1.0 (git DESCRIBE, commit HASH)", the commit this tree's build came from.
    static const std::regex line(R"(^(\S+) (\d+\.\d+\.\d+) \(git (\S+), commit ([0-9a-f]{40}|unknown)\).*\n$)");
    std::smatch m;
    ASSERT_TRUE(std::regex_match(r.out, m, line)) << name << ": " << r.out;
    EXPECT_EQ(m[1].str(), name);
    if (git.status == 0 && git.out.size() >= 40) {
      // The build's commit (a later commit without a rebuild would differ: build first).
      EXPECT_EQ(m[4].str(), git.out.substr(0, 40)) << name << ": " << r.out;
    }
  }
  // A flag mistyped: one line with a did-you-mean, exit 2.
  const RunResult bad = run_command(quoted(FLUID_EXE) + " x.toml --stpes 5", dir);
  EXPECT_EQ(bad.status, 2);
  EXPECT_TRUE(contains(bad.err, "did you mean \"--steps\"")) << bad.err;
  EXPECT_EQ(cosim::test::lines(bad.err), 1u) << bad.err;
  fs::remove_all(dir);
}

// ---- one check of both sides ----

TEST(WatchRun, CheckFindsTyposOnBothSides) {
  const fs::path dir = scratch("check");
  const fs::path small = kSource / "scenes" / "coupled_small.toml";
  const std::string check = "bash " + quoted((kSource / "launch" / "check.sh").string()) + " ";
  const std::string env = "COSIM_FLUID_EXE=" + quoted(FLUID_EXE) + " COSIM_SOLID_EXE=" + quoted(SOLID_EXE) + " ";

  // A clean coupled scene: both sides ok.
  RunResult r = run_command(env + check + quoted(small.string()), dir);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, ": fluid: ok")) << r.out;
  EXPECT_TRUE(contains(r.out, ": solid: ok")) << r.out;

  // A typo in the solid's [[sheet]] (theta for theta_deg): the fluid alone would pass it.
  const fs::path sheet_typo = edited_scene(small, dir / "sheet_typo.toml", {{"theta_deg", ""}}, {{"[[sheet]]", "theta = 90"}});
  r = run_command(quoted(FLUID_EXE) + " " + quoted(sheet_typo.string()) + " --check", dir);
  EXPECT_EQ(r.status, 0) << "the fluid leaves the solid's sections to the solid: " << r.err;
  r = run_command(env + check + quoted(sheet_typo.string()), dir);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(contains(r.out, ": fluid: ok")) << r.out;
  EXPECT_TRUE(contains(r.out, "did you mean \"theta_deg\"")) << r.out;

  // A model name cut short (corotation for corotational), and a typo on the fluid's side in
  // the same file: both reported in one call.
  const fs::path both = edited_scene(small, dir / "both.toml", {{"model", "\"corotation\""}, {"tau", ""}},
                                     {{"[fluid]", "tua = 0.8"}});
  r = run_command(env + check + quoted(both.string()), dir);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "fluid: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "did you mean \"tau\"")) << r.out;
  EXPECT_TRUE(contains(r.out, "did you mean \"corotational\"")) << r.out;
  // One line per scene and side.
  EXPECT_EQ(cosim::test::lines(r.out), 2u) << r.out;
  fs::remove_all(dir);
}

// ---- physical units in scenes ----

/// The header line of `fluid --check` that starts with `key` (after its indent).
std::string header_line(const std::string& out, const std::string& key) {
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("  " + key, 0) == 0) return line;
  return "";
}

TEST(WatchRun, PhysicalUnitsInScenes) {
  const fs::path dir = scratch("units");
  const fs::path tiny = kSource / "tests" / "scenes" / "tiny_channel.toml";
  // The lattice scene, and the same in physical units: u_max 0.05 c, 20 steps of dt.
  const RunResult lattice = run_command(quoted(FLUID_EXE) + " " + quoted(tiny.string()) + " --check", dir);
  ASSERT_EQ(lattice.status, 0) << lattice.err;
  // c = dx / dt from the header: "dt = dx / c = X ns (c = sqrt(3) c_s = C m/s)".
  static const std::regex units_re(R"(dt = dx / c = ([0-9.e+-]+) ns \(c = sqrt\(3\) c_s = ([0-9.e+-]+) m/s\))");
  std::smatch m;
  const std::string units_line = header_line(lattice.out, "units");
  ASSERT_TRUE(std::regex_search(units_line, m, units_re)) << lattice.out;
  const double dt_us = std::stod(m[1].str()) * 1e-3, c = std::stod(m[2].str());
  const double u_m_s = 0.05 * c, duration_us = 20 * dt_us;
  char u_text[64], d_text[64];
  std::snprintf(u_text, sizeof u_text, "%.17g", u_m_s);
  std::snprintf(d_text, sizeof d_text, "%.17g", duration_us);
  const fs::path physical =
      edited_scene(tiny, dir / "physical.toml", {{"u_max", ""}, {"steps", ""}},
                   {{"[inlet]", std::string("u_max_m_s = ") + u_text}, {"[run]", std::string("duration_us = ") + d_text}});
  const RunResult p = run_command(quoted(FLUID_EXE) + " " + quoted(physical.string()) + " --check", dir);
  ASSERT_EQ(p.status, 0) << p.err;
  // The same run: the same speed (the faces line), the same steps (the run line).
  EXPECT_EQ(header_line(p.out, "faces"), header_line(lattice.out, "faces")) << p.out;
  EXPECT_EQ(header_line(p.out, "run"), header_line(lattice.out, "run")) << p.out;
  EXPECT_EQ(header_line(p.out, "fluid"), header_line(lattice.out, "fluid")) << p.out;
  // Echoed in lattice units at start-up.
  EXPECT_TRUE(contains(p.out, "inlet.u_max_m_s = ")) << p.out;
  EXPECT_TRUE(contains(p.out, "-> inlet.u_max = 0.05 (U/c")) << p.out;
  EXPECT_TRUE(contains(p.out, "-> run.steps = 20 LB steps")) << p.out;

  // One of the two at a time.
  const fs::path both_u = edited_scene(tiny, dir / "both_u.toml", {}, {{"[inlet]", "u_max_m_s = 4.0"}});
  RunResult r = run_command(quoted(FLUID_EXE) + " " + quoted(both_u.string()) + " --check", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.err, "inlet.u_max = 0.05 and inlet.u_max_m_s = 4")) << r.err;
  EXPECT_EQ(cosim::test::lines(r.err), 1u) << r.err;
  const fs::path both_t = edited_scene(tiny, dir / "both_t.toml", {}, {{"[run]", "duration_us = 1.0"}});
  r = run_command(quoted(FLUID_EXE) + " " + quoted(both_t.string()) + " --check", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.err, "run.steps = 20 and run.duration_us = 1")) << r.err;
  // A bad physical value: named, with what is allowed.
  const fs::path fast = edited_scene(tiny, dir / "fast.toml", {{"u_max", ""}}, {{"[inlet]", "u_max_m_s = 400.0"}});
  r = run_command(quoted(FLUID_EXE) + " " + quoted(fast.string()) + " --check", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.err, "inlet.u_max_m_s = 400")) << r.err;
  const fs::path short_run = edited_scene(tiny, dir / "short.toml", {{"steps", ""}}, {{"[run]", "duration_us = 1e-9"}});
  r = run_command(quoted(FLUID_EXE) + " " + quoted(short_run.string()) + " --check", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.err, "run.duration_us = 1e-09")) << r.err;
  fs::remove_all(dir);
}

}  // namespace
