// The force on a held body (fluid/ib/held_body.hpp) as a time series: held_body.csv beside
// monitor.h5 in the output folder of a fluid-only or a coupled run (where the sheets' force
// comes beside it: Turek and Hron's cylinder with its elastic bar).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "fluid/ib/immersed_boundary.hpp"
#include "protocol/units.hpp"

namespace cosim::fluid {

/// The factor from a lattice force summed over a span of `nz` cells to newtons per metre of
/// depth: rho c^2 dx / nz (F_LB of Eq. 28 over the span's dx nz).
inline double held_body_newtons_per_m(const protocol::UnitConverter& units, int nz) {
  return units.force_lb_N() / units.dx_m() / double(nz);
}

/// held_body.csv: a header line, then one row per record() with
///   step, time_s, drag_N_per_m, lift_N_per_m
/// (the step and time at the end of the interval; drag and lift the mean over the interval's
/// steps of the force on the body per unit depth, x and y); with `sheets` (a coupled run)
/// four more columns
///   sheet_drag_N_per_m, sheet_lift_N_per_m, total_drag_N_per_m, total_lift_N_per_m
/// the fluid's force on the sheets (minus the sum of their impulses J_l of the step, as for
/// the body) and the sum of both: the force on the body with its sheets. Written anew,
/// flushed after every row. Throws std::runtime_error (one line) on I/O failure.
class HeldBodyLog {
 public:
  /// `newtons_per_m`: the factor from a lattice force summed over the span to N per metre of
  /// depth (rho c^2 dx / nz).
  HeldBodyLog(const std::string& path, double dt_s, double newtons_per_m, bool sheets = false);
  ~HeldBodyLog();
  HeldBodyLog(const HeldBodyLog&) = delete;
  HeldBodyLog& operator=(const HeldBodyLog&) = delete;

  /// The force of one step (lattice units, the whole span).
  void add(const Vec3& force);
  /// The forces of one step on the body and on the sheets (lattice units). @pre sheets
  void add(const Vec3& body, const Vec3& sheets);
  /// Writes the mean of the forces added since the last row, at `step`.
  void record(std::int64_t step);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  double dt_s_, scale_;
  bool sheets_;
  Vec3 sum_{0.0, 0.0, 0.0}, sheet_sum_{0.0, 0.0, 0.0};
  std::int64_t count_ = 0;
};

}  // namespace cosim::fluid
