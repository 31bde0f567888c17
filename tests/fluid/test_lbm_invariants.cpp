// Invariants of the D3Q19 BGK model: moments of the equilibrium (Eq. 11), conservation by
// the collision (Eq. 10 with Guo forcing, Eq. 26) and by a whole periodic step.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "fluid/collision/bgk_guo.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/collision/stream_collide.hpp"
#include "tests/support/boundary_grids.hpp"

namespace {

using namespace cosim::fluid;
using L = D3Q19;

TEST(Lattice, WeightsAndVelocitiesAreIsotropic) {
  double w = 0, c2[3][3] = {};
  for (int q = 0; q < L::Q; ++q) {
    w += L::w[q];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) c2[a][b] += L::w[q] * L::c(q, a) * L::c(q, b);
    EXPECT_EQ(L::cx[L::opp[q]], -L::cx[q]);
    EXPECT_EQ(L::cy[L::opp[q]], -L::cy[q]);
    EXPECT_EQ(L::cz[L::opp[q]], -L::cz[q]);
  }
  EXPECT_NEAR(w, 1.0, 1e-15);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(c2[a][b], a == b ? L::cs2 : 0.0, 1e-15);
}

TEST(Lattice, EquilibriumReproducesMoments) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.1, 0.1), R(0.8, 1.2);
  for (int trial = 0; trial < 50; ++trial) {
    const double rho = R(rng), u[3] = {U(rng), U(rng), U(rng)};
    double m0 = 0, m1[3] = {}, m2[3][3] = {};
    for (int q = 0; q < L::Q; ++q) {
      const double f = equilibrium(q, rho, u[0], u[1], u[2]);
      m0 += f;
      for (int a = 0; a < 3; ++a) {
        m1[a] += L::c(q, a) * f;
        for (int b = 0; b < 3; ++b) m2[a][b] += L::c(q, a) * L::c(q, b) * f;
      }
    }
    EXPECT_NEAR(m0, rho, 1e-14);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(m1[a], rho * u[a], 1e-15);
      // Momentum flux: rho c_s^2 delta_ab + rho u_a u_b.
      for (int b = 0; b < 3; ++b)
        EXPECT_NEAR(m2[a][b], rho * (a == b ? L::cs2 : 0.0) + rho * u[a] * u[b], 1e-15);
    }
  }
}

TEST(Lattice, BgkConservesMassAndMomentum) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> P(0.0, 0.1), Fd(-1e-3, 1e-3);
  for (const double tau : {0.51, 0.77, 1.0, 2.0}) {
    const BgkGuo bgk(tau);
    double f[L::Q];
    for (double& v : f) v = P(rng);
    const Moments before = moments(f);
    // Without force: mass and momentum unchanged to round-off.
    bgk.collide(f, 0, 0, 0);
    const Moments after = moments(f);
    EXPECT_NEAR(after.rho, before.rho, 1e-15);
    EXPECT_NEAR(after.jx, before.jx, 1e-15);
    EXPECT_NEAR(after.jy, before.jy, 1e-15);
    EXPECT_NEAR(after.jz, before.jz, 1e-15);
    // With Guo forcing the momentum grows by exactly F (one step, dt = 1).
    const double F[3] = {Fd(rng), Fd(rng), Fd(rng)};
    bgk.collide(f, F[0], F[1], F[2]);
    const Moments forced = moments(f);
    EXPECT_NEAR(forced.rho, after.rho, 1e-15);
    EXPECT_NEAR(forced.jx, after.jx + F[0], 1e-15);
    EXPECT_NEAR(forced.jy, after.jy + F[1], 1e-15);
    EXPECT_NEAR(forced.jz, after.jz + F[2], 1e-15);
  }
}

