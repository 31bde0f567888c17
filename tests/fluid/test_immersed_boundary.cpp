// Unit tests of the immersed boundary: the delta kernel (Eqs. 22-23), the adjointness of
// interpolation (Eq. 17) and spreading (Eq. 21), and the reduction of the momentum-exchange
// force (Eqs. 14, 18-19) to g = 2 rho (U_B - u) (DESIGN 2.1).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/ib/delta_kernel.hpp"
#include "fluid/lattice/equilibrium.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"

namespace {

using namespace cosim::fluid;

TEST(ImmersedBoundary, DeltaKernelPartitionOfUnity) {
  // Eq. 23 itself: support |x| < 2, peak 2/(2h) = 1/2, even.
  EXPECT_DOUBLE_EQ(delta_h(0.0), 0.5);
  EXPECT_EQ(delta_h(2.0), 0.0);
  EXPECT_EQ(delta_h(-2.5), 0.0);
  EXPECT_DOUBLE_EQ(delta_h(0.7), delta_h(-0.7));

  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> pos(-30.0, 30.0);
  double worst_moment_error = 0.0;
  for (int trial = 0; trial < 1000; ++trial) {
    const Vec3 X{pos(rng), pos(rng), pos(rng)};
    const DeltaStencil s = delta_stencil(X);
    // Zeroth moment per axis and of the product D (Eq. 22): exactly one.
    for (int a = 0; a < 3; ++a) {
      double sum = 0.0, first = 0.0;
      for (int i = 0; i < kDeltaNodes; ++i) {
        sum += s.w[a][i];
        first += (s.first[a] + i) * s.w[a][i];
      }
      EXPECT_NEAR(sum, 1.0, 1e-14);
      // First moment: the position, up to the known defect of the cosine kernel, which is
      // a function of the fractional offset only and never exceeds 0.0212 dx.
      const double frac = X[a] - std::floor(X[a]);
      const double defect = delta_first_moment_error(frac);
      EXPECT_NEAR(first, X[a] + defect, 1e-12);
      EXPECT_LT(std::abs(defect), 0.0212);
      worst_moment_error = std::max(worst_moment_error, std::abs(first - X[a]));
    }
    double D = 0.0;
    for (int k = 0; k < kDeltaNodes; ++k)
      for (int j = 0; j < kDeltaNodes; ++j)
        for (int i = 0; i < kDeltaNodes; ++i) D += s.weight(i, j, k);
    EXPECT_NEAR(D, 1.0, 1e-14);
  }
  // Markers on a node or half-way between nodes: the first moment is exact.
  for (const double x : {3.0, 3.5, -7.0, -7.5}) {
    const DeltaStencil s = delta_stencil({x, x, x});
    double first = 0.0;
    for (int i = 0; i < kDeltaNodes; ++i) first += (s.first[0] + i) * s.w[0][i];
    EXPECT_NEAR(first, x, 1e-13);
  }
  RecordProperty("worst_first_moment_error_dx", std::to_string(worst_moment_error));
}

TEST(ImmersedBoundary, InterpolateSpreadAreAdjoint) {
  // x and z periodic, y bounded (walls at y = -1/2 and ny - 1/2).
  const GridShape shape{12, 9, 7};
  const ImmersedBoundary ib(shape, {true, false, true});
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);

  const std::size_t n_cells = std::size_t(shape.cells());
  auto cell = [&](int x, int y, int z) {
    return std::size_t(x) + std::size_t(shape.nx) * (std::size_t(y) + std::size_t(shape.ny) * z);
  };
  std::vector<Vec3> v(n_cells);
  for (auto& c : v) c = {uni(rng), uni(rng), uni(rng)};

  // Markers: random in the box, plus some within a kernel width of the walls and some
  // straddling (and beyond) the periodic faces.
  std::vector<Vec3> X;
  std::uniform_real_distribution<double> px(-0.5, shape.nx - 0.5), py(-0.5, shape.ny - 0.5),
      pz(-0.5, shape.nz - 0.5), near(0.0, 1.5);
  for (int l = 0; l < 20; ++l) X.push_back({px(rng), py(rng), pz(rng)});
  for (int l = 0; l < 10; ++l) X.push_back({px(rng), -0.5 + near(rng), pz(rng)});
  for (int l = 0; l < 10; ++l) X.push_back({px(rng), shape.ny - 0.5 - near(rng), pz(rng)});
  for (int l = 0; l < 10; ++l) X.push_back({-0.5 + 0.5 * uni(rng), py(rng), pz(rng)});
  for (int l = 0; l < 10; ++l)
    X.push_back({shape.nx - 0.5 + 0.5 * uni(rng), py(rng), shape.nz - 0.5 + 0.5 * uni(rng)});
  X.push_back({-0.4, -0.4, -0.4});  // corner: wall and two periodic faces
  std::vector<Vec3> J(X.size());
  for (auto& j : J) j = {uni(rng), uni(rng), uni(rng)};

