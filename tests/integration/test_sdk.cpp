// The solid library (sdk/include/cosim/solid.hpp): its examples, a spring-network sheet in C++
// (examples/spring_sheet) and in Python (examples/python_sheet, module `cosim`), couple with
// the fluid as two processes through launch/run-coupled.sh --solid-cmd (a private network
// namespace as root); and the C++ example builds against an installed prefix, outside the
// source tree, and couples too.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/run_compare.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::quoted;
using cosim::test::run_command;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kBuild = COSIM_BINARY_DIR;

/// run-coupled.sh on scenes/coupled_spring_sheet.toml with `solid_cmd`; both exit 0, the
/// fluid reports 60 LB steps done and the solid its end on the library.
void expect_couples(const std::string& solid_cmd, const fs::path& dir) {
  fs::remove_all(dir);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const auto r = run_command("bash " + quoted((kSource / "launch" / "run-coupled.sh").string()) + " " +
                                 quoted((kSource / "scenes" / "coupled_spring_sheet.toml").string()) + " --output " +
                                 quoted(out.string()) + " --no-build --quiet --solid-cmd " + quoted(solid_cmd),
                             dir / "launcher");
  const std::string fluid_log = slurp(out / "fluid.log"), solid_log = slurp(out / "solid.log");
  EXPECT_EQ(r.status, 0) << r.out << r.err << fluid_log << solid_log;
  EXPECT_EQ(slurp(out / "fluid.exit"), "0\n");
  EXPECT_EQ(slurp(out / "solid.exit"), "0\n");
  EXPECT_NE(fluid_log.find("coupled run done, 60 LB steps"), std::string::npos) << fluid_log;
  EXPECT_NE(solid_log.find("solid: coupled run done at step 59 of 60, 7500 substeps"), std::string::npos) << solid_log;
}

TEST(SolidLibrary, SdkSolidCouplesWithFluid) {
  expect_couples(SPRING_SHEET_EXE, fs::path(::testing::TempDir()) / "cosim_sdk_cpp");
}

TEST(SolidLibrary, PythonSolidCouplesWithFluid) {
  expect_couples("env PYTHONPATH=" + (kBuild / "sdk" / "python").string() + " /usr/bin/python3 " +
                     (kSource / "examples" / "python_sheet" / "spring_sheet.py").string(),
                 fs::path(::testing::TempDir()) / "cosim_sdk_python");
}

// The library's checkpoints: a run with [coupling] checkpoint_every = 20 continued from its
// step-40 pair (run-coupled.sh --restart) ends with the fluid's monitor.h5 and the
// library's solid.h5 of the full run, bit for bit; a restart the fluid refuses leaves the
// run's folder as it was.
TEST(SolidLibrary, SdkSolidRestartsFromCheckpoint) {
  const fs::path dir = cosim::test::scratch("sdk_restart");
  const fs::path scene = dir / "coupled_spring_sheet_checkpoints.toml";
  {
    std::string text = slurp(kSource / "scenes" / "coupled_spring_sheet.toml");
    const std::string key = "rigid_steps = 10\n";
    ASSERT_NE(text.find(key), std::string::npos);
    text.replace(text.find(key), key.size(), key + "checkpoint_every = 20\n");
    std::ofstream(scene) << text;
  }
  const fs::path full = dir / "full", restarted = dir / "restarted";
  const std::string solid = " --solid-cmd " + quoted(SPRING_SHEET_EXE);
  ASSERT_EQ(cosim::test::run_launcher(kSource, scene, full, solid), 0) << cosim::test::logs(full);
  ASSERT_TRUE(fs::exists(full / "checkpoints" / "solid_00000040.h5")) << cosim::test::logs(full);
  ASSERT_EQ(cosim::test::run_launcher(kSource, scene, restarted,
                                      solid + " --restart " + quoted((full / "checkpoints").string())),
            0)
      << cosim::test::logs(restarted);
  const std::string solid_log = slurp(restarted / "solid.log");
  EXPECT_NE(solid_log.find("at step 40"), std::string::npos) << solid_log;
  EXPECT_NE(solid_log.find("coupled run done at step 59 of 60"), std::string::npos) << solid_log;
  EXPECT_EQ(cosim::test::compare_h5(full, restarted, "monitor.h5"), "");
  // solid.h5 holds the whole run: the rows before step 40 travel in the checkpoint.
  EXPECT_EQ(cosim::test::compare_h5(full, restarted, "solid.h5"), "");
  // A restart into the run's own folder that the fluid refuses (its checkpoint damaged; the
  // library solid has read its own) changes no file there: solid.h5 is not rewritten.
  const fs::path fluid_checkpoint = full / "checkpoints" / "fluid_00000040.h5";
  fs::copy_file(fluid_checkpoint, dir / "sound.h5");
  cosim::test::flip_bit(fluid_checkpoint, "populations");
  const auto before = cosim::test::every_file(full);
  const fs::path log = dir / "refused.log";
  const int s = std::system(("bash " + quoted((kSource / "launch" / "run-coupled.sh").string()) + " " +
                             quoted(scene.string()) + " --no-build --quiet --restart " + quoted(full.string()) + solid +
                             " >" + quoted(log.string()) + " 2>&1")
                                .c_str());
  EXPECT_EQ(WIFEXITED(s) ? WEXITSTATUS(s) : -1, 2) << slurp(log);
  EXPECT_NE(slurp(log).find("does not match its checksum"), std::string::npos) << slurp(log);
  EXPECT_EQ(cosim::test::changed_files(before, cosim::test::every_file(full)), "") << slurp(log);
}