// A whole step (kernel, ghost fill) of a periodic box conserves mass and momentum.
TEST(Lattice, PeriodicStepConservesMassAndMomentum) {
  FluidParams p;
  p.shape = {13, 9, 11};
  p.tau = 0.6;
  FluidSolver s(p);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-0.05, 0.05), R(0.95, 1.05);
  s.initialize([&](int, int, int) { return CellState{R(rng), U(rng), U(rng), U(rng)}; });
  auto totals = [&] {
    MacroscopicFields m;
    s.macroscopic(m);
    double t[4] = {};
    for (std::size_t i = 0; i < m.rho.size(); ++i) {
      t[0] += m.rho[i];
      t[1] += m.rho[i] * m.ux[i];
      t[2] += m.rho[i] * m.uy[i];
      t[3] += m.rho[i] * m.uz[i];
    }
    return std::array<double, 4>{t[0], t[1], t[2], t[3]};
  };
  const auto before = totals();
  for (int n = 0; n < 20; ++n) s.step();
  const auto after = totals();
  EXPECT_NEAR(after[0], before[0], 1e-11);
  for (int a = 1; a < 4; ++a) EXPECT_NEAR(after[a], before[a], 1e-12);
}

// The vectorised bulk kernel and the one-cell reference collision agree.
TEST(Lattice, KernelMatchesReferenceCollision) {
  FluidParams p;
  p.shape = {17, 6, 5};
  p.tau = 0.7;
  p.body_force = {1e-5, -2e-5, 3e-6};
  FluidSolver s(p);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-0.05, 0.05), R(0.95, 1.05);
  s.initialize([&](int, int, int) { return CellState{R(rng), U(rng), U(rng), U(rng)}; });
  // Expected post-collision values from pulled populations, one cell at a time.
  const BgkGuo bgk(p.tau);
  std::vector<std::array<double, L::Q>> expect;
  for (int z = 0; z < 5; ++z)
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 17; ++x) {
        std::array<double, L::Q> f;
        s.populations_at(x, y, z, f.data());
        bgk.collide(f.data(), p.body_force[0], p.body_force[1], p.body_force[2]);
        expect.push_back(f);
      }
  s.step();
  std::size_t k = 0;
  for (int z = 0; z < 5; ++z)
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 17; ++x, ++k)
        for (int q = 0; q < L::Q; ++q) EXPECT_NEAR(s.state().at(q, x, y, z), expect[k][q], 1e-15);
}

// FluidSolver::step() splits the boundaries (the kernel writes the x outflows, the inlets
// are filled once, the rest after the kernel); the result must be the bits of the plain
// sequence: kernel, a collision again of the cells with an IB force, every ghost filled.
// Boundary cells next to the outflow receive a force too, so that their ghosts are rewritten.
// A step in two parts (FluidSolver::begin_step, then the forces, then finish_step), as the
// coupled fluid runs it while the solid computes the forces, gives step()'s state bit for bit,
// with either row schedule and either store; out of order it throws.
TEST(Lattice, SplitStepEqualsStep) {
  for (const Precision precision : {Precision::Double, Precision::Mixed}) {
    FluidParams p;
    p.shape = {21, 10, 7};
    p.tau = 0.65;
    p.body_force = {2e-6, 0.0, -1e-6};
    p.faces[XMin].kind = FaceKind::Inlet;
    p.faces[XMin].inlet_speed = 0.05;
    p.faces[XMax].kind = FaceKind::Outflow;
    p.faces[YMin].kind = FaceKind::Wall;
    p.faces[YMax].kind = FaceKind::FreeSlip;
    p.precision = precision;
    // Forces added between begin_step() and finish_step(): the two-grid propagation's split
    // step (in place the forced cells must be known before begin_step():
    // InPlacePropagationRefusesWhatItDoesNotKeep).
    p.propagation = Propagation::TwoGrid;
    FluidSolver whole(p), split(p);
    const auto init = [](int x, int y, int z) {
      return CellState{1.0 + 0.01 * std::sin(x + y), 0.03 * std::cos(z), 0.01 * std::sin(y), -0.01};
    };
    whole.initialize(init);
    split.initialize(init);
    split.set_row_schedule(RowSchedule::Dynamic);
    const std::array<std::array<int, 3>, 3> cells{{{0, 2, 3}, {20, 4, 1}, {7, 5, 5}}};
    for (int step = 0; step < 6; ++step) {
      const double F = 1e-4 * (step + 1);
      for (const auto& c : cells) whole.add_force(c[0], c[1], c[2], F, -F, 0.5 * F);
      whole.step();
      split.begin_step();
      EXPECT_TRUE(split.mid_step());
      EXPECT_EQ(split.step_count(), step);
      for (const auto& c : cells) split.add_force(c[0], c[1], c[2], F, -F, 0.5 * F);
      split.finish_step();
    }
    int mismatches = 0;
    for (int z = 0; z < p.shape.nz; ++z)
      for (int y = 0; y < p.shape.ny; ++y)
        for (int x = 0; x < p.shape.nx; ++x) {
          double a[L::Q], b[L::Q];
          whole.populations_at(x, y, z, a);
          split.populations_at(x, y, z, b);
          for (int q = 0; q < L::Q; ++q) mismatches += a[q] != b[q];
        }
    EXPECT_EQ(mismatches, 0) << precision_name(precision);
    EXPECT_THROW(split.finish_step(), std::logic_error);
    split.begin_step();
    EXPECT_THROW(split.begin_step(), std::logic_error);
  }
}

