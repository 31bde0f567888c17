// OUTPUT/solid.h5 of a library solid (sdk/include/cosim/solid.hpp): one row per
// solid_state_t the library sent (the spin-up's and the solid's answers), written when the
// run ends (done or stopped). IO only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "protocol/units.hpp"

namespace cosim::protocol {
class CheckpointWriter;
class CheckpointReader;
}  // namespace cosim::protocol

namespace cosim::sdk {

/// Datasets (n rows, N markers): step [n] int64, time_s [n] (the LB step's end, step x
/// dt_LB), marker_position_um [n][N][3] (X_l), marker_force_N [n][N][3] (the fluid's mean
/// force on each marker over the step, -J_l F_LB), and where the solid reports its energy
/// (Solid::energy_lb) total_energy_J [n] (E after the step) and fluid_work_J [n] (the
/// fluid's work on the markers up to the step before, sdk/energy_balance.hpp; NaN where not
/// yet known). Attributes: model, num_markers; the run's provenance and each dataset's
/// units (common/run/provenance_h5.hpp).
class SolidSeries {
 public:
  SolidSeries(const protocol::UnitConverter& units, std::string model, Eigen::Index markers);

  /// One row; `energy_lb` and `work_lb` NaN when not reported.
  void add(std::int64_t step, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j, double energy_lb,
           double work_lb);
  /// Writes `path` (replaced). @throws std::runtime_error naming the file
  void write(const std::string& path) const;
  std::size_t rows() const { return steps_.size(); }

  /// The rows so far into a checkpoint (datasets series_*), so that a restart's solid.h5
  /// holds the whole run, as the solid server's does.
  void save(protocol::CheckpointWriter& w) const;
  /// The rows of a checkpoint written by save(), in place of these; a checkpoint without
  /// them (an older library's) leaves the series empty and returns false.
  /// @throws std::runtime_error for series datasets that do not fit this solid's markers
  bool restore(const protocol::CheckpointReader& r);

 private:
  const protocol::UnitConverter& units_;
  std::string model_;
  Eigen::Index n_;
  bool energy_ = false;
  std::vector<std::int64_t> steps_;
  std::vector<double> time_s_, x_um_, force_N_, energy_J_, work_J_;
};

}  // namespace cosim::sdk