  // <spread J, v> over the lattice ...
  std::vector<Vec3> F(n_cells, Vec3{0, 0, 0});
  for (std::size_t l = 0; l < X.size(); ++l)
    ib.spread(X[l], J[l], [&](int x, int y, int z, const Vec3& f) {
      for (int c = 0; c < 3; ++c) F[cell(x, y, z)][std::size_t(c)] += f[std::size_t(c)];
    });
  double lhs = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < n_cells; ++i)
    for (int c = 0; c < 3; ++c) {
      lhs += F[i][std::size_t(c)] * v[i][std::size_t(c)];
      scale += std::abs(F[i][std::size_t(c)] * v[i][std::size_t(c)]);
    }
  // ... against <J, interpolate v> over the markers.
  double rhs = 0.0;
  const auto field = [&](int x, int y, int z) { return v[cell(x, y, z)]; };
  for (std::size_t l = 0; l < X.size(); ++l) {
    const Vec3 vl = ib.interpolate(X[l], field);
    for (int c = 0; c < 3; ++c) rhs += J[l][std::size_t(c)] * vl[std::size_t(c)];
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", std::abs(lhs - rhs) / scale);
  RecordProperty("adjoint_relative_difference", buf);
  EXPECT_NEAR(lhs, rhs, 1e-14 * scale);

  // Wrapping: a marker shifted by a period interpolates the same values.
  for (std::size_t l = 0; l < 5; ++l) {
    const Vec3 a = ib.interpolate(X[l], field);
    const Vec3 b = ib.interpolate({X[l][0] + shape.nx, X[l][1], X[l][2] - shape.nz}, field);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[std::size_t(c)], b[std::size_t(c)], 1e-14);
  }
  // Away from the walls the whole impulse lands on the lattice (zeroth moment); next to a
  // wall the part of the kernel beyond it is skipped.
  auto spread_total = [&](const Vec3& Xl) {
    double total = 0.0;
    ib.spread(Xl, {1.0, 0.0, 0.0}, [&](int, int, int, const Vec3& f) { total += f[0]; });
    return total;
  };
  EXPECT_NEAR(spread_total({-0.3, 4.2, 6.8}), 1.0, 1e-14);
  EXPECT_LT(spread_total({5.0, -0.2, 3.0}), 0.9);
}

TEST(ImmersedBoundary, SampleAndSpreadReachTheSolver) {
  // The solver-facing paths: sample() interpolates rho and rho u (Eq. 17), spread() hands
  // the whole impulse to the fluid through Guo's forcing (total momentum grows by sum J).
  FluidParams p;
  p.shape = {10, 8, 6};
  p.tau = 0.7;
  FluidSolver solver(p);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  auto state = [](int x, int y, int z) {
    return CellState{1.0 + 0.01 * std::sin(x + 2.0 * y), 0.01 * std::cos(y + z),
                     0.02 * std::sin(0.5 * x), -0.01 * std::cos(x - z)};
  };
  solver.initialize(state);
  const ImmersedBoundary ib(solver);
  const Vec3 X{9.7, 0.2, 3.4};
  const MarkerSample s = ib.sample(solver, X);
  const auto ref = ib.interpolate(X, [&](int x, int y, int z) {
    const CellState c = solver.cell(x, y, z);
    return std::array<double, 4>{c.rho, c.rho * c.ux, c.rho * c.uy, c.rho * c.uz};
  });
  EXPECT_NEAR(s.rho, ref[0], 1e-14);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.rho * s.u[std::size_t(c)], ref[std::size_t(c) + 1], 1e-14);

  auto total_momentum = [&] {
    Vec3 m{0, 0, 0};
    MacroscopicFields f;
    solver.macroscopic(f);
    for (std::size_t i = 0; i < f.rho.size(); ++i) {
      m[0] += f.rho[i] * f.ux[i];
      m[1] += f.rho[i] * f.uy[i];
      m[2] += f.rho[i] * f.uz[i];
    }
    return m;
  };
  const Vec3 before = total_momentum();
  const std::vector<Vec3> Xs{{9.7, 0.2, 3.4}, {2.5, 7.9, 5.5}, {4.0, 4.0, 0.0}};
  std::vector<Vec3> Js;
  Vec3 sumJ{0, 0, 0};
  for (std::size_t l = 0; l < Xs.size(); ++l) {
    Js.push_back({1e-3 * uni(rng), 1e-3 * uni(rng), 1e-3 * uni(rng)});
    for (int c = 0; c < 3; ++c) sumJ[std::size_t(c)] += Js.back()[std::size_t(c)];
  }
  ib.spread(solver, Xs, Js);
  solver.step();
  const Vec3 after = total_momentum();
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(after[std::size_t(c)] - before[std::size_t(c)], sumJ[std::size_t(c)], 1e-13);
}