// The solver's step (the kernel writes the x-outflow ghosts, inlets stay from
// fill_static_ghosts, fill_step_ghosts does the rest) against the plain step: kernel without
// outflow, forced cells collided again, every ghost refilled by fill_ghosts. For the store
// of precision T: the single store's kernel writes each outflow ghost from the boundary
// cell's populations as stored (rounded to float), the values fill_ghosts reads back, so the
// two agree bit for bit in either store.
template <class T>
void expect_fused_step_matches_ghost_fill_step(Precision precision) {
  for (FluidParams p : cosim::test::every_boundary_grids()) {
    p.precision = precision;
    FluidSolver s(p);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> U(-0.04, 0.04), R(0.97, 1.03);
    s.initialize([&](int, int, int) { return CellState{R(rng), U(rng), U(rng), U(rng)}; });

    const GridLayout& lay = s.layout();
    const std::size_t n = std::size_t(L::Q) * lay.stride();
    BasicPopulationField<T> a(lay), b(lay);
    if constexpr (std::is_same_v<T, double>)
      std::copy(s.state().q(0), s.state().q(0) + n, a.q(0));
    else
      std::copy(s.state_single().q(0), s.state_single().q(0) + n, a.q(0));
    const BoundaryConditions& bc = s.boundaries();
    const BgkGuo bgk(p.tau);
    const int nx = p.shape.nx;
    for (int step = 0; step < 12; ++step) {
      // Forces on cells of both x boundary layers and one inside.
      const std::array<std::array<int, 3>, 3> cells{{{0, 2, 3}, {nx - 1, 4, 1}, {7, 5, 5}}};
      const double F[3] = {1e-4 * (step + 1), -2e-4, 5e-5};
      for (const auto& x : cells) s.add_force(x[0], x[1], x[2], F[0], F[1], F[2]);
      s.step();

      stream_collide(a, b, p.tau, p.body_force);
      for (const auto& x : cells) {
        double f[L::Q];
        for (int q = 0; q < L::Q; ++q)
          f[q] = a.at(q, x[0] - L::cx[q], x[1] - L::cy[q], x[2] - L::cz[q]);
        bgk.collide(f, p.body_force[0] + F[0], p.body_force[1] + F[1], p.body_force[2] + F[2]);
        for (int q = 0; q < L::Q; ++q) b.at(q, x[0], x[1], x[2]) = static_cast<T>(f[q]);
      }
      bc.fill_ghosts(b);
      std::swap(a, b);
    }
    int mismatches = 0;
    for (int z = 0; z < p.shape.nz; ++z)
      for (int y = 0; y < p.shape.ny; ++y)
        for (int x = 0; x < nx; ++x) {
          double f[L::Q];
          s.populations_at(x, y, z, f);
          for (int q = 0; q < L::Q; ++q) {
            const double ref = a.at(q, x - L::cx[q], y - L::cy[q], z - L::cz[q]);
            if (f[q] != ref && ++mismatches <= 5)
              ADD_FAILURE() << precision_name(precision) << " store, grid " << nx << " x "
                            << p.shape.ny << " x " << p.shape.nz << ", cell (" << x << ", " << y
                            << ", " << z << ") q " << q << ": " << f[q] << " != " << ref;
          }
        }
    EXPECT_EQ(mismatches, 0) << precision_name(precision);
  }
}

