// A run a physicist can watch, check, cite and plot (issue 19): every launch script answers
// --help without installing or building, every executable --version; one check of both
// sides of a coupled scene with did-you-mean; scene keys in physical units; and, on a
// shortened scenes/coupled_small.toml through launch/run-coupled.sh (two processes), the
// launcher's one progress line and --quiet's summary, provenance and units in every output,
// the XDMF geometry of the fluid and the sheets in one frame (tests/integration/xdmf_geometry.py). The
// paper's figures (launch/paper-figures.sh --tiny) are in test_plots.cpp, a long test.
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

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::quoted;
using cosim::test::run_command;
using cosim::test::RunResult;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;

fs::path scratch(const std::string& name) { return cosim::test::fresh_scratch("cosim_watch_" + name); }

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

using cosim::test::contains;

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
    // help.sh, folders.sh and traffic-log.sh are sourced by the scripts, not run.
    if (name == "help.sh" || name == "folders.sh" || name == "traffic-log.sh" || (ext != ".sh" && ext != ".py"))
      continue;
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
  const bool in_git = run_command("git -C " + quoted(kSource.string()) + " rev-parse HEAD", dir).status == 0;
  for (const auto& [name, exe] : std::vector<std::pair<std::string, std::string>>{{"fluid", FLUID_EXE},
                                                                                 {"solid", SOLID_EXE},
                                                                                 {"cosim-log", COSIM_LOG_EXE},
                                                                                 {"cosim-replay", REPLAY_EXE},
                                                                                 {"bench", FLUID_BENCH_EXE},
                                                                                 {"solid_bench", SOLID_BENCH_EXE},
                                                                                 {"prescribed_plate", PRESCRIBED_PLATE_EXE},
                                                                                 {"cosim-conformance", CONFORMANCE_EXE},
                                                                                 {"spring_sheet", SPRING_SHEET_EXE}}) {
    const RunResult r = run_command(quoted(exe) + " --version", dir);
    EXPECT_EQ(r.status, 0) << name << ": " << r.err;
    // "NAME 0.1.0 (git DESCRIBE, commit HASH)", the commit this tree's build came from.
    static const std::regex line(R"(^(\S+) (\d+\.\d+\.\d+) \(git (\S+), commit ([0-9a-f]{40}|unknown)\).*\n$)");
    std::smatch m;
    ASSERT_TRUE(std::regex_match(r.out, m, line)) << name << ": " << r.out;
    EXPECT_EQ(m[1].str(), name);
    if (in_git) {
      // A commit of this repository (the build's; HEAD itself once rebuilt after a commit).
      EXPECT_EQ(run_command("git -C " + quoted(kSource.string()) + " cat-file -e " + m[4].str() + "^{commit}", dir)
                    .status,
                0)
          << name << ": " << r.out;
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

  // A model name cut short (corotation for corotational), and a typo in a section only the
  // fluid reads ([run]; [fluid] is read by both since its medium sets both sides' units) in
  // the same file: both reported in one call.
  const fs::path both = edited_scene(small, dir / "both.toml", {{"model", "\"corotation\""}}, {{"[run]", "stpes = 100"}});
  r = run_command(env + check + quoted(both.string()), dir);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "fluid: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "did you mean \"steps\"")) << r.out;
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
  // u_max = u_max_m_s / c: 0.05 to the 5 digits of c in the header the test took it from.
  static const std::regex echo_re(R"(-> inlet\.u_max = ([0-9.e+-]+) \(U/c)");
  ASSERT_TRUE(std::regex_search(p.out, m, echo_re)) << p.out;
  EXPECT_NEAR(std::stod(m[1].str()), 0.05, 0.05 * 2e-5) << p.out;
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


// ---- a coupled run: two processes through launch/run-coupled.sh ----

/// coupled_small, 60 LB steps (30 rigid), snapshots of fields, a plane and the sheets.
fs::path short_scene(const fs::path& dir) {
  std::istringstream in(slurp(kSource / "scenes" / "coupled_small.toml"));
  std::ostringstream o;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("steps =", 0) == 0) line = "steps = 60";
    if (line.rfind("monitor_every =", 0) == 0) line = "monitor_every = 20";
    if (line.rfind("rigid_steps =", 0) == 0) line = "rigid_steps = 30";
    if (line.rfind("fields_every =", 0) == 0) line = "fields_every = 30\nplanes_every = 30\nplanes_y = [0.5]";
    if (line.rfind("sheets_every =", 0) == 0) line = "sheets_every = 30";
    o << line << "\n";
  }
  const fs::path p = dir / "watch_small.toml";
  std::ofstream(p) << o.str();
  return p;
}

