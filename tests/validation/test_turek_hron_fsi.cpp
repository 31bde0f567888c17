// Turek & Hron's FSI2 as a coupled run (issue 29; docs/validation.md, "FSI2"): the cylinder
// held by the fluid, the elastic bar a sheet of the solid server, two processes through
// launch/run-coupled.sh. launch/turek_hron_fsi_study.py writes the scene at 10 cells per
// diameter, runs it, measures A's displacement over the last period and checks it against
// the reference; the test asserts its verdict and that it measured.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/support/run_command.hpp"

namespace {

const std::filesystem::path kSource = COSIM_SOURCE_DIR;

// The bands: u_y(A)'s amplitude within 10 %, the flapping frequency within 5 %,
// u_x(A)'s mean within 15 %. The flap's frequency is read from the reference's u_x(A)
// frequency (3.8 Hz, twice the flap's; the reference's own u_y(A) value, 2.0 Hz, is rounded
// to 2.5 % and contradicts it: launch/turek_hron_fsi_study.py, CHECKS); u_x(A)'s frequency
// is checked against its 3.8 Hz as well. The run: 13 s; the bar grows from rest into its
// periodic flapping by 12 s at this resolution (docs/validation.md, "FSI2").
TEST(TurekHronFsi, TurekHronFsi2MatchesReference) {
  cosim::test::expect_study_passes(
      kSource / "launch" / "turek_hron_fsi_study.py", "cosim_turek_hron_fsi2",
      "--case fsi2 --resolutions 10 --seconds 13 --window 1.0"
      " --tolerance u_y_amplitude=0.10,flap_frequency=0.05,u_x_frequency=0.05,u_x_mean=0.15",
      "fsi2 n 10", {"u_y_amplitude", "flap_frequency", "u_x_frequency", "u_x_mean"});
}

}  // namespace
