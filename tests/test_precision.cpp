// The single-precision population store (FluidParams::precision, scene key run.precision):
// a run that stores its populations as float stays within the round-off bound derived below
// of the same run in double, and as close to the analytic solution.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <numbers>
#include <random>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/config/scene_config.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/collision/stream_collide.hpp"

namespace {

using namespace cosim::fluid;

/// Unit round-off of float (round to nearest): |fl(v) - v| <= 2^-24 |v|.
constexpr double kFloatRoundoff = 0x1p-24;

/// The tolerance, from float round-off alone (no fitted constant):
///  - every step stores each population once, so the single run's f_q is the double run's
///    value of that step up to |delta f_q| <= 2^-24 f_q, plus what earlier steps carried in;
///  - a velocity u_x = (sum_a c_ax f_a + F_x / 2) / rho (Eqs. 7-8 with Guo's shift) then
///    moves by at most 2^-24 (sum over c_x != 0 of f_q + |u_x| sum_a f_a) / rho per step.
///    Near equilibrium f_q = E_q rho (1 + 3 c.u + O(u^2)) (Eq. 11) and the weights of the
///    directions with c_x != 0 add up to 2/18 + 8/36 = 1/3 (Eq. 12), the odd terms cancel in
///    the pairs (q, opp q): the sum is rho (1/3 + O(u^2)); with |u| <= u_max the step's bound
///    is 2^-24 (1/3 + 2 u_max), the 2 u_max covering |u_x| and the O(u^2) terms (u_max < 0.1);
///  - the errors of n steps add at most linearly: streaming and bounce-back only permute
///    populations, and the BGK collision (Eq. 10) keeps rho and j and multiplies the rest of a
///    perturbation by 1 - 1/tau, |1 - 1/tau| < 1 for tau > 1/2: the update does not amplify
///    it. The initial state (Eq. 11, rounded once) is one more rounding.
/// Rounding to nearest errs both ways, so the errors rather grow as sqrt(n); the linear sum
/// is the worst case.
double roundoff_bound(int steps, double u_max) {
  return (steps + 1) * kFloatRoundoff * (1.0 / 3.0 + 2.0 * u_max);
}

/// The "single" mode's tolerances against double (FloatArithmeticWithinTolerance, where they
/// were measured): velocity, lattice units; relative L2 error added to the double run's.
constexpr double kSingleTolerancePoiseuille = 1e-6;  // measured 4.377e-07
constexpr double kSingleToleranceL2 = 4e-6;          // measured 4.840e-04 - 4.824e-04 = 1.6e-06
constexpr double kSingleToleranceChannel = 2e-6;     // measured 9.690e-07

/// Start-up of plane Poiseuille flow (as launch/error_study.py's resolution row): walls at
/// y = -1/2 and N - 1/2, periodic x and z, body force G = 8 nu U / N^2 from t = 0, compared at
/// t nu / H^2 = 0.1 with u(y, t) = G y'(H - y') / (2 nu) - sum over odd n of
/// 4 G H^2 / (nu n^3 pi^3) sin(n pi y'/H) exp(-nu n^2 pi^2 t / H^2), y' = y + 1/2, H = N.
struct Poiseuille {
  int cells = 32;
  double tau = 0.8, u_max = 0.05;
  double nu() const { return (tau - 0.5) / 3.0; }
  double force() const { return 8.0 * nu() * u_max / (cells * cells); }
  int steps() const { return int(std::lround(0.1 * cells * cells / nu())); }
  double exact(int y) const {
    const double h = cells, yp = y + 0.5, g = force(), t = steps();
    double u = g * yp * (h - yp) / (2.0 * nu());
    for (int n = 1; n < 4001; n += 2) {
      const double amp = 4.0 * g * h * h / (nu() * n * n * n * std::pow(std::numbers::pi, 3)) *
                         std::exp(-nu() * n * n * std::numbers::pi * std::numbers::pi * t / (h * h));
      if (amp < 1e-18 * g * h * h / nu()) break;
      u -= amp * std::sin(n * std::numbers::pi * yp / h);
    }
    return u;
  }
  /// The relative L2 error of u_x against exact() over the 8 x cells x 8 grid.
  double l2_error(const FluidSolver& s) const {
    double num = 0.0, den = 0.0;
    for (int z = 0; z < 8; ++z)
      for (int y = 0; y < cells; ++y)
        for (int x = 0; x < 8; ++x) {
          const double e = exact(y);
          num += std::pow(s.cell(x, y, z).ux - e, 2);
          den += e * e;
        }
    return std::sqrt(num / den);
  }
  /// The root mean square of exact() over the grid.
  double rms_exact() const {
    double den = 0.0;
    for (int y = 0; y < cells; ++y) den += exact(y) * exact(y);
    return std::sqrt(den / cells);
  }
  FluidParams params(Precision p) const {
    FluidParams fp;
    fp.shape = {8, cells, 8};
    fp.tau = tau;
    fp.faces[YMin].kind = FaceKind::Wall;
    fp.faces[YMax].kind = FaceKind::Wall;
    fp.body_force = {force(), 0.0, 0.0};
    fp.precision = p;
    return fp;
  }
};

/// The paper's channel in small: Blasius inlet, outflow, plate, free slip, periodic span.
FluidParams channel(Precision p) {
  FluidParams fp = blasius_channel({40, 16, 12}, 0.6, 0.05, 4.0);
  fp.precision = p;
  return fp;
}

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", v);
  return buf;
}

