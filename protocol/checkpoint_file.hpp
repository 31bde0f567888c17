// One side's coupled checkpoint in an HDF5 file (DESIGN 2.4): named 1-D arrays (doubles,
// int64, raw bytes such as an encoded LCM message kept for a resend) and scalar
// attributes. Written under "<name>.part" and renamed when complete, so a file with the
// final name is never half written (a peer killed while writing leaves only a .part).
// Internal to the .cpp files of the servers, like hdf5_handle.hpp.
//
// The layout of the files themselves (which arrays, which attributes) is the servers'
// (fluid/coupled/fluid_run.cpp, solid/solid_checkpoints.cpp) and protocol/README.md section 10.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/hdf5_handle.hpp"
#include "protocol/hdf5_quiet.hpp"

namespace cosim::protocol {

/// "fluid_00001200.h5" for side "fluid" at step 1200.
inline std::string checkpoint_name(const std::string& side, std::int64_t step) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%08lld.h5", side.c_str(), static_cast<long long>(step));
  return name;
}

/// Keeps the newest `keep` files PREFIX*.h5 of `dir` (by name: the step is zero-padded).
inline void prune_checkpoints(const std::filesystem::path& dir, const std::string& prefix,
                              std::size_t keep) {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && e.path().extension() == ".h5") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (std::size_t k = 0; k + keep < files.size(); ++k) std::filesystem::remove(files[k]);
}

