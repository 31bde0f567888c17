// The conformance kit (cosim-conformance, tools/conformance/): every registered model of the
// solid server, the C example, and both solid-library examples pass every check (the
// registered models also against their golden traces, tests/conformance/golden/MODEL.csv,
// tolerance 1e-9); deliberately broken solids (tests/conformance/broken_solid.cpp) each fail
// the check that names their fault.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "solid/model/model_registry.hpp"
#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::quoted;
using cosim::test::run_command;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kScene = kSource / "scenes" / "conformance.toml";

cosim::test::RunResult kit(const std::string& solid_cmd, const fs::path& scene, const fs::path& dir,
                           const std::string& extra = "") {
  return run_command(std::string(CONFORMANCE_EXE) + " --solid-cmd " + quoted(solid_cmd) + " " + quoted(scene.string()) +
                         " --work " + quoted((dir / "work").string()) + extra,
                     dir);
}

TEST(Conformance, ConformanceKitPassesEveryModel) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_conformance_models";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const cosim::solid::SolidModelEntry& e : cosim::solid::solid_models()) {
    const std::string model(e.name);
    const fs::path scene = dir / (model + ".toml");
    {
      std::ofstream out(scene);
      out << slurp(kScene) << "\n[solid]\nmodel = \"" << model << "\"\n";
      // The options a model cannot do without (scenes/README.md).
      if (model == "sprung") out << "spring_frequency_hz = 5.3238e6\n";
    }
    const fs::path golden = kSource / "tests" / "conformance" / "golden" / (model + ".csv");
    const auto r = kit(SOLID_EXE, scene, dir / model, " --golden " + quoted(golden.string()));
    EXPECT_EQ(r.status, 0) << model << ":\n" << r.out << r.err;
    EXPECT_NE(r.out.find("19 of 19 checks pass"), std::string::npos) << model << ":\n" << r.out;
    // Every model's solid.h5 has total_energy_J: the energy balance applies.
    EXPECT_NE(r.out.find("the solid's energy change is the work of the fluid's reaction"), std::string::npos)
        << model << ":\n" << r.out;
  }
  const std::string python = "env PYTHONPATH=" + (fs::path(COSIM_BINARY_DIR) / "sdk" / "python").string() +
                             " /usr/bin/python3 " + (kSource / "examples" / "python_sheet" / "spring_sheet.py").string();
  for (const auto& [name, cmd] : {std::pair<std::string, std::string>{"prescribed_plate", PRESCRIBED_PLATE_EXE},
                                  {"spring_sheet", SPRING_SHEET_EXE},
                                  {"python_sheet", python}}) {
    const auto r = kit(cmd, kScene, dir / name);
    EXPECT_EQ(r.status, 0) << name << ":\n" << r.out << r.err;
    EXPECT_NE(r.out.find("18 of 18 checks pass"), std::string::npos) << name << ":\n" << r.out;
    // The library's examples report their energy (Solid::energy_lb); the C plate none.
    EXPECT_NE(r.out.find(name == "prescribed_plate" ? "energy balance           not applicable"
                                                    : "the solid's energy change is the work of the fluid's reaction"),
              std::string::npos)
        << name << ":\n" << r.out;
  }
}

TEST(Conformance, ConformanceKitCatchesBrokenSolids) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_conformance_broken";
  fs::remove_all(dir);
  // fault, the check that must fail, and the words its reason must hold.
  const struct {
    const char* fault;
    const char* check;
    const char* words;
  } cases[] = {
      {"sign", "FAIL  spin-up impulse", "the sign is reversed"},
      {"no-average", "FAIL  spin-up impulse", "not averaged over the A_T substeps"},
      {"no-resend", "FAIL  resend", "no answer to resend_t"},
      {"substeps", "FAIL  substep count", "substeps = 149, expected 150"},
      {"nan", "FAIL  finite values", "= nan: a NaN"},
  };
  for (const auto& c : cases) {
    const auto r = kit(std::string(BROKEN_SOLID_EXE) + " --fault " + c.fault, kScene, dir / c.fault, " --sessions main");
    EXPECT_EQ(r.status, 1) << c.fault << ":\n" << r.out << r.err;
    const std::size_t at = r.out.find(c.check);
    ASSERT_NE(at, std::string::npos) << c.fault << ":\n" << r.out;
    const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
    EXPECT_NE(line.find(c.words), std::string::npos) << c.fault << ": " << line;
  }
  // The same solid without a fault passes: the failures are the faults', not the plate's.
  const auto r = kit(std::string(BROKEN_SOLID_EXE) + " --fault none", kScene, dir / "none");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
}

