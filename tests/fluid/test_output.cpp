// Monitoring and output of the fluid server: the health summary finds the bad cell and
// names it, snapshots and the monitor log read back with the HDF5 API, and the vorticity
// of a solid-body rotation is twice the angular velocity.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/io/field_writer.hpp"
#include "fluid/observables/flow_monitor.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/io/monitor_log.hpp"

namespace {

using namespace cosim::fluid;
namespace fs = std::filesystem;
using L = D3Q19;

/// A fresh directory under the system's temporary directory, removed at the end.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    path = fs::temp_directory_path() /
           ("cosim_test_output_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

FluidParams periodic_box(int nx, int ny, int nz) {
  FluidParams p;
  p.shape = {nx, ny, nz};
  p.tau = 0.8;
  return p;
}

void random_flow(FluidSolver& s, unsigned seed, double umax = 0.05) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-umax, umax), R(0.95, 1.05);
  s.initialize([&](int, int, int) { return CellState{R(rng), U(rng), U(rng), U(rng)}; });
}

/// A whole dataset as doubles, with its dimensions.
std::vector<double> read_dataset(hid_t file, const char* name, std::vector<hsize_t>& dims) {
  const hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  EXPECT_GE(d, 0) << name;
  const hid_t sp = H5Dget_space(d);
  const int rank = H5Sget_simple_extent_ndims(sp);
  dims.assign(std::size_t(rank), 0);
  H5Sget_simple_extent_dims(sp, dims.data(), nullptr);
  hsize_t n = 1;
  for (const hsize_t v : dims) n *= v;
  std::vector<double> out(n);
  if (n > 0) {
    EXPECT_GE(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), 0);
  }
  H5Sclose(sp);
  H5Dclose(d);
  return out;
}

