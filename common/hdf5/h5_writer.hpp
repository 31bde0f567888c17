// The one HDF5 writer of the project (HDF5 C API): output files, scalar attributes, datasets
// written whole from a span, datasets reserved for the rows each process writes
// (hdf5_handle.hpp: WriteGroup), appendable (chunked, extendible) series, and the "units"
// attribute of every dataset (dataset_units.hpp). Every dataset any output holds is created
// by create_dataset() below: the only H5Dcreate of the tree. Internal to the .cpp files of
// the writers, like hdf5_handle.hpp.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "common/hdf5/dataset_units.hpp"
#include "common/hdf5/hdf5_handle.hpp"

namespace cosim::protocol {

// ---- files ----------------------------------------------------------------------------------

/// Creates (or truncates) an HDF5 output file that carries the run's provenance
/// (common/run/provenance_h5.hpp). It is written in the HDF5 1.8 file format, whose object
/// headers keep attributes of any size (dense attribute storage): the `scene_toml`
/// attribute holds a scene file of any length (the 1.6 format, HDF5's default, refuses an
/// attribute over 64 KiB). Datasets are stored as before.
inline H5Id create_output_file(const std::string& path, const std::string& what) {
  const H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, what);
  h5_check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V18, H5F_LIBVER_V18), what);
  return H5Id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose, what);
}

// ---- types ----------------------------------------------------------------------------------

/// The file (little-endian, fixed size) and memory types of a C++ value type.
template <class T>
struct H5Types;
template <>
struct H5Types<double> {
  static hid_t file() { return H5T_IEEE_F64LE; }
  static hid_t memory() { return H5T_NATIVE_DOUBLE; }
};
template <>
struct H5Types<float> {
  static hid_t file() { return H5T_IEEE_F32LE; }
  static hid_t memory() { return H5T_NATIVE_FLOAT; }
};
template <>
struct H5Types<std::int64_t> {
  static hid_t file() { return H5T_STD_I64LE; }
  static hid_t memory() { return H5T_NATIVE_INT64; }
};
template <>
struct H5Types<std::int32_t> {
  static hid_t file() { return H5T_STD_I32LE; }
  static hid_t memory() { return H5T_NATIVE_INT32; }
};
template <>
struct H5Types<std::int8_t> {
  static hid_t file() { return H5T_STD_I8LE; }
  static hid_t memory() { return H5T_NATIVE_INT8; }
};
template <>
struct H5Types<std::uint8_t> {
  static hid_t file() { return H5T_STD_U8LE; }
  static hid_t memory() { return H5T_NATIVE_UINT8; }
};
template <>
struct H5Types<std::uint64_t> {
  static hid_t file() { return H5T_STD_U64LE; }
  static hid_t memory() { return H5T_NATIVE_UINT64; }
};

// ---- attributes -----------------------------------------------------------------------------

/// A scalar attribute `name` of `file_type` on `object` from `value` (of `mem_type`).
inline void put_attribute(hid_t object, const std::string& name, hid_t file_type, hid_t mem_type, const void* value,
                          const std::string& what) {
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose, what);
  const H5Id attr(H5Acreate2(object, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                  what);
  h5_check(H5Awrite(attr.get(), mem_type, value), what);
}

/// A scalar number attribute (double: float64, std::int64_t: int64, std::uint64_t: uint64).
template <class T>
  requires std::is_arithmetic_v<T>
void put_attribute(hid_t object, const std::string& name, T value, const std::string& what = {}) {
  put_attribute(object, name, H5Types<T>::file(), H5Types<T>::memory(), &value,
                what.empty() ? "cannot write the attribute " + name : what);
}

/// How a string attribute is stored: its characters alone (one NUL for an empty text), or
/// with the terminating NUL counted in its size (the RCGP cache's files).
enum class StringSize { text, with_nul };

/// A scalar string attribute `name` on `object` (replaced when it exists).
inline void put_attribute(hid_t object, const std::string& name, const std::string& value,
                          StringSize size = StringSize::text, const std::string& what = {}) {
  const std::string w = what.empty() ? "cannot write the attribute " + name : what;
  if (H5Aexists(object, name.c_str()) > 0) h5_check(H5Adelete(object, name.c_str()), w);
  const H5Id type(H5Tcopy(H5T_C_S1), H5Tclose, w);
  const std::size_t n = size == StringSize::with_nul ? value.size() + 1 : std::max<std::size_t>(1, value.size());
  h5_check(H5Tset_size(type.get(), n), w);
  const std::string padded = value.empty() ? std::string(1, '\0') : value;
  put_attribute(object, name, type.get(), type.get(), padded.c_str(), w);
}
inline void put_attribute(hid_t object, const std::string& name, const char* value,
                          StringSize size = StringSize::text, const std::string& what = {}) {
  put_attribute(object, name, std::string(value), size, what);
}