TEST(Lattice, FusedStepMatchesGhostFillStep) {
  expect_fused_step_matches_ghost_fill_step<double>(Precision::Double);
}

TEST(Lattice, FusedStepMatchesGhostFillStepSingleStore) {
  expect_fused_step_matches_ghost_fill_step<float>(Precision::Mixed);
}

// The in-place propagation (FluidParams::propagation, the AA pattern: the state alternates
// between the Canonical and the Swapped layout) against the two-grid step, bit for bit:
// every interior population and every ghost a pull reads, the pulled populations of every
// cell after each step (odd and even step counts), the kernel's extrema; on every boundary
// kind, both stores, forced cells (before begin_step and again between begin_step and
// finish_step, boundary layers included), both row schedules, the state read whole at a
// Swapped step (turned Canonical) and stepped on, a copy_state / restore_state round trip;
// on every kernel level this CPU runs. The grids: every_boundary_grids(), one with
// reflecting x faces, one with periodic x faces and an inlet on z, and two with outflows on
// y and z and free slip next to walls (edge ghosts of GhostFillDoesNotReadStaleValues).
template <class T>
int in_place_mismatches(const FluidParams& base, Precision precision) {
  FluidParams p = base;
  p.precision = precision;
  p.propagation = Propagation::TwoGrid;
  FluidSolver two(p);
  p.propagation = Propagation::InPlace;
  FluidSolver one(p);
  const auto init = [](std::mt19937& rng) {
    return [&rng](int, int, int) {
      std::uniform_real_distribution<double> U(-0.04, 0.04), R(0.97, 1.03);
      const double rho = R(rng), ux = U(rng), uy = U(rng), uz = U(rng);
      return CellState{rho, ux, uy, uz};
    };
  };
  std::mt19937 r1(5), r2(5);
  two.initialize(init(r1));
  one.initialize(init(r2));
  const GridShape& g = p.shape;
  const std::string where = std::string(precision_name(precision)) + " store, level " + active_kernel().level +
                            ", grid " + std::to_string(g.nx) + " x " + std::to_string(g.ny) + " x " +
                            std::to_string(g.nz);
  int bad = 0;
  // `what` names the value (called only for a mismatch).
  const auto same = [&](double a, double b, const auto& what) {
    if (std::memcmp(&a, &b, sizeof a) == 0) return;
    if (++bad <= 5) ADD_FAILURE() << where << ": " << what() << ": " << a << " != " << b;
  };
  // Every interior value of the two Canonical fields and every ghost pulled into a cell.
  const auto compare_states = [&](int step) {
    const BasicPopulationField<T>* a;
    const BasicPopulationField<T>* b;
    if constexpr (std::is_same_v<T, double>)
      a = &two.state(), b = &one.state();
    else
      a = &two.state_single(), b = &one.state_single();
    EXPECT_EQ(one.population_layout(), PopulationLayout::Canonical);
    for (int q = 0; q < L::Q; ++q)
      for (int z = -1; z <= g.nz; ++z)
        for (int y = -1; y <= g.ny; ++y)
          for (int x = -1; x <= g.nx; ++x) {
            const bool in = x >= 0 && x < g.nx && y >= 0 && y < g.ny && z >= 0 && z < g.nz;
            const int px = x + L::cx[q], py = y + L::cy[q], pz = z + L::cz[q];
            const bool pulled = px >= 0 && px < g.nx && py >= 0 && py < g.ny && pz >= 0 && pz < g.nz;
            if (in || pulled)
              same(a->at(q, x, y, z), b->at(q, x, y, z), [&] {
                return "state after step " + std::to_string(step) + ", q " + std::to_string(q) + " at (" +
                       std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + ")";
              });
          }
  };
  const int nx = g.nx;
  const std::array<std::array<int, 3>, 4> cells{{{0, 2, 3}, {nx - 1, 4, 1}, {7, 5, 5}, {3, 0, 0}}};
  for (int step = 1; step <= 9; ++step) {
    for (FluidSolver* s : {&two, &one}) {
      s->set_row_schedule(step % 3 == 2 ? RowSchedule::Dynamic : RowSchedule::Static);
      const double F = 1e-4 * step;
      if (step != 4)
        for (const auto& c : cells) s->add_force(c[0], c[1], c[2], F, -F, 0.5 * F);
      s->begin_step();
      if (step % 2 == 1)  // more force on cells forced before begin_step
        for (const auto& c : cells) s->add_force(c[0], c[1], c[2], -0.3 * F, 0.0, 2.0 * F);
      s->finish_step();
    }
    // Canonical -> Swapped -> Canonical ..., except where a whole read turned it Canonical
    // (after steps 5, 7 and 8).
    const bool canonical = step == 2 || step == 4 || step == 7;
    EXPECT_EQ(one.population_layout(), canonical ? PopulationLayout::Canonical : PopulationLayout::Swapped)
        << where << ", step " << step;
    const KernelExtrema& e1 = two.last_step_extrema();
    const KernelExtrema& e2 = one.last_step_extrema();
    same(e1.rho_min, e2.rho_min, [] { return "rho_min"; });
    same(e1.rho_max, e2.rho_max, [] { return "rho_max"; });
    same(e1.u2_max, e2.u2_max, [] { return "u2_max"; });
    EXPECT_EQ(e1.finite, e2.finite);
    EXPECT_EQ(two.step_count(), one.step_count());
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < nx; ++x) {
          double a[L::Q], b[L::Q];
          two.populations_at(x, y, z, a);
          one.populations_at(x, y, z, b);
          for (int q = 0; q < L::Q; ++q)
            same(a[q], b[q], [&] {
              return "pulled population " + std::to_string(q) + " of (" + std::to_string(x) + ", " +
                     std::to_string(y) + ", " + std::to_string(z) + ") after step " + std::to_string(step);
            });
        }
    // Read whole at a Swapped step (5: turned Canonical, so step 6 starts Canonical) and at a
    // Canonical one (8); a kept state restored at step 7 (Swapped then: kept Canonical).
    if (step == 5 || step == 8) compare_states(step);
    if (step == 7) {
      BasicPopulationField<T> k1, k2;
      two.copy_state(k1);
      one.copy_state(k2);
      two.step();
      one.step();
      two.restore_state(k1, 7);
      one.restore_state(k2, 7);
    }
  }
  compare_states(9);
  return bad;
}

