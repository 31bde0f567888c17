// `solid`: runs a solid model on its own, without a fluid (standalone mode, for validation):
// free vibration in vacuum from an initial perturbation, or the static deflection under a
// uniform pressure reached by dynamic relaxation. A scene with a [coupling] section runs
// coupled to the fluid over LCM instead (coupled_solid.hpp, protocol/README.md).
//
//   solid SCENE.toml [--substeps N] [--output DIR] [--quiet] [--check]
//   solid COUPLED.toml --token T [--channel-prefix P] [--lcm-url U] [--output DIR] [--quiet]
//                      [--check]       (the token may come from $COSIM_RUN_TOKEN instead)
//
// Exit status of a coupled run: protocol/README.md section 9 (0 done, 1 system, 2 bad input
// or refused handshake or malformed message, 3 unhealthy, 4 peer lost).
//
// Exit status: 0 the run finished; 1 an output or system error; 2 the scene file, the
// command line or the model's construction is invalid, or [run] dt_s is above the model's
// stable step (one line on stderr); 3 a non-finite position, velocity or energy appeared:
// one line on stderr naming the substep and the CGP, and that state is not written.
//
// Output: OUTPUT/solid.h5 with one row every record_every substeps (and at substep 0 and the
// last): substep, time_s, the marked CGP's displacement of each sheet (um, rows x sheets x 3)
// and along the sheet's normal (um, rows x sheets), kinetic, elastic and total energy (J).
// With [output] sheets_every = N > 0 also OUTPUT/sheets_NNNNNN.h5 every N substeps (and at
// substep 0 and the last) and OUTPUT/sheets.xmf (solid/io/sheet_snapshots.hpp).
//
// The static run is a dynamic relaxation: the model integrates
//   M dV/dt = F^int + F^p - 2 zeta omega_1 M V
// with F^p = p dx_CG^2 n per CGP and omega_1 = 2 pi f_1 its first vacuum eigenfrequency;
// the damping force is evaluated with the velocities at the start of each substep and
// handed to the model as part of the external force. zeta = 1 damps the first mode
// critically; every mode then decays at least as fast as exp(-zeta omega_1 t).
#include <hdf5.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <Eigen/Core>