/// Empty if every tag opened is closed in order (enough XML to catch a truncated or garbled
/// file), else what is wrong.
std::string unbalanced_tags(const std::string& text) {
  std::vector<std::string> stack;
  std::size_t pos = 0;
  while ((pos = text.find('<', pos)) != std::string::npos) {
    const std::size_t end = text.find('>', pos);
    if (end == std::string::npos) return "unterminated tag";
    const std::string tag = text.substr(pos + 1, end - pos - 1);
    pos = end + 1;
    if (tag.empty()) return "empty tag";
    if (tag[0] == '?' || tag[0] == '!' || tag.back() == '/') continue;
    const bool closing = tag[0] == '/';
    const std::size_t from = closing ? 1 : 0;
    const std::string name = tag.substr(from, tag.find_first_of(" \t\n", from) - from);
    if (!closing) {
      stack.push_back(name);
      continue;
    }
    if (stack.empty() || stack.back() != name) return "unexpected </" + name + ">";
    stack.pop_back();
  }
  return stack.empty() ? "" : "<" + stack.back() + "> not closed";
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// summarize() agrees with macroscopic() (Eqs. 7-8) and finds the cell with the largest Mach
// number, the extreme densities and the first non-finite cell.
TEST(Output, SummaryFindsNanRhoAndMachCells) {
  FluidParams p = periodic_box(8, 6, 5);
  p.body_force = {1e-5, 0, -2e-5};
  FluidSolver s(p);
  random_flow(s, 17);
  s.step();

  const FlowSummary a = summarize(s);
  MacroscopicFields m;
  s.macroscopic(m);
  double mass = 0, mom[3] = {}, u2max = -1, rmin = 1e300, rmax = -1e300;
  std::size_t imach = 0, imin = 0, imax = 0;
  for (std::size_t i = 0; i < m.rho.size(); ++i) {
    mass += m.rho[i];
    mom[0] += m.rho[i] * m.ux[i];
    mom[1] += m.rho[i] * m.uy[i];
    mom[2] += m.rho[i] * m.uz[i];
    const double u2 = m.ux[i] * m.ux[i] + m.uy[i] * m.uy[i] + m.uz[i] * m.uz[i];
    if (u2 > u2max) {
      u2max = u2;
      imach = i;
    }
    if (m.rho[i] < rmin) {
      rmin = m.rho[i];
      imin = i;
    }
    if (m.rho[i] > rmax) {
      rmax = m.rho[i];
      imax = i;
    }
  }
  const auto index = [&](const CellIndex& c) { return m.index(c.x, c.y, c.z); };
  EXPECT_EQ(a.step, 1);
  EXPECT_NEAR(a.mass, mass, 1e-12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.momentum[k], mom[k], 1e-13);
  EXPECT_NEAR(a.max_mach, std::sqrt(3.0 * u2max), 1e-14);
  EXPECT_EQ(index(a.max_mach_cell), imach);
  EXPECT_DOUBLE_EQ(a.rho_min, rmin);
  EXPECT_EQ(index(a.rho_min_cell), imin);
  EXPECT_DOUBLE_EQ(a.rho_max, rmax);
  EXPECT_EQ(index(a.rho_max_cell), imax);
  EXPECT_FALSE(a.has_nan);

  // Pull streaming: f_q(x) = state_q(x - c_q). The rest population (q = 0) is pulled by
  // its own cell only; q = 1 (c = +x) at x - 1 is pulled by x alone.
  PopulationField& f = s.mutable_state();
  f.at(1, 2, 3, 1) += 0.5;        // jx and rho up at (3, 3, 1): Mach about 0.5 sqrt(3) / 1.5
  f.at(0, 6, 0, 4) -= 2.0;        // rho about -1 at (6, 0, 4)
  f.at(0, 5, 5, 0) += 1.0;        // rho about 2 at (5, 5, 0)
  const FlowSummary b = summarize(s);
  EXPECT_FALSE(b.has_nan);
  EXPECT_EQ(b.max_mach_cell.x, 3);
  EXPECT_EQ(b.max_mach_cell.y, 3);
  EXPECT_EQ(b.max_mach_cell.z, 1);
  EXPECT_GT(b.max_mach, 0.5);
  EXPECT_EQ(b.rho_min_cell.x, 6);
  EXPECT_EQ(b.rho_min_cell.y, 0);
  EXPECT_EQ(b.rho_min_cell.z, 4);
  EXPECT_LT(b.rho_min, -0.9);
  EXPECT_EQ(b.rho_max_cell.x, 5);
  EXPECT_EQ(b.rho_max_cell.y, 5);
  EXPECT_EQ(b.rho_max_cell.z, 0);

  // Two NaN cells: the first in x-fastest order is reported; the extrema skip them.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.at(0, 7, 4, 3) = nan;  // index 7 + 8 (4 + 6 * 3) = 183
  f.at(0, 1, 2, 4) = nan;  // index 1 + 8 (2 + 6 * 4) = 209
  const FlowSummary c = summarize(s);
  EXPECT_TRUE(c.has_nan);
  EXPECT_EQ(c.nan_cell.x, 7);
  EXPECT_EQ(c.nan_cell.y, 4);
  EXPECT_EQ(c.nan_cell.z, 3);
  EXPECT_TRUE(std::isnan(c.nan_state.rho));
  EXPECT_TRUE(std::isnan(c.mass));
  EXPECT_EQ(c.rho_min_cell.x, 6);
  EXPECT_TRUE(std::isfinite(c.max_mach));

  // An infinite population (not NaN) counts too: +inf in q = 3 (c = +y) pulled by (0, 1, 0).
  f.at(0, 7, 4, 3) = 0.3;
  f.at(0, 1, 2, 4) = 0.3;
  f.at(3, 0, 0, 0) = std::numeric_limits<double>::infinity();
  const FlowSummary d = summarize(s);
  EXPECT_TRUE(d.has_nan);
  EXPECT_EQ(d.nan_cell.x, 0);
  EXPECT_EQ(d.nan_cell.y, 1);
  EXPECT_EQ(d.nan_cell.z, 0);
}

// The kernel's extrema (FluidSolver::last_step_extrema) of the state a step read agree with
// summarize() of that state, in both stores and with partial groups of lanes (nx = 21), and
// kernel_state_problem() names the cell from them without a pass of its own until one is due.
TEST(Output, KernelExtremaCheckTheStateTheStepRead) {
  for (const Precision precision : {Precision::Double, Precision::Mixed})
    for (const int nx : {8, 21}) {
      SCOPED_TRACE(std::string(precision_name(precision)) + ", nx " + std::to_string(nx));
      FluidParams p = periodic_box(nx, 6, 5);
      p.body_force = {1e-5, 0, -2e-5};
      p.precision = precision;
      // The two-grid propagation keeps the state the step read (previous_state()); in place
      // (the default) kernel_state_problem() looks at the state now.
      p.propagation = Propagation::TwoGrid;
      FluidSolver s(p);
      random_flow(s, 23);
      s.step();
      const FlowSummary before = summarize(s);  // state 1, which the next step reads
      s.step();
      const KernelExtrema& e = s.last_step_extrema();
      EXPECT_TRUE(e.finite);
      // Other summation orders than summarize()'s: a few units in the last place.
      EXPECT_NEAR(e.rho_min, before.rho_min, 1e-14);
      EXPECT_NEAR(e.rho_max, before.rho_max, 1e-14);
      EXPECT_NEAR(std::sqrt(3.0 * e.u2_max), before.max_mach, 1e-13);
      EXPECT_EQ(kernel_state_problem(s, HealthLimits{}), "");
      // Limits the state breaks: the pass over that state names the step, the cell, the value.
      const std::string mach = kernel_state_problem(s, HealthLimits{0.5 * before.max_mach, 0.0});
      char cell[64];
      std::snprintf(cell, sizeof cell, "step 1: cell (%d, %d, %d): Mach ", before.max_mach_cell.x,
                    before.max_mach_cell.y, before.max_mach_cell.z);
      EXPECT_EQ(mach.rfind(cell, 0), 0u) << mach;
      const std::string dense = kernel_state_problem(s, HealthLimits{0.3, 0.0, 0.5, before.rho_max - 1e-6});
      EXPECT_NE(dense.find("above watchdog.rho_max"), std::string::npos) << dense;
    }
  // A NaN the step reads: pulled by (3, 2, 1) through q = 5 (c = +z); two grids, as above.
  FluidParams two_grid = periodic_box(6, 5, 4);
  two_grid.propagation = Propagation::TwoGrid;
  FluidSolver s(two_grid);
  s.initialize_uniform(1.0, {0.0, 0.02, 0.0});
  s.mutable_state().at(5, 3, 2, 0) = std::numeric_limits<double>::quiet_NaN();
  s.step();
  EXPECT_FALSE(s.last_step_extrema().finite);
  EXPECT_EQ(kernel_state_problem(s, HealthLimits{}), "step 0: cell (3, 2, 1): rho is NaN");
  // In place (the default) the state the step read is gone: the pass reads the state now.
  FluidSolver one(periodic_box(6, 5, 4));
  one.initialize_uniform(1.0, {0.0, 0.02, 0.0});
  one.mutable_state().at(5, 3, 2, 0) = std::numeric_limits<double>::quiet_NaN();
  one.step();
  EXPECT_FALSE(one.last_step_extrema().finite);
  const std::string now = kernel_state_problem(one, HealthLimits{});
  EXPECT_EQ(now.rfind("step 1: cell (", 0), 0u) << now;
  EXPECT_NE(now.find("is NaN"), std::string::npos) << now;
}

TEST(Output, HealthProblemNamesStepCellAndQuantity) {
  const HealthLimits limits;  // Mach 0.3, rho > 0
  FlowSummary s;
  s.step = 1200;
  s.mass = 100;
  s.max_mach = 0.05;
  s.max_mach_cell = {1, 2, 3};
  s.rho_min = 0.98;
  s.rho_min_cell = {4, 5, 6};
  s.rho_max = 1.02;
  s.rho_max_cell = {7, 8, 9};
  EXPECT_EQ(health_problem(s, limits), "");

  s.max_mach = 0.41;
  EXPECT_EQ(health_problem(s, limits), "step 1200: cell (1, 2, 3): Mach 0.41 above the limit 0.3");
  s.rho_min = -0.02;
  s.rho_min_cell = {14, 3, 7};
  EXPECT_EQ(health_problem(s, limits), "step 1200: cell (14, 3, 7): rho = -0.02 <= 0");
  s.has_nan = true;
  s.nan_cell = {2, 0, 11};
  s.nan_state = {1.0, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  EXPECT_EQ(health_problem(s, limits), "step 1200: cell (2, 0, 11): u_x is NaN");
  s.nan_state = {1.0, 0.0, 0.0, -std::numeric_limits<double>::infinity()};
  EXPECT_EQ(health_problem(s, limits), "step 1200: cell (2, 0, 11): u_z is -inf");
  s.nan_state = {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 0.0};
  EXPECT_EQ(health_problem(s, limits), "step 1200: cell (2, 0, 11): rho is NaN");

  // From a real solver: uniform flow at u = 0.2 is Mach 0.346; a NaN population is caught.
  FluidSolver solver(periodic_box(6, 5, 4));
  solver.initialize_uniform(1.0, {0.0, 0.2, 0.0});
  solver.step();
  const std::string mach = health_problem(summarize(solver), limits);
  EXPECT_NE(mach.find("step 1: cell ("), std::string::npos) << mach;
  EXPECT_NE(mach.find("Mach 0.346 above the limit 0.3"), std::string::npos) << mach;
  EXPECT_EQ(health_problem(summarize(solver), HealthLimits{0.4, 0.0}), "");
  solver.mutable_state().at(5, 3, 2, 0) = std::numeric_limits<double>::quiet_NaN();  // c = +z: (3, 2, 1)
  EXPECT_EQ(health_problem(summarize(solver), limits), "step 1: cell (3, 2, 1): rho is NaN");
}

TEST(Output, FieldFileRoundTrip) {
  const TempDir tmp("fields");
  FluidParams p = periodic_box(7, 5, 4);
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::FreeSlip;
  FluidSolver s(p);
  random_flow(s, 23);
  const double dx_um = 0.2561, dt_us = 4.4603e-4;
  FieldWriter w((tmp.path / "out").string(), dx_um, dt_us);
  s.step();
  w.write(s);
  for (int k = 0; k < 2; ++k) s.step();
  w.write(s);

  MacroscopicFields m;
  s.macroscopic(m);
  std::vector<double> wx, wy, wz;
  vorticity(s, m, wx, wy, wz);
  const fs::path h5 = tmp.path / "out" / "fields_000003.h5";
  ASSERT_TRUE(fs::exists(h5));
  const hid_t file = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  const std::vector<double> rho = read_dataset(file, "rho", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 5, 7}));
  const std::vector<double> u = read_dataset(file, "u", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 5, 7, 3}));
  const std::vector<double> vort = read_dataset(file, "vorticity", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 5, 7, 3}));
  std::int64_t step = -1;
  const hid_t attr = H5Aopen(file, "step", H5P_DEFAULT);
  H5Aread(attr, H5T_NATIVE_INT64, &step);
  H5Aclose(attr);
  H5Fclose(file);
  EXPECT_EQ(step, 3);
  ASSERT_EQ(rho.size(), m.rho.size());
  const double us = dx_um / dt_us;  // lattice velocity to m/s
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < 7; ++x) {
        const std::size_t i = m.index(x, y, z);
        const std::size_t h = (std::size_t(z) * 5 + y) * 7 + x;  // [nz][ny][nx], x fastest
        EXPECT_EQ(h, i);
        EXPECT_DOUBLE_EQ(rho[h], m.rho[i]);
        EXPECT_DOUBLE_EQ(u[3 * h], us * m.ux[i]);
        EXPECT_DOUBLE_EQ(u[3 * h + 1], us * m.uy[i]);
        EXPECT_DOUBLE_EQ(u[3 * h + 2], us * m.uz[i]);
        EXPECT_DOUBLE_EQ(vort[3 * h], wx[i] / dt_us);
        EXPECT_DOUBLE_EQ(vort[3 * h + 1], wy[i] / dt_us);
        EXPECT_DOUBLE_EQ(vort[3 * h + 2], wz[i] / dt_us);
      }

  // The XDMF index lists both snapshots and the three datasets, and is well formed.
  std::ifstream in(tmp.path / "out" / "fields.xmf");
  std::stringstream text;
  text << in.rdbuf();
  const std::string xmf = text.str();
  EXPECT_EQ(unbalanced_tags(xmf), "") << xmf;
  EXPECT_EQ(xmf.rfind("<?xml", 0), 0u);
  EXPECT_NE(xmf.find("Version=\"3.0\""), std::string::npos);
  EXPECT_NE(xmf.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_EQ(count(xmf, "TopologyType=\"3DCoRectMesh\" Dimensions=\"4 5 7\""), 2u);
  EXPECT_EQ(count(xmf, "GeometryType=\"ORIGIN_DXDYDZ\""), 2u);
  EXPECT_NE(xmf.find("0.2561 0.2561 0.2561"), std::string::npos);
  for (const char* ds : {"fields_000001.h5:/rho", "fields_000001.h5:/u", "fields_000001.h5:/vorticity",
                         "fields_000003.h5:/rho", "fields_000003.h5:/u", "fields_000003.h5:/vorticity"})
    EXPECT_EQ(count(xmf, std::string(">") + ds + "<"), 1u) << ds;
  EXPECT_NE(xmf.find("Dimensions=\"4 5 7 3\""), std::string::npos);
  EXPECT_NE(xmf.find("<Time Value=\"0.0013380"), std::string::npos) << xmf;  // 3 dt_us
  // Nothing half-written is left behind.
  for (const auto& e : fs::directory_iterator(tmp.path / "out"))
    EXPECT_NE(e.path().extension(), ".part") << e.path();

  // Rewriting a step replaces its entry instead of listing it twice.
  w.write(s);
  EXPECT_EQ(w.snapshots(), 2u);

  // I/O failure: one line naming the file.
  fs::remove_all(tmp.path / "out");
  try {
    w.write(s);
    ADD_FAILURE() << "writing into a removed directory did not throw";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("fields_000003.h5"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  std::ofstream(tmp.path / "a_file") << "x";
  EXPECT_THROW(FieldWriter((tmp.path / "a_file").string(), dx_um, dt_us), std::runtime_error);
  EXPECT_THROW(FieldWriter((tmp.path / "ok").string(), 0.0, dt_us), std::invalid_argument);
}

// u = Omega x (r - r0) is a rigid rotation: curl u = 2 Omega everywhere. The field is linear,
// so the central differences inside and the one-sided ones at walls are exact.
// A y plane of the grid (the paper's Figs. 9 and 12): the plane's cells of the whole-grid
// fields, vorticity included (computed from the whole field), placed at y dx in the XDMF.
TEST(Output, PlaneSnapshotIsTheGridsPlane) {
  const TempDir tmp("planes");
  FluidParams p = periodic_box(7, 5, 4);
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::FreeSlip;
  FluidSolver s(p);
  random_flow(s, 29);
  s.step();
  const double dx_um = 0.2561, dt_us = 4.4603e-4;
  FieldWriter w((tmp.path / "out").string(), dx_um, dt_us, "plane_y3", 3);
  w.write(s);
  MacroscopicFields m;
  s.macroscopic(m);
  std::vector<double> wx, wy, wz;
  vorticity(s, m, wx, wy, wz);
  const fs::path h5 = tmp.path / "out" / "plane_y3_000001.h5";
  ASSERT_TRUE(fs::exists(h5));
  const hid_t file = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  const std::vector<double> rho = read_dataset(file, "rho", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 1, 7}));
  const std::vector<double> vort = read_dataset(file, "vorticity", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 1, 7, 3}));
  H5Fclose(file);
  for (int z = 0; z < 4; ++z)
    for (int x = 0; x < 7; ++x) {
      const std::size_t i = m.index(x, 3, z), h = std::size_t(z) * 7 + x;
      EXPECT_EQ(rho[h], m.rho[i]);
      EXPECT_DOUBLE_EQ(vort[3 * h + 1], wy[i] / dt_us);  // the writer multiplies by 1 / dt
    }
  std::ifstream in(tmp.path / "out" / "plane_y3.xmf");
  std::stringstream text;
  text << in.rdbuf();
  const std::string xmf = text.str();
  EXPECT_EQ(unbalanced_tags(xmf), "") << xmf;
  EXPECT_NE(xmf.find("Dimensions=\"4 1 7\""), std::string::npos);
  // y = (3 + 1/2) dx: node j at (j + 1/2) dx, the sheets' frame (XdmfGeometryMatchesSheets).
  EXPECT_NE(xmf.find(">0 0.89635 0</DataItem>"), std::string::npos) << xmf;
  // A plane outside the grid is refused.
  FieldWriter bad((tmp.path / "bad").string(), dx_um, dt_us, "plane_y9", 9);
  EXPECT_THROW(bad.write(s), std::invalid_argument);
}

