// The flapping flag (issue 16 item 4, docs/validation.md "The flapping flag"): the filament of
// Huang, Shin & Sung (2007) as a span-periodic sheet in a uniform stream (Re 200, mass ratio
// 1.5, bending rigidity 0.001; no gravity), two processes through launch/run-coupled.sh. A shortened case
// of launch/flapping_flag_study.py: the coarse grid (16.5 cells along L) and 36 convective times
// L / U, measured over the last 40 % (21.6 to 36 L / U: three periods of the saturated
// flapping); its own tolerance (docs/validation.md, "The flapping flag"): the sheet flaps
// (peak-to-peak trailing-edge amplitude at least 0.05 L), St = f L / U within 5 % and A / L
// within 10 % of the study's finest grid. The published values could not be retrieved, so the
// reference is the converged study, not the paper. The study script measures and checks; the
// test asserts its verdict and that it measured.
//
// PinnedFlagWithGravityConvergesToFinestGrid: the same filament in Huang, Shin & Sung's own
// configuration as its public implementations set it (bending rigidity 0.0015, Froude number
// 0.5 along the stream: [solid] gravity_m_s2; pinned leading edge: [[sheet]] leading_edge),
// docs/validation.md "Huang, Shin & Sung's configuration": the coarse grid's full run (16.5
// cells along L, 60 L / U, measured over 45 to 60 L / U once the slower growth has saturated),
// St within 5 % and A / L within 10 % of the study's finest grid (32.5 cells). Again not the
// published values, which were not found.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kSource = COSIM_SOURCE_DIR;
// The finest grid of the study (48.5 dx along L, docs/validation.md): St 0.2645 +- 5 %,
// A / L 1.192 +- 10 %.
constexpr const char* kStBand = "0.251,0.278";
constexpr const char* kAmpBand = "1.073,1.311";

// Runs the study on the coarse grid (16 cells along L) with `options` and the bands, and
// checks its verdict.
void expect_study_passes(const std::string& folder, const std::string& options, const char* st_band,
                         const char* amp_band) {
  const fs::path out = fs::path(::testing::TempDir()) / folder;
  fs::remove_all(out);
  const cosim::test::RunResult r = cosim::test::run_command(
      // One OpenMP thread: two spinning threads on two cores that other work shares ran 25
      // times slower here (0.8 against 19 MLUPS); one runs the 36 L / U case in about a minute.
      "OMP_NUM_THREADS=1 /usr/bin/python3 " + cosim::test::quoted((kSource / "launch" / "flapping_flag_study.py").string()) +
          " --out " + cosim::test::quoted(out.string()) + " --resolutions 16 " + options +
          " --st-band " + std::string(st_band) + " --amp-band " + std::string(amp_band),
      out / "logs");
  std::printf("%s%s", r.out.c_str(), r.err.c_str());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("check N 16: A/L"), std::string::npos) << "the flapping was not measured";
  EXPECT_EQ(r.out.find("FAILED"), std::string::npos) << "a check failed";
}

TEST(SheetInStream, FlappingFlagConvergesToFinestGrid) {
  expect_study_passes("cosim_flapping_flag", "--length-times 36 --measure-from 0.6", kStBand, kAmpBand);
}

// The finest grid of Huang's configuration (32.5 dx along L, docs/validation.md): St 0.3153
// +- 5 %, A / L 0.833 +- 10 %; the coarse grid measured St 0.3155 and A / L 0.775 (-7.0 %).
constexpr const char* kPinnedStBand = "0.2995,0.3311";
constexpr const char* kPinnedAmpBand = "0.750,0.916";

TEST(SheetInStream, PinnedFlagWithGravityConvergesToFinestGrid) {
  expect_study_passes("cosim_flapping_flag_pinned",
                      "--gamma 0.0015 --froude 0.5 --leading-edge pinned --length-times 60 --measure-from 0.75",
                      kPinnedStBand, kPinnedAmpBand);
}

}  // namespace