// Issue 34: a solid's faults that used to end with advice about dt_CG, the inlet or the
// grid, or with "silent" and "signal 15", end with a message naming the solid and the
// quantity (tests/conformance/broken_sdk_solid.cpp on scenes/coupled_spring_sheet.toml).
TEST(SolidLibrary, CoupledRunBlamesTheSolidForItsFaults) {
  const fs::path dir = cosim::test::scratch("sdk_blame");
  const fs::path scene = kSource / "scenes" / "coupled_spring_sheet.toml";
  struct Case {
    std::string fault;     ///< --fault (and --from)
    int status;            ///< the launcher's
    std::vector<std::string> said;  ///< in its output, all of them
  };
  const std::vector<Case> cases = {
      // The library's energy balance (the sheet reports its energy).
      {"reaction-sign,with-energy", 3, {"the solid stopped at step", "watchdog energy_balance", "the solid gains energy"}},
      // No energy reported: the coordinator's own balance of the fluid's work.
      {"reaction-sign", 3,
       {"watchdog cgp_speed", "while the fluid took energy from them", "comes from the solid"}},
      // Positions in um: the coordinator's motion against the impulses.
      {"um", 3, {"watchdog cgp_speed at step 10", "the solid's positions and impulses disagree", "not in lattice units"}},
      {"exit-early --from 30", 4,
       {"the solid exited 0 before the run's end: its last solid_state_t was of step 29; the fluid waited for step 30 of 60"}},
      {"linger", 1, {"the solid did not exit within its grace of 3 s after the fluid's stop_t (the fluid ended with exit 0 at step 60"}},
  };
  for (const Case& c : cases) {
    std::string name = c.fault;
    for (char& ch : name)
      if (ch == ' ' || ch == ',') ch = '_';
    const fs::path out = dir / name;
    const int status = cosim::test::run_launcher(
        kSource, scene, out, "--solid-cmd " + quoted(std::string(BROKEN_SDK_SOLID_EXE) + " --fault " + c.fault),
        "COSIM_STOP_GRACE_S=3");
    EXPECT_EQ(status, c.status) << c.fault << "\n" << cosim::test::logs(out);
    const std::string said = slurp(out / "launcher.log");
    for (const std::string& s : c.said) EXPECT_NE(said.find(s), std::string::npos) << c.fault << ": " << s << "\n" << said;
    // No advice that the measurement does not support.
    for (const std::string advice : {"a smaller dt_CG may cure it", "a slower inlet or a finer grid", "signal 15"}) {
      EXPECT_EQ(said.find(advice), std::string::npos) << c.fault << ": " << advice << "\n" << said;
    }
  }
}

