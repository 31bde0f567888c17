#include "solid/coupled_series.hpp"

#include <hdf5.h>

#include "protocol/hdf5_handle.hpp"
#include "protocol/hdf5_quiet.hpp"
#include "solid/solid_h5.hpp"

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

void CoupledSeries::write(const std::string& path, const Attributes& a) const {
  const protocol::H5Quiet quiet;
  protocol::H5Id file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                      "cannot create " + path);
  const hid_t f = file.get();
  const hsize_t n = rows(), ns = static_cast<hsize_t>(sheets);
  const auto doubles = [&](const char* name, const std::vector<hsize_t>& dims, const std::vector<double>& v) {
    write_dataset(f, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dims, v.data());
  };
  write_dataset(f, "step", H5T_STD_I64LE, H5T_NATIVE_INT64, {n}, step.data());
  doubles("time_s", {n}, time_s);
  doubles("solid_time_s", {n}, solid_time_s);
  doubles("marked_displacement_um", {n, ns, 3}, displacement_um);
  doubles("marked_normal_displacement_um", {n, ns}, normal_um);
  doubles("fluid_force_N", {n, ns, 3}, fluid_force_N);
  doubles("bulk_velocity_m_s", {n}, bulk_velocity_m_s);
  doubles("force_coefficients", {n, ns, 3}, force_coefficients);
  doubles("leading_edge_strain", {n, ns, 3}, edge_strain);
  doubles("kinetic_energy_J", {n}, kinetic_J);
  doubles("elastic_energy_J", {n}, elastic_J);
  doubles("total_energy_J", {n}, total_J);
  write_attribute(f, "scene", a.scene);
  write_attribute(f, "model", a.model);
  write_attribute(f, "mode", "coupled");
  write_attribute(f, "token", a.token);
  write_attribute(f, "dt_s", a.dt_cg_s);
  write_attribute(f, "dt_lb_s", a.dt_lb_s);
  write_attribute(f, "time_ratio", static_cast<double>(a.time_ratio));
  write_attribute(f, "total_steps", static_cast<double>(a.total_steps));
  write_attribute(f, "rigid_steps", static_cast<double>(a.rigid_steps));
  protocol::stamp_file(f);
  file.close("cannot close " + path);
}

}  // namespace cosim::solid
