// The parallel (Jacobi) coupling scheme of DESIGN 2.1 (protocol/README.md section 14) against
// the serial scheme, two processes each through launch/run-coupled.sh.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/run_compare.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::expect_run_done;
using cosim::test::logs;
using cosim::test::replace_in;
using cosim::test::read_datasets;
using cosim::test::run_launcher;
using cosim::test::scratch;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;

/// scenes/coupled_small.toml with 120 LB steps (40 rigid, 80 free), no field or sheet
/// snapshots, and the given coupling scheme.
fs::path small_scene(const fs::path& dir, const std::string& scheme) {
  return cosim::test::write_edited_scene(kSource / "scenes" / "coupled_small.toml",
                                         {{"steps = 200", "steps = 120"},
                                          {"rigid_steps = 50", "rigid_steps = 40\nscheme = \"" + scheme + "\""},
                                          {"fields_every = 50", "fields_every = 0"},
                                          {"sheets_every = 50", "sheets_every = 0"}},
                                         dir / (scheme + ".toml"));
}

/// A per-step series of 3-vectors of solid.h5 (the first sheet): `name` [rows, sheets, 3].
std::vector<std::array<double, 3>> series(const fs::path& out, const std::string& name) {
  const auto sets = read_datasets(out / "solid.h5");
  const auto it = sets.find(name);
  if (it == sets.end() || it->second.dims.size() != 3 || it->second.dims[2] != 3)
    throw std::runtime_error((out / "solid.h5").string() + " has no " + name + " [rows, sheets, 3]");
  const auto rows = it->second.dims[0], sheets = it->second.dims[1];
  std::vector<std::array<double, 3>> v(rows);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < 3; ++c) v[r][c] = it->second.values[(r * sheets) * 3 + c];
  return v;
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

// The parallel scheme drives the solid's interval n -> n+1 with the fluid sampled at step n
// instead of n+1 (the serial scheme's); everything else, the impulses the fluid spreads
// included, is the serial scheme's. The bound on the difference, derived before the runs:
// to first order in dt_LB, a drive one LB step older changes the solid's response by at most
// the change of that response over one LB step, and the fluid's reply to it (which is the
// next drive) by the same once more: |q_par(n) - q_ser(n)| <= 2 max_k |q_ser(k) - q_ser(k-1)|
// over the free steps, for q the marked CGP's displacement and the fluid force on the sheet,
// the serial run's own one-step changes setting the scale. A scheme that lagged more than one
// step, spread other impulses than the solid's, or went unstable breaks it.
TEST(TwoProcess, ParallelSchemeMatchesSerial) {
  const fs::path dir = scratch("parallel_scheme");
  const fs::path serial = dir / "serial", parallel = dir / "parallel";
  ASSERT_EQ(run_launcher(kSource, small_scene(dir, "serial"), serial), 0) << logs(serial);
  ASSERT_EQ(run_launcher(kSource, small_scene(dir, "parallel"), parallel), 0) << logs(parallel);
  EXPECT_NE(slurp(parallel / "solid.log").find("parallel scheme"), std::string::npos) << logs(parallel);

  constexpr std::size_t kRigid = 40, kSteps = 120;
  for (const char* name : {"marked_displacement_um", "fluid_force_N"}) {
    const auto s = series(serial, name), p = series(parallel, name);
    ASSERT_EQ(s.size(), kSteps) << name;
    ASSERT_EQ(p.size(), kSteps) << name;
    // The spin-up is exchanged in the serial order: identical bit for bit up to the release.
    for (std::size_t n = 0; n < kRigid; ++n)
      for (std::size_t c = 0; c < 3; ++c) ASSERT_EQ(s[n][c], p[n][c]) << name << " row " << n;
    double diff = 0.0, one_step = 0.0, scale = 0.0;
    for (std::size_t n = kRigid; n < kSteps; ++n) {
      diff = std::max(diff, distance(s[n], p[n]));
      one_step = std::max(one_step, distance(s[n], s[n - 1]));
      scale = std::max(scale, distance(s[n], {0.0, 0.0, 0.0}));
    }
    std::printf("%s: max |parallel - serial| = %.4g, the serial run's largest one-step change %.4g "
                "(bound %.4g), largest value %.4g\n",
                name, diff, one_step, 2.0 * one_step, scale);
    EXPECT_GT(diff, 0.0) << name << ": the parallel run equals the serial one (was the scheme applied?)";
    EXPECT_LE(diff, 2.0 * one_step) << name << "\n" << logs(parallel);
  }
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