TEST(Output, VorticityOfSolidBodyRotation) {
  FluidParams p = periodic_box(9, 8, 7);
  for (auto& face : p.faces) face.kind = FaceKind::Wall;
  const FluidSolver s(p);
  MacroscopicFields m;
  m.shape = s.shape();
  const std::size_t n = std::size_t(m.shape.cells());
  m.rho.assign(n, 1.0);
  m.ux.resize(n);
  m.uy.resize(n);
  m.uz.resize(n);
  const double Om[3] = {1e-3, -2e-3, 3e-3}, r0[3] = {4.0, 3.5, 3.0};
  for (int z = 0; z < 7; ++z)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 9; ++x) {
        const double r[3] = {x - r0[0], y - r0[1], z - r0[2]};
        const std::size_t i = m.index(x, y, z);
        m.ux[i] = Om[1] * r[2] - Om[2] * r[1];
        m.uy[i] = Om[2] * r[0] - Om[0] * r[2];
        m.uz[i] = Om[0] * r[1] - Om[1] * r[0];
      }
  std::vector<double> wx, wy, wz;
  vorticity(s, m, wx, wy, wz);
  ASSERT_EQ(wx.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_NEAR(wx[i], 2 * Om[0], 1e-15);
    EXPECT_NEAR(wy[i], 2 * Om[1], 1e-15);
    EXPECT_NEAR(wz[i], 2 * Om[2], 1e-15);
  }

  // Periodic faces wrap: u_x = sin(k z) on a periodic z axis gives, by central
  // differences, omega_y = du_x/dz = sin(k) cos(k z) at every z, the faces included.
  const FluidSolver sp(periodic_box(3, 4, 10));
  MacroscopicFields mp;
  mp.shape = sp.shape();
  const std::size_t np = std::size_t(mp.shape.cells());
  mp.rho.assign(np, 1.0);
  mp.ux.resize(np);
  mp.uy.assign(np, 0.0);
  mp.uz.assign(np, 0.0);
  const double k = 2 * std::numbers::pi / 10;
  for (int z = 0; z < 10; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 3; ++x) mp.ux[mp.index(x, y, z)] = std::sin(k * z);
  vorticity(sp, mp, wx, wy, wz);
  for (int z = 0; z < 10; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 3; ++x) {
        const std::size_t i = mp.index(x, y, z);
        EXPECT_NEAR(wy[i], std::sin(k) * std::cos(k * z), 1e-15) << "z = " << z;
        EXPECT_EQ(wx[i], 0.0);
        EXPECT_EQ(wz[i], 0.0);
      }
}

