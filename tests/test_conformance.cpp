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
    }
    const fs::path golden = kSource / "tests" / "conformance" / "golden" / (model + ".csv");
    const auto r = kit(SOLID_EXE, scene, dir / model, " --golden " + quoted(golden.string()));
    EXPECT_EQ(r.status, 0) << model << ":\n" << r.out << r.err;
    EXPECT_NE(r.out.find("14 of 14 checks pass"), std::string::npos) << model << ":\n" << r.out;
  }
  const std::string python = "env PYTHONPATH=" + (fs::path(COSIM_BINARY_DIR) / "sdk" / "python").string() +
                             " /usr/bin/python3 " + (kSource / "examples" / "python_sheet" / "spring_sheet.py").string();
  for (const auto& [name, cmd] : {std::pair<std::string, std::string>{"prescribed_plate", PRESCRIBED_PLATE_EXE},
                                  {"spring_sheet", SPRING_SHEET_EXE},
                                  {"python_sheet", python}}) {
    const auto r = kit(cmd, kScene, dir / name);
    EXPECT_EQ(r.status, 0) << name << ":\n" << r.out << r.err;
    EXPECT_NE(r.out.find("13 of 13 checks pass"), std::string::npos) << name << ":\n" << r.out;
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
    const auto r = kit(std::string(BROKEN_SOLID_EXE) + " --fault " + c.fault, kScene, dir / c.fault);
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

}  // namespace
