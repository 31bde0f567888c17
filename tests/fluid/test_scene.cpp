// Scene files: every malformed file is rejected with one line that names the key, the value
// and what is allowed; every shipped scene loads; the `fluid` executable maps a bad scene to
// exit status 2, a finished run to 0 and an unhealthy flow to 3.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/run_compare.hpp"
#include "fluid/config/scene_config.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::lines;
using cosim::test::RunResult;
using cosim::test::slurp;
const auto& quote = cosim::test::quoted;
using cosim::fluid::FaceKind;
using cosim::fluid::FluidScene;
using cosim::fluid::SceneError;
using cosim::fluid::load_scene;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kBad = kSource / "tests" / "scenes" / "bad";

/// The SceneError text of loading `path`, or "" if it loads.
std::string rejection(const fs::path& path) {
  try {
    load_scene(path.string());
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

struct BadCase {
  const char* file;
  std::vector<const char*> expected;  // substrings of the one-line message
};

// file -> what the message must say: the key, the value as written, the allowed range.
const std::vector<BadCase> kBadCases = {
    {"tau_half.toml", {":12: fluid.tau = 0.5: must be > 0.5", "unstable at or below 1/2"}},
    {"tau_too_large.toml", {"fluid.tau = 3: must be in (0.5, 2]"}},
    {"tau_not_finite.toml", {"fluid.tau = nan: must be a finite number"}},
    {"tau_and_reynolds.toml",
     {"fluid.tau = 0.8, fluid.reynolds = 5: give exactly one of the two"}},
    {"reynolds_too_small.toml",
     {"fluid.reynolds = 0.1: gives tau = 6.357", "above the limit 2"}},
    {"unknown_key.toml",
     {"fluid.tua = 0.8: unknown key in [fluid]; allowed: tau, reynolds, reference_length_um",
      "did you mean \"tau\""}},
    {"misspelt_section.toml", {"[boundary]: unknown section", "did you mean \"boundaries\""}},
    {"top_level_key.toml", {":2: steps = 100: unknown key at the top level"}},
    {"wrong_type.toml", {":7: grid.nx = \"sixteen\": must be an integer, not a string"}},
    {"float_for_integer.toml", {"grid.nx = 16.5: must be an integer"}},
    {"grid_too_small.toml", {"grid.ny = 4: must be an integer number of cells from 8 to 65536"}},
    {"grid_too_large.toml",
     {"grid = 60000 x 60000 x 60000: the population grid (in-place propagation) needs", "more than 75 % of this machine's memory",
      "the rest is left to the solid server and the system"}},
    {"inlet_mach.toml",
     {"inlet.u_max = 0.2: Mach 0.346", "exceeds run.mach_limit = 0.3", "largest allowed speed is 0.1732"}},
    {"mach_limit_range.toml", {"run.mach_limit = 0.7: must be in (0, 0.5]"}},
    {"missing_boundary.toml", {"boundaries.z_max: missing; all six faces are required"}},
    {"unknown_boundary_kind.toml",
     {"boundaries.y_max = \"slip\": must be one of \"periodic\", \"wall\", \"free_slip\", "
      "\"inlet\", \"outflow\""}},
    {"periodic_pair.toml",
     {"boundaries.x_min = \"periodic\", boundaries.x_max = \"outflow\"", "periodic partner"}},
    {"blasius_without_layer.toml", {"inlet.boundary_layer_um: missing", "(0, ny dx_um = 2.0488]"}},
    {"blasius_without_plate.toml",
     {"inlet.profile = \"blasius\": needs boundaries.y_min = \"wall\"", "not \"free_slip\""}},
    {"inlet_without_inlet_face.toml", {"[inlet]: given, but no face of [boundaries] is \"inlet\""}},
    {"steps_zero.toml", {"run.steps = 0: must be an integer >= 1"}},
    {"syntax_error.toml", {"syntax_error.toml:9:6: TOML syntax error"}},
    {"duplicate_key.toml", {":10:6: TOML syntax error", "'nz'"}},
    {"wall_velocity_not_wall.toml",
     {"wall_velocity.y_max = [0.05, 0, 0]: only a wall can move", "is \"free_slip\""}},
    {"planes_y_range.toml", {"output.planes_y = [0.5, 1.5]: must be an array of numbers in (0, 1)"}},
    {"planes_without_heights.toml",
     {"output.planes_y: missing; planes_every > 0 needs the planes"}},
    {"coupling_scheme_unknown.toml",
     {":36: coupling.scheme = \"gauss-seidel\": must be one of \"serial\", \"implicit\", \"parallel\""}},
    {"coupling_iterations_serial.toml",
     {":36: coupling.max_iterations = 5: belongs to coupling.scheme = \"implicit\"; this scene's scheme is "
      "\"serial\""}},
    {"coupling_tolerance_range.toml", {":37: coupling.tolerance = 0: must be a number in [1e-14, 1)"}},
    {"coupling_ttl.toml",
     {"coupling.lcm_url = \"udpm://239.255.76.67:7667?ttl=1\": must be a udpm:// URL with ttl=0"}},
    {"solid_without_coupling.toml",
     {"[sheet]: a solid section needs a [coupling] section"}},
    {"watchdog_rho_bounds.toml",
     {":36: watchdog.rho_min = 1.2: must be in (0, 1): the lowest healthy density"}},
    {"watchdog_unknown_key.toml",
     {":36: watchdog.max_cgp_sped = 0.3: unknown key in [watchdog]; allowed: health_every, rho_min,",
      "did you mean \"max_cgp_speed\""}},
    {"precision_unknown.toml",
     {":30: run.precision = \"quad\": must be one of \"double\", \"mixed\", \"single\", \"half\""}},
    {"thin_span_not_periodic.toml",
     {"grid.nz = 2: below 8 cells only between periodic z faces", "boundaries.z_min = \"wall\""}},
    {"parabolic_without_walls.toml",
     {"inlet.profile = \"parabolic\": \"parabolic\" needs walls on y_min and y_max", "y_max is \"free_slip\""}},
    {"held_body_outside.toml", {"held_body.center_um = [100, 1]: must lie inside the domain"}},
    {"medium_half.toml", {"fluid.density_kg_m3 = 1000: needs fluid.sound_speed_m_s too"}},
    {"propagation_unknown.toml",
     {":30: run.propagation = \"pull\": must be one of \"two-grid\", \"in-place\""}},
};

TEST(Scene, BadSceneFilesAreRejected) {
  // Every file in tests/scenes/bad/ has a row, and every row a file.
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(kBad))
    if (e.path().extension() == ".toml") files.push_back(e.path().filename().string());
  EXPECT_EQ(files.size(), kBadCases.size());
  EXPECT_GE(kBadCases.size(), 12u);
  for (const std::string& f : files)
    EXPECT_TRUE(std::any_of(kBadCases.begin(), kBadCases.end(),
                            [&](const BadCase& c) { return f == c.file; }))
        << f << " has no expected message in the table";

  for (const BadCase& c : kBadCases) {
    const fs::path path = kBad / c.file;
    const std::string msg = rejection(path);
    ASSERT_FALSE(msg.empty()) << c.file << " was accepted";
    EXPECT_EQ(msg.find('\n'), std::string::npos) << c.file << ": more than one line: " << msg;
    EXPECT_EQ(msg.rfind(path.string(), 0), 0u) << c.file << ": does not start with the file: " << msg;
    for (const char* part : c.expected)
      EXPECT_NE(msg.find(part), std::string::npos)
          << c.file << ": expected \"" << part << "\" in: " << msg;
  }
}

TEST(Scene, MissingFileIsRejected) {
  const std::string msg = rejection(kBad / "no_such_scene.toml");
  EXPECT_NE(msg.find("no_such_scene.toml: cannot read the scene file: no such file"),
            std::string::npos) << msg;
  const std::string dir = rejection(kBad);
  EXPECT_NE(dir.find("not a regular file"), std::string::npos) << dir;
}

TEST(Scene, GoodScenesLoad) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kSource / "scenes")) {
    if (e.path().extension() != ".toml") continue;
    // Solid-only scenes (the solid server's standalone mode) have no fluid to load;
    // test_solid_scene checks them.
    if (e.path().filename().string().starts_with("sheet_")) continue;
    ++n;
    EXPECT_EQ(rejection(e.path()), "") << e.path();
  }
  EXPECT_GE(n, 2);
  for (const char* f : {"tiny_channel.toml", "runaway_force.toml"})
    EXPECT_EQ(rejection(kSource / "tests" / "scenes" / f), "") << f;
}