double max_velocity_difference(const FluidSolver& a, const FluidSolver& b) {
  MacroscopicFields ma, mb;
  a.macroscopic(ma);
  b.macroscopic(mb);
  double d = 0.0;
  for (std::size_t i = 0; i < ma.ux.size(); ++i)
    d = std::max({d, std::abs(ma.ux[i] - mb.ux[i]), std::abs(ma.uy[i] - mb.uy[i]),
                  std::abs(ma.uz[i] - mb.uz[i])});
  return d;
}

TEST(Precision, SinglePrecisionWithinTolerance) {
  // Poiseuille start-up against its analytic solution.
  const Poiseuille P;
  FluidSolver dbl(P.params(Precision::Double)), sgl(P.params(Precision::Mixed));
  // Half the memory on the paper's grid (rows padded to whole 64-byte lines either way).
  EXPECT_LT(double(population_bytes({120, 60, 90}, Precision::Mixed)),
            0.55 * double(population_bytes({120, 60, 90}, Precision::Double)));
  EXPECT_EQ(sgl.population_bytes(), population_bytes(sgl.shape(), Precision::Mixed));
  for (int n = 0; n < P.steps(); ++n) {
    dbl.step();
    sgl.step();
  }
  const double bound = roundoff_bound(P.steps(), P.u_max);
  const double diff = max_velocity_difference(sgl, dbl);
  RecordProperty("poiseuille_max_difference", sci(diff));
  RecordProperty("poiseuille_bound", sci(bound));
  EXPECT_LE(diff, bound) << P.steps() << " steps";
  EXPECT_GT(diff, 0.0) << "the single store should round";
  // Relative L2 error against the analytic profile: the single run's may exceed the
  // double's only by the round-off bound (triangle inequality).
  const double err_d = P.l2_error(dbl), err_s = P.l2_error(sgl);
  const double rms_exact = P.rms_exact();
  RecordProperty("poiseuille_error_double", sci(err_d));
  RecordProperty("poiseuille_error_single", sci(err_s));
  EXPECT_LT(err_d, 0.01);  // the scheme itself (second order; about 1e-3 at 32 cells)
  EXPECT_LE(err_s, err_d + bound / rms_exact);

  // The channel's open boundaries (inlet, outflow written by the kernel, plate, free slip).
  FluidSolver cd(channel(Precision::Double)), cs(channel(Precision::Mixed));
  const double u_in = channel(Precision::Double).faces[XMin].inlet_speed;
  cd.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  cs.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  const int steps = 400;
  for (int n = 0; n < steps; ++n) {
    cd.step();
    cs.step();
  }
  const double cdiff = max_velocity_difference(cs, cd);
  RecordProperty("channel_max_difference", sci(cdiff));
  EXPECT_LE(cdiff, roundoff_bound(steps, u_in));
}