#include "common/text/cli_parse.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/progress.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/interrupt.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/io/solid_log.hpp"
#include "solid/coupled/initial_deflection.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/io/sheet_snapshots.hpp"
#include "solid/model/sheet_spec.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance_h5.hpp"
#include "solid/model/solid_model.hpp"
#include "solid/io/output_units.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::solid {
namespace {

namespace exit_code = protocol::exit_code;  // protocol/README.md section 9, defined once

using Clock = std::chrono::steady_clock;
using protocol::fmt;
using protocol::indent;
using protocol::one_line;
using protocol::PhysicalConstants;
using protocol::UnitConverter;
using protocol::H5Id;

/// First root of cos(x) cosh(x) = -1: the clamped-free beam's first mode (Euler-Bernoulli).
constexpr double kBeamRoot1 = 1.8751040687119611;

/// The first CGP with a non-finite position or velocity, as a diagnosis; "" if none.
std::string non_finite_state(const SolidModel& model, const SolidConfig& config) {
  const Eigen::Matrix3Xd& x = model.positions();
  const Eigen::Matrix3Xd& v = model.velocities();
  if (x.allFinite() && v.allFinite()) return "";
  for (Eigen::Index l = 0; l < x.cols(); ++l) {
    const bool bad_x = !x.col(l).allFinite(), bad_v = !v.col(l).allFinite();
    if (!bad_x && !bad_v) continue;
    const Eigen::Vector3d q = bad_x ? Eigen::Vector3d(x.col(l)) : Eigen::Vector3d(v.col(l));
    return describe_cgp(config, l) + ": " + (bad_x ? "position" : "velocity") + " (" +
           fmt("%g", q[0]) + ", " + fmt("%g", q[1]) + ", " + fmt("%g", q[2]) + ")" +
           (bad_x ? " bohr" : " bohr/t_AU");
  }
  return "";
}

/// The CGP with the largest speed, and that speed (bohr / t_AU).
std::pair<Eigen::Index, double> fastest_cgp(const SolidModel& model) {
  const Eigen::Matrix3Xd& v = model.velocities();
  Eigen::Index fastest = 0;
  double top = 0.0;
  for (Eigen::Index l = 0; l < v.cols(); ++l) {
    const double speed = v.col(l).stableNorm();  // no overflow of the squares
    if (speed > top || std::isnan(speed)) {
      fastest = l;
      top = speed;
      if (std::isnan(speed)) break;
    }
  }
  return {fastest, top};
}

/// The time series of solid.h5, kept in memory and written once.
struct Series {
  int sheets = 0;
  std::vector<std::int64_t> substep;
  std::vector<double> time_s, displacement_um, normal_um, kinetic_J, elastic_J, total_J;
  std::size_t rows() const { return substep.size(); }
};

void create_output_directory(const SolidScene& scene) {
  std::error_code ec;
  std::filesystem::create_directories(scene.output_dir, ec);
  if (ec)
    throw std::runtime_error("cannot create the output directory " + scene.output_dir + ": " +
                             ec.message());
}

void write_series(const SolidScene& scene, const Series& s) {
  create_output_directory(scene);
  const std::string path = (std::filesystem::path(scene.output_dir) / "solid.h5").string();
  const protocol::H5Quiet quiet;
  H5Id file = protocol::create_output_file(path, "cannot create " + path);
  const hid_t f = file.get();
  const hsize_t n = s.rows(), ns = hsize_t(s.sheets);
  protocol::write_dataset(f, "substep", H5T_STD_I64LE, H5T_NATIVE_INT64, {n}, s.substep.data());
  protocol::write_dataset(f, "time_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.time_s.data());
  protocol::write_dataset(f, "marked_displacement_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns, 3},
                s.displacement_um.data());
  protocol::write_dataset(f, "marked_normal_displacement_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns},
                s.normal_um.data());
  protocol::write_dataset(f, "kinetic_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.kinetic_J.data());
  protocol::write_dataset(f, "elastic_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.elastic_J.data());
  protocol::write_dataset(f, "total_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.total_J.data());
  protocol::put_attribute(f, "scene", scene.name);
  protocol::put_attribute(f, "model", scene.model);
  protocol::put_attribute(f, "mode", scene.mode == SolidRunMode::Free ? "free" : "static");
  protocol::put_attribute(f, "dt_s", scene.dt_s);
  protocol::stamp_file(f);
  file.close("cannot close " + path);
}

/// The standalone run's progress line on stderr (common/run/progress.hpp): substep, simulated
/// time, rate and ETA; none where `logger` does not show progress (--quiet).
class Progress {
 public:
  Progress(const log::Logger& logger, std::int64_t total, double dt_s) : line_(logger), clock_(total), dt_s_(dt_s) {}

  void update(std::int64_t k) {
    if (!line_.due(k == clock_.total())) return;
    char text[192];
    std::snprintf(text, sizeof text, "substep %lld/%lld  t = %.4g us  %.3g substeps/s  ETA %s",
                  static_cast<long long>(k), static_cast<long long>(clock_.total()), double(k) * dt_s_ * 1e6,
                  clock_.rate(k), protocol::format_duration(clock_.eta_s(k)).c_str());
    line_.show(text);
  }
  void clear() { line_.clear(); }
  double elapsed_s() const { return clock_.elapsed_s(); }

 private:
  protocol::ProgressLine line_;
  protocol::ProgressClock clock_;
  double dt_s_;
};

void print_header(const SolidScene& s, const SolidModel& model) {
  solid_log().info() << "scene " << s.name << (s.description.empty() ? "" : ": ") << s.description << " (" << s.path
                     << ")";
  std::printf("%s", indent(model.startup_report()).c_str());
  std::printf("  sheets   %zu sheet(s), %lld CGPs\n", s.config.sheets.size(),
              static_cast<long long>(model.num_cgps()));
  for (std::size_t k = 0; k < s.config.sheets.size(); ++k) {
    const SheetSpec& sh = s.config.sheets[k];
    // Each CGP carries a full cell of mass: the sheet is nx_cg spacings wide, and its free
    // part reaches half a spacing above the top row (docs/solid.md).
    std::printf("    sheet %zu: %d x %d CGPs (W %.4g um, free height %.4g um), spacing %.4g x %.4g um, "
                "theta %.4g deg, %d clamped row(s), CGP mass %.4g kg, base (%.4g, %.4g, %.4g) um\n",
                k, sh.nx_cg, sh.ny_cg, um_from_bohr(sh.width_spacing_bohr) * sh.nx_cg,
                um_from_bohr(sh.height_spacing_bohr) * (sh.ny_cg - sh.clamped_rows + 0.5),
                um_from_bohr(sh.width_spacing_bohr), um_from_bohr(sh.height_spacing_bohr),
                sh.theta_deg, sh.clamped_rows,
                sh.cgp_mass_me * PhysicalConstants::electron_mass_kg,
                um_from_bohr(sh.base_bohr[0]), um_from_bohr(sh.base_bohr[1]),
                um_from_bohr(sh.base_bohr[2]));
  }
  const double stable_s = model.stable_time_step() * PhysicalConstants::time_au_s;
  std::printf("  step     dt = %.5g s%s; stable step of the model 2 / omega_max = ", s.dt_s,
              s.dt_is_default ? " (dt_CG of the paper, Eq. 16)" : "");
  if (std::isfinite(stable_s))
    std::printf("%.5g s (dt is %.3g of it)\n", stable_s, s.dt_s / stable_s);
  else
    std::printf("none (no dynamics)\n");
  const std::vector<double> f = model.vacuum_eigenfrequencies_hz();
  if (!f.empty()) {
    std::printf("  vacuum   f =");
    for (std::size_t k = 0; k < std::min<std::size_t>(f.size(), 4); ++k)
      std::printf("%s %.5g MHz", k ? "," : "", f[k] * 1e-6);
    std::printf("; first period %.5g us = %.4g substeps\n", 1e6 / f[0], 1.0 / (f[0] * s.dt_s));
  }
  std::printf("  run      %s; %lld substeps = %.5g us; record every %lld; output %s%s\n",
              s.mode == SolidRunMode::Free
                  ? (s.tip_displacement_bohr == 0.0
                         ? std::string("released flat and at rest under gravity")
                         : "free vibration from a tip displacement of " +
                               fmt("%.4g", um_from_bohr(s.tip_displacement_bohr)) + " um")
                        .c_str()
                  : ("static load " + fmt("%.4g", s.pressure_Pa) +
                     " Pa by dynamic relaxation, damping ratio " + fmt("%.3g", s.damping_ratio))
                        .c_str(),
              static_cast<long long>(s.substeps), double(s.substeps) * s.dt_s * 1e6,
              static_cast<long long>(s.record_every), s.output_dir.c_str(),
              s.sheets_every > 0
                  ? (", sheet snapshots every " + std::to_string(s.sheets_every) + " substeps")
                        .c_str()
                  : "");
  std::fflush(stdout);
}

/// Frequency of x(t) - mean from its zero crossings (linear interpolation between records):
/// m half periods between the first crossing and crossing m, f = m / (2 (t_m - t_0)). m is
/// taken even where there are three crossings or more, so that both ends cross in the same
/// direction and an offset of the mean (a run of a non-integer number of periods) shifts
/// them alike. nullopt with fewer than two crossings.
std::optional<double> crossing_frequency(const std::vector<double>& t, const std::vector<double>& x,
                                         int* crossings) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= double(std::max<std::size_t>(1, x.size()));
  std::vector<double> tc;
  for (std::size_t k = 1; k < x.size(); ++k) {
    const double a = x[k - 1] - mean, b = x[k] - mean;
    if ((a < 0.0) == (b < 0.0)) continue;
    tc.push_back(t[k - 1] + (t[k] - t[k - 1]) * a / (a - b));
  }
  *crossings = int(tc.size());
  if (tc.size() < 2) return std::nullopt;
  std::size_t m = tc.size() - 1;
  if (m >= 2) m -= m % 2;
  if (!(tc[m] > tc[0])) return std::nullopt;
  return double(m) / (2.0 * (tc[m] - tc[0]));
}

void print_free_summary(const SolidModel& model, const Series& series) {
  const std::vector<double> f = model.vacuum_eigenfrequencies_hz();
  for (int k = 0; k < series.sheets; ++k) {
    std::vector<double> w(series.rows());
    for (std::size_t r = 0; r < series.rows(); ++r)
      w[r] = series.normal_um[r * std::size_t(series.sheets) + std::size_t(k)];
    int crossings = 0;
    const std::optional<double> fm = crossing_frequency(series.time_s, w, &crossings);
    log::Line line = solid_log().info();
    line << "sheet " << k << " marked CGP: ";
    if (!fm)
      line << log::printf_text("%d zero crossing(s) of w - mean, too few to measure a frequency%s", crossings,
                               f.empty() ? "" : " (run at least one period of the first mode)");
    else if (f.empty())
      line << log::printf_text("oscillation %.6g MHz from %d zero crossings (the model reports no vacuum "
                               "eigenfrequency)",
                               *fm * 1e-6, crossings);
    else
      line << log::printf_text("oscillation %.6g MHz from %d zero crossings; f1 = %.6g MHz; relative "
                               "difference %+.3e",
                               *fm * 1e-6, crossings, f[0] * 1e-6, (*fm - f[0]) / f[0]);
  }
  const double e0 = series.total_J.empty() ? 0.0 : series.total_J.front();
  double drift = 0.0, kinetic = 0.0;
  for (double e : series.total_J) drift = std::max(drift, std::abs(e - e0));
  for (double e : series.kinetic_J) kinetic = std::max(kinetic, e);
  // A sheet released flat under gravity starts at E0 = 0 (round-off): its drift is measured
  // against the largest kinetic energy of the run instead.
  if (std::abs(e0) >= kinetic && e0 != 0.0)
    solid_log().info() << log::printf_text("energy E0 = %.6g J; drift max|E - E0| / E0 = %.3e", e0,
                                           drift / std::abs(e0));
  else if (kinetic > 0.0)
    solid_log().info() << log::printf_text(
        "energy E0 = %.6g J; drift max|E - E0| / max E_kin = %.3e (max E_kin %.6g J)", e0, drift / kinetic, kinetic);
  else
    solid_log().info() << log::printf_text("energy E0 = 0 J; drift max|E - E0| = %.3e J", drift);
}

void print_static_summary(const SolidScene& s, const SolidModel& model, const Series& series) {
  const std::vector<double> f = model.vacuum_eigenfrequencies_hz();
  for (int k = 0; k < series.sheets; ++k) {
    const double w = series.rows() ? series.normal_um[(series.rows() - 1) *
                                                          std::size_t(series.sheets) +
                                                      std::size_t(k)]
                                   : 0.0;
    log::Line line = solid_log().info();
    line << "sheet " << k << " marked CGP: final normal deflection " << log::printf_text("%.6g", w) << " um";
    if (!f.empty() && s.pressure_Pa != 0.0) {
      // Euler-Bernoulli clamped-free beam under uniform load: w_tip = q L^4 / (8 EI), and
      // omega_1 = beta_1^2 sqrt(EI / (mu L^4)), so w_tip = beta_1^4 / 8 (q / mu) / omega_1^2,
      // with q / mu = p / rho_2D = force over mass of one CGP.
      const SheetSpec& sh = s.config.sheets[std::size_t(k)];
      const double cell_m2 = sh.cell_area_bohr2() * PhysicalConstants::bohr_m * PhysicalConstants::bohr_m;
      const double accel = s.pressure_Pa * cell_m2 /
                           (sh.cgp_mass_me * PhysicalConstants::electron_mass_kg);
      const double omega1 = 2.0 * std::numbers::pi * f[0];
      const double beam_um = std::pow(kBeamRoot1, 4) / 8.0 * accel / (omega1 * omega1) / kMicrometre;
      line << log::printf_text("; beam theory from f1: %.6g um (ratio %.4f)", beam_um,
                               beam_um != 0.0 ? w / beam_um : 0.0);
    }
  }
  const auto [l, v] = fastest_cgp(model);
  solid_log().info() << log::printf_text("largest speed left %.4g m/s at %s", v * UnitConverter::velocity_au_m_s(),
                                         describe_cgp(s.config, l).c_str());
}

/// Builds the model; construction errors are the scene's (exit 2).
std::unique_ptr<SolidModel> build_model(const SolidScene& s) {
  try {
    return make_solid_model(s.model, s.config);
  } catch (const std::invalid_argument& e) {
    throw SolidSceneError(s.path + ": solid.model = \"" + s.model + "\": " + e.what());
  } catch (const std::runtime_error& e) {
    throw SolidSceneError(s.path + ": solid.model = \"" + s.model +
                          "\": the construction failed: " + e.what());
  }
}

/// The [run] dt_s against the model's stable step; a SolidSceneError if above.
void check_time_step(const SolidScene& s, const SolidModel& model) {
  const double stable_s = model.stable_time_step() * PhysicalConstants::time_au_s;
  if (s.dt_s <= stable_s) return;
  throw SolidSceneError(s.path + ": run.dt_s = " + fmt("%.6g", s.dt_s) +
                        (s.dt_is_default ? " (the default, dt_CG)" : "") +
                        ": above the stable step 2 / omega_max of solid model \"" + s.model +
                        "\"; the largest allowed is " + fmt("%.6g", stable_s) + " s");
}

int run(const SolidScene& s, SolidModel& model, bool quiet) {
  create_output_directory(s);
  protocol::write_provenance_files(s.output_dir);  // OUTPUT/scene.toml, provenance_solid.toml
  create_output_directory(s);  // before the run, not after it
  const double dt_au = s.dt_s / PhysicalConstants::time_au_s;
  const Eigen::Index n = model.num_cgps();
  const std::vector<double> f = model.vacuum_eigenfrequencies_hz();
  const bool dynamic = !f.empty();

  if (s.mode == SolidRunMode::Free && s.tip_displacement_bohr != 0.0) {
    if (dynamic)
      apply_initial_deflection(s.config, s.tip_displacement_bohr, s.deflection_shape, model);
    else
      std::printf("  note     model \"%s\" has no dynamics: the perturbation is not applied\n",
                  s.model.c_str());
  }

  // The constant part of the external force: the pressure load along each sheet's normal.
  Eigen::Matrix3Xd load = Eigen::Matrix3Xd::Zero(3, n);
  if (s.mode == SolidRunMode::Static) {
    for (std::size_t k = 0; k < s.config.sheets.size(); ++k) {
      const SheetSpec& sh = s.config.sheets[k];
      const double cell_m2 = sh.cell_area_bohr2() * PhysicalConstants::bohr_m * PhysicalConstants::bohr_m;
      const double force_au = s.pressure_Pa * cell_m2 / UnitConverter::force_au_N();
      load.middleCols(first_cgp(s.config, k), sh.num_cgps()).colwise() = force_au * sheet_normal(sh);
    }
  }
  // Damping rate 2 zeta omega_1 (1 / t_AU) of the dynamic relaxation; 0 without dynamics.
  const double damping =
      s.mode == SolidRunMode::Static && dynamic
          ? 2.0 * s.damping_ratio * 2.0 * std::numbers::pi * f[0] * PhysicalConstants::time_au_s
          : 0.0;
  const Eigen::RowVectorXd mass = model.masses().transpose();

  std::vector<Eigen::Vector3d> normals;
  for (const SheetSpec& sh : s.config.sheets) normals.push_back(sheet_normal(sh));
  Series series;
  series.sheets = int(s.config.sheets.size());
  // Records the current state; false (after printing the diagnosis) if an energy is not
  // finite.
  const auto record = [&](std::int64_t k) {
    const SolidObservables o = model.observables();
    const double ek = joule_from_hartree(o.kinetic_energy_au);
    const double ee = joule_from_hartree(o.elastic_energy_au);
    if (!std::isfinite(ek) || !std::isfinite(ee)) {
      const auto [l, v] = fastest_cgp(model);
      std::fflush(stdout);
      solid_log().error() << log::printf_text("non-finite energy, run stopped: substep %lld: kinetic %g J, elastic "
                                              "%g J; fastest %s at %g m/s",
                                              static_cast<long long>(k), ek, ee, describe_cgp(s.config, l).c_str(),
                                              v * UnitConverter::velocity_au_m_s());
      return false;
    }
    series.substep.push_back(k);
    series.time_s.push_back(double(k) * s.dt_s);
    for (int sh = 0; sh < series.sheets; ++sh) {
      const Eigen::Vector3d d = o.marked_displacement_bohr[std::size_t(sh)];
      for (int c = 0; c < 3; ++c) series.displacement_um.push_back(um_from_bohr(d[c]));
      series.normal_um.push_back(um_from_bohr(d.dot(normals[std::size_t(sh)])));
    }
    series.kinetic_J.push_back(ek);
    series.elastic_J.push_back(ee);
    series.total_J.push_back(ek + ee);
    return true;
  };

  Progress progress(solid_log(quiet ? log::Level::info : log::Level::progress), s.substeps, s.dt_s);
  const auto stop = [&](std::int64_t k, const std::string& problem) {
    progress.clear();
    std::fflush(stdout);
    solid_log().error() << "non-finite state, run stopped: substep " << k << ", " << one_line(problem);
    write_series(s, series);  // the finite records before it
    return exit_code::unhealthy;
  };

  std::optional<SheetSnapshotWriter> snapshots;
  if (s.sheets_every > 0) snapshots.emplace(s.output_dir, s.config);
  const auto snapshot = [&](std::int64_t k) {
    if (snapshots && sheet_snapshot_due(k, s.substeps, s.sheets_every))
      snapshots->write(k, double(k) * s.dt_s, model);
  };

  if (const std::string bad = non_finite_state(model, s.config); !bad.empty()) return stop(0, bad);
  if (!record(0)) {
    write_series(s, series);
    return exit_code::unhealthy;
  }
  snapshot(0);
  Eigen::Matrix3Xd external = load;
  for (std::int64_t k = 1; k <= s.substeps; ++k) {
    if (damping > 0.0)
      external = load - damping * (model.velocities().array().rowwise() * mass.array()).matrix();
    try {
      model.substep(dt_au, external);
    } catch (const std::exception& e) {
      if (const std::string bad = non_finite_state(model, s.config); !bad.empty())
        return stop(k, bad);
      throw std::runtime_error("substep " + std::to_string(k) + ": " + e.what());
    }
    if (const std::string bad = non_finite_state(model, s.config); !bad.empty())
      return stop(k, bad);
    if (k % s.record_every == 0 || k == s.substeps) {
      if (!record(k)) {
        progress.clear();
        write_series(s, series);
        return exit_code::unhealthy;
      }
    }
    snapshot(k);
    progress.update(k);
  }
  progress.clear();
  write_series(s, series);
  const double wall = progress.elapsed_s();
  solid_log().info() << log::printf_text("done, %lld substeps (%.5g us) in %.1f s, %.3g us per CGP substep; %zu "
                                         "records in %s",
                                         static_cast<long long>(s.substeps), double(s.substeps) * s.dt_s * 1e6, wall,
                                         n > 0 ? wall / double(s.substeps) / double(n) * 1e6 : 0.0, series.rows(),
                                         (std::filesystem::path(s.output_dir) / "solid.h5").string().c_str());
  if (snapshots)
    solid_log().info() << snapshots->count() << " sheet snapshots in " << snapshots->xdmf_path().string();
  if (s.mode == SolidRunMode::Free)
    print_free_summary(model, series);
  else
    print_static_summary(s, model, series);
  return exit_code::ok;
}

int main_impl(int argc, char** argv) {
  CLI::App app{
      "Runs a solid model on its own (no fluid): free vibration from a perturbation, or the "
      "static deflection under a uniform pressure; or, for a scene with [coupling], coupled to "
      "the fluid over LCM.\nExit status: 0 done, 1 output/system error, 2 invalid scene, "
      "command line or model (coupled: also a refused handshake or a malformed message), 3 "
      "non-finite state, 4 (coupled) the fluid was lost or stopped with an error.",
      "solid"};
  std::string scene_path, output, token, channel_prefix, lcm_url;
  std::int64_t substeps = 0, time_ratio = 0;
  bool quiet = false, check = false;
  app.add_option("scene", scene_path, "solid scene file (TOML), e.g. scenes/sheet_free_vibration.toml")
      ->required();
  CLI::Option* o_substeps = app.add_option("--substeps", substeps, "number of substeps (run.substeps)");
  CLI::Option* o_output = app.add_option("--output", output, "output directory (output.directory)");
  CLI::Option* o_token =
      app.add_option("--token", token, "coupled: the run's token (default: $COSIM_RUN_TOKEN)");
  CLI::Option* o_prefix = app.add_option("--channel-prefix", channel_prefix,
                                         "coupled: LCM channel prefix (coupling.channel_prefix)");
  CLI::Option* o_url = app.add_option("--lcm-url", lcm_url, "coupled: LCM URL (coupling.lcm_url)");
  CLI::Option* o_time_ratio = app.add_option(
      "--time-ratio", time_ratio,
      "coupled: A_T, substeps per LB step (coupling.time_ratio; the launcher's watchdog retry)");
  std::string restart;
  app.add_option("--restart", restart,
                 "coupled: continue from this checkpoint (OUTPUT/checkpoints/solid_N.h5); the "
                 "fluid restarts from its checkpoint of the same step (launch/run-coupled.sh "
                 "--restart DIR picks both)");
  std::string faults;
  CLI::Option* o_faults = app.add_option(
      "--faults", faults,
      "coupled, tests: inject transport faults into what the solid publishes, e.g. "
      "drop=0.01,duplicate=0.01,reorder=0.01,delay=0.01,delay_ms=20,seed=1 (default: "
      "$COSIM_FAULTS; protocol/fault_injection.hpp)");
  app.add_flag("--quiet", quiet, "no progress line on stderr");
  app.add_flag("--check", check, "validate the scene, build the model, print the header, and exit");
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, "solid")) return *code;

  SolidScene scene;
  std::unique_ptr<SolidModel> model;
  try {
    scene = load_solid_scene(scene_path);
    SolidSceneOverrides ov;
    if (o_substeps->count()) ov.substeps = substeps;
    if (o_output->count()) ov.output_dir = output;
    if (o_prefix->count()) ov.channel_prefix = channel_prefix;
    if (o_url->count()) ov.lcm_url = lcm_url;
    if (o_time_ratio->count()) ov.time_ratio = time_ratio;
    apply_overrides(scene, ov);
    if (o_token->count() && !scene.coupled())
      throw SolidSceneError("command line: --token: only for a coupled scene (one with a "
                            "[coupling] section)");
    if (!scene.coupled()) {
      model = build_model(scene);
      check_time_step(scene, *model);
    }
  } catch (const SolidSceneError& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "%s\n", one_line(e.what()).c_str());
    return exit_code::bad_input;
  }
  protocol::record_scene(scene.path);
  if (scene.coupled()) {
    protocol::catch_interrupts();  // before any thread starts (OpenMP, LCM)
    CoupledSolidOptions co;
    co.token = token;
    if (!o_token->count())
      if (const char* env = std::getenv("COSIM_RUN_TOKEN")) co.token = env;
    co.quiet = quiet;
    co.check_only = check;
    co.restart = restart;
    try {
      co.read_environment();  // the run id, --new-time-ratio, the run's key
      co.faults = protocol::fault_settings_from(o_faults->count() ? &faults : nullptr);
    } catch (const std::invalid_argument& e) {
      std::fflush(stdout);
      solid_log().error() << e.what();
      return exit_code::bad_input;
    }
    std::fflush(stdout);
    return run_coupled_solid(scene, co, std::cout, std::cerr);
  }
  print_header(scene, *model);
  if (check) return exit_code::ok;
  try {
    return run(scene, *model, quiet);
  } catch (const std::invalid_argument& e) {
    // restore() refusing the perturbed state, or a model refusing its inputs.
    std::fflush(stdout);
    std::fprintf(stderr, "%s: solid.model = \"%s\": %s\n", scene.path.c_str(), scene.model.c_str(),
                 one_line(e.what()).c_str());
    return exit_code::bad_input;
  }
}

}  // namespace
}  // namespace cosim::solid

int main(int argc, char** argv) {
  try {
    return cosim::solid::main_impl(argc, argv);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    cosim::solid::solid_log().error() << cosim::solid::one_line(e.what());
    return cosim::protocol::exit_code::system;
  }
}
