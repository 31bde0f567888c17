// The solid library (sdk/include/cosim/solid.hpp): its examples, a spring-network sheet in C++
// (examples/spring_sheet) and in Python (examples/python_sheet, module `cosim`), couple with
// the fluid as two processes through launch/run-coupled.sh --solid-cmd (a private network
// namespace as root); and the C++ example builds against an installed prefix, outside the
// source tree, and couples too.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

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
// step-40 pair (run-coupled.sh --restart) ends with the fluid's monitor.h5 of the full run,
// bit for bit.
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
  EXPECT_NE(r.out.find("17 of 17 checks pass"), std::string::npos) << r.out;
  r = run_command("PYTHONPATH=" + quoted((prefix / "lib" / "python3" / "dist-packages").string()) +
                      " /usr/bin/python3 -c 'import cosim; print(cosim.synthetic_scene(2, 3, 10).positions.shape)'",
                  dir / "python");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "(6, 3)\n") << r.err;
}

}  // namespace
