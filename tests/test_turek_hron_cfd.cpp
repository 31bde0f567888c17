// Turek & Hron's CFD2 and CFD3 (issue 29; docs/validation.md, "Turek & Hron's CFD cases"):
// the cylinder with its bar, both rigid and held at rest by the fluid (fluid/ib/held_body.hpp),
// in the channel with the ramped parabolic inlet. The scenes scenes/benchmarks/
// turek_hron_cfd{2,3}.toml are run in process at a coarser grid than theirs (the [grid]
// rewritten: nx = 25 n, ny = 4.1 n, dx = D / n for n cells per diameter), through the same
// scene reader, inlet ramp and held body as `build/fluid/fluid SCENE`.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fluid/config/scene_config.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/ib/held_body.hpp"

namespace {

using namespace cosim::fluid;

/// The scene file with its [grid] at n cells per diameter (D = 0.1 m), written to a
/// temporary file and loaded.
FluidScene scene_at(const std::string& file, int n) {
  std::ifstream in(std::string(COSIM_SOURCE_DIR) + "/" + file);
  std::ostringstream text;
  std::string line;
  bool grid = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '[') grid = line.rfind("[grid]", 0) == 0;
    if (grid && line.rfind("nx =", 0) == 0) line = "nx = " + std::to_string(25 * n);
    if (grid && line.rfind("ny =", 0) == 0) line = "ny = " + std::to_string(41 * n / 10);
    if (grid && line.rfind("dx_um =", 0) == 0) line = "dx_um = " + std::to_string(1e5 / n);
    text << line << "\n";
  }
  const std::string path = testing::TempDir() + "turek_hron_" + std::to_string(n) + "_" +
                           std::filesystem::path(file).filename().string();
  std::ofstream(path) << text.str();
  return load_scene(path);
}

struct Series {
  std::vector<double> t, drag, lift;  ///< s, N/m (means over each sample's steps)
  double seconds = 0.0;               ///< wall time
  double tau = 0.0;
  std::int64_t steps = 0;
};

/// The scene run for `duration_s`, the force on the body sampled as means over `every` steps.
Series run_scene(const FluidScene& s, double duration_s, int every) {
  const cosim::protocol::UnitConverter units(unit_inputs(s));
  SerialDomain domain(s.params);
  domain.initialize(s);
  domain.set_inlet_scale(inlet_ramp(0.0, s.inlet_ramp_steps));
  HeldBody body(s.held_body->shape, ImmersedBoundary(s.params));
  const double newtons_per_m = units.force_lb_N() / units.dx_m() / double(s.params.shape.nz);
  Series r;
  r.tau = s.params.tau;
  r.steps = std::int64_t(std::llround(duration_s / units.dt_lb_s()));
  const auto t0 = std::chrono::steady_clock::now();
  double fx = 0.0, fy = 0.0;
  for (std::int64_t n = 1; n <= r.steps; ++n) {
    const Vec3& F = body.hold(domain);
    fx += F[0];
    fy += F[1];
    domain.step();
    domain.set_inlet_scale(inlet_ramp(double(n), s.inlet_ramp_steps));
    if (n % every == 0) {
      r.t.push_back(double(n) * units.dt_lb_s());
      r.drag.push_back(newtons_per_m * fx / every);
      r.lift.push_back(newtons_per_m * fy / every);
      fx = fy = 0.0;
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

double mean_over(const Series& r, const std::vector<double>& v, double from, double to) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < r.t.size(); ++i)
    if (r.t[i] > from && r.t[i] <= to) sum += v[i], ++n;
  return n > 0 ? sum / n : NAN;
}

/// Mean +- amplitude [frequency] over the last period, as the benchmark defines them: the
/// period between the last two up-crossings of the lift through its mean (linear
/// interpolation), mean = (max + min) / 2, amplitude = (max - min) / 2 of each quantity in it.
struct LastPeriod {
  double frequency = 0.0;
  double drag_mean = 0.0, drag_amplitude = 0.0, lift_mean = 0.0, lift_amplitude = 0.0;
  int crossings = 0;
};

LastPeriod last_period(const Series& r, double from) {
  LastPeriod p;
  std::size_t i0 = 0;
  while (i0 < r.t.size() && r.t[i0] < from) ++i0;
  double lo = 1e300, hi = -1e300;
  for (std::size_t i = i0; i < r.t.size(); ++i) lo = std::min(lo, r.lift[i]), hi = std::max(hi, r.lift[i]);
  const double level = 0.5 * (lo + hi);
  std::vector<double> up;
  std::vector<std::size_t> at;
  for (std::size_t i = i0 + 1; i < r.t.size(); ++i)
    if (r.lift[i - 1] < level && r.lift[i] >= level) {
      const double w = (level - r.lift[i - 1]) / (r.lift[i] - r.lift[i - 1]);
      up.push_back(r.t[i - 1] + w * (r.t[i] - r.t[i - 1]));
      at.push_back(i);
    }
  p.crossings = int(up.size());
  if (up.size() < 2) return p;
  p.frequency = 1.0 / (up.back() - up[up.size() - 2]);
  double dmin = 1e300, dmax = -1e300, lmin = 1e300, lmax = -1e300;
  for (std::size_t i = at[at.size() - 2]; i < at.back(); ++i) {
    dmin = std::min(dmin, r.drag[i]), dmax = std::max(dmax, r.drag[i]);
    lmin = std::min(lmin, r.lift[i]), lmax = std::max(lmax, r.lift[i]);
  }
  p.drag_mean = 0.5 * (dmax + dmin);
  p.drag_amplitude = 0.5 * (dmax - dmin);
  p.lift_mean = 0.5 * (lmax + lmin);
  p.lift_amplitude = 0.5 * (lmax - lmin);
  return p;
}

}  // namespace