/// The "units" attribute of a dataset, from the table (dataset_units()) unless `units` is given.
inline void put_units(hid_t dataset, const std::string& name, const std::string& units = {}) {
  if (!units.empty()) {
    put_attribute(dataset, "units", units);
    return;
  }
  if (const auto u = dataset_units(name)) put_attribute(dataset, "units", *u);
}

/// A "units" attribute (dataset_units()) on every dataset of the file's root group that has
/// none yet.
inline void stamp_units(hid_t file) {
  std::vector<std::string> datasets;
  h5_check(H5Literate(
               file, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr,
               [](hid_t group, const char* name, const H5L_info_t*, void* out) -> herr_t {
                 const hid_t object = H5Oopen(group, name, H5P_DEFAULT);
                 if (object < 0) return -1;
                 if (H5Iget_type(object) == H5I_DATASET) static_cast<std::vector<std::string>*>(out)->push_back(name);
                 return H5Oclose(object);
               },
               &datasets),
           "cannot list the datasets");
  for (const std::string& name : datasets) {
    if (!dataset_units(name)) continue;
    const H5Id dset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, "cannot open the dataset " + name);
    if (H5Aexists(dset.get(), "units") > 0) continue;
    put_units(dset.get(), name);
  }
}

// ---- datasets -------------------------------------------------------------------------------

/// How a dataset's storage is laid out.
struct DatasetLayout {
  /// Contiguous, allocated when first written (HDF5's default).
  static DatasetLayout contiguous() { return {}; }
  /// Contiguous, allocated at creation and never filled: the processes of a WriteGroup
  /// write its rows later (write_rows).
  static DatasetLayout reserved() {
    DatasetLayout l;
    l.early_no_fill = true;
    return l;
  }
  /// Chunked, its first dimension extendible without limit (SeriesDataset), `chunk_rows`
  /// rows a chunk.
  static DatasetLayout extendible(hsize_t chunk_rows) {
    DatasetLayout l;
    l.chunk_rows = chunk_rows;
    return l;
  }
  hsize_t chunk_rows = 0;  ///< 0: not chunked
  bool early_no_fill = false;
};

/// Creates dataset `name` of `dims` and `file_type` in `loc` (the one H5Dcreate of the
/// project). An extendible layout starts at dims[0] rows and grows without limit; its
/// chunks hold chunk_rows rows of every other dimension (at least 1).
inline H5Id create_dataset(hid_t loc, const std::string& name, hid_t file_type, const std::vector<hsize_t>& dims,
                           const DatasetLayout& layout, const std::string& what) {
  if (dims.empty()) throw std::invalid_argument(what + ": a dataset of no dimension");
  const H5Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, what);
  std::vector<hsize_t> max = dims;
  if (layout.chunk_rows > 0) {
    max[0] = H5S_UNLIMITED;
    std::vector<hsize_t> chunk{layout.chunk_rows};
    for (std::size_t k = 1; k < dims.size(); ++k) chunk.push_back(std::max<hsize_t>(dims[k], 1));
    h5_check(H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()), what);
  }
  if (layout.early_no_fill) {
    h5_check(H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY), what);
    h5_check(H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER), what);
  }
  const H5Id space(H5Screate_simple(int(dims.size()), dims.data(), layout.chunk_rows > 0 ? max.data() : nullptr),
                   H5Sclose, what);
  return H5Id(H5Dcreate2(loc, name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
              H5Dclose, what);
}

/// Dataset `name` of `dims` reserved for its rows (dims[0] the rows the processes share out),
/// written later by write_rows: the leading process, before the others open the file.
/// Returns it open (for attributes).
inline H5Id reserve_dataset(hid_t loc, const std::string& name, hid_t file_type, const std::vector<hsize_t>& dims,
                            const std::string& what) {
  return create_dataset(loc, name, file_type, dims, DatasetLayout::reserved(), what);
}

/// Writes every value of dataset `set` from `data` (of `mem_type`, row-major); nothing for
/// a dataset of no values.
inline void fill_dataset(hid_t set, hid_t mem_type, const void* data, const std::string& what) {
  const H5Id space(H5Dget_space(set), H5Sclose, what);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) h5_fail(what);
  if (n > 0) h5_check(H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
}