TEST(Output, MonitorLogAppends) {
  const TempDir tmp("monitor");
  const double dt_us = 4.4603e-4;
  FluidSolver s(periodic_box(6, 5, 4));
  random_flow(s, 31);
  std::vector<FlowSummary> rows;
  for (int k = 0; k < 3; ++k) {
    s.step();
    rows.push_back(summarize(s));
  }
  rows.back().has_nan = true;
  rows.back().nan_cell = {1, 2, 3};

  const fs::path path = tmp.path / "run" / "monitor.h5";
  {
    MonitorLog log(path.string(), dt_us);
    for (const FlowSummary& r : rows) log.append(r);
    EXPECT_EQ(log.rows(), 3);
  }
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  const std::vector<double> step = read_dataset(file, "step", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{3}));
  const std::vector<double> time = read_dataset(file, "time_us", dims);
  const std::vector<double> mass = read_dataset(file, "mass", dims);
  const std::vector<double> mom = read_dataset(file, "momentum", dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{3, 3}));
  const std::vector<double> mach = read_dataset(file, "max_mach", dims);
  const std::vector<double> rmin = read_dataset(file, "rho_min", dims);
  const std::vector<double> rmax = read_dataset(file, "rho_max", dims);
  const std::vector<double> nan_cell = read_dataset(file, "nan_cell", dims);
  const std::vector<double> has_nan = read_dataset(file, "has_nan", dims);
  H5Fclose(file);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(step[k], double(k + 1));
    EXPECT_DOUBLE_EQ(time[k], double(k + 1) * dt_us);
    EXPECT_EQ(mass[k], rows[k].mass);
    for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(mom[3 * k + a], rows[k].momentum[a]);
    EXPECT_EQ(mach[k], rows[k].max_mach);
    EXPECT_EQ(rmin[k], rows[k].rho_min);
    EXPECT_EQ(rmax[k], rows[k].rho_max);
    EXPECT_EQ(has_nan[k], k == 2 ? 1.0 : 0.0);
  }
  EXPECT_EQ(nan_cell[0], -1.0);
  EXPECT_EQ(nan_cell[6], 1.0);
  EXPECT_EQ(nan_cell[8], 3.0);

  // A run that dies without closing the file keeps every appended row.
  const fs::path crashed = tmp.path / "crashed.h5";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    MonitorLog log(crashed.string(), dt_us);
    log.append(rows[0]);
    log.append(rows[1]);
    std::_Exit(0);  // no destructors, no H5Fclose
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  const hid_t f2 = H5Fopen(crashed.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f2, 0);
  const std::vector<double> step2 = read_dataset(f2, "step", dims);
  EXPECT_EQ(step2, (std::vector<double>{1.0, 2.0}));
  H5Fclose(f2);

  // The stdout line: one line with the step, the time and the observables.
  const std::string line = format_summary(rows[1], dt_us, rows[0].mass);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(line.rfind("step 2  t = 0.00089206 us  mass drift ", 0), 0u) << line;
  EXPECT_NE(line.find("max Mach"), std::string::npos) << line;
  EXPECT_NE(format_summary(rows[2], dt_us, rows[0].mass).find("NON-FINITE at (1, 2, 3)"), std::string::npos);
}

}  // namespace