// The same exit codes from C++ and Python: an answer with one marker too few is refused with
// exit code 3 (unhealthy) by the library in either language.
TEST(SolidLibrary, MisSizedAnswerExitsThreeFromCppAndPython) {
  const fs::path dir = cosim::test::scratch("sdk_mis_sized");
  const fs::path scene = kSource / "scenes" / "coupled_spring_sheet.toml";
  const std::string python = "env PYTHONPATH=" + (kBuild / "sdk" / "python").string() + " /usr/bin/python3 " +
                             (kSource / "tests" / "conformance" / "broken_python_solid.py").string();
  for (const std::string& solid : {std::string(BROKEN_SDK_SOLID_EXE), python}) {
    const fs::path out = dir / (solid == python ? "python" : "cpp");
    const int status = cosim::test::run_launcher(kSource, scene, out, "--solid-cmd " + quoted(solid + " --fault mis-sized"));
    EXPECT_EQ(status, 3) << cosim::test::logs(out);
    EXPECT_EQ(slurp(out / "solid.exit"), "3\n") << cosim::test::logs(out);
    EXPECT_NE(slurp(out / "solid.log").find("the solid's answer for LB step 10"), std::string::npos) << cosim::test::logs(out);
  }
}

// OUTPUT/solid.h5 of a library solid: a row per LB step with the markers, the fluid's force
// on them and the solid's energy; the scene's [solid] section, which a library solid does not
// read, named once in a warning.
TEST(SolidLibrary, LibrarySolidWritesSolidH5) {
  const fs::path dir = cosim::test::scratch("sdk_solid_h5");
  const fs::path scene = dir / "coupled_spring_sheet_with_solid.toml";
  std::ofstream(scene) << slurp(kSource / "scenes" / "coupled_spring_sheet.toml") << "\n[solid]\nmodel = \"rcgp\"\n";
  const fs::path out = dir / "out";
  cosim::test::expect_run_done(out, cosim::test::run_launcher(kSource, scene, out, "--solid-cmd " + quoted(SPRING_SHEET_EXE)));
  const std::string solid_log = slurp(out / "solid.log");
  const std::string warning = "solid: warning: " + scene.string() + ": [solid] not read";
  ASSERT_NE(solid_log.find(warning), std::string::npos) << solid_log;
  EXPECT_EQ(solid_log.find(warning, solid_log.find(warning) + 1), std::string::npos) << solid_log;
  const auto d = cosim::test::read_datasets(out / "solid.h5");
  for (const char* name : {"step", "time_s", "marker_position_um", "marker_force_N", "total_energy_J", "fluid_work_J"})
    ASSERT_TRUE(d.count(name)) << name;
  // Steps 0 to 59 (the fluid's solid_state_t(0 .. N - 1)), 40 markers.
  ASSERT_EQ(d.at("step").values.size(), 60u);
  EXPECT_EQ(d.at("step").values.front(), 0.0);
  EXPECT_EQ(d.at("step").values.back(), 59.0);
  EXPECT_EQ(d.at("marker_position_um").dims, (std::vector<hsize_t>{60, 40, 3}));
  // The first marker 12 dx downstream (x = 3.0734 um, the scene's base_um), held in the spin-up (step 9 where step 0 was), moved after the release.
  const std::vector<double>& x = d.at("marker_position_um").values;
  EXPECT_NEAR(x[0], 3.0734, 1e-9);
  const std::size_t row = 40 * 3, top = 39 * 3;
  EXPECT_EQ(x[9 * row + top], x[top]);
  EXPECT_NE(x[59 * row + top], x[top]);
  // The drag on the sheet in the spin-up: the fluid pushes the markers downstream (+x).
  double fx = 0.0;
  for (std::size_t l = 0; l < 40; ++l) fx += d.at("marker_force_N").values[(5 * 40 + l) * 3];
  EXPECT_GT(fx, 0.0);
  // At rest in the spin-up; energy and the fluid's work on the sheet after the release.
  const std::vector<double>& e = d.at("total_energy_J").values;
  EXPECT_EQ(e[5], 0.0);
  EXPECT_GT(e.back(), 0.0);
  EXPECT_GT(d.at("fluid_work_J").values.back(), 0.0);
  EXPECT_NE(solid_log.find("solid: energy balance: the largest unexplained energy"), std::string::npos) << solid_log;
}

