// A coupled run watched, cited and opened in ParaView (issue 19), two processes through
// launch/run-coupled.sh on a shortened scenes/coupled_small.toml: the launcher's one
// progress line (phase, step, time, MLUPS, both sides' shares, ETA) and the release line;
// --quiet keeping the summary; provenance and units in every output; the XDMF geometry of
// the fluid and the sheets in one frame.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
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
  const fs::path dir = fs::path(::testing::TempDir()) / ("cosim_watchc_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

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

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

TEST(WatchCoupled, CoupledProgressLineHasEta) {
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

TEST(WatchCoupled, OutputsCarryProvenance) {
  const fs::path dir = scratch("provenance");
  const fs::path scene = short_scene(dir);
  const fs::path out = dir / "out";
  const RunResult r = launch(scene, out, "--quiet");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  // The folder: a copy of the scene, and each server's provenance.
  EXPECT_EQ(slurp(out / "scene.toml"), slurp(scene));
  const RunResult git = run_command("git -C " + quoted(kSource.string()) + " rev-parse HEAD", dir / "git");
  for (const char* side : {"fluid", "solid"}) {
    const std::string p = slurp(out / (std::string("provenance_") + side + ".toml"));
    for (const char* key : {"version = \"", "git_commit = \"", "git_describe = \"", "command_line = \"",
                            "start_time_utc = \"", "host_cpu = \"", "scene_path = \""})
      EXPECT_TRUE(contains(p, key)) << side << ": " << key << "\n" << p;
    EXPECT_TRUE(contains(p, std::string("program = \"") + side + "\"")) << p;
    EXPECT_TRUE(contains(p, "--channel-prefix")) << "the command line as run: " << p;
    if (git.status == 0) EXPECT_TRUE(contains(p, git.out.substr(0, 40))) << p;
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

TEST(WatchCoupled, XdmfGeometryMatchesSheets) {
  const fs::path dir = scratch("xdmf");
  const fs::path scene = short_scene(dir);
  const fs::path out = dir / "out";
  const RunResult r = launch(scene, out, "--quiet");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const RunResult g = run_command("/usr/bin/python3 " + quoted((kSource / "tests" / "xdmf_geometry.py").string()) +
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
  // fluid node; its stream-wise position on the fluid's node i = 12 (base_um x = 12 dx).
  EXPECT_NEAR(number_after(j, "sheets.xmf", "bounds", 2), 0.0, 1e-9) << j;
  const double sheet_x = number_after(j, "sheets.xmf", "bounds", 0);
  EXPECT_NEAR(sheet_x, 12 * dx, 1e-6) << j;
  const double node = sheet_x / dx;  // the fluid's nodes at x = i dx
  EXPECT_NEAR(node, std::round(node), 1e-6);
  fs::remove_all(dir);
}

}  // namespace