RunResult launch(const fs::path& scene, const fs::path& out, const std::string& options, const std::string& env = "") {
  return run_command(env + " bash " + quoted((kSource / "launch" / "run-coupled.sh").string()) + " " +
                         quoted(scene.string()) + " --output " + quoted(out.string()) + " --no-build " + options,
                     out.parent_path() / (out.filename().string() + "_launcher"));
}

TEST(WatchRun, CoupledProgressLineHasEta) {
  const fs::path dir = scratch("progress");
  const fs::path scene = short_scene(dir);
  const RunResult r = launch(scene, dir / "out", "", "COSIM_PROGRESS_EVERY_S=0.2 COSIM_RUN_LABEL='run 1 of 1'");
  ASSERT_EQ(r.status, 0) << r.out << r.err << slurp(dir / "out" / "fluid.log");
  // One line: the run's label, the phase, step, simulated time, MLUPS, both sides' compute
  // and wait shares, the ETA.
  static const std::regex line(
      R"(run 1 of 1  (spin-up|free)  step \d+/60 \(\d+ %\)  t = \S+ us  \S+ MLUPS  fluid compute \d+ % wait \d+ %  solid compute \d+ % wait \d+ %  ETA \d+ s)");
  EXPECT_TRUE(std::regex_search(r.out, line)) << r.out;
  // The release, after the 30 rigid steps.
  EXPECT_TRUE(contains(r.out, "fluid: sheet released at step 30 (t = ")) << r.out;
  // The monitor rows stay in fluid.log.
  EXPECT_FALSE(contains(r.out, "\nstep 20  t = ")) << r.out;
  EXPECT_TRUE(contains(slurp(dir / "out" / "fluid.log"), "step 20  t = "));
  // The closing summary is shown.
  EXPECT_TRUE(contains(r.out, "fluid: coupled run done, 60 LB steps")) << r.out;

  // --quiet: no progress, the summary kept.
  const RunResult q = launch(scene, dir / "quiet", "--quiet", "COSIM_PROGRESS_EVERY_S=0.2");
  ASSERT_EQ(q.status, 0) << q.out << q.err;
  EXPECT_FALSE(contains(q.out, "ETA")) << q.out;
  EXPECT_TRUE(contains(q.out, "fluid: coupled run done, 60 LB steps")) << q.out;
  EXPECT_TRUE(contains(q.out, "fluid: per LB step: compute")) << q.out;
  fs::remove_all(dir);
}

// ---- provenance ----

std::string string_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return "<missing>";
  const hid_t a = H5Aopen(object, name, H5P_DEFAULT);
  const hid_t t = H5Aget_type(a);
  std::string value;
  if (H5Tget_class(t) == H5T_STRING) {
    value.resize(H5Tget_size(t));
    H5Aread(a, t, value.data());
    value = value.c_str();
  } else {
    value = "<not a string>";
  }
  H5Tclose(t);
  H5Aclose(a);
  return value;
}

struct Datasets {
  std::vector<std::string> names;
};

herr_t collect(hid_t group, const char* name, const H5L_info_t*, void* data) {
  const hid_t o = H5Oopen(group, name, H5P_DEFAULT);
  if (H5Iget_type(o) == H5I_DATASET) static_cast<Datasets*>(data)->names.push_back(name);
  return H5Oclose(o);
}

