// The precision modes (FluidParams::precision, scene key run.precision): a run that stores
// its populations as float stays within the round-off bound derived below of the same run in
// double, and as close to the analytic solution; float arithmetic ("single") and the 16-bit
// store ("half") within tolerances measured here; every mode bit-identical run to run and
// across kernel levels.
#include <gtest/gtest.h>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <numbers>
#include <utility>
#include <random>
#include <vector>

#include "common/run/checkpoint_file.hpp"
#include "fluid/io/store_io.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/half.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/config/scene_config.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/collision/stream_collide.hpp"
#include "tests/support/run_command.hpp"

namespace {

using namespace cosim::fluid;

#if defined(__x86_64__)
/// Codes whose float from the portable conversion differs from F16C's vcvtph2ps.
__attribute__((target("f16c"))) unsigned half_mismatches_decode() {
  unsigned bad = 0;
  for (unsigned h = 0; h < 65536; ++h)
    bad += __builtin_bit_cast(std::uint32_t, float_of_binary16(std::uint16_t(h))) !=
           __builtin_bit_cast(std::uint32_t, _cvtsh_ss(std::uint16_t(h)));
  return bad;
}

/// Floats whose code from the portable conversion differs from F16C's vcvtps2ph rounding to
/// nearest, 4 at a time, of either sign: every float whose code is subnormal or 0 by rounding
/// (|x| from 2^-26, below the smallest subnormal's half 2^-25, up to 2^-13: the number of
/// bits rounded away changes with the exponent), of the normal codes those of the lowest two
/// exponents, of [0.5, 2) and of the top three (up to 2^17, past the overflow to infinity at
/// 65520: a normal code rounds its float's low 13 mantissa bits alike at every exponent), every
/// infinity and NaN; of the rest, every 257th.
__attribute__((target("f16c"))) std::uint64_t half_mismatches_encode() {
  using U4 = std::uint32_t __attribute__((vector_size(16)));
  using F4 = float __attribute__((vector_size(16)));
  std::uint64_t bad = 0;
  const auto check = [&](std::uint32_t b) {
    const U4 u = {b, b + 1, b + 2, b + 3};
    const U4 mine = binary16_bits_of_float_bits<U4, F4>(u);
    const __m128i hw = _mm_cvtps_ph(__builtin_bit_cast(__m128, u), _MM_FROUND_TO_NEAREST_INT);
    const U4 theirs = __builtin_bit_cast(U4, _mm_cvtepu16_epi32(hw));
    const U4 diff = mine != theirs;
    bad += (diff[0] != 0) + (diff[1] != 0) + (diff[2] != 0) + (diff[3] != 0);
  };
  for (std::uint32_t sign = 0; sign < 2; ++sign)
    for (std::uint32_t exponent = 0; exponent < 256; ++exponent) {
      const std::uint32_t first = sign << 31 | exponent << 23;
      const bool all = (exponent >= 127 - 26 && exponent < 127 - 12) || exponent == 126 || exponent == 127 ||
                       (exponent >= 127 + 14 && exponent < 127 + 17) || exponent == 255;
      for (std::uint32_t m = 0; m < (1u << 23); m += all ? 4 : 4 * 257) check(first | m);
    }
  return bad;
}
#endif

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

/// A store's value from a double (encode_population for the half store's codes) and its bits.
template <class T>
T stored_value(double v, int q) {
  return encode_population<T>(v, q);
}
template <class T>
bool same_bits(T a, T b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

/// The non-temporal kernel against the cached one on a store T in `arithmetic`, every
/// remainder of nx modulo the line's values (see SingleStoreStreamingMatchesCachedStores).
template <class T>
void streaming_matches_cached(Precision precision, Arithmetic arithmetic, int values_per_line) {
  using L = D3Q19;
  for (int nx = 1; nx <= values_per_line + 24; ++nx) {
    const GridShape shape{nx, 3, 2};
    const GridLayout lay = layout_of(shape, precision);
    ASSERT_EQ(lay.values_per_line(), values_per_line);
    BasicPopulationField<T> src(lay), nt(lay), cached(lay);
    const std::size_t n = std::size_t(L::Q) * lay.stride();
    std::mt19937 rng{static_cast<unsigned>(nx)};
    std::uniform_real_distribution<double> U(0.01, 0.1);
    for (int q = 0; q < L::Q; ++q)
      for (std::size_t i = 0; i < lay.stride(); ++i) src.q(q)[i] = stored_value<T>(U(rng), q);
    const T sentinel = stored_value<T>(-7.0, 0);
    std::fill(nt.q(0), nt.q(0) + n, sentinel);
    std::fill(cached.q(0), cached.q(0) + n, sentinel);
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
            const T a = nt.at(q, x, y, z), b = cached.at(q, x, y, z);
            if (!same_bits(a, b) && ++mismatches <= 5)
              ADD_FAILURE() << precision_name(precision) << ", nx " << nx << ", q " << q << ", cell (" << x << ", "
                            << y << ", " << z << "): " << decode_population(a, q) << " (non-temporal) != "
                            << decode_population(b, q) << " (cached)";
          }
    EXPECT_EQ(mismatches, 0) << precision_name(precision) << ", nx " << nx;
    // An inlet on x_max: its static ghosts (here the sentinel) stay as they were.
    std::fill(nt.q(0), nt.q(0) + n, sentinel);
    out.x_max = false;
    out.keep_x_max_ghosts = true;
    stream_collide(src, nt, 0.7, {1e-5, 0.0, -2e-5}, Stores::Streaming, out, nullptr, RowSchedule::Static, arithmetic);
    int overwritten = 0;
    for (int q = 0; q < L::Q; ++q)
      for (int z = 0; z < shape.nz; ++z)
        for (int y = 0; y < shape.ny; ++y) overwritten += !same_bits(nt.at(q, nx, y, z), sentinel);
    EXPECT_EQ(overwritten, 0) << precision_name(precision) << ", nx " << nx << ": x = nx ghosts of an inlet overwritten";
  }
}

TEST(Precision, SingleStoreStreamingMatchesCachedStores) {
  // The float store's non-temporal kernel writes whole 64-byte lines of 16 floats: each
  // row's last, partial line is assembled with its outflow ghost and streamed whole
  // (fluid/collision/stream_collide.cpp), on rows that own that line (GridLayout::row_values). Every
  // remainder of nx modulo 16, with outflow ghosts written by the kernel on either x face,
  // against the kernel with ordinary stores: the same arithmetic, so bit for bit.
  streaming_matches_cached<float>(Precision::Mixed, Arithmetic::Double, 16);
  streaming_matches_cached<float>(Precision::Single, Arithmetic::Float, 16);
}

TEST(Precision, HalfStoreStreamingMatchesCachedStores) {
  // The same for the half store's lines of 32 codes (2, 4 or 8 float groups per line on
  // v4, v3, v2), every level this CPU runs.
  const std::string before = active_kernel().level;
  for (const std::string& level : kernel_levels()) {
    if (!cpu_runs_level(level)) continue;
    set_kernel_level(level);
    streaming_matches_cached<Half16>(Precision::Half, Arithmetic::Float, 32);
  }
  set_kernel_level(before);
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
/// `whole_store`: the state as stored, ghosts included (as a checkpoint holds it); else the
/// populations every interior cell pulls (populations_at, ghosts pulled into a cell
/// included), which the two propagations share (their other ghosts differ).
std::vector<unsigned char> mode_bits(Precision precision, Propagation propagation, bool whole_store = true) {
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
  const GridShape& g = s.shape();
  if (!whole_store) {
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) {
          double f[D3Q19::Q];
          s.populations_at(x, y, z, f);
          add(f, sizeof f);
        }
    return bits;
  }
  // Interior and ghosts, as the populations a checkpoint holds.
  for (int z = -1; z <= g.nz; ++z)
    for (int y = -1; y <= g.ny; ++y)
      for (int x = -1; x <= g.nx; ++x)
        for (int q = 0; q < D3Q19::Q; ++q) {
          if (precision == Precision::Double) {
            const double v = s.state().at(q, x, y, z);
            add(&v, sizeof v);
          } else if (stores_halves(precision)) {
            const Half16 v = s.state_half().at(q, x, y, z);
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
  // The half store: the same populations in place as with two grids (the in-place kernel's
  // x ghosts and the two-grid kernel's outflow ghosts encode alike), as in the other modes.
  for (const Precision mode : kPrecisionModes)
    EXPECT_TRUE(mode_bits(mode, Propagation::InPlace, false) == mode_bits(mode, Propagation::TwoGrid, false))
        << precision_name(mode) << ": in place and with two grids differ";
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
  // The half store's codes continue only a half run, and a half run only them.
  for (const Precision p : {Precision::Double, Precision::Mixed, Precision::Single}) {
    EXPECT_NE(precision_problem("half", true, p), "") << precision_name(p);
    EXPECT_NE(precision_problem(precision_name(p), true, Precision::Half), "") << precision_name(p);
  }
  EXPECT_NE(precision_problem("single", false, Precision::Half), "");
}

TEST(Precision, DoubleAccessorsRefuseTheSingleStore) {
  FluidSolver s(channel(Precision::Mixed));
  EXPECT_THROW((void)s.state(), std::logic_error);
  EXPECT_NO_THROW((void)s.state_single());
  FluidSolver d(channel(Precision::Double));
  EXPECT_THROW((void)d.state_single(), std::logic_error);
}

TEST(Precision, HalfConversionMatchesF16c) {
  // The portable binary16 conversion of the half store (fluid/lattice/half.hpp: the baseline
  // level's, and the one of the code outside the kernel) against the CPU's F16C, for every
  // one of the 2^16 codes and every float that rounds to a finite non-zero code or to the
  // overflow (half_mismatches_encode): the same bits, so every level stores the same codes.
  // (All 2^32 floats, checked once the same way: 0 mismatches, 8 s on a loaded machine.)
#if defined(__x86_64__)
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("f16c")) GTEST_SKIP() << "this CPU has no F16C";
  EXPECT_EQ(half_mismatches_decode(), 0u);
  EXPECT_EQ(half_mismatches_encode(), 0u);
#else
  GTEST_SKIP() << "F16C is x86-64's";
#endif
}

/// The "half" mode (16-bit store of f_q - w_q, float arithmetic: fluid/lattice/half.hpp)
/// against the same runs in double, as FloatArithmeticWithinTolerance. Its tolerance is
/// measured: each step rounds every stored f_q - w_q to 11 significant bits (to nearest: a
/// relative error up to 2^-11), and Poiseuille's driving force adds only w_q 3 c.F = 6.5e-6 per
/// step to populations whose f_q - w_q are 1e-3 to 5e-3 (codes 9.5e-7 to 3.8e-6 apart): the
/// error is far above float's and far below a linear sum over the steps would allow.
/// Measured on the AMD EPYC of docs/performance.md (every level gives the same bits:
/// PrecisionModesAreBitIdenticalPerLevel), this test's own printout:
///   Poiseuille (1024 steps, U = 0.05): max |u_half - u_double| = 1.949e-04 (single:
///   4.377e-07), relative L2 error against the analytic profile double 4.824e-04, half
///   4.724e-03 (the store's rounding, not the scheme, dominates at 32 cells);
///   channel (400 steps, inlet 0.05, open boundaries): 7.452e-05;
///   |f_q - w_q| of the double runs' last states (interior): 4.2e-08 to 5.3e-03
///   (Poiseuille), 3.6e-08 to 1.1e-02 (channel): inside FP16S' normal range [1.9e-9, 2).
/// Tolerances: those values rounded up to one significant digit and doubled.
constexpr double kHalfTolerancePoiseuille = 4e-4;  // measured 1.949e-04
constexpr double kHalfToleranceL2 = 1e-2;          // measured 4.724e-03 - 4.824e-04 = 4.2e-03
constexpr double kHalfToleranceChannel = 2e-4;     // measured 7.452e-05

/// The smallest non-zero and the largest |f_q - w_q| of a double run's state (interior).
std::pair<double, double> shifted_range(const FluidSolver& s) {
  double lo = 1e300, hi = 0.0;
  const GridShape& g = s.shape();
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x)
        for (int q = 0; q < D3Q19::Q; ++q) {
          const double d = std::abs(s.state().at(q, x, y, z) - D3Q19::w[q]);
          if (d > 0.0) lo = std::min(lo, d);
          hi = std::max(hi, d);
        }
  return {lo, hi};
}

TEST(Precision, HalfStoreWithinTolerance) {
  const Poiseuille P;
  FluidSolver dbl(P.params(Precision::Double)), half(P.params(Precision::Half));
  // A quarter of the double store's bytes per value; the layout's padding (whole 64-byte
  // lines of 32 codes) makes it 0.294 of the double store's memory on the paper's grid.
  EXPECT_LT(double(population_bytes({120, 60, 90}, Precision::Half)),
            0.3 * double(population_bytes({120, 60, 90}, Precision::Double)));
  EXPECT_EQ(half.population_bytes(), population_bytes(half.shape(), Precision::Half));
  for (int n = 0; n < P.steps(); ++n) {
    dbl.step();
    half.step();
  }
  const double diff = max_velocity_difference(half, dbl);
  const double err_d = P.l2_error(dbl), err_h = P.l2_error(half);
  const auto [plo, phi] = shifted_range(dbl);
  std::printf("Poiseuille, %d steps: max |u_half - u_double| %s; relative L2 error double %s, half %s; "
              "|f - w| from %s to %s\n",
              P.steps(), sci(diff).c_str(), sci(err_d).c_str(), sci(err_h).c_str(), sci(plo).c_str(),
              sci(phi).c_str());
  RecordProperty("poiseuille_max_difference_half", sci(diff));
  RecordProperty("poiseuille_error_half", sci(err_h));
  EXPECT_GT(diff, 0.0) << "the half store should round";
  EXPECT_LE(diff, kHalfTolerancePoiseuille) << P.steps() << " steps";
  EXPECT_LE(err_h, err_d + kHalfToleranceL2);

  FluidSolver cd(channel(Precision::Double)), ch(channel(Precision::Half));
  const double u_in = channel(Precision::Double).faces[XMin].inlet_speed;
  cd.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  ch.initialize_uniform(1.0, {u_in, 0.0, 0.0});
  for (int n = 0; n < 400; ++n) {
    cd.step();
    ch.step();
  }
  const double cdiff = max_velocity_difference(ch, cd);
  const auto [clo, chi] = shifted_range(cd);
  std::printf("channel, 400 steps: max |u_half - u_double| %s; |f - w| from %s to %s\n", sci(cdiff).c_str(),
              sci(clo).c_str(), sci(chi).c_str());
  RecordProperty("channel_max_difference_half", sci(cdiff));
  EXPECT_LE(cdiff, kHalfToleranceChannel);
}

TEST(Precision, HalfStoreAccessors) {
  FluidSolver h(channel(Precision::Half));
  EXPECT_THROW((void)h.state(), std::logic_error);
  EXPECT_THROW((void)h.state_single(), std::logic_error);
  EXPECT_NO_THROW((void)h.state_half());
  // A code stands for f_q = w_q + value: the rest state's populations are code 0.
  FluidSolver rest(channel(Precision::Half));
  rest.initialize_uniform(1.0, {0.0, 0.0, 0.0});
  EXPECT_EQ(rest.state_half().at(0, 3, 3, 3).bits, 0u);
  double f[D3Q19::Q];
  rest.populations_at(3, 3, 3, f);
  for (int q = 0; q < D3Q19::Q; ++q) EXPECT_EQ(f[q], D3Q19::w[q]) << q;
}

TEST(Precision, HalfStoreCheckpointRoundTrips) {
  // A checkpoint's "populations" hold the half store's codes as unsigned 16-bit integers
  // (fluid/coupled/fluid_run.cpp, fluid/io/store_io.hpp): written and read back into another
  // solver, the same bits, and the two step on alike.
  namespace fs = std::filesystem;
  const FluidParams p = channel(Precision::Half);
  FluidSolver a(p), b(p);
  a.initialize([](int x, int y, int z) {
    return CellState{1.0 + 0.01 * std::sin(x + 2 * y), 0.05 + 0.01 * std::cos(z + x), 0.01 * std::sin(y), -0.01};
  });
  for (int n = 0; n < 5; ++n) a.step();
  const fs::path dir = cosim::test::fresh_scratch("cosim_half_checkpoint");
  const fs::path file = dir / "fluid.h5";
  StoreShare share;
  share.value_bytes = sizeof(Half16);
  share.whole_stride = share.local_stride = share.count = a.layout().stride();
  const std::size_t bytes = std::size_t(D3Q19::Q) * a.layout().stride() * sizeof(Half16);
  {
    cosim::protocol::CheckpointWriter w(file);
    w.reserve("populations", H5T_STD_U16LE, std::size_t(D3Q19::Q) * a.layout().stride());
    w.pause();
    ASSERT_EQ(write_store_share(w.part(), "populations", a.state_data(), share, nullptr), "");
    w.commit();
  }
  ASSERT_EQ(read_store_share(file.string(), "populations", b.mutable_state_data(), share), "");
  EXPECT_EQ(std::memcmp(a.state_data(), b.state_data(), bytes), 0);
  for (int n = 0; n < 3; ++n) {
    a.step();
    b.step();
  }
  EXPECT_EQ(std::memcmp(a.state_data(), b.state_data(), bytes), 0) << "the restored state steps otherwise";
  fs::remove_all(dir);
}

}  // namespace
