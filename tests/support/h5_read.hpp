// Reading a test's HDF5 output back with the HDF5 C API: one dataset converted to the
// caller's type with its dimensions, the rows of a dataset, an attribute of the root group.
// Each opens the file read-only and closes everything it opened; what cannot be read comes
// back empty (or -1 rows), for the test to assert on.
#pragma once

#include <hdf5.h>

#include <filesystem>
#include <string>
#include <vector>

namespace cosim::test {

/// Dataset `name` of `file` converted to T by HDF5 (`mem_type`, e.g. H5T_NATIVE_DOUBLE), its
/// dimensions in `dims` (where not null); empty if the file, the dataset or the read fails.
template <class T>
std::vector<T> read_dataset(const std::filesystem::path& file, const char* name, hid_t mem_type,
                            std::vector<hsize_t>* dims = nullptr) {
  std::vector<T> out;
  std::vector<hsize_t> shape;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    if (dims != nullptr) dims->clear();
    return out;
  }
  const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d >= 0) {
    const hid_t s = H5Dget_space(d);
    shape.assign(std::size_t(H5Sget_simple_extent_ndims(s)), 0);
    H5Sget_simple_extent_dims(s, shape.data(), nullptr);
    hsize_t n = 1;
    for (const hsize_t k : shape) n *= k;
    out.resize(n);
    if (H5Dread(d, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) out.clear();
    H5Sclose(s);
    H5Dclose(d);
  }
  H5Fclose(f);
  if (dims != nullptr) *dims = shape;
  return out;
}

/// The rows (first dimension) of dataset `name` of `file`; -1 if it cannot be read.
inline long long dataset_rows(const std::filesystem::path& file, const char* name) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return -1;
  long long rows = -1;
  const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d >= 0) {
    const hid_t space = H5Dget_space(d);
    hsize_t dims[3] = {0, 0, 0};
    if (space >= 0 && H5Sget_simple_extent_dims(space, dims, nullptr) >= 1)
      rows = static_cast<long long>(dims[0]);
    if (space >= 0) H5Sclose(space);
    H5Dclose(d);
  }
  H5Fclose(f);
  return rows;
}

/// Attribute `name` of the root group of `file` read as T (`mem_type`); T{} if it cannot be read.
template <class T>
T read_attribute(const std::filesystem::path& file, const char* name, hid_t mem_type) {
  T v{};
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return v;
  const hid_t a = H5Aopen(f, name, H5P_DEFAULT);
  if (a >= 0) {
    H5Aread(a, mem_type, &v);
    H5Aclose(a);
  }
  H5Fclose(f);
  return v;
}

/// A string attribute of the root group of `file` ("" if it cannot be read).
inline std::string root_attribute(const std::filesystem::path& file, const char* name) {
  std::string value;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return value;
  if (H5Aexists(f, name) > 0) {
    const hid_t a = H5Aopen(f, name, H5P_DEFAULT);
    const hid_t t = H5Aget_type(a);
    value.resize(H5Tget_size(t));
    if (H5Aread(a, t, value.data()) < 0) value.clear();
    while (!value.empty() && value.back() == '\0') value.pop_back();
    H5Tclose(t);
    H5Aclose(a);
  }
  H5Fclose(f);
  return value;
}

}  // namespace cosim::test