TEST(WatchRun, OutputsCarryProvenance) {
  const fs::path dir = scratch("provenance");
  const fs::path scene = short_scene(dir);
  const fs::path out = dir / "out";
  const RunResult r = launch(scene, out, "--quiet");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  // The folder: a copy of the scene, and each server's provenance.
  EXPECT_EQ(slurp(out / "scene.toml"), slurp(scene));
  for (const char* side : {"fluid", "solid"}) {
    const std::string p = slurp(out / (std::string("provenance_") + side + ".toml"));
    for (const char* key : {"version = \"", "git_commit = \"", "git_describe = \"", "command_line = \"",
                            "start_time_utc = \"", "host_cpu = \"", "scene_path = \""})
      EXPECT_TRUE(contains(p, key)) << side << ": " << key << "\n" << p;
    EXPECT_TRUE(contains(p, std::string("program = \"") + side + "\"")) << p;
    EXPECT_TRUE(contains(p, "--channel-prefix")) << "the command line as run: " << p;
  }
  // Every HDF5 file: the provenance on its root, units on every dataset.
  int files = 0;
  for (const auto& e : fs::directory_iterator(out)) {
    if (e.path().extension() != ".h5") continue;
    ++files;
    const std::string name = e.path().filename().string();
    const hid_t f = H5Fopen(e.path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(f, 0) << name;
    for (const char* key : {"version", "git_commit", "command_line", "start_time_utc", "host_cpu", "program"})
      EXPECT_NE(string_attribute(f, key), "<missing>") << name << ": " << key;
    EXPECT_EQ(string_attribute(f, "scene_toml"), slurp(scene)) << name;
    EXPECT_TRUE(contains(string_attribute(f, "host_cpu"), "logical CPUs")) << name;
    Datasets d;
    H5Literate(f, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr, collect, &d);
    EXPECT_FALSE(d.names.empty()) << name;
    for (const std::string& ds : d.names) {
      const hid_t set = H5Dopen2(f, ds.c_str(), H5P_DEFAULT);
      const std::string units = string_attribute(set, "units");
      EXPECT_NE(units, "<missing>") << name << ":/" << ds << " has no units";
      EXPECT_FALSE(units.empty()) << name << ":/" << ds;
      H5Dclose(set);
    }
    H5Fclose(f);
  }
  // monitor.h5, solid.h5, fields and plane snapshots at steps 0, 30, 60, sheets at 0, 30, 60.
  EXPECT_GE(files, 11);
  fs::remove_all(dir);
}

// ---- XDMF ----

double number_after(const std::string& json, const std::string& file, const std::string& key, int index = -1) {
  // A tiny reader of xdmf_geometry.py's JSON: FILE's object, then KEY's value (or the
  // index-th number of its array, flattened).
  const std::size_t at = json.find("\"" + file + "\"");
  if (at == std::string::npos) return NAN;
  const std::size_t k = json.find("\"" + key + "\"", at);
  if (k == std::string::npos) return NAN;
  std::size_t p = json.find(':', k) + 1;
  for (int i = 0; i <= std::max(0, index); ++i) {
    p = json.find_first_of("-0123456789", p);
    if (i < std::max(0, index)) p = json.find_first_of(",]", p) + 1;
  }
  return std::stod(json.substr(p));
}

TEST(WatchRun, XdmfGeometryMatchesSheets) {
  const fs::path dir = scratch("xdmf");
  const fs::path scene = short_scene(dir);
  const fs::path out = dir / "out";
  const RunResult r = launch(scene, out, "--quiet");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const RunResult g = run_command("/usr/bin/python3 " + quoted((kSource / "tests" / "integration" / "xdmf_geometry.py").string()) +
                                      " " + quoted(out.string()),
                                  dir / "geometry");
  ASSERT_EQ(g.status, 0) << g.err;
  const std::string& j = g.out;
  const double dx = 0.2561;  // coupled_small's [grid] dx_um; a 40 x 30 x 30 grid
  // The fluid's node (i, j, k) at (i, j + 1/2, k) dx: the plate, the half-way bounce-back
  // wall, at y = 0 as in the sheets' frame; the domain spans [0, ny dx] in y.
  EXPECT_NEAR(number_after(j, "fields.xmf", "bounds", 0), 0.0, 1e-9) << j;
  EXPECT_NEAR(number_after(j, "fields.xmf", "bounds", 1), 39 * dx, 1e-9) << j;
  EXPECT_NEAR(number_after(j, "fields.xmf", "bounds", 2), 0.5 * dx, 1e-9) << j;
  EXPECT_NEAR(number_after(j, "fields.xmf", "bounds", 3), 29.5 * dx, 1e-9) << j;
  EXPECT_NEAR(number_after(j, "fields.xmf", "bounds", 4), 0.0, 1e-9) << j;
  // The plane y = L/2: cell 15 at 15.5 dx, as its HDF5 file's y_um says.
  EXPECT_NEAR(number_after(j, "plane_y15.xmf", "bounds", 2), 15.5 * dx, 1e-9) << j;
  EXPECT_NEAR(number_after(j, "plane_y15.xmf", "y_um_attribute"), 15.5 * dx, 1e-9) << j;
  // The sheets at step 0: the clamped base on the plate, y = 0, half a cell below the first
  // fluid node; stream-wise at the scene's base_um x = 3.0734 um, which the fluid's frame
  // puts 0.0002 um downstream of its node i = 12 (x = 12 dx: nodes at i dx, no shift in x).
  EXPECT_NEAR(number_after(j, "sheets.xmf", "bounds", 2), 0.0, 1e-9) << j;
  const double sheet_x = number_after(j, "sheets.xmf", "bounds", 0);
  EXPECT_NEAR(sheet_x, 3.0734, 1e-9) << j;
  EXPECT_NEAR(sheet_x - 12 * dx, 0.0002, 1e-9) << j;
  fs::remove_all(dir);
}

}  // namespace