TEST(ImmersedBoundary, BatchedSampleEqualsMarkerByMarker) {
  // sample() over many markers computes each stencil node's moments once and sums them per
  // marker; it must give marker by marker sample()'s bits: a sheet of markers a cell apart
  // (overlapping stencils) crossing the periodic z faces and touching the y_min wall, and
  // markers far apart (the box of all stencils mostly empty).
  for (const Precision precision : {Precision::Double, Precision::Mixed}) {
    FluidParams p;
    p.shape = {24, 20, 16};
    p.tau = 0.7;
    p.precision = precision;
    p.faces[YMin].kind = FaceKind::Wall;
    p.faces[YMax].kind = FaceKind::FreeSlip;
    FluidSolver solver(p);
    solver.initialize([](int x, int y, int z) {
      return CellState{1.0 + 0.01 * std::sin(x + 2.0 * y), 0.01 * std::cos(y + z), 0.02 * std::sin(0.5 * x),
                       -0.01 * std::cos(x - z)};
    });
    solver.step();
    const ImmersedBoundary ib(solver);
    std::vector<Vec3> sheet, far{{1.3, 2.2, 3.7}, {22.6, 17.1, 12.4}};
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 5; ++i) sheet.push_back({7.3 + 0.1 * j, 0.4 + 0.93 * j, 13.2 + 0.95 * i});
    for (const std::vector<Vec3>& X : {sheet, far}) {
      std::vector<MarkerSample> batch(X.size());
      ib.sample(solver, X, batch);
      for (std::size_t l = 0; l < X.size(); ++l) {
        const MarkerSample one = ib.sample(solver, X[l]);
        EXPECT_EQ(batch[l].rho, one.rho) << "marker " << l;
        EXPECT_EQ(batch[l].weight, ib.kernel_weight(X[l])) << "marker " << l;
        for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(batch[l].u[c], one.u[c]) << "marker " << l << ", u " << c;
      }
    }
  }
}

TEST(ImmersedBoundary, ReducedForceEqualsPopulationSum) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  // Arbitrary (non-equilibrium) populations at a marker.
  for (int trial = 0; trial < 100; ++trial) {
    double f[D3Q19::Q];
    for (int q = 0; q < D3Q19::Q; ++q) f[q] = D3Q19::w[q] * (1.0 + 0.3 * uni(rng));
    double rho = 0, j[3] = {0, 0, 0};
    for (int q = 0; q < D3Q19::Q; ++q) {
      rho += f[q];
      for (int a = 0; a < 3; ++a) j[a] += D3Q19::c(q, a) * f[q];
    }
    const Vec3 u{j[0] / rho, j[1] / rho, j[2] / rho};
    const Vec3 U_B{0.05 * uni(rng), 0.05 * uni(rng), 0.05 * uni(rng)};
    const Vec3 g_sum = momentum_exchange_force_from_populations(f, U_B);
    const Vec3 g_red = momentum_exchange_force(rho, u, U_B);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g_sum[std::size_t(a)], g_red[std::size_t(a)], 1e-15);
  }

  // The same through the solver: populations interpolated at a marker (Eq. 17) against
  // rho and u interpolated by sample(). Populations are set away from equilibrium by hand.
  FluidParams p;
  p.shape = {8, 8, 4};
  p.faces[YMin].kind = FaceKind::Wall;
  p.faces[YMax].kind = FaceKind::Wall;
  FluidSolver solver(p);
  PopulationField& state = solver.mutable_state();
  for (int z = 0; z < p.shape.nz; ++z)
    for (int y = 0; y < p.shape.ny; ++y)
      for (int x = 0; x < p.shape.nx; ++x)
        for (int q = 0; q < D3Q19::Q; ++q) state.at(q, x, y, z) = D3Q19::w[q] * (1.0 + 0.2 * uni(rng));
  solver.refresh_ghosts();
  const ImmersedBoundary ib(solver);
  for (const Vec3& X : {Vec3{3.3, 3.6, 1.2}, Vec3{7.8, 0.1, 3.9}, Vec3{0.0, 6.9, 0.5}}) {
    const Vec3 U_B{0.01, -0.02, 0.03};
    double f[D3Q19::Q];
    ib.interpolate_populations(solver, X, f);
    const MarkerSample s = ib.sample(solver, X);
    const Vec3 g_sum = momentum_exchange_force_from_populations(f, U_B);
    const Vec3 g_red = momentum_exchange_force(s.rho, s.u, U_B);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g_sum[std::size_t(a)], g_red[std::size_t(a)], 1e-14);
  }
}

}  // namespace
