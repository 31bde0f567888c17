// The time series of a coupled run, OUTPUT/solid.h5 (protocol/README.md section 10 keeps it
// in the solid's checkpoints too): one row per LB step, step 0 included, kept in memory and
// appended to solid.h5 as the run goes (CoupledSeriesFile), like monitor.h5, so that a
// killed solid leaves its rows (KilledSolidLeavesItsRows).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace cosim::solid {

struct CoupledSeries {
  int sheets = 0;
  std::vector<std::int64_t> step;
  std::vector<double> time_s, solid_time_s, displacement_um, normal_um, fluid_force_N, kinetic_J,
      elastic_J, total_J;
  /// U_b (Eq. 34) of the fluid_state_t behind each row, m/s; 0 at step 0.
  std::vector<double> bulk_velocity_m_s;
  /// C_x, C_y, C_z of each sheet (Eq. 33: F / (rho_f U_b^2 W H / 2)); C_D = C_x, and the
  /// lift is C_z (span-wise) for a sheet turned about y, C_y normal to the plate.
  std::vector<double> force_coefficients;
  /// Area strain at the bottom, middle and top of each sheet's leading edge (Figs. 11, 14).
  std::vector<double> edge_strain;

  std::size_t rows() const { return step.size(); }

  /// The double columns by name: one table for writing a checkpoint and reading it back.
  std::vector<std::pair<const char*, std::vector<double>*>> columns();

  /// What solid.h5 says of the run besides its columns.
  struct Attributes {
    std::string scene, model, token;
    double dt_cg_s = 0.0, dt_lb_s = 0.0;
    int time_ratio = 0;
    std::int64_t total_steps = 0, rigid_steps = 0;
  };
};

/// solid.h5 as the run goes: created (an existing file replaced) with the attributes and the
/// rows recorded so far, then append() adds the rows recorded since and flushes the file.
/// Datasets (n rows, S sheets): step [n] int64, time_s [n], solid_time_s [n],
/// marked_displacement_um [n][S][3], marked_normal_displacement_um [n][S],
/// fluid_force_N [n][S][3], bulk_velocity_m_s [n], force_coefficients [n][S][3],
/// leading_edge_strain [n][S][3], kinetic_energy_J, elastic_energy_J, total_energy_J [n].
/// Every error is a std::runtime_error of one line naming the file.
class CoupledSeriesFile {
 public:
  CoupledSeriesFile(const std::string& path, const CoupledSeries::Attributes& a, CoupledSeries& s);
  ~CoupledSeriesFile();
  CoupledSeriesFile(const CoupledSeriesFile&) = delete;
  CoupledSeriesFile& operator=(const CoupledSeriesFile&) = delete;

  /// Appends the rows of `s` after those written, and flushes.
  void append(CoupledSeries& s);
  /// Closes the file (its last metadata written).
  void close();
  std::size_t rows() const;
  const std::string& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cosim::solid