TEST(Precision, SingleStoreStreamingMatchesCachedStores) {
  // The single store's non-temporal kernel writes whole 64-byte lines of 16 floats: each
  // row's last, partial line is assembled with its outflow ghost and streamed whole
  // (fluid/collision/stream_collide.cpp), on rows that own that line (GridLayout::row_values). Every
  // remainder of nx modulo 16, with outflow ghosts written by the kernel on either x face,
  // against the kernel with ordinary stores: the same arithmetic, so bit for bit.
  using L = D3Q19;
  for (const Arithmetic arithmetic : {Arithmetic::Double, Arithmetic::Float})  // mixed, single
  for (int nx = 1; nx <= 40; ++nx) {
    const GridShape shape{nx, 3, 2};
    const GridLayout lay = layout_of(shape, Precision::Mixed);
    ASSERT_EQ(lay.values_per_line(), 16);
    PopulationFieldSingle src(lay), nt(lay), cached(lay);
    const std::size_t n = std::size_t(L::Q) * lay.stride();
    std::mt19937 rng{static_cast<unsigned>(nx)};
    std::uniform_real_distribution<float> U(0.01f, 0.1f);
    for (std::size_t i = 0; i < n; ++i) src.q(0)[i] = U(rng);
    std::fill(nt.q(0), nt.q(0) + n, -7.0f);
    std::fill(cached.q(0), cached.q(0) + n, -7.0f);
    KernelOutflow out;
    out.x_min = nx % 2 == 0;
    out.x_max = true;
    out.rho_x_min = 1.01;
    out.rho_x_max = 0.99;
    stream_collide(src, nt, 0.7, {1e-5, 0.0, -2e-5}, Stores::Streaming, out, nullptr, RowSchedule::Static, arithmetic);
    stream_collide(src, cached, 0.7, {1e-5, 0.0, -2e-5}, Stores::Cached, out, nullptr, RowSchedule::Static,
                   arithmetic);
    int mismatches = 0;
    for (int q = 0; q < L::Q; ++q)
      for (int z = 0; z < shape.nz; ++z)
        for (int y = 0; y < shape.ny; ++y)
          for (int x = -1; x <= nx; ++x) {
            // Interior cells, and the ghosts the kernel writes: populations entering the
            // grid through an outflow face.
            const bool interior = x >= 0 && x < nx;
            const bool ghost = (x == -1 && out.x_min && L::cx[q] == 1) ||
                               (x == nx && out.x_max && L::cx[q] == -1);
            if (!interior && !ghost) continue;
            const float a = nt.at(q, x, y, z), b = cached.at(q, x, y, z);
            if (a != b && ++mismatches <= 5)
              ADD_FAILURE() << "nx " << nx << ", q " << q << ", cell (" << x << ", " << y << ", "
                            << z << "): " << a << " (non-temporal) != " << b << " (cached)";
          }
    EXPECT_EQ(mismatches, 0) << "nx " << nx;
    // An inlet on x_max: its static ghosts (here -7) stay as they were.
    std::fill(nt.q(0), nt.q(0) + n, -7.0f);
    out.x_max = false;
    out.keep_x_max_ghosts = true;
    stream_collide(src, nt, 0.7, {1e-5, 0.0, -2e-5}, Stores::Streaming, out, nullptr, RowSchedule::Static, arithmetic);
    int overwritten = 0;
    for (int q = 0; q < L::Q; ++q)
      for (int z = 0; z < shape.nz; ++z)
        for (int y = 0; y < shape.ny; ++y) overwritten += nt.at(q, nx, y, z) != -7.0f;
    EXPECT_EQ(overwritten, 0) << "nx " << nx << ": x = nx ghosts of an inlet overwritten";
  }
}