TEST(Lattice, InPlaceStepMatchesTwoGridStep) {
  const std::string before = active_kernel().level;
  int levels = 0;
  for (const std::string& level : kernel_levels()) {
    if (!cpu_runs_level(level)) continue;
    set_kernel_level(level);
    std::vector<FluidParams> grids = cosim::test::every_boundary_grids();
    {
      // Reflecting x faces: the in-place kernel leaves them to the ghost fill (InPlaceXFaces).
      FluidParams p = grids.back();
      p.shape = {13, 7, 9};
      p.faces[XMin].kind = FaceKind::Wall;
      p.faces[XMin].wall_velocity = {0.0, 0.01, 0.0};
      p.faces[XMax].kind = FaceKind::FreeSlip;
      p.faces[ZMin].kind = p.faces[ZMax].kind = FaceKind::Inlet;
      p.faces[ZMin].inlet_speed = p.faces[ZMax].inlet_speed = 0.03;
      grids.push_back(p);
      // Periodic x (the kernel's) and y, an inlet and free slip on z.
      p.faces[XMin].kind = p.faces[XMax].kind = FaceKind::Periodic;
      p.faces[YMin].kind = p.faces[YMax].kind = FaceKind::Periodic;
      p.faces[ZMax] = FaceSpec{};
      p.faces[ZMax].kind = FaceKind::FreeSlip;
      grids.push_back(p);
      // Outflows on y and z next to periodic x (their edge ghosts: the image's column), a
      // moving wall on y next to free slip and an outflow on z.
      p.faces[YMin] = p.faces[YMax] = p.faces[ZMin] = p.faces[ZMax] = FaceSpec{};
      p.faces[YMin].kind = FaceKind::Outflow;
      p.faces[YMin].outflow_density = 1.01;
      p.faces[YMax].kind = FaceKind::Wall;
      p.faces[YMax].wall_velocity = {0.01, 0.0, -0.01};
      p.faces[ZMin].kind = FaceKind::FreeSlip;
      p.faces[ZMax].kind = FaceKind::Outflow;
      grids.push_back(p);
      // The kernel's x inlet and outflow; free slip and a wall on y, a wall and an outflow
      // on z (walls on both sides of a free slip face, an outflow next to both).
      p.faces[XMin].kind = FaceKind::Inlet;
      p.faces[XMin].inlet_speed = 0.03;
      p.faces[XMax].kind = FaceKind::Outflow;
      p.faces[YMin] = p.faces[YMax] = p.faces[ZMin] = p.faces[ZMax] = FaceSpec{};
      p.faces[YMin].kind = FaceKind::FreeSlip;
      p.faces[YMax].kind = FaceKind::Wall;
      p.faces[ZMin].kind = FaceKind::Wall;
      p.faces[ZMin].wall_velocity = {0.02, 0.0, 0.0};
      p.faces[ZMax].kind = FaceKind::Outflow;
      p.faces[ZMax].outflow_density = 0.995;
      grids.push_back(p);
    }
    for (const FluidParams& p : grids) {
      EXPECT_EQ(in_place_mismatches<double>(p, Precision::Double), 0) << level;
      EXPECT_EQ(in_place_mismatches<float>(p, Precision::Mixed), 0) << level;
    }
    ++levels;
  }
  EXPECT_GE(levels, 1);
  set_kernel_level(before);
}

