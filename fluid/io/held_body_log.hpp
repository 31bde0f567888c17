// The force on a held body (fluid/ib/held_body.hpp) as a time series: held_body.csv beside
// monitor.h5 in a fluid-only run's output folder.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "fluid/ib/immersed_boundary.hpp"

namespace cosim::fluid {

/// held_body.csv: a header line, then one row per record() with
///   step, time_s, drag_N_per_m, lift_N_per_m
/// (the step and time at the end of the interval; drag and lift the mean over the interval's
/// steps of the force on the body per unit depth, x and y). Written anew, flushed after
/// every row. Throws std::runtime_error (one line) on I/O failure.
class HeldBodyLog {
 public:
  /// `newtons_per_m`: the factor from a lattice force summed over the span to N per metre of
  /// depth (rho c^2 dx / nz).
  HeldBodyLog(const std::string& path, double dt_s, double newtons_per_m);
  ~HeldBodyLog();
  HeldBodyLog(const HeldBodyLog&) = delete;
  HeldBodyLog& operator=(const HeldBodyLog&) = delete;

  /// The force of one step (lattice units, the whole span).
  void add(const Vec3& force);
  /// Writes the mean of the forces added since the last row, at `step`.
  void record(std::int64_t step);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  double dt_s_, scale_;
  Vec3 sum_{0.0, 0.0, 0.0};
  std::int64_t count_ = 0;
};

}  // namespace cosim::fluid