/// The "single" mode (float store and float arithmetic) against the same run in double, and
/// the "mixed" one for scale. Its tolerance is measured, not derived: float arithmetic rounds
/// each of the collision's some 200 operations per cell, which a bound like roundoff_bound()
/// would add up to far more than happens. Measured on the AMD EPYC of docs/performance.md
/// (every kernel level gives the same bits: PrecisionModesAreBitIdenticalPerLevel), this
/// test's own printout:
///   Poiseuille (1024 steps, U = 0.05): max |u_single - u_double| = 4.377e-07 (mixed:
///   5.215e-08, within its derived bound), relative L2 error against the analytic profile
///   double 4.824e-04, single 4.840e-04;
///   channel (400 steps, inlet 0.05, open boundaries): 9.690e-07.
/// The tolerances are those values rounded up to one significant digit and doubled
/// (docs/results/precision-modes-20261206.md).
TEST(Precision, FloatArithmeticWithinTolerance) {
  const Poiseuille P;
  FluidSolver dbl(P.params(Precision::Double)), mix(P.params(Precision::Mixed)), sgl(P.params(Precision::Single));
  EXPECT_EQ(sgl.population_bytes(), mix.population_bytes());
  for (int n = 0; n < P.steps(); ++n) {
    dbl.step();
    mix.step();
    sgl.step();
  }
  const double diff = max_velocity_difference(sgl, dbl), diff_mixed = max_velocity_difference(mix, dbl);
  const double err_d = P.l2_error(dbl), err_s = P.l2_error(sgl);
  std::printf("Poiseuille, %d steps: max |u_single - u_double| %s (mixed %s); relative L2 error double %s, single %s\n",
              P.steps(), sci(diff).c_str(), sci(diff_mixed).c_str(), sci(err_d).c_str(), sci(err_s).c_str());
  RecordProperty("poiseuille_max_difference_single", sci(diff));
  RecordProperty("poiseuille_error_single", sci(err_s));
  EXPECT_GT(diff, 0.0) << "float arithmetic should round";
  EXPECT_LE(diff, kSingleTolerancePoiseuille) << P.steps() << " steps";
  EXPECT_LE(err_s, err_d + kSingleToleranceL2);

  FluidSolver cd(channel(Precision::Double)), cs(channel(Precision::Single));
  const double u_in = channel(Precision::Double).faces[XMin].inlet_speed;
  cd.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  cs.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  for (int n = 0; n < 400; ++n) {
    cd.step();
    cs.step();
  }
  const double cdiff = max_velocity_difference(cs, cd);
  std::printf("channel, 400 steps: max |u_single - u_double| %s\n", sci(cdiff).c_str());
  RecordProperty("channel_max_difference_single", sci(cdiff));
  EXPECT_LE(cdiff, kSingleToleranceChannel);
}