TEST(SolidLibrary, InstalledPackageBuildsExample) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_sdk_install";
  fs::remove_all(dir);
  const fs::path prefix = dir / "prefix", src = dir / "spring_sheet", build = dir / "build";
  auto r = run_command("cmake --install " + quoted(kBuild.string()) + " --prefix " + quoted(prefix.string()), dir / "install");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  for (const char* f : {"bin/fluid", "bin/solid", "bin/cosim-log", "bin/cosim-replay", "bin/cosim-conformance",
                        "include/cosim/solid.hpp", "include/cosimlcm/hello_t.hpp", "share/cosim/lcm/hello_t.lcm",
                        "lib/cmake/cosim/cosimConfig.cmake", "lib/pkgconfig/cosim.pc"})
    EXPECT_TRUE(fs::exists(prefix / f)) << f;
  // The example's sources as an installation ships them, built outside the source tree.
  fs::copy(prefix / "share" / "cosim" / "examples" / "spring_sheet", src, fs::copy_options::recursive);
  r = run_command("cmake -S " + quoted(src.string()) + " -B " + quoted(build.string()) + " -DCMAKE_PREFIX_PATH=" +
                      quoted(prefix.string()) + " && cmake --build " + quoted(build.string()),
                  dir / "cmake");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  // pkg-config knows the library too.
  r = run_command("PKG_CONFIG_PATH=" + quoted((prefix / "lib" / "pkgconfig").string()) + " pkg-config --libs cosim",
                  dir / "pkgconfig");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("-lcosim_sdk"), std::string::npos) << r.out;
  expect_couples((build / "spring_sheet").string(), dir / "run");
  // The installed conformance kit (its scene from PREFIX/share/cosim/scenes) passes it, and
  // the installed Python module imports.
  r = run_command(quoted((prefix / "bin" / "cosim-conformance").string()) + " --solid-cmd " +
                      quoted((build / "spring_sheet").string()) + " --work " + quoted((dir / "kit").string()),
                  dir / "conformance");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find((prefix / "share" / "cosim" / "scenes" / "conformance.toml").string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("18 of 18 checks pass"), std::string::npos) << r.out;
  r = run_command("PYTHONPATH=" + quoted((prefix / "lib" / "python3" / "dist-packages").string()) +
                      " /usr/bin/python3 -c 'import cosim; print(cosim.synthetic_scene(2, 3, 10).positions.shape)'",
                  dir / "python");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "(6, 3)\n") << r.err;
}