// The ghost fill reads only the interior (and the constants of the faces): two solvers with
// the same parameters and state whose fields differ only in their ghosts (NaN in one, a
// finite garbage value in the other, written before the fill) pull the same, finite
// populations into every cell, after the fill and after two steps (the two-grid step fills
// the other grid, poisoned, at the second), in either propagation
// and store. The grids: every combination of the face kinds per axis (each kind on both
// faces, a wall with free slip, an outflow with an inlet), so among them an outflow on a y
// or z face next to the faces of every kind of an axis before it (its edge ghosts) and free
// slip next to a wall in either fill order (their shared edges).
std::vector<FluidParams> stale_ghost_grids() {
  // Per axis, the kinds of its min and max faces: each kind on both, and mixed pairs.
  using K = FaceKind;
  const std::pair<K, K> pairs[] = {{K::Periodic, K::Periodic}, {K::Inlet, K::Inlet},     {K::Outflow, K::Outflow},
                                   {K::Wall, K::Wall},         {K::FreeSlip, K::FreeSlip}, {K::Wall, K::FreeSlip},
                                   {K::Outflow, K::Inlet}};
  std::vector<FluidParams> out;
  for (const auto& px : pairs)
    for (const auto& py : pairs)
      for (const auto& pz : pairs) {
        FluidParams p;
        p.shape = {6, 5, 4};
        p.tau = 0.65;
        p.body_force = {2e-6, -1e-6, 1e-6};
        const std::pair<K, K>* axes[3] = {&px, &py, &pz};
        for (int f = 0; f < kFaces; ++f) {
          const int a = face_axis(f);
          FaceSpec& s = p.faces[f];
          s.kind = face_side(f) == 0 ? axes[a]->first : axes[a]->second;
          s.inlet_speed = 0.03;
          s.outflow_density = face_side(f) == 0 ? 1.01 : 0.99;
          s.wall_velocity[(a + 1) % 3] = 0.01 * (f + 1);
        }
        out.push_back(p);
      }
  return out;
}

/// "double store, in-place, faces x_min=periodic ...": which case a failure is in.
std::string case_name(const FluidParams& p, Precision precision, Propagation propagation) {
  std::string faces;
  for (int f = 0; f < kFaces; ++f) faces += std::string(" ") + face_name(f) + "=" + kind_name(p.faces[f].kind);
  return std::string(precision_name(precision)) + " store, " + propagation_name(propagation) + ", faces" + faces;
}

template <class T>
BasicPopulationField<T>& mutable_field(FluidSolver& s) {
  if constexpr (std::is_same_v<T, double>)
    return s.mutable_state();
  else
    return s.mutable_state_single();
}