/// Writes a checkpoint file: put() the arrays, attr() the scalars, then commit().
class CheckpointWriter {
 public:
  /// Creates `path`.part (the folder must exist). Throws std::runtime_error naming it.
  explicit CheckpointWriter(std::filesystem::path path)
      : path_(std::move(path)), part_(path_.string() + ".part") {
    const H5Quiet quiet;
    file_ = H5Id(H5Fcreate(part_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                 "cannot create the checkpoint " + part_);
  }

  void put(const std::string& name, const std::vector<double>& v) {
    put_raw(name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, v.size(), v.data());
  }
  void put(const std::string& name, const double* data, std::size_t n) {
    put_raw(name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, n, data);
  }
  void put(const std::string& name, const float* data, std::size_t n) {
    put_raw(name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, n, data);
  }
  void put(const std::string& name, const std::vector<std::int64_t>& v) {
    put_raw(name, H5T_STD_I64LE, H5T_NATIVE_INT64, v.size(), v.data());
  }
  void put(const std::string& name, const std::vector<std::uint8_t>& v) {
    put_raw(name, H5T_STD_U8LE, H5T_NATIVE_UINT8, v.size(), v.data());
  }

  void attr(const std::string& name, std::int64_t value) {
    scalar(name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
  }
  void attr(const std::string& name, double value) {
    scalar(name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
  }
  void text(const std::string& name, const std::string& value) {
    put(name, std::vector<std::uint8_t>(value.begin(), value.end()));
  }

  /// Closes the file and renames it to its final name.
  void commit() {
    const H5Quiet quiet;
    file_.close("cannot close the checkpoint " + part_);
    std::error_code ec;
    std::filesystem::rename(part_, path_, ec);
    if (ec) throw std::runtime_error("cannot rename " + part_ + " to " + path_.string() + ": " + ec.message());
  }

 private:
  void put_raw(const std::string& name, hid_t file_type, hid_t mem_type, std::size_t n,
               const void* data) {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + part_ + ": cannot write " + name;
    const hsize_t dims[1] = {static_cast<hsize_t>(n)};
    const H5Id space(H5Screate_simple(1, dims, nullptr), H5Sclose, what);
    const H5Id set(H5Dcreate2(file_.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT,
                              H5P_DEFAULT, H5P_DEFAULT),
                   H5Dclose, what);
    if (n > 0) h5_check(H5Dwrite(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
  }
  void scalar(const std::string& name, hid_t file_type, hid_t mem_type, const void* value) {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + part_ + ": cannot write the attribute " + name;
    const H5Id space(H5Screate(H5S_SCALAR), H5Sclose, what);
    const H5Id a(H5Acreate2(file_.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                 H5Aclose, what);
    h5_check(H5Awrite(a.get(), mem_type, value), what);
  }

  std::filesystem::path path_;
  std::string part_;
  H5Id file_;
};

/// Reads a checkpoint file. Every accessor throws std::runtime_error naming the file and
/// the array or attribute that is missing or has the wrong size.
class CheckpointReader {
 public:
  explicit CheckpointReader(const std::filesystem::path& path) : path_(path.string()) {
    const H5Quiet quiet;
    if (!std::filesystem::is_regular_file(path))
      throw std::runtime_error("checkpoint " + path_ + ": no such file");
    file_ = H5Id(H5Fopen(path_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose,
                 "checkpoint " + path_ + ": cannot open it as HDF5");
  }

  const std::string& path() const { return path_; }

  std::vector<double> doubles(const std::string& name) const {
    std::vector<double> v(length(name));
    read(name, H5T_NATIVE_DOUBLE, v.data(), v.size());
    return v;
  }
  std::vector<std::int64_t> int64s(const std::string& name) const {
    std::vector<std::int64_t> v(length(name));
    read(name, H5T_NATIVE_INT64, v.data(), v.size());
    return v;
  }
  std::vector<std::uint8_t> bytes(const std::string& name) const {
    std::vector<std::uint8_t> v(length(name));
    read(name, H5T_NATIVE_UINT8, v.data(), v.size());
    return v;
  }
  /// An array that must hold exactly `n` doubles.
  std::vector<double> doubles(const std::string& name, std::size_t n) const {
    return sized(doubles(name), name, n);
  }
  /// An array that must hold exactly `n` floats (the single-precision population store).
  std::vector<float> floats(const std::string& name, std::size_t n) const {
    std::vector<float> v(length(name));
    read(name, H5T_NATIVE_FLOAT, v.data(), v.size());
    return sized(std::move(v), name, n);
  }
  std::string text(const std::string& name) const {
    const std::vector<std::uint8_t> b = bytes(name);
    return std::string(b.begin(), b.end());
  }

  std::int64_t int64_attr(const std::string& name) const {
    std::int64_t v = 0;
    read_attr(name, H5T_NATIVE_INT64, &v);
    return v;
  }
  double double_attr(const std::string& name) const {
    double v = 0.0;
    read_attr(name, H5T_NATIVE_DOUBLE, &v);
    return v;
  }
  /// Whether the file holds an attribute or an array of this name (a key that older
  /// checkpoints lack).
  bool has(const std::string& name) const {
    const H5Quiet quiet;
    return H5Aexists(file_.get(), name.c_str()) > 0 || H5Lexists(file_.get(), name.c_str(), H5P_DEFAULT) > 0;
  }

 private:
  template <class V>
  V sized(V v, const std::string& name, std::size_t n) const {
    if (v.size() != n)
      throw std::runtime_error("checkpoint " + path_ + ": " + name + " has " + std::to_string(v.size()) +
                               " values, this run needs " + std::to_string(n) +
                               " (a checkpoint of another scene?)");
    return v;
  }
  std::size_t length(const std::string& name) const {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_ + ": no array " + name;
    if (H5Lexists(file_.get(), name.c_str(), H5P_DEFAULT) <= 0) throw std::runtime_error(what);
    const H5Id set(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
    const H5Id space(H5Dget_space(set.get()), H5Sclose, what);
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 0) h5_fail(what);
    return static_cast<std::size_t>(n);
  }
  void read(const std::string& name, hid_t mem_type, void* data, std::size_t n) const {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_ + ": cannot read " + name;
    const H5Id set(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
    if (n > 0) h5_check(H5Dread(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
  }
  void read_attr(const std::string& name, hid_t mem_type, void* data) const {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_ + ": no attribute " + name;
    if (H5Aexists(file_.get(), name.c_str()) <= 0) throw std::runtime_error(what);
    const H5Id a(H5Aopen(file_.get(), name.c_str(), H5P_DEFAULT), H5Aclose, what);
    h5_check(H5Aread(a.get(), mem_type, data), what);
  }

  std::string path_;
  H5Id file_;
};

}  // namespace cosim::protocol