// The paper's channel (section 3): Re = U_max H / nu = 40 with U_max/c = 0.104 and
// H = 8.8 um gives tau of about 0.770 (DESIGN 5); the Blasius layer is 0.1 H.
TEST(Scene, ChannelSceneIsThePapersChannel) {
  const FluidScene s = load_scene((kSource / "scenes" / "channel.toml").string());
  EXPECT_EQ(s.params.shape.nx, 120);
  EXPECT_EQ(s.params.shape.ny, 60);
  EXPECT_EQ(s.params.shape.nz, 90);
  const double h_cells = 8.8 / 0.2561;
  EXPECT_NEAR(s.params.tau, 0.5 + 3.0 * 0.104 * h_cells / 40.0, 1e-12);
  EXPECT_NEAR(s.params.tau, 0.770, 0.005);
  ASSERT_TRUE(s.reynolds.has_value());
  EXPECT_NEAR(*s.reynolds, 40.0, 1e-9);
  using cosim::fluid::InletProfile;
  using cosim::fluid::XMin;
  EXPECT_EQ(s.params.faces[XMin].kind, FaceKind::Inlet);
  EXPECT_EQ(s.params.faces[XMin].profile, InletProfile::Blasius);
  EXPECT_NEAR(s.params.faces[XMin].boundary_layer, 0.1 * h_cells, 1e-12);
  EXPECT_EQ(s.params.faces[cosim::fluid::YMin].kind, FaceKind::Wall);

  // The reduced scene: the same Re and physical box at twice dx.
  const FluidScene r = load_scene((kSource / "scenes" / "channel_reduced.toml").string());
  EXPECT_NEAR(*r.reynolds, 40.0, 1e-9);
  EXPECT_NEAR(r.params.shape.nx * r.dx_um, s.params.shape.nx * s.dx_um, 1e-9);
  EXPECT_NEAR(r.params.faces[XMin].inlet_speed, s.params.faces[XMin].inlet_speed, 0.0);
}

