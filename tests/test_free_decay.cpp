// The sheet released in still air against Sader's theory (issue 16, docs/validation.md "The
// sheet in still air"): the finest affordable case of launch/free_decay_study.py, the
// paper's sheet with CGPs 100 times heavier (it rings) at the paper's resolution in the
// small box, two processes through launch/run-coupled.sh, held to the tolerance that the
// study supports. The study script runs the case, computes the reference
// (launch/sader.py) and checks; the test asserts its verdict and that it measured.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kSource = COSIM_SOURCE_DIR;

TEST(SheetInAir, FreeDecayMatchesSader) {
  const fs::path out = fs::path(::testing::TempDir()) / "cosim_free_decay";
  fs::remove_all(out);
  // The tolerances: docs/validation.md, "The sheet in still air" (the study's table).
  const cosim::test::RunResult r = cosim::test::run_command(
      "/usr/bin/python3 " + cosim::test::quoted((kSource / "launch" / "free_decay_study.py").string()) +
          " --out " + cosim::test::quoted(out.string()) +
          " --cases heavy --resolutions 0.2561 --boxes small --t-end-us 1.9"
          " --tolerance t_cross1=0.05,t_cross2=0.05,freq=0.05,undershoot=0.15",
      out / "logs");
  std::printf("%s%s", r.out.c_str(), r.err.c_str());
  EXPECT_EQ(r.status, 0) << r.err;
  for (const char* k : {"t_cross1", "t_cross2", "freq", "undershoot"})
    EXPECT_NE(r.out.find(std::string("0.2561 small: ") + k), std::string::npos) << k << " not checked";
}

}  // namespace