/// Steps of a small channel with forced cells (the immersed boundary's path) in a mode, as
/// bits: the state, and the extrema of every step (fluid/collision/kernel_dispatch.hpp).
std::vector<unsigned char> mode_bits(Precision precision, Propagation propagation) {
  FluidParams p = channel(precision);
  p.propagation = propagation;
  FluidSolver s(p);
  s.initialize([](int x, int y, int z) {
    return CellState{1.0 + 0.01 * std::sin(x + 2 * y), 0.05 + 0.01 * std::cos(z + x), 0.01 * std::sin(y), -0.01};
  });
  std::vector<unsigned char> bits;
  const auto add = [&](const void* v, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(v);
    bits.insert(bits.end(), b, b + n);
  };
  for (int step = 0; step < 12; ++step) {
    const double F = 1e-4 * (step + 1);
    s.add_force(0, 3, 4, F, -F, 0.5 * F);
    s.add_force(p.shape.nx - 1, 5, 2, -F, F, 0.0);
    s.add_force(17, 8, 6, F, 0.0, -F);
    s.step();
    const KernelExtrema& e = s.last_step_extrema();
    add(&e.rho_min, sizeof e.rho_min);
    add(&e.rho_max, sizeof e.rho_max);
    add(&e.u2_max, sizeof e.u2_max);
  }
  // Interior and ghosts, as the populations a checkpoint holds.
  const GridShape& g = s.shape();
  for (int z = -1; z <= g.nz; ++z)
    for (int y = -1; y <= g.ny; ++y)
      for (int x = -1; x <= g.nx; ++x)
        for (int q = 0; q < D3Q19::Q; ++q) {
          if (precision == Precision::Double) {
            const double v = s.state().at(q, x, y, z);
            add(&v, sizeof v);
          } else {
            const float v = s.state_single().at(q, x, y, z);
            add(&v, sizeof v);
          }
        }
  return bits;
}

TEST(Precision, PrecisionModesAreBitIdenticalPerLevel) {
  // Each mode, each kernel level this CPU runs (fluid/collision/kernel_dispatch.hpp), both
  // propagations: two runs give the same bits, and every level gives the bits of the lowest
  // one (the arithmetic is elementwise, -ffp-contract=off, in float as in double).
  const std::vector<std::string> levels = kernel_levels();
  const std::string before = active_kernel().level;
  for (const Precision mode : kPrecisionModes)
    for (const Propagation prop : {Propagation::InPlace, Propagation::TwoGrid}) {
      std::vector<unsigned char> reference;
      std::string reference_level;
      for (const std::string& level : levels) {
        if (!cpu_runs_level(level)) continue;
        set_kernel_level(level);
        const std::vector<unsigned char> a = mode_bits(mode, prop), b = mode_bits(mode, prop);
        EXPECT_TRUE(a == b) << precision_name(mode) << ", " << propagation_name(prop) << ", " << level
                            << ": two runs differ";
        if (reference.empty()) {
          reference = a;
          reference_level = level;
        } else {
          EXPECT_TRUE(a == reference) << precision_name(mode) << ", " << propagation_name(prop) << ", " << level
                                      << " differs from " << reference_level;
        }
      }
      EXPECT_FALSE(reference.empty());
    }
  set_kernel_level(before);
  // The modes differ from each other: each runs its own arithmetic or store.
  EXPECT_TRUE(mode_bits(Precision::Mixed, Propagation::InPlace) != mode_bits(Precision::Single, Propagation::InPlace));
}

TEST(Precision, CheckpointsOfAnotherModeAreRefused) {
  // fluid_run.cpp: a checkpoint names its mode ("precision") and, since issue 35, its
  // arithmetic; an unmarked "single" is an older build's, today's "mixed".
  for (const Precision p : kPrecisionModes) EXPECT_EQ(precision_problem(precision_name(p), true, p), "");
  EXPECT_EQ(precision_problem("double", false, Precision::Double), "");
  EXPECT_NE(precision_problem("single", false, Precision::Single).find("older build"), std::string::npos);
  EXPECT_NE(precision_problem("single", false, Precision::Mixed), "");
  EXPECT_NE(precision_problem("mixed", true, Precision::Single), "");
  EXPECT_NE(precision_problem("double", true, Precision::Mixed), "");
}

TEST(Precision, DoubleAccessorsRefuseTheSingleStore) {
  FluidSolver s(channel(Precision::Mixed));
  EXPECT_THROW((void)s.state(), std::logic_error);
  EXPECT_NO_THROW((void)s.state_single());
  FluidSolver d(channel(Precision::Double));
  EXPECT_THROW((void)d.state_single(), std::logic_error);
}

}  // namespace