// CFD2 (Re 100, steady): drag 136.70 N/m and lift 10.534 N/m (Turek & Hron 2006; FeatFlow's
// CFD2 page), each required within 3 %.
TEST(TurekHronCfd, TurekHronCfd2MatchesReference) {
  constexpr int kCellsPerD = 10;
  constexpr double kDuration = 10.0, kDrag = 136.70, kLift = 10.534;
  const FluidScene s = scene_at("scenes/benchmarks/turek_hron_cfd2.toml", kCellsPerD);
  const Series r = run_scene(s, kDuration, 10);
  const double drag = mean_over(r, r.drag, kDuration - 0.5, kDuration);
  const double lift = mean_over(r, r.lift, kDuration - 0.5, kDuration);
  const double drag_before = mean_over(r, r.drag, kDuration - 1.0, kDuration - 0.5);
  std::printf("CFD2 at %d cells/D (tau %.4f, %lld steps, %.1f s): drag %.3f N/m (%+.2f %%), lift %.4f N/m (%+.2f %%); "
              "drag 0.5 s before %.3f\n",
              kCellsPerD, r.tau, static_cast<long long>(r.steps), r.seconds, drag, 100.0 * (drag / kDrag - 1.0), lift,
              100.0 * (lift / kLift - 1.0), drag_before);
  testing::Test::RecordProperty("drag_N_per_m", std::to_string(drag));
  testing::Test::RecordProperty("lift_N_per_m", std::to_string(lift));
  EXPECT_NEAR(drag, drag_before, 1e-3 * kDrag) << "not steady";
  EXPECT_NEAR(drag, kDrag, 0.03 * kDrag);
  EXPECT_NEAR(lift, kLift, 0.03 * kLift);
}

// CFD3 (Re 200, periodic): drag 439.45 +- 5.6183, lift -11.893 +- 437.81 N/m at 4.3956 Hz over
// the last period; mean drag and lift amplitude required within 5 %, the frequency within 3 %.
TEST(TurekHronCfd, TurekHronCfd3MatchesReference) {
  constexpr int kCellsPerD = 10;
  constexpr double kDuration = 10.0, kDrag = 439.45, kLiftAmplitude = 437.81, kFrequency = 4.3956;
  const FluidScene s = scene_at("scenes/benchmarks/turek_hron_cfd3.toml", kCellsPerD);
  const Series r = run_scene(s, kDuration, 2);
  const LastPeriod p = last_period(r, kDuration - 1.0);
  std::printf("CFD3 at %d cells/D (tau %.4f, %lld steps, %.1f s): drag %.3f +- %.3f N/m, lift %.3f +- %.3f N/m, "
              "%.4f Hz (%d up-crossings in the last second); against the reference: mean drag %+.2f %%, lift "
              "amplitude %+.2f %%, frequency %+.2f %%\n",
              kCellsPerD, r.tau, static_cast<long long>(r.steps), r.seconds, p.drag_mean, p.drag_amplitude,
              p.lift_mean, p.lift_amplitude, p.frequency, p.crossings, 100.0 * (p.drag_mean / kDrag - 1.0),
              100.0 * (p.lift_amplitude / kLiftAmplitude - 1.0), 100.0 * (p.frequency / kFrequency - 1.0));
  ASSERT_GE(p.crossings, 2) << "no shedding";
  EXPECT_NEAR(p.drag_mean, kDrag, 0.05 * kDrag);
  EXPECT_NEAR(p.lift_amplitude, kLiftAmplitude, 0.05 * kLiftAmplitude);
  EXPECT_NEAR(p.frequency, kFrequency, 0.03 * kFrequency);
}
