// Writing the solid server's time series (OUTPUT/solid.h5) with the HDF5 C API: one dataset
// per quantity, scalar attributes. Shared by the standalone run (main.cpp) and the coupled
// run (coupled_series.cpp); internal to those .cpp files, like common/hdf5/hdf5_handle.hpp.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <string>
#include <vector>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/provenance_h5.hpp"

namespace cosim::solid {

/// A dataset of `dims` (the first dimension may be 0) from `data`, row-major.
inline void write_dataset(hid_t file, const char* name, hid_t file_type, hid_t mem_type,
                          const std::vector<hsize_t>& dims, const void* data) {
  using protocol::H5Id;
  const std::string what = std::string("cannot write the dataset ") + name;
  const H5Id space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose, what);
  const H5Id dset(H5Dcreate2(file, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT,
                             H5P_DEFAULT),
                  H5Dclose, what);
  if (dims.front() > 0)
    protocol::h5_check(H5Dwrite(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
}

inline void write_attribute(hid_t file, const char* name, const std::string& value) {
  protocol::put_string_attribute(file, name, value);
}

inline void write_attribute(hid_t file, const char* name, double value) {
  using protocol::H5Id;
  const std::string what = std::string("cannot write the attribute ") + name;
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose, what);
  const H5Id attr(H5Acreate2(file, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                  H5Aclose, what);
  protocol::h5_check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value), what);
}

}  // namespace cosim::solid
