#include "sdk/solid_series.hpp"

#include <hdf5.h>

#include <cmath>
#include <utility>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "common/run/checkpoint_file.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance_h5.hpp"

namespace cosim::sdk {

SolidSeries::SolidSeries(const protocol::UnitConverter& units, std::string model, Eigen::Index markers)
    : units_(units), model_(std::move(model)), n_(markers) {}

void SolidSeries::add(std::int64_t step, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j, double energy_lb,
                      double work_lb) {
  steps_.push_back(step);
  time_s_.push_back(static_cast<double>(step) * units_.dt_lb_s());
  const double um = units_.dx_m() * 1e6, newton = units_.force_lb_N();
  for (Eigen::Index l = 0; l < n_; ++l)
    for (int c = 0; c < 3; ++c) {
      x_um_.push_back(x(c, l) * um);
      force_N_.push_back(-j(c, l) * newton);
    }
  const double joule = units_.energy_lb_J();
  energy_ = energy_ || std::isfinite(energy_lb);
  energy_J_.push_back(energy_lb * joule);
  work_J_.push_back(work_lb * joule);
}

void SolidSeries::write(const std::string& path) const {
  using protocol::H5Id;
  const protocol::H5Quiet quiet;
  const std::string what = "cannot write " + path;
  H5Id file = protocol::create_output_file(path, what);
  const hsize_t n = steps_.size(), m = static_cast<hsize_t>(n_);
  protocol::write_dataset(file.get(), "step", H5T_STD_I64LE, H5T_NATIVE_INT64, {n}, steps_.data());
  protocol::write_dataset(file.get(), "time_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, time_s_.data());
  protocol::write_dataset(file.get(), "marker_position_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, m, 3}, x_um_.data());
  protocol::write_dataset(file.get(), "marker_force_N", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, m, 3}, force_N_.data());
  if (energy_) {
    protocol::write_dataset(file.get(), "total_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, energy_J_.data());
    protocol::write_dataset(file.get(), "fluid_work_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, work_J_.data());
  }
  protocol::put_attribute(file.get(), "model", model_);
  protocol::put_attribute(file.get(), "num_markers", static_cast<double>(n_));
  protocol::stamp_file(file.get());
  file.close(what);
}

void SolidSeries::save(protocol::CheckpointWriter& w) const {
  w.put("series_step", steps_);
  w.put("series_marker_position_um", x_um_);
  w.put("series_marker_force_N", force_N_);
  w.put("series_total_energy_J", energy_J_);
  w.put("series_fluid_work_J", work_J_);
}

bool SolidSeries::restore(const protocol::CheckpointReader& r) {
  if (!r.has("series_step")) return false;
  std::vector<std::int64_t> steps = r.int64s("series_step");
  const std::size_t n = steps.size(), values = n * static_cast<std::size_t>(n_) * 3;
  std::vector<double> x = r.doubles("series_marker_position_um", values), f = r.doubles("series_marker_force_N", values),
                      e = r.doubles("series_total_energy_J", n), w = r.doubles("series_fluid_work_J", n);
  steps_ = std::move(steps);
  time_s_.clear();
  for (const std::int64_t s : steps_) time_s_.push_back(static_cast<double>(s) * units_.dt_lb_s());
  x_um_ = std::move(x);
  force_N_ = std::move(f);
  energy_J_ = std::move(e);
  work_J_ = std::move(w);
  energy_ = false;
  for (const double v : energy_J_) energy_ = energy_ || std::isfinite(v);
  return true;
}

}  // namespace cosim::sdk
