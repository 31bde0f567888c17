#include "fluid/io/monitor_log.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <vector>

#include "fluid/io/hdf5_handle.hpp"
#include "fluid/io/hdf5_quiet.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance_h5.hpp"

namespace cosim::fluid {

namespace {

/// One extendible dataset [n] (width 1) or [n][width], 512 rows a chunk.
protocol::SeriesDataset make_column(hid_t file, const char* name, hid_t file_type, hid_t mem_type, int width) {
  constexpr hsize_t kChunkRows = 512;
  std::vector<hsize_t> row_dims;
  if (width != 1) row_dims.push_back(hsize_t(width));
  return protocol::SeriesDataset(file, name, file_type, mem_type, std::move(row_dims), kChunkRows,
                                 std::string("the monitor dataset ") + name);
}

std::array<std::int32_t, 3> cell_row(const CellIndex& c) { return {c.x, c.y, c.z}; }

}  // namespace

struct MonitorLog::Impl {
  std::string path;
  double dt_us;
  H5Id file;
  std::vector<protocol::SeriesDataset> columns;
  std::int64_t rows = 0;
};

MonitorLog::MonitorLog(const std::string& path, double dt_us) : impl_(std::make_unique<Impl>()) {
  if (!(dt_us > 0.0)) throw std::invalid_argument("MonitorLog: dt_us must be positive, got " + std::to_string(dt_us));
  impl_->path = path;
  impl_->dt_us = dt_us;
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
    if (ec) throw std::runtime_error("cannot create the directory " + parent.string() + ": " + ec.message());
  }
  const H5Quiet quiet;
  impl_->file = protocol::create_output_file(path, "cannot create the monitor file " + path);
  const hid_t f = impl_->file.get();
  auto& c = impl_->columns;
  c.push_back(make_column(f, "step", H5T_STD_I64LE, H5T_NATIVE_INT64, 1));
  c.push_back(make_column(f, "time_us", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1));
  c.push_back(make_column(f, "mass", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1));
  c.push_back(make_column(f, "momentum", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 3));
  c.push_back(make_column(f, "max_mach", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1));
  c.push_back(make_column(f, "rho_min", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1));
  c.push_back(make_column(f, "rho_max", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1));
  c.push_back(make_column(f, "max_mach_cell", H5T_STD_I32LE, H5T_NATIVE_INT32, 3));
  c.push_back(make_column(f, "rho_min_cell", H5T_STD_I32LE, H5T_NATIVE_INT32, 3));
  c.push_back(make_column(f, "rho_max_cell", H5T_STD_I32LE, H5T_NATIVE_INT32, 3));
  c.push_back(make_column(f, "nan_cell", H5T_STD_I32LE, H5T_NATIVE_INT32, 3));
  c.push_back(make_column(f, "has_nan", H5T_STD_I8LE, H5T_NATIVE_INT8, 1));
  protocol::stamp_file(f);
  h5_check(H5Fflush(f, H5F_SCOPE_LOCAL), "cannot flush the monitor file " + path);
  h5_check(H5Fflush(f, H5F_SCOPE_LOCAL), "cannot flush the monitor file " + path);
}

MonitorLog::~MonitorLog() = default;
MonitorLog::MonitorLog(MonitorLog&&) noexcept = default;
MonitorLog& MonitorLog::operator=(MonitorLog&&) noexcept = default;

std::int64_t MonitorLog::rows() const { return impl_->rows; }
const std::string& MonitorLog::path() const { return impl_->path; }

void MonitorLog::append(const FlowSummary& s) {
  const H5Quiet quiet;
  const double time_us = double(s.step) * impl_->dt_us;
  const std::array<std::int32_t, 3> cells[4] = {cell_row(s.max_mach_cell), cell_row(s.rho_min_cell),
                                                cell_row(s.rho_max_cell), cell_row(s.nan_cell)};
  const std::int8_t has_nan = s.has_nan ? 1 : 0;
  const void* data[] = {&s.step,        &time_us,   &s.mass,      s.momentum.data(), &s.max_mach,
                        &s.rho_min,     &s.rho_max, cells[0].data(), cells[1].data(), cells[2].data(),
                        cells[3].data(), &has_nan};
  auto& c = impl_->columns;
  static_assert(sizeof data / sizeof data[0] == 12);
  for (std::size_t k = 0; k < c.size(); ++k) c[k].append(data[k], 1);
  ++impl_->rows;
  h5_check(H5Fflush(impl_->file.get(), H5F_SCOPE_LOCAL), "cannot flush the monitor file " + impl_->path);
}

std::string format_summary(const FlowSummary& s, double dt_us, double mass0) {
  const double drift = mass0 != 0.0 ? (s.mass - mass0) / mass0 : s.mass - mass0;
  char buf[384];
  int n = std::snprintf(buf, sizeof buf,
                        "step %lld  t = %.6g us  mass drift %+.3e  momentum (%+.4e, %+.4e, %+.4e)  "
                        "max Mach %.4f at (%d, %d, %d)  rho [%.6f, %.6f]",
                        static_cast<long long>(s.step), double(s.step) * dt_us, drift, s.momentum[0],
                        s.momentum[1], s.momentum[2], s.max_mach, s.max_mach_cell.x, s.max_mach_cell.y,
                        s.max_mach_cell.z, s.rho_min, s.rho_max);
  std::string line(buf, std::size_t(std::max(0, std::min(n, int(sizeof buf) - 1))));
  if (s.has_nan) {
    std::snprintf(buf, sizeof buf, "  NON-FINITE at (%d, %d, %d)", s.nan_cell.x, s.nan_cell.y, s.nan_cell.z);
    line += buf;
  }
  return line;
}

}  // namespace cosim::fluid