/// Dataset `name` of `dims` (row-major, any of them may be 0) written whole from `data`
/// (of `mem_type`). Returns it open (for attributes).
inline H5Id write_dataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type,
                          const std::vector<hsize_t>& dims, const void* data, const std::string& what = {}) {
  const std::string w = what.empty() ? "cannot write the dataset " + name : what;
  H5Id set = create_dataset(loc, name, file_type, dims, DatasetLayout::contiguous(), w);
  fill_dataset(set.get(), mem_type, data, w);
  return set;
}

/// The same from a span of `dims` values (one dimension of all of them when `dims` is empty).
template <class T>
H5Id write_dataset(hid_t loc, const std::string& name, std::span<const T> data, std::vector<hsize_t> dims = {},
                   const std::string& what = {}) {
  const std::string w = what.empty() ? "cannot write the dataset " + name : what;
  if (dims.empty()) dims = {hsize_t(data.size())};
  hsize_t n = 1;
  for (const hsize_t d : dims) n *= d;
  if (n != data.size())
    throw std::invalid_argument(w + ": " + std::to_string(data.size()) + " values for " + std::to_string(n));
  return write_dataset(loc, name, H5Types<T>::file(), H5Types<T>::memory(), dims, data.data(), w);
}

/// Writes rows [first, first + count) of dataset `set` (along its first dimension, every
/// value of the others) from `data` (`count` rows, contiguous, of `mem_type`) with the
/// transfer property list `dxpl`; `count` = 0 selects nothing (a process without rows still
/// takes part in a collective write).
inline void write_rows(hid_t set, hid_t mem_type, hsize_t first, hsize_t count, const void* data, hid_t dxpl,
                       const std::string& what) {
  write_leading_box(set, mem_type, &first, &count, 1, data, dxpl, what);
}

/// Writes rows [first, first + count) of dataset `name` of `file` (reserve_dataset) from
/// `data`; every process of the group calls it (collective), `count` = 0 for one that has
/// no rows.
inline void write_rows(hid_t file, const std::string& name, hid_t mem_type, hsize_t first, hsize_t count,
                       const void* data, const WriteGroup& group, const std::string& what) {
  const H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const H5Id dxpl = group.transfer(what);
  write_rows(set.get(), mem_type, first, count, data, dxpl.get(), what);
}

/// An appendable series: a chunked dataset [rows][row_dims...] whose first dimension grows
/// with each append (monitor.h5, solid.h5 of a coupled run).
class SeriesDataset {
 public:
  SeriesDataset() = default;
  /// Creates dataset `name` of `file_type` in `loc` with no rows; `label` names it in errors
  /// ("cannot create LABEL", "cannot append to LABEL").
  SeriesDataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, std::vector<hsize_t> row_dims,
                hsize_t chunk_rows, std::string label)
      : mem_type_(mem_type), row_dims_(std::move(row_dims)), label_(std::move(label)) {
    std::vector<hsize_t> dims{0};
    dims.insert(dims.end(), row_dims_.begin(), row_dims_.end());
    set_ = create_dataset(loc, name, file_type, dims, DatasetLayout::extendible(chunk_rows), "cannot create " + label_);
  }

  /// Appends `n` rows from `data` (contiguous, of the memory type).
  void append(const void* data, hsize_t n) {
    const std::string what = "cannot append to " + label_;
    std::vector<hsize_t> extent{rows_ + n}, start{rows_}, count{n};
    hsize_t per_row = 1;
    for (const hsize_t d : row_dims_) {
      extent.push_back(d);
      start.push_back(0);
      count.push_back(d);
      per_row *= d;
    }
    h5_check(H5Dset_extent(set_.get(), extent.data()), what);
    if (per_row > 0 && n > 0) {
      const H5Id file_space(H5Dget_space(set_.get()), H5Sclose, what);
      h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
               what);
      const H5Id mem_space(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose, what);
      h5_check(H5Dwrite(set_.get(), mem_type_, mem_space.get(), file_space.get(), H5P_DEFAULT, data), what);
    }
    rows_ += n;
  }
  hsize_t rows() const { return rows_; }
  /// The values of one row.
  hsize_t per_row() const {
    hsize_t p = 1;
    for (const hsize_t d : row_dims_) p *= d;
    return p;
  }
  hid_t mem_type() const { return mem_type_; }
  hid_t get() const { return set_.get(); }

 private:
  H5Id set_;
  hid_t mem_type_ = -1;
  std::vector<hsize_t> row_dims_;
  std::string label_;
  hsize_t rows_ = 0;
};

}  // namespace cosim::protocol
