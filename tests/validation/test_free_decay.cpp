// The sheet released in still air against Sader's theory (issue 16, docs/validation.md "The
// sheet in still air"): the finest affordable case of launch/free_decay_study.py, the
// paper's sheet with CGPs 100 times heavier (it rings) at the paper's resolution in the
// small box, two processes through launch/run-coupled.sh, held to the tolerance that the
// study supports. The study script runs the case, computes the reference
// (launch/sader.py) and checks; the test asserts its verdict and that it measured.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <string>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kSource = COSIM_SOURCE_DIR;

/// launch/free_decay_study.py with `args` passes its checks `keys` of the case `where`.
void expect_study_passes(const std::string& name, const std::string& args, const std::string& where,
                         std::initializer_list<const char*> keys) {
  cosim::test::expect_study_passes(kSource / "launch" / "free_decay_study.py", name, args, where, keys);
}

// The tolerances: docs/validation.md, "The sheet in still air" (the study's table).
TEST(SheetInAir, FreeDecayMatchesSader) {
  expect_study_passes("cosim_free_decay",
                      "--cases heavy --resolutions 0.2561 --boxes small --t-end-us 1.9"
                      " --tolerance t_cross1=0.05,t_cross2=0.05,freq=0.05,undershoot=0.15,zeta=0.25",
                      "0.2561 small", {"t_cross1", "t_cross2", "freq", "undershoot", "zeta"});
}

// Sader's own problem (docs/validation.md, "The strip limit"): a rigid strip of the paper's
// width and mass per area on a spring at the paper's sheet's vacuum frequency (the `sprung`
// model), periodic along its length (L/b infinite), far from any wall, released from a
// translation. At dx 0.128 um (the sheet as 10 x 8 CGPs) in the x2 box the coupling meets the
// strip theory within 1.2 %; at 0.2561 um within 5 %, at 0.5122 um it misses by 14-32 %.
// Run to 0.6 us: past the undershoot (at 0.46 us), which is all the checks read.
TEST(SheetInAir, SlenderSheetFreeDecayMatchesSader) {
  expect_study_passes("cosim_slender_free_decay",
                      "--cases paper --resolutions 0.128 --boxes x2 --aspects strip --sheet-refine 2"
                      " --t-end-us 0.6 --tolerance t_cross1=0.05,undershoot=0.05,zeta=0.10",
                      "strip (L/b infinite)", {"t_cross1", "undershoot", "zeta"});
}

}  // namespace
