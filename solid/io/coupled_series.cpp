#include "solid/io/coupled_series.hpp"

#include <hdf5.h>

#include <algorithm>
#include <stdexcept>

#include "common/hdf5/h5_writer.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "common/run/provenance_h5.hpp"

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

struct CoupledSeriesFile::Impl {
  std::string path;
  protocol::H5Id file;
  std::vector<protocol::SeriesDataset> columns;
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
    m.columns.emplace_back(m.file.get(), name, file_type, mem_type, std::move(row_dims), 256,
                           path + ":/" + std::string(name));
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
    protocol::put_attribute(m.file.get(), "scene", a.scene);
    protocol::put_attribute(m.file.get(), "model", a.model);
    protocol::put_attribute(m.file.get(), "mode", "coupled");
    protocol::put_attribute(m.file.get(), "token", a.token);
    protocol::put_attribute(m.file.get(), "dt_s", a.dt_cg_s);
    protocol::put_attribute(m.file.get(), "dt_lb_s", a.dt_lb_s);
    protocol::put_attribute(m.file.get(), "time_ratio", static_cast<double>(a.time_ratio));
    protocol::put_attribute(m.file.get(), "total_steps", static_cast<double>(a.total_steps));
    protocol::put_attribute(m.file.get(), "rigid_steps", static_cast<double>(a.rigid_steps));
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
    protocol::SeriesDataset& c = m.columns[k];
    const std::size_t bytes = H5Tget_size(c.mem_type());
    if (c.rows() < n) c.append(static_cast<const char*>(data[k]) + c.rows() * c.per_row() * bytes, n - c.rows());
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
