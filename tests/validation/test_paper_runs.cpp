// Short coupled runs of the paper's reduced scenes (section 3.1): two processes through
// launch/run-coupled.sh, then the solid's time series read back from solid.h5.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/h5_read.hpp"
#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;
const fs::path kSource = COSIM_SOURCE_DIR;

/// A paper scene shortened to its spin-up plus `free_steps`, without field output.
fs::path shortened(const std::string& name, int free_steps, const fs::path& dir) {
  std::istringstream in(slurp(kSource / "scenes" / "paper" / (name + ".toml")));
  std::ostringstream out;
  long rigid = -1;
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("rigid_steps = ", 0) == 0) rigid = std::stol(line.substr(14));
    lines.push_back(line);
  }
  for (std::string& line : lines) {
    if (line.rfind("steps = ", 0) == 0) line = "steps = " + std::to_string(rigid + free_steps);
    if (line.rfind("fields_every = ", 0) == 0) line = "fields_every = 0";
    out << line << "\n";
  }
  const fs::path p = dir / (name + ".toml");
  std::ofstream(p) << out.str();
  return p;
}

struct Series {
  std::vector<double> data;
  std::vector<hsize_t> dims;
};

Series read(const fs::path& file, const char* name) {
  Series s;
  s.data = cosim::test::read_dataset<double>(file, name, H5T_NATIVE_DOUBLE, &s.dims);
  return s;
}

/// Runs the scene; returns the output folder (asserting both processes exited 0).
fs::path run(const std::string& name, int free_steps) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cosim_paper_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir / "out");
  const fs::path scene = shortened(name, free_steps, dir);
  const std::string cmd = "bash " + (kSource / "launch" / "run-coupled.sh").string() + " " +
                          scene.string() + " --output " + (dir / "out").string() +
                          " --no-build --quiet >" + (dir / "launcher.log").string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << slurp(dir / "launcher.log") << slurp(dir / "out" / "fluid.log")
      << slurp(dir / "out" / "solid.log");
  return dir / "out";
}

constexpr int kFreeSteps = 300;  // about 0.27 us after release at the reduced resolution

// Fig. 5 at Re 40: released at 90 deg, the sheet bends downstream; C_D dominates (Fig. 6).
TEST(PaperRuns, SheetAt90DegreesBendsDownstream) {
  const fs::path out = run("single_theta90_re40_reduced", kFreeSteps);
  const Series x = read(out / "solid.h5", "marked_displacement_um");
  const Series c = read(out / "solid.h5", "force_coefficients");
  ASSERT_EQ(x.dims.size(), 3u);
  const std::size_t rows = x.dims[0];
  ASSERT_GT(rows, static_cast<std::size_t>(kFreeSteps));
  const std::size_t released = rows - kFreeSteps;
  double mean_x = 0.0, cd = 0.0, cy = 0.0, cz = 0.0;
  for (std::size_t r = released; r < rows; ++r) {
    mean_x += x.data[3 * r] / kFreeSteps;
    cd += c.data[3 * r] / kFreeSteps;
    cy += c.data[3 * r + 1] / kFreeSteps;
    cz += c.data[3 * r + 2] / kFreeSteps;
  }
  std::printf("after release: mean stream-wise displacement %.4g um; mean C_D %.4g, C_y %.4g, "
              "C_z %.4g\n", mean_x, cd, cy, cz);
  EXPECT_GT(mean_x, 0.0);
  EXPECT_GT(cd, std::abs(cy));
  EXPECT_GT(cd, std::abs(cz));
  EXPECT_GT(cd, 0.0);
}

// Fig. 7 at 0 deg: a sheet parallel to the flow in a span-wise symmetric channel feels no
// span-wise force; its marked CGP stays on the symmetry plane (to 1e-9 of H).
TEST(PaperRuns, SheetAtZeroAngleStaysSymmetric) {
  const fs::path out = run("single_theta00_re40_reduced", kFreeSteps);
  const Series x = read(out / "solid.h5", "marked_displacement_um");
  ASSERT_EQ(x.dims.size(), 3u);
  double worst = 0.0, stream = 0.0;
  for (std::size_t r = 0; r < x.dims[0]; ++r) {
    worst = std::max(worst, std::abs(x.data[3 * r + 2]));
    stream = std::max(stream, std::abs(x.data[3 * r]));
  }
  const double h_um = 8.8;
  std::printf("largest span-wise displacement %.3g um (%.3g H); stream-wise up to %.3g um\n",
              worst, worst / h_um, stream);
  EXPECT_LT(worst, 1e-9 * h_um);
  EXPECT_GT(stream, 0.0) << "the flow must act on the sheet";
}

}  // namespace