// Issue 34: an installation runs by itself. Every installed program carries a RUNPATH (the
// installed example bin/spring_sheet finds libcosim_sdk with no environment set), passes the
// installed conformance kit, and PREFIX/bin/cosim-run runs an installed coupled scene with the
// installed servers: all with an empty environment but PATH.
TEST(SolidLibrary, InstalledToolsRunFromThePrefix) {
  const fs::path dir = cosim::test::scratch("installed_tools");
  const fs::path prefix = dir / "prefix";
  auto r = run_command("cmake --install " + quoted(kBuild.string()) + " --prefix " + quoted(prefix.string()), dir / "install");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  for (const auto& e : fs::directory_iterator(prefix / "bin")) {
    if (slurp(e.path()).rfind("\x7f" "ELF", 0) != 0) continue;  // scripts (cosim-run)
    r = run_command("readelf -d " + quoted(e.path().string()), dir / "readelf");
    EXPECT_NE(r.out.find("(RUNPATH)"), std::string::npos) << e.path() << "\n" << r.out;
    EXPECT_NE(r.out.find("$ORIGIN/../lib"), std::string::npos) << e.path() << "\n" << r.out;
  }
  const std::string bare = "env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin ";
  r = run_command(bare + quoted((prefix / "bin" / "cosim-conformance").string()) + " --solid-cmd " +
                      quoted((prefix / "bin" / "spring_sheet").string()) + " --work " + quoted((dir / "kit").string()),
                  dir / "conformance");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("checks pass"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("FAIL"), std::string::npos) << r.out;
  // A coupled run from the prefix alone (its launcher, scene, servers and example).
  const fs::path out = dir / "run";
  r = run_command("cd " + quoted(dir.string()) + " && " + bare + quoted((prefix / "bin" / "cosim-run").string()) + " " +
                      quoted((prefix / "share" / "cosim" / "scenes" / "coupled_spring_sheet.toml").string()) +
                      " --quiet --output " + quoted(out.string()) + " --solid-cmd " +
                      quoted((prefix / "bin" / "spring_sheet").string()),
                  dir / "cosim_run");
  EXPECT_EQ(r.status, 0) << r.out << r.err << cosim::test::logs(out);
  EXPECT_EQ(slurp(out / "fluid.exit"), "0\n") << cosim::test::logs(out);
  EXPECT_EQ(slurp(out / "solid.exit"), "0\n") << cosim::test::logs(out);
  EXPECT_NE(slurp(out / "fluid.log").find("coupled run done, 60 LB steps"), std::string::npos) << cosim::test::logs(out);
  EXPECT_TRUE(fs::exists(out / "solid.h5"));
}

// Issue 31 step 5: library solids run every coupling scheme through the solid server's
// scheme registry (solid/schemes/). The spring sheet in C++ and in Python, coupled under the
// serial, parallel and implicit schemes, each twice: both runs complete, and their HDF5
// outputs (the fluid's monitor.h5, the library's solid.h5) are bit-identical run to run.
TEST(SolidLibrary, SdkSolidRunsEveryScheme) {
  const fs::path dir = cosim::test::scratch("sdk_every_scheme");
  const std::string python = "env PYTHONPATH=" + (kBuild / "sdk" / "python").string() + " /usr/bin/python3 " +
                             (kSource / "examples" / "python_sheet" / "spring_sheet.py").string();
  const std::vector<std::pair<std::string, std::string>> solids{{"cpp", SPRING_SHEET_EXE}, {"python", python}};
  for (const char* scheme : {"serial", "parallel", "implicit"}) {
    std::string text = slurp(kSource / "scenes" / "coupled_spring_sheet.toml");
    cosim::test::replace_in(text, "rigid_steps = 10\n", "rigid_steps = 10\nscheme = \"" + std::string(scheme) + "\"\n");
    const fs::path scene = dir / (std::string(scheme) + ".toml");
    std::ofstream(scene) << text;
    for (const auto& [name, cmd] : solids) {
      const fs::path a = dir / (std::string(scheme) + "_" + name + "_a"), b = dir / (std::string(scheme) + "_" + name + "_b");
      for (const fs::path& out : {a, b}) {
        SCOPED_TRACE(out.string());
        cosim::test::expect_run_done(out, cosim::test::run_launcher(kSource, scene, out, "--solid-cmd " + quoted(cmd)));
        const std::string solid_log = slurp(out / "solid.log");
        EXPECT_NE(solid_log.find("solid: coupled run done at step"), std::string::npos) << solid_log;
        if (std::string(scheme) == "implicit") {
          EXPECT_NE(solid_log.find("solid: implicit scheme: 50 steps iterated"), std::string::npos) << solid_log;
        }
        if (std::string(scheme) == "parallel") {
          EXPECT_NE(solid_log.find("parallel scheme"), std::string::npos) << solid_log;
        }
      }
      std::size_t files = 0;
      EXPECT_EQ(cosim::test::compare_outputs(a, b, &files), "") << scheme << " " << name;
      EXPECT_GE(files, 2u) << scheme << " " << name;  // monitor.h5 and solid.h5 at least
    }
  }
}

}  // namespace