// The planted defects of tests/conformance/: the raw-protocol plate (broken_solid.cpp), the
// library's C++ sheet (broken_sdk_solid.cpp) and its Python sheet (broken_python_solid.py).
std::string planted(const std::string& solid, const std::string& fault) {
  if (solid == "raw") return std::string(BROKEN_SOLID_EXE) + " --fault " + fault;
  if (solid == "c++") return std::string(BROKEN_SDK_SOLID_EXE) + " --fault " + fault;
  return "env PYTHONPATH=" + (fs::path(COSIM_BINARY_DIR) / "sdk" / "python").string() + " /usr/bin/python3 " +
         (kSource / "tests" / "conformance" / "broken_python_solid.py").string() + " --fault " + fault;
}

/// The kit (the sessions named) fails `solid --fault fault`, and the line of `check` says
/// FAIL with `words`; the kit's output.
std::string expect_caught(const std::string& solid, const std::string& fault, const std::string& sessions,
                          const std::string& check, const std::string& words, const fs::path& dir) {
  const std::string where = solid + " --fault " + fault;
  const auto r = kit(planted(solid, fault), kScene, dir, " --sessions " + sessions);
  EXPECT_EQ(r.status, 1) << where << ":\n" << r.out << r.err;
  const std::size_t at = r.out.find("FAIL  " + check);
  EXPECT_NE(at, std::string::npos) << where << ": no FAIL of '" << check << "':\n" << r.out;
  if (at == std::string::npos) return r.out;
  const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
  EXPECT_NE(line.find(words), std::string::npos) << where << ": " << line;
  return r.out;
}

TEST(Conformance, ConformanceKitCatchesScaleAndLagErrors) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_conformance_scale";
  fs::remove_all(dir);
  const struct {
    const char* fault;
    const char* words;
  } cases[] = {
      {"double", "J_l is twice the expected impulse"},
      {"half", "J_l is half the expected impulse"},
      {"over-time-ratio", "divided by A_T once too often"},
      {"late", "the impulse is sent one exchange late"},
  };
  for (const char* solid : {"raw", "c++", "python"})
    for (const auto& c : cases)
      expect_caught(solid, c.fault, "main", "impulse vs motion", c.words, dir / (std::string(solid) + "_" + c.fault));
}

TEST(Conformance, ConformanceKitCatchesInconsistentMotion) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_conformance_motion";
  fs::remove_all(dir);
  const struct {
    const char* fault;
    const char* check;
    const char* words;
  } cases[] = {
      {"frozen", "impulse vs motion", "the positions are frozen while the impulse follows a motion"},
      {"end-of-step", "impulse vs motion", "the position at the interval's end"},
      {"reaction-sign", "response to the fluid", "the reaction on the solid has the wrong sign"},
  };
  for (const char* solid : {"c++", "python"})
    for (const auto& c : cases)
      expect_caught(solid, c.fault, "main,long", c.check, c.words, dir / (std::string(solid) + "_" + c.fault));
  // Markers that receive half the reaction they report (J_l = g dA at their motion, so every
  // other check passes): the solid's own energy (solid.h5) gains half the fluid's work.
  for (const char* solid : {"c++", "python"}) {
    const std::string out = expect_caught(solid, "half-reaction,with-energy", "main", "energy balance",
                                          "its markers receive half the reaction it reports",
                                          dir / (std::string(solid) + "_half_reaction"));
    EXPECT_NE(out.find("10 of 11 checks pass; FAIL: energy balance\n"), std::string::npos) << solid << ":\n" << out;
  }
}

TEST(Conformance, ConformanceKitChecksLongRunsAndRestarts) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_conformance_long";
  fs::remove_all(dir);
  // A defect from step 50 on: the short sessions see nothing, the long one names the step.
  for (const char* solid : {"raw", "c++"}) {
    const std::string out = expect_caught(solid, "double --from 50", "main,long", "long session",
                                          "solid_state_t(50), session 'long'", dir / (std::string(solid) + "_from50"));
    EXPECT_NE(out.find("PASS  impulse vs motion"), std::string::npos) << solid << ":\n" << out;
  }
  // A restore() that restores nothing: the continuation after the restart differs.
  for (const char* solid : {"c++", "python"})
    expect_caught(solid, "restore-nothing", "main,repeat,restart", "restart", "restore() must bring back the whole state",
                  dir / (std::string(solid) + "_restore"));
}

}  // namespace
