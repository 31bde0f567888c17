// The fluid kernel of every instruction-set level built into the binary
// (fluid/collision/kernel_dispatch.hpp): each level the CPU runs gives the same bits run after run, and
// the same bits as the lowest level, on every boundary kind, with forced cells, both stores,
// ordinary and non-temporal stores, the outflow ghosts the kernel writes and the watchdog's
// extrema.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/collision/stream_collide.hpp"
#include "tests/support/boundary_grids.hpp"

namespace {

using namespace cosim::fluid;
using L = D3Q19;

/// The values of fields and the extrema of a run, as bits.
struct Result {
  std::vector<unsigned char> bytes;
  void add(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    bytes.insert(bytes.end(), b, b + n);
  }
  void add(const KernelExtrema& e) {
    add(&e.rho_min, sizeof e.rho_min);
    add(&e.rho_max, sizeof e.rho_max);
    add(&e.u2_max, sizeof e.u2_max);
    bytes.push_back(e.finite ? 1 : 0);
  }
  /// Interior and ghosts; not the padding (the single store's line writes fill it with
  /// whatever its last group held, which depends on the group width).
  template <class T>
  void add(const BasicPopulationField<T>& f) {
    const GridShape& g = f.layout().shape();
    for (int q = 0; q < L::Q; ++q)
      for (int z = -1; z <= g.nz; ++z)
        for (int y = -1; y <= g.ny; ++y) add(f.q(q) + f.layout().index(-1, y, z), sizeof(T) * std::size_t(g.nx + 2));
  }
};


template <class T>
const BasicPopulationField<T>& state_of(const FluidSolver& s) {
  if constexpr (std::is_same_v<T, double>)
    return s.state();
  else
    return s.state_single();
}

/// Steps of the solver with forced cells (boundary layers included), then the kernel alone
/// with ordinary and with non-temporal stores, outflow ghosts and extrema.
template <class T>
void run(const FluidParams& base, Precision precision, Result& r) {
  FluidParams p = base;
  p.precision = precision;
  FluidSolver s(p);
  s.initialize([](int x, int y, int z) {
    return CellState{1.0 + 0.01 * std::sin(x + 2 * y), 0.03 * std::cos(z + x), 0.01 * std::sin(y), -0.01};
  });
  const int nx = p.shape.nx;
  for (int step = 0; step < 8; ++step) {
    if (step == 4) s.set_row_schedule(RowSchedule::Dynamic);
    const double F = 1e-4 * (step + 1);
    for (const std::array<int, 3> c : {std::array<int, 3>{0, 2, 3}, {nx - 1, 4, 1}, {7, 5, 5}})
      s.add_force(c[0], c[1], c[2], F, -F, 0.5 * F);
    s.step();
    r.add(s.last_step_extrema());
  }
  r.add(state_of<T>(s));
  // Ordinary and non-temporal stores store the same values, ghosts included (an inlet's
  // static ghost on x_max too).
  const BoundaryConditions& bc = s.boundaries();
  Result by_stores[2];
  for (const Stores stores : {Stores::Cached, Stores::Streaming}) {
    BasicPopulationField<T> out(s.layout());
    bc.fill_static_ghosts(out);
    KernelExtrema e;
    stream_collide(state_of<T>(s), out, p.tau, p.body_force, stores, bc.kernel_outflow(), &e, RowSchedule::Static,
                   arithmetic_of(precision));
    Result& k = by_stores[stores == Stores::Streaming];
    k.add(out);
    k.add(e);
    r.add(k.bytes.data(), k.bytes.size());
  }
  EXPECT_TRUE(by_stores[0].bytes == by_stores[1].bytes)
      << precision_name(precision) << " store, grid " << p.shape.nx << " x " << p.shape.ny << " x "
      << p.shape.nz << ": non-temporal and ordinary stores differ";
}

Result run_all() {
  Result r;
  for (const FluidParams& p : cosim::test::every_boundary_grids()) {
    run<double>(p, Precision::Double, r);
    run<float>(p, Precision::Mixed, r);
    run<float>(p, Precision::Single, r);
  }
  return r;
}

// What is compared across levels: every stored value, bit for bit. The levels differ in
// vector width only; their sources are compiled with -ffp-contract=off (no level fuses a
// multiply and an add into an FMA where another rounds twice), so every level rounds alike.
TEST(Kernel, KernelDispatchCoversEveryLevel) {
  const std::vector<std::string> levels = kernel_levels();
  ASSERT_FALSE(levels.empty());
  const std::string before = active_kernel().level;
  ASSERT_TRUE(cpu_runs_level(levels.front())) << "this CPU runs no kernel level of the binary";
  set_kernel_level(levels.front());
  const Result reference = run_all();
  ASSERT_FALSE(reference.bytes.empty());
  int ran = 0;
  for (const std::string& level : levels) {
    if (!cpu_runs_level(level)) {
      std::printf("level %s: not run (this CPU, %s, lacks its instructions)\n", level.c_str(),
                  cpu_model().c_str());
      continue;
    }
    set_kernel_level(level);
    EXPECT_EQ(active_kernel().level, level);
    const Result first = run_all(), second = run_all();
    EXPECT_TRUE(first.bytes == second.bytes) << level << ": two runs differ";
    EXPECT_TRUE(first.bytes == reference.bytes) << level << " differs from " << levels.front();
    if (first.bytes == second.bytes && first.bytes == reference.bytes)
      std::printf("level %s (%s): %zu bytes of state and extrema, same bits in two runs and as %s\n",
                level.c_str(), active_kernel().vectors, first.bytes.size(), levels.front().c_str());
    ++ran;
  }
  EXPECT_GE(ran, 1);
  set_kernel_level(before);
  // A level that is not built in, or that the CPU cannot run, is refused with one line.
  EXPECT_THROW(set_kernel_level("x86-64-v9"), std::invalid_argument);
  for (const std::string& level : levels) {
    if (!cpu_runs_level(level)) {
      EXPECT_THROW(set_kernel_level(level), std::invalid_argument);
    }
  }
  EXPECT_EQ(active_kernel().level, before);
}

}  // namespace