template <class T>
int stale_ghost_mismatches(const FluidParams& base, Precision precision, Propagation propagation) {
  FluidParams p = base;
  p.precision = precision;
  p.propagation = propagation;
  FluidSolver a(p), b(p);
  const auto init = [](int x, int y, int z) {
    return CellState{1.0 + 0.01 * std::sin(x + 2 * y + 3 * z), 0.02 * std::cos(y + z), 0.015 * std::sin(x + z),
                     -0.01 * std::cos(x + y)};
  };
  a.initialize(init);
  b.initialize(init);
  const GridShape& g = p.shape;
  const auto poison = [&](FluidSolver& s, T value) {
    BasicPopulationField<T>& f = mutable_field<T>(s);
    for (int q = 0; q < L::Q; ++q)
      for (int z = -1; z <= g.nz; ++z)
        for (int y = -1; y <= g.ny; ++y)
          for (int x = -1; x <= g.nx; ++x)
            if (x < 0 || x >= g.nx || y < 0 || y >= g.ny || z < 0 || z >= g.nz) f.at(q, x, y, z) = value;
    s.refresh_ghosts();
  };
  poison(a, std::numeric_limits<T>::quiet_NaN());
  poison(b, T(0.375));
  const std::string where = case_name(p, precision, propagation);
  int bad = 0;
  for (int step = 0; step <= 2; ++step) {
    if (step > 0) {
      a.step();
      b.step();
    }
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) {
          double fa[L::Q], fb[L::Q];
          a.populations_at(x, y, z, fa);
          b.populations_at(x, y, z, fb);
          for (int q = 0; q < L::Q; ++q)
            if ((std::memcmp(&fa[q], &fb[q], sizeof(double)) != 0 || !std::isfinite(fa[q])) && ++bad <= 3)
              ADD_FAILURE() << where << ": pulled population " << q << " of (" << x << ", " << y << ", " << z
                            << ") after step " << step << ": " << fa[q] << " (NaN ghosts) vs " << fb[q];
        }
  }
  return bad;
}

TEST(Lattice, GhostFillDoesNotReadStaleValues) {
  for (const FluidParams& p : stale_ghost_grids())
    for (const Propagation prop : {Propagation::TwoGrid, Propagation::InPlace}) {
      EXPECT_EQ(stale_ghost_mismatches<double>(p, Precision::Double, prop), 0);
      EXPECT_EQ(stale_ghost_mismatches<float>(p, Precision::Mixed, prop), 0);
    }
}

// A grid one cell thick and periodic along z is its own z image (GridLayout::wraps_z: no z
// ghost fill, the pulls across z read the plane itself). It must step as the same flow on a
// thicker periodic grid, which fills its z ghosts: a state and forces that do not depend on z
// stay so, and every plane of the thick grid holds the thin grid's bits. Every x / y face
// pair of stale_ghost_grids, both stores and propagations, forced cells, an odd number of
// steps (the in-place state ends Swapped), every kernel level this CPU runs.
template <class T>
int thin_grid_mismatches(FluidParams p, Precision precision, Propagation propagation) {
  p.precision = precision;
  p.propagation = propagation;
  p.faces[ZMin] = p.faces[ZMax] = FaceSpec{};  // periodic
  FluidParams thick = p;
  p.shape.nz = 1;
  thick.shape.nz = 3;
  FluidSolver a(p), b(thick);
  EXPECT_TRUE(a.layout().wraps_z());
  EXPECT_FALSE(b.layout().wraps_z());
  const auto init = [](int x, int y, int) {
    return CellState{1.0 + 0.01 * std::sin(x + 2 * y), 0.02 * std::cos(y), 0.015 * std::sin(x), -0.01 * std::cos(x + y)};
  };
  a.initialize(init);
  b.initialize(init);
  const std::string where = case_name(p, precision, propagation);
  int bad = 0;
  for (int step = 1; step <= 3; ++step) {
    for (const auto& [x, y] : {std::pair{0, 0}, std::pair{2, 3}, std::pair{p.shape.nx - 1, p.shape.ny - 1}}) {
      const double fx = 1e-4 * step, fy = -2e-4, fz = 3e-4;
      a.add_force(x, y, 0, fx, fy, fz);
      for (int z = 0; z < thick.shape.nz; ++z) b.add_force(x, y, z, fx, fy, fz);
    }
    a.step();
    b.step();
    for (int z = 0; z < thick.shape.nz; ++z)
      for (int y = 0; y < p.shape.ny; ++y)
        for (int x = 0; x < p.shape.nx; ++x) {
          double fa[L::Q], fb[L::Q];
          a.populations_at(x, y, 0, fa);
          b.populations_at(x, y, z, fb);
          for (int q = 0; q < L::Q; ++q)
            if ((std::memcmp(&fa[q], &fb[q], sizeof(double)) != 0 || !std::isfinite(fa[q])) && ++bad <= 3)
              ADD_FAILURE() << where << ": population " << q << " of (" << x << ", " << y << ") after step " << step
                            << ": " << fa[q] << " (one cell thick) vs " << fb[q] << " (plane " << z << " of 3)";
        }
  }
  return bad;
}

