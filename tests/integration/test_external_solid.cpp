// A solid written in another language from protocol/README.md alone (the C example
// examples/prescribed_plate, a rigid plate in a prescribed oscillation) couples with the
// fluid as two processes over LCM, started by launch/run-coupled.sh --solid-cmd (in a private
// network namespace when root).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kPlate = PRESCRIBED_PLATE_EXE;

TEST(TwoProcess, ExternalSolidProcessCouples) {
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_external_solid";
  fs::remove_all(dir);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const std::string cmd = "bash " + (kSource / "launch" / "run-coupled.sh").string() + " " +
                          (kSource / "scenes" / "coupled_plate.toml").string() + " --output " +
                          out.string() + " --no-build --quiet --solid-cmd " + kPlate.string() + " >" +
                          (out / "launcher.log").string() + " 2>&1";
  const int s = std::system(cmd.c_str());
  const int status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  const std::string fluid_log = slurp(out / "fluid.log"), solid_log = slurp(out / "solid.log");
  EXPECT_EQ(status, 0) << slurp(out / "launcher.log") << fluid_log << solid_log;
  EXPECT_EQ(slurp(out / "fluid.exit"), "0\n");
  EXPECT_EQ(slurp(out / "solid.exit"), "0\n");
  EXPECT_NE(fluid_log.find("coupled run done, 100 LB steps"), std::string::npos) << fluid_log;
  // The plate takes momentum from the stream-wise flow: a finite, non-zero mean drag.
  const std::string key = "mean drag Fx = ";
  const std::size_t at = solid_log.find(key);
  ASSERT_NE(at, std::string::npos) << solid_log;
  const double drag = std::strtod(solid_log.c_str() + at + key.size(), nullptr);
  EXPECT_TRUE(std::isfinite(drag)) << solid_log;
  EXPECT_NE(drag, 0.0) << solid_log;
  fs::remove_all(dir);
}

}  // namespace