TEST(Scene, CommandLineOverridesAreValidated) {
  FluidScene s = load_scene((kSource / "tests" / "scenes" / "tiny_channel.toml").string());
  cosim::fluid::SceneOverrides o;
  o.steps = 7;
  o.output_dir = "elsewhere";
  cosim::fluid::apply_overrides(s, o);
  EXPECT_EQ(s.steps, 7);
  EXPECT_EQ(s.output_dir, "elsewhere");
  o = {};
  o.monitor_every = 0;
  try {
    cosim::fluid::apply_overrides(s, o);
    ADD_FAILURE() << "--monitor-every 0 accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("command line: --monitor-every = 0: must be"),
              std::string::npos) << e.what();
  }
}

// ---- the executable ----

/// Runs `fluid ARGS` with stdout and stderr captured in files of a scratch directory.
RunResult run_fluid(const std::string& args, const fs::path& scratch) {
  return cosim::test::run_command(quote(FLUID_EXE) + " " + args, scratch);
}

fs::path scratch_dir(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_scene_" + name); }

TEST(FluidExecutable, BadSceneExitsTwoWithOneLine) {
  const fs::path scratch = scratch_dir("bad");
  const fs::path bad = kBad / "tau_half.toml";
  const RunResult r = run_fluid(quote(bad.string()) + " --quiet", scratch);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err, rejection(bad) + "\n");
  EXPECT_EQ(r.out, "");

  // Command-line errors, from CLI11 or from validating an override: also 2, one line.
  for (const std::string& args : {std::string("--no-such-option"),
                                 quote((kSource / "scenes" / "channel.toml").string()) + " --steps abc",
                                 quote((kSource / "scenes" / "channel.toml").string()) + " --steps 0",
                                 std::string("")}) {
    const RunResult c = run_fluid(args, scratch);
    EXPECT_EQ(c.status, 2) << args;
    EXPECT_EQ(lines(c.err), 1u) << args << ": " << c.err;
  }
  fs::remove_all(scratch);
}

