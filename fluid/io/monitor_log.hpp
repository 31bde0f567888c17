// Time series of the fluid's health observables (DESIGN 4.4) in an HDF5 file.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "fluid/observables/flow_monitor.hpp"

namespace cosim::fluid {

/// monitor.h5: one row per append() in extendible datasets (lattice units unless named)
///   step [n] int64, time_us [n], mass [n], momentum [n][3], max_mach [n], rho_min [n],
///   rho_max [n], max_mach_cell / rho_min_cell / rho_max_cell / nan_cell [n][3] int32
///   (x, y, z; -1 where none), has_nan [n] int8.
/// The file is created anew (an existing one is replaced) and flushed after every row, so
/// a run that crashes keeps what it wrote. Throws std::runtime_error (one line) on I/O
/// failure.
class MonitorLog {
 public:
  /// @pre dt_us > 0
  MonitorLog(const std::string& path, double dt_us);
  ~MonitorLog();
  MonitorLog(MonitorLog&&) noexcept;
  MonitorLog& operator=(MonitorLog&&) noexcept;

  void append(const FlowSummary& s);
  std::int64_t rows() const;
  const std::string& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One human-readable line for stdout: step, t [us], mass drift (mass - mass0) / mass0,
/// total momentum, max Mach and where, rho range, and the first non-finite cell if any.
std::string format_summary(const FlowSummary& s, double dt_us, double mass0);

}  // namespace cosim::fluid
