#include "tools/conformance/solid_energy.hpp"

#include <hdf5.h>

#include <exception>
#include <filesystem>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"

namespace cosim::conformance {

namespace {

using protocol::H5Id;

/// The 1-D dataset `name` of `file` as `mem_type` values.
template <class T>
std::vector<T> column(hid_t file, const std::string& name, hid_t mem_type, const std::string& what) {
  const H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, what + ": cannot open " + name);
  const H5Id space(H5Dget_space(set.get()), H5Sclose, what);
  if (H5Sget_simple_extent_ndims(space.get()) != 1) throw std::runtime_error(what + ": " + name + " is not one column");
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) protocol::h5_fail(what);
  std::vector<T> v(static_cast<std::size_t>(n));
  if (n > 0) protocol::h5_check(H5Dread(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), what + ": " + name);
  return v;
}

}  // namespace

SolidEnergies read_solid_energies(const std::string& path) {
  SolidEnergies e;
  if (!std::filesystem::exists(path)) {
    e.none = "the solid wrote no " + path;
    return e;
  }
  try {
    const protocol::H5Quiet quiet;
    const std::string what = "cannot read " + path;
    const H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, what);
    if (H5Lexists(file.get(), "total_energy_J", H5P_DEFAULT) <= 0) {
      e.none = path + " has no total_energy_J";
      return e;
    }
    e.step = column<std::int64_t>(file.get(), "step", H5T_NATIVE_INT64, what);
    e.total_J = column<double>(file.get(), "total_energy_J", H5T_NATIVE_DOUBLE, what);
    if (e.step.size() != e.total_J.size())
      throw std::runtime_error(path + ": " + std::to_string(e.step.size()) + " steps but " +
                               std::to_string(e.total_J.size()) + " total_energy_J");
  } catch (const std::exception& x) {
    e = SolidEnergies{};
    e.none = x.what();
  }
  return e;
}

}  // namespace cosim::conformance