TEST(Lattice, ThinPeriodicGridMatchesThickerOne) {
  const std::string before = active_kernel().level;
  std::vector<FluidParams> grids;
  for (const FluidParams& p : stale_ghost_grids())  // one per x / y pair
    if (p.faces[ZMin].kind == FaceKind::Periodic) grids.push_back(p);
  ASSERT_EQ(grids.size(), 49u);
  int levels = 0;
  for (const std::string& level : kernel_levels()) {
    if (!cpu_runs_level(level)) continue;
    set_kernel_level(level);
    for (const FluidParams& p : grids)
      for (const Propagation prop : {Propagation::TwoGrid, Propagation::InPlace}) {
        EXPECT_EQ(thin_grid_mismatches<double>(p, Precision::Double, prop), 0) << level;
        EXPECT_EQ(thin_grid_mismatches<float>(p, Precision::Mixed, prop), 0) << level;
      }
    ++levels;
  }
  EXPECT_GE(levels, 1);
  set_kernel_level(before);
}

// An outflow's edge ghosts next to a halo axis would extrapolate from a neighbour block's
// cell, which the exchange does not send whole: refused (the slabs have their halo on z).
TEST(Lattice, OutflowAfterAHaloAxisIsRefused) {
  const GridLayout lay = layout_of({6, 5, 4}, Precision::Double);
  std::array<FaceSpec, kFaces> faces{};
  faces[YMin].kind = faces[YMax].kind = FaceKind::Outflow;
  EXPECT_THROW(BoundaryConditions(lay, faces, {true, true, false, false, false, false}), std::invalid_argument);
  EXPECT_NO_THROW(BoundaryConditions(lay, faces, {false, false, false, false, true, true}));
  faces[YMin].kind = faces[YMax].kind = FaceKind::Wall;
  faces[ZMax].kind = FaceKind::Outflow;
  faces[ZMin].kind = FaceKind::Inlet;
  EXPECT_THROW(BoundaryConditions(lay, faces, {false, false, false, true, false, false}), std::invalid_argument);
  faces[ZMin] = faces[ZMax] = FaceSpec{};
  faces[XMin].kind = FaceKind::Inlet;
  faces[XMax].kind = FaceKind::Outflow;
  EXPECT_NO_THROW(BoundaryConditions(lay, faces, {false, false, false, false, true, false}));
}

// What the in-place propagation does not keep is refused with a logic_error, not read wrong.
TEST(Lattice, InPlacePropagationRefusesWhatItDoesNotKeep) {
  FluidParams p = cosim::test::every_boundary_grids().front();
  p.propagation = Propagation::InPlace;
  FluidSolver s(p);
  s.add_force(1, 1, 1, 1e-4, 0.0, 0.0);
  s.begin_step();
  s.add_force(1, 1, 1, 1e-4, 0.0, 0.0);                                  // forced before: kept
  EXPECT_THROW(s.add_force(2, 2, 2, 1e-4, 0.0, 0.0), std::logic_error);  // not kept
  EXPECT_THROW(s.state(), std::logic_error);
  double f[L::Q];
  EXPECT_THROW(s.populations_at(0, 0, 0, f), std::logic_error);
  s.finish_step();
  EXPECT_THROW(s.previous_state(), std::logic_error);
  EXPECT_FALSE(s.has_previous_state());
  EXPECT_EQ(s.population_layout(), PopulationLayout::Swapped);
  EXPECT_NO_THROW(s.state());
  EXPECT_EQ(s.population_layout(), PopulationLayout::Canonical);
}

}  // namespace