TEST(FluidExecutable, TinySceneRunsAndWritesOutput) {
  const fs::path scratch = scratch_dir("tiny");
  fs::remove_all(scratch);
  const fs::path out = scratch / "out";
  const RunResult r =
      run_fluid(quote((kSource / "tests" / "scenes" / "tiny_channel.toml").string()) +
                    " --steps 12 --monitor-every 4 --fields-every 6 --quiet --output " +
                    quote(out.string()),
                scratch);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("tau = 0.61714"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "monitor.h5"));
  EXPECT_TRUE(fs::exists(out / "fields.xmf"));
  std::size_t snapshots = 0;
  for (const auto& e : fs::directory_iterator(out))
    if (e.path().extension() == ".h5" && e.path().filename() != "monitor.h5") ++snapshots;
  EXPECT_EQ(snapshots, 3u);  // steps 0, 6, 12
  fs::remove_all(scratch);
}

TEST(FluidExecutable, UnhealthyFlowExitsThreeWithOneLine) {
  const fs::path scratch = scratch_dir("runaway");
  fs::remove_all(scratch);
  const RunResult r =
      run_fluid(quote((kSource / "tests" / "scenes" / "runaway_force.toml").string()) +
                    " --quiet --output " + quote((scratch / "out").string()),
                scratch);
  EXPECT_EQ(r.status, 3) << r.out << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  // u = (n + 1/2) F with F = 0.01 passes Mach 0.3 (u = 0.1732) at n = 17.
  EXPECT_NE(r.err.find("step 17"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Mach"), std::string::npos) << r.err;
  fs::remove_all(scratch);
}

/// `scene` with run.propagation = `propagation` added, written to `dir`.
fs::path with_propagation(const fs::path& scene, const std::string& propagation, const fs::path& dir) {
  std::ifstream in(scene);
  std::ostringstream text;
  std::string line;
  while (std::getline(in, line)) {
    text << line << "\n";
    if (line == "[run]") text << "propagation = \"" << propagation << "\"\n";
  }
  const fs::path out = dir / (propagation + ".toml");
  std::ofstream(out) << text.str();
  return out;
}

// The in-place propagation writes the two-grid run's bits: the reduced paper channel
// (Blasius inlet, outflow, wall, free slip, periodic z), an odd number of steps, snapshots
// and monitor rows at Canonical and Swapped steps; every HDF5 dataset compared.
TEST(FluidExecutable, InPlacePropagationWritesTheTwoGridBits) {
  const fs::path scratch = scratch_dir("in_place");
  for (const std::string prop : {"two-grid", "in-place"}) {
    const RunResult r = run_fluid(quote(with_propagation(kSource / "scenes" / "channel_reduced.toml", prop, scratch).string()) +
                                      " --steps 101 --monitor-every 5 --fields-every 25 --quiet --output " +
                                      quote((scratch / prop).string()),
                                  scratch);
    ASSERT_EQ(r.status, 0) << prop << ": " << r.err;
    if (prop == "in-place") {
      EXPECT_NE(r.out.find("1 x 19 doubles"), std::string::npos) << r.out;
    }
  }
  std::size_t files = 0;
  EXPECT_EQ(cosim::test::compare_outputs(scratch / "two-grid", scratch / "in-place", &files), "");
  EXPECT_EQ(files, 7u);  // fields at 0, 25, 50, 75, 100, 101 and the monitor
  // An unhealthy flow is stopped as in the two-grid run: the same one line.
  std::string lines_of[2];
  int k = 0;
  for (const std::string prop : {"two-grid", "in-place"}) {
    const RunResult r = run_fluid(quote(with_propagation(kSource / "tests" / "scenes" / "runaway_force.toml", prop, scratch).string()) +
                                      " --quiet --output " + quote((scratch / ("runaway_" + prop)).string()),
                                  scratch);
    EXPECT_EQ(r.status, 3) << prop << ": " << r.out << r.err;
    lines_of[k++] = r.err;
  }
  EXPECT_EQ(lines_of[0], lines_of[1]);
  EXPECT_NE(lines_of[1].find("step 17"), std::string::npos) << lines_of[1];
  fs::remove_all(scratch);
}

// In place is the default propagation (issue 35): every shipped scene with a fluid names no
// [run] propagation and loads in place; the fluid says so (`--print run.propagation`, the
// header's memory line); and the reduced paper channel without the key writes the bits of its
// run with propagation = "two-grid" (an odd number of steps: the in-place state ends Swapped).
TEST(FluidExecutable, InPlaceIsTheDefaultPropagation) {
  int n = 0;
  for (const auto& e : fs::recursive_directory_iterator(kSource / "scenes")) {
    if (e.path().extension() != ".toml") continue;
    const std::string text = slurp(e.path());
    if (text.find("\n[grid]") == std::string::npos) continue;  // solid-only (test_solid_scene)
    EXPECT_EQ(text.find("propagation"), std::string::npos) << e.path() << " names its propagation";
    // The stability matrix's scenes that the fluid refuses on purpose (scenes/stability/) load nothing.
    if (!rejection(e.path()).empty()) continue;
    ++n;
    EXPECT_EQ(load_scene(e.path().string()).params.propagation, cosim::fluid::Propagation::InPlace) << e.path();
  }
  EXPECT_GE(n, 30);
  const fs::path scratch = scratch_dir("default_propagation");
  const fs::path channel = kSource / "scenes" / "channel_reduced.toml";
  const RunResult printed = run_fluid(quote(channel.string()) + " --print run.propagation,run.precision", scratch);
  ASSERT_EQ(printed.status, 0) << printed.err;
  EXPECT_EQ(printed.out, "run.propagation=in-place\nrun.precision=double\n");
  const std::string args = " --steps 51 --monitor-every 5 --fields-every 25 --quiet --output ";
  const RunResult by_default = run_fluid(quote(channel.string()) + args + quote((scratch / "default").string()), scratch);
  ASSERT_EQ(by_default.status, 0) << by_default.err;
  EXPECT_NE(by_default.out.find("1 x 19 doubles per cell, with ghosts; in-place propagation"), std::string::npos)
      << by_default.out;
  const RunResult two_grid = run_fluid(
      quote(with_propagation(channel, "two-grid", scratch).string()) + args + quote((scratch / "two-grid").string()),
      scratch);
  ASSERT_EQ(two_grid.status, 0) << two_grid.err;
  EXPECT_NE(two_grid.out.find("2 x 19 doubles per cell, with ghosts; two-grid propagation"), std::string::npos)
      << two_grid.out;
  std::size_t files = 0;
  EXPECT_EQ(cosim::test::compare_outputs(scratch / "two-grid", scratch / "default", &files), "");
  EXPECT_EQ(files, 5u);  // fields at 0, 25, 50, 51 and the monitor
  fs::remove_all(scratch);
}

}  // namespace
