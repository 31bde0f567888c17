#include "solid/io/coupled_series.hpp"

#include <hdf5.h>

#include <algorithm>
#include <stdexcept>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "solid/io/solid_h5.hpp"

namespace cosim::solid {

std::vector<std::pair<const char*, std::vector<double>*>> CoupledSeries::columns() {
  return {{"time_s", &time_s},
          {"solid_time_s", &solid_time_s},
          {"displacement_um", &displacement_um},
          {"normal_um", &normal_um},
          {"fluid_force_N", &fluid_force_N},
          {"kinetic_J", &kinetic_J},
          {"elastic_J", &elastic_J},
          {"total_J", &total_J},
          {"bulk_velocity_m_s", &bulk_velocity_m_s},
          {"force_coefficients", &force_coefficients},
          {"edge_strain", &edge_strain}};
}

namespace {

/// One extendible dataset of the file: `per_row` values a row, rows of shape `row_dims`.
struct SeriesColumn {
  const char* name;
  hid_t file_type, mem_type;
  std::vector<hsize_t> row_dims;
  protocol::H5Id set;
};

}  // namespace

struct CoupledSeriesFile::Impl {
  std::string path;
  protocol::H5Id file;
  std::vector<SeriesColumn> columns;
  std::size_t rows = 0;
  /// The data of column k, in the order of `columns`.
  static std::vector<const void*> sources(CoupledSeries& s) {
    return {s.step.data(),          s.time_s.data(),           s.solid_time_s.data(),     s.displacement_um.data(),
            s.normal_um.data(),     s.fluid_force_N.data(),    s.bulk_velocity_m_s.data(), s.force_coefficients.data(),
            s.edge_strain.data(),   s.kinetic_J.data(),        s.elastic_J.data(),        s.total_J.data()};
  }
};

CoupledSeriesFile::CoupledSeriesFile(const std::string& path, const CoupledSeries::Attributes& a, CoupledSeries& s)
    : impl_(std::make_unique<Impl>()) {
  const protocol::H5Quiet quiet;
  Impl& m = *impl_;
  m.path = path;
  m.file = protocol::create_output_file(path, "cannot create " + path);
  const hsize_t ns = static_cast<hsize_t>(s.sheets);
  const auto column = [&](const char* name, hid_t file_type, hid_t mem_type, std::vector<hsize_t> row_dims) {
    const std::string what = path + ": cannot create the dataset " + std::string(name);
    std::vector<hsize_t> dims{0}, max{H5S_UNLIMITED}, chunk{256};
    for (const hsize_t d : row_dims) {
      dims.push_back(d);
      max.push_back(d);
      chunk.push_back(std::max<hsize_t>(d, 1));
    }
    const protocol::H5Id space(H5Screate_simple(int(dims.size()), dims.data(), max.data()), H5Sclose, what);
    const protocol::H5Id plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, what);
    protocol::h5_check(H5Pset_chunk(plist.get(), int(chunk.size()), chunk.data()), what);
    protocol::H5Id set(
        H5Dcreate2(m.file.get(), name, file_type, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT), H5Dclose,
        what);
    m.columns.push_back({name, file_type, mem_type, std::move(row_dims), std::move(set)});
  };
  const hid_t f64 = H5T_IEEE_F64LE, d = H5T_NATIVE_DOUBLE;
  column("step", H5T_STD_I64LE, H5T_NATIVE_INT64, {});
  column("time_s", f64, d, {});
  column("solid_time_s", f64, d, {});
  column("marked_displacement_um", f64, d, {ns, 3});
  column("marked_normal_displacement_um", f64, d, {ns});
  column("fluid_force_N", f64, d, {ns, 3});
  column("bulk_velocity_m_s", f64, d, {});
  column("force_coefficients", f64, d, {ns, 3});
  column("leading_edge_strain", f64, d, {ns, 3});
  column("kinetic_energy_J", f64, d, {});
  column("elastic_energy_J", f64, d, {});
  column("total_energy_J", f64, d, {});
  try {
    write_attribute(m.file.get(), "scene", a.scene);
    write_attribute(m.file.get(), "model", a.model);
    write_attribute(m.file.get(), "mode", "coupled");
    write_attribute(m.file.get(), "token", a.token);
    write_attribute(m.file.get(), "dt_s", a.dt_cg_s);
    write_attribute(m.file.get(), "dt_lb_s", a.dt_lb_s);
    write_attribute(m.file.get(), "time_ratio", static_cast<double>(a.time_ratio));
    write_attribute(m.file.get(), "total_steps", static_cast<double>(a.total_steps));
    write_attribute(m.file.get(), "rigid_steps", static_cast<double>(a.rigid_steps));
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  protocol::stamp_file(m.file.get());  // provenance, and the units of every column
  append(s);
}

CoupledSeriesFile::~CoupledSeriesFile() = default;

void CoupledSeriesFile::append(CoupledSeries& s) {
  Impl& m = *impl_;
  const std::size_t n = s.rows();
  if (n <= m.rows || !m.file.get()) return;
  const protocol::H5Quiet quiet;
  const std::vector<const void*> data = Impl::sources(s);
  for (std::size_t k = 0; k < m.columns.size(); ++k) {
    SeriesColumn& c = m.columns[k];
    const std::string what = m.path + ": cannot append to " + c.name;
    std::vector<hsize_t> extent{n}, start{m.rows}, count{n - m.rows};
    hsize_t per_row = 1;
    for (const hsize_t dim : c.row_dims) {
      extent.push_back(dim);
      start.push_back(0);
      count.push_back(dim);
      per_row *= dim;
    }
    protocol::h5_check(H5Dset_extent(c.set.get(), extent.data()), what);
    if (per_row == 0) continue;
    const protocol::H5Id file_space(H5Dget_space(c.set.get()), H5Sclose, what);
    protocol::h5_check(
        H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), what);
    const protocol::H5Id mem_space(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose, what);
    const std::size_t bytes = H5Tget_size(c.mem_type);
    const auto* from = static_cast<const char*>(data[k]) + m.rows * per_row * bytes;
    protocol::h5_check(H5Dwrite(c.set.get(), c.mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, from),
                       what);
  }
  m.rows = n;
  protocol::h5_check(H5Fflush(m.file.get(), H5F_SCOPE_LOCAL), m.path + ": cannot flush");
}

void CoupledSeriesFile::close() {
  const protocol::H5Quiet quiet;
  impl_->columns.clear();
  impl_->file.close("cannot close " + impl_->path);
}

std::size_t CoupledSeriesFile::rows() const { return impl_->rows; }
const std::string& CoupledSeriesFile::path() const { return impl_->path; }

}  // namespace cosim::solid
