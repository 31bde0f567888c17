// The bar of Turek & Hron's benchmark as a sheet of [material], for the tests of its
// solid-only cases (tests/validation/test_turek_hron_csm.cpp, tests/validation/test_turek_hron_convergence.cpp):
// the scenes at a chosen marker spacing, the static deflection by dynamic relaxation, the
// undamped release cut into periods, and the published values.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "protocol/units.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::test::turek_hron {

namespace fs = std::filesystem;
using cosim::protocol::PhysicalConstants;
using cosim::solid::SolidModel;
using cosim::solid::SolidScene;

inline const fs::path kScenes = fs::path(COSIM_SOURCE_DIR) / "scenes" / "benchmarks";


namespace fs = std::filesystem;
using cosim::protocol::PhysicalConstants;
using cosim::solid::SolidModel;
using cosim::solid::SolidScene;

constexpr double kBarLength_m = 0.35;

/// The scene `name` with `free_rows` free rows (ny_cg = free_rows + 1, spacing L / (free_rows
/// + 1/2), square), written to the test's folder and loaded; the scene's own resolution is
/// 17 free rows (0.02 m).
inline SolidScene bar_scene(const std::string& name, int free_rows) {
  std::ifstream in(kScenes / (name + ".toml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  const auto replace = [&s](const std::string& from, const std::string& to) {
    const auto at = s.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    s.replace(at, from.size(), to);
  };
  char spacing[64];
  std::snprintf(spacing, sizeof spacing, "spacing_um = %.17g", kBarLength_m / (free_rows + 0.5) * 1e6);
  replace("ny_cg = 18", "ny_cg = " + std::to_string(free_rows + 1));
  replace("spacing_um = 20000.0", spacing);
  const fs::path path = fs::path(::testing::TempDir()) / (name + "_" + std::to_string(free_rows) + ".toml");
  std::ofstream(path) << s;
  return cosim::solid::load_solid_scene(path.string());
}

/// Displacement of point A (m): the free edge's midpoint against the flat sheet's.
inline Eigen::Vector3d tip_displacement_m(const SolidScene& scene, const SolidModel& model, const Eigen::Matrix3Xd& flat) {
  const cosim::solid::SheetSpec& spec = scene.config.sheets.front();
  return (cosim::solid::free_edge_midpoint(spec, model.positions()) - cosim::solid::free_edge_midpoint(spec, flat)) *
         PhysicalConstants::bohr_m;
}

/// A step of 0.8 of the model's stable step (the scene's dt_s is for its own resolution).
inline double time_step_au(const SolidModel& model) { return 0.8 * model.stable_time_step(); }

/// CSM1, CSM2: the static deflection of A (m) by dynamic relaxation, critically damped in
/// the first mode, until the fastest CGP moves less than 1e-9 of the tip's deflection per
/// second (checked every 1000 substeps, at most 60 s).
inline Eigen::Vector3d static_tip(const std::string& name, int free_rows) {
  const SolidScene scene = bar_scene(name, free_rows);
  const std::unique_ptr<SolidModel> model = cosim::solid::make_solid_model(scene.model, scene.config);
  const Eigen::Matrix3Xd flat = model->positions();
  const double dt = time_step_au(*model);
  const double omega1 = 2.0 * std::numbers::pi * model->vacuum_eigenfrequencies_hz().front() * PhysicalConstants::time_au_s;
  const double damping = 2.0 * scene.damping_ratio * omega1;
  const Eigen::RowVectorXd mass = model->masses().transpose();
  const double limit_s = 60.0, s_per_au = PhysicalConstants::time_au_s;
  Eigen::Matrix3Xd external(3, model->num_cgps());
  for (std::int64_t k = 1; double(k) * dt * s_per_au < limit_s; ++k) {
    external = -damping * (model->velocities().array().rowwise() * mass.array()).matrix();
    model->substep(dt, external);
    if (k % 1000 == 0) {
      const double speed_m_s = model->velocities().colwise().norm().maxCoeff() * PhysicalConstants::bohr_m / s_per_au;
      if (speed_m_s < 1e-9 * tip_displacement_m(scene, *model, flat).norm()) break;
    }
  }
  return tip_displacement_m(scene, *model, flat);
}

/// Mean +- amplitude [frequency] of a component over one period.
struct Oscillation {
  double mean = 0.0, amplitude = 0.0, frequency_hz = 0.0;
};

/// One full period of u_y(A), between two successive minima (each refined by the parabola
/// through it and its neighbours), and u_x(A), u_y(A) over it.
struct Period {
  double start_s = 0.0, end_s = 0.0;
  Oscillation x, y;
};

/// Every full period of y in the series, in time order.
inline std::vector<Period> periods(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& y) {
  std::vector<double> minima;  // refined times
  std::vector<std::size_t> at;
  for (std::size_t k = 1; k + 1 < y.size(); ++k) {
    if (!(y[k] < y[k - 1] && y[k] <= y[k + 1])) continue;
    const double curv = y[k - 1] - 2.0 * y[k] + y[k + 1];
    const double shift = curv > 0.0 ? 0.5 * (y[k - 1] - y[k + 1]) / curv : 0.0;
    minima.push_back(t[k] + shift * (t[k + 1] - t[k]));
    at.push_back(k);
  }
  std::vector<Period> out;
  for (std::size_t m = 1; m < at.size(); ++m) {
    const std::size_t a = at[m - 1], b = at[m];
    const auto over = [&](const std::vector<double>& v) {
      const auto [lo, hi] = std::minmax_element(v.begin() + std::ptrdiff_t(a), v.begin() + std::ptrdiff_t(b) + 1);
      Oscillation o;
      o.mean = 0.5 * (*hi + *lo);
      o.amplitude = 0.5 * (*hi - *lo);
      o.frequency_hz = 1.0 / (minima[m] - minima[m - 1]);
      return o;
    };
    out.push_back({minima[m - 1], minima[m], over(x), over(y)});
  }
  return out;
}

/// CSM3: the bar released flat and at rest, undamped, for `seconds`; A's displacement every
/// substep, cut into periods.
inline std::vector<Period> csm3(int free_rows, double seconds) {
  const SolidScene scene = bar_scene("turek_hron_csm3", free_rows);
  const std::unique_ptr<SolidModel> model = cosim::solid::make_solid_model(scene.model, scene.config);
  const Eigen::Matrix3Xd flat = model->positions();
  const double dt = time_step_au(*model), dt_s = dt * PhysicalConstants::time_au_s;
  const Eigen::Matrix3Xd none = Eigen::Matrix3Xd::Zero(3, model->num_cgps());
  std::vector<double> t, ux, uy;
  for (std::int64_t k = 1; double(k) * dt_s <= seconds; ++k) {
    model->substep(dt, none);
    const Eigen::Vector3d u = tip_displacement_m(scene, *model, flat);
    t.push_back(double(k) * dt_s);
    ux.push_back(u.x());
    uy.push_back(u.y());
  }
  return periods(t, ux, uy);
}

inline void print_static(const char* name, int rows, const Eigen::Vector3d& u, double ref_x, double ref_y) {
  std::printf("%s, %d free rows (h = %.5g m): u_x(A) = %.5g mm (%+.2f %%), u_y(A) = %.5g mm (%+.2f %%)\n", name, rows,
              kBarLength_m / (rows + 0.5), u.x() * 1e3, 100.0 * (u.x() / ref_x - 1.0), u.y() * 1e3,
              100.0 * (u.y() / ref_y - 1.0));
}

// The published values, m and Hz.
constexpr double kCsm1X = -7.187e-3, kCsm1Y = -66.10e-3;
constexpr double kCsm2X = -0.4690e-3, kCsm2Y = -16.97e-3;
constexpr double kCsm3XMean = -14.305e-3, kCsm3XAmp = 14.305e-3, kCsm3YMean = -63.607e-3, kCsm3YAmp = 65.160e-3,
                 kCsm3F = 1.0995;
constexpr int kRows = 17;  // the scenes' resolution, h = 0.02 m

}  // namespace cosim::test::turek_hron
