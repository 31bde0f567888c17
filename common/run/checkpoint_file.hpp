// One side's coupled checkpoint in an HDF5 file (DESIGN 2.4): named 1-D arrays (doubles,
// int64, raw bytes such as an encoded LCM message kept for a resend) and scalar
// attributes. Written under "<name>.part" and renamed when complete, so a file with the
// final name is never half written (a peer killed while writing leaves only a .part).
// Internal to the .cpp files of the servers, like hdf5_handle.hpp.
//
// Every array carries a "checksum" attribute (checksum.hpp) over its bytes as stored, and
// the file an "attributes_checksum" over its scalar attributes (name and bytes, by name);
// a reader verifies them all when it opens the file, so a corrupted checkpoint is refused
// naming the file and the array (CorruptCheckpointIsRefused).
//
// The layout of the files themselves (which arrays, which attributes) is the servers'
// (fluid/coupled/fluid_run.cpp, solid/coupled/solid_checkpoints.cpp) and protocol/README.md section 10.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/run/atomic_file.hpp"
#include "common/run/checksum.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"

namespace cosim::protocol {

/// "fluid_00001200.h5" for side "fluid" at step 1200.
inline std::string checkpoint_name(const std::string& side, std::int64_t step) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%08lld.h5", side.c_str(), static_cast<long long>(step));
  return name;
}

/// The text array `name` ("run_id") of a checkpoint file, read without verifying the file;
/// "" when it has none or cannot be read.
inline std::string checkpoint_text_unverified(const std::filesystem::path& file, const std::string& name) {
  const H5Quiet quiet;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return "";
  std::string text;
  if (H5Lexists(f, name.c_str(), H5P_DEFAULT) > 0) {
    const hid_t set = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
    if (set >= 0) {
      const hid_t space = H5Dget_space(set);
      const hssize_t n = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
      if (n > 0) {
        text.resize(static_cast<std::size_t>(n));
        if (H5Dread(set, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()) < 0) text.clear();
      }
      if (space >= 0) H5Sclose(space);
      H5Dclose(set);
    }
  }
  H5Fclose(f);
  H5Eclear2(H5E_DEFAULT);
  return text;
}

/// Keeps the newest `keep` files PREFIX*.h5 of `dir` (by name: the step is zero-padded) of
/// the run `run_id` (their "run_id" text): another run's checkpoints in the folder, and
/// files that are not checkpoints, are never removed.
inline void prune_checkpoints(const std::filesystem::path& dir, const std::string& prefix, std::size_t keep,
                              const std::string& run_id) {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && e.path().extension() == ".h5") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<std::filesystem::path> own;
  for (const auto& f : files)
    if (checkpoint_text_unverified(f, "run_id") == run_id) own.push_back(f);
  for (std::size_t k = 0; k + keep < own.size(); ++k) std::filesystem::remove(own[k]);
}

/// The checksum of every byte of dataset `set` as stored (its file type), read in blocks of
/// at most 1 Mi values: the populations of a large grid are not held twice.
inline std::uint64_t stored_checksum(hid_t set, const std::string& what) {
  const H5Id type(H5Dget_type(set), H5Tclose, what);
  const H5Id space(H5Dget_space(set), H5Sclose, what);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) h5_fail(what);
  const std::size_t size = H5Tget_size(type.get());
  const hsize_t block = hsize_t(1) << 20;
  std::vector<unsigned char> buf(static_cast<std::size_t>(std::min<hsize_t>(hsize_t(n), block)) * size);
  Checksum sum;
  for (hsize_t at = 0; at < hsize_t(n); at += block) {
    const hsize_t count[1] = {std::min<hsize_t>(block, hsize_t(n) - at)};
    const hsize_t start[1] = {at};
    const H5Id mem(H5Screate_simple(1, count, nullptr), H5Sclose, what);
    const H5Id file_space(H5Dget_space(set), H5Sclose, what);
    h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr), what);
    h5_check(H5Dread(set, type.get(), mem.get(), file_space.get(), H5P_DEFAULT, buf.data()), what);
    sum.add(buf.data(), static_cast<std::size_t>(count[0]) * size);
  }
  return sum.value();
}

/// Writes a checkpoint file: put() the arrays, attr() the scalars, then commit().
class CheckpointWriter {
 public:
  /// Creates `path`.part (the folder must exist). Every error is a std::runtime_error naming
  /// `path` (the .part file is removed when the writer goes without commit()).
  explicit CheckpointWriter(std::filesystem::path path)
      : path_(std::move(path)), part_(part_path(path_).string()) {
    const H5Quiet quiet;
    file_ = H5Id(H5Fcreate(part_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                 "cannot create the checkpoint " + path_.string());
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

  /// An array of `n` values of `file_type` whose values other processes write (each its
  /// own rows, h5_writer.hpp: write_rows) between pause() and commit(), which sums them
  /// from the file.
  void reserve(const std::string& name, hid_t file_type, std::size_t n) {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_.string() + ": cannot write " + name;
    reserve_dataset(file_.get(), name, file_type, {static_cast<hsize_t>(n)}, what);
    reserved_.push_back(name);
  }
  /// Closes the file (it stays at part()) for the writers of the reserved arrays.
  void pause() {
    const H5Quiet quiet;
    file_.close("cannot write the checkpoint " + path_.string());
  }
  /// The file's name while it is written.
  const std::string& part() const { return part_; }

  /// Closes the file and renames it to its final name. On any failure the .part file is
  /// removed (nothing half written stays behind) and the error names the file.
  void commit() {
    const H5Quiet quiet;
    if (file_.get() < 0)
      file_ = H5Id(H5Fopen(part_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose,
                   "cannot write the checkpoint " + path_.string());
    for (const std::string& name : reserved_) {
      const std::string what = "checkpoint " + path_.string() + ": cannot sum " + name;
      const H5Id set(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
      put_checksum(set.get(), stored_checksum(set.get(), what), what);
    }
    Checksum sum;
    for (const auto& [name, bytes] : attributes_) sum.add(name).add(bytes);
    const std::uint64_t value = sum.value();
    scalar_unsummed("attributes_checksum", H5T_STD_U64LE, H5T_NATIVE_UINT64, &value);
    file_.close("cannot write the checkpoint " + path_.string());
    rename_or_throw(part_, path_);
    committed_ = true;
  }

  ~CheckpointWriter() {
    if (committed_) return;
    file_ = H5Id();  // closed (errors ignored): a failed write leaves no .part behind
    std::error_code ec;
    std::filesystem::remove(part_, ec);
  }
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;

 private:
  void put_raw(const std::string& name, hid_t file_type, hid_t mem_type, std::size_t n,
               const void* data) {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_.string() + ": cannot write " + name;
    const H5Id set = write_dataset(file_.get(), name, file_type, mem_type, {static_cast<hsize_t>(n)}, data, what);
    // The memory types are the file's little-endian ones on every host we build for: the
    // bytes summed are the bytes stored.
    put_checksum(set.get(), Checksum().add(data, n * H5Tget_size(mem_type)).value(), what);
  }
  static void put_checksum(hid_t set, std::uint64_t sum, const std::string& what) {
    put_attribute(set, "checksum", sum, what);
  }
  void scalar(const std::string& name, hid_t file_type, hid_t mem_type, const void* value) {
    const auto* b = static_cast<const char*>(value);
    attributes_[name] = std::string(b, b + H5Tget_size(mem_type));
    scalar_unsummed(name, file_type, mem_type, value);
  }
  void scalar_unsummed(const std::string& name, hid_t file_type, hid_t mem_type, const void* value) {
    const H5Quiet quiet;
    const std::string what = "checkpoint " + path_.string() + ": cannot write the attribute " + name;
    put_attribute(file_.get(), name, file_type, mem_type, value, what);
  }

  std::filesystem::path path_;
  std::string part_;
  H5Id file_;
  std::map<std::string, std::string> attributes_;  ///< name -> bytes, for attributes_checksum
  std::vector<std::string> reserved_;              ///< arrays summed from the file at commit()
  bool committed_ = false;
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
    verify();
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
  /// Throws unless array `name` holds exactly `n` values (read in shares by the processes
  /// of a run, store_io.hpp).
  void check_array(const std::string& name, std::size_t n) const {
    const std::size_t have = length(name);
    if (have != n)
      throw std::runtime_error("checkpoint " + path_ + ": " + name + " has " + std::to_string(have) +
                               " values, this run needs " + std::to_string(n) + " (a checkpoint of another scene?)");
  }
  /// Whether the file holds an attribute or an array of this name (a key that older
  /// checkpoints lack).
  bool has(const std::string& name) const {
    const H5Quiet quiet;
    return H5Aexists(file_.get(), name.c_str()) > 0 || H5Lexists(file_.get(), name.c_str(), H5P_DEFAULT) > 0;
  }

 private:
  /// Every array's checksum, then the attributes'; throws naming the first that differs.
  void verify() const {
    const H5Quiet quiet;
    std::vector<std::string> names;
    H5Literate(
        file_.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
          static_cast<std::vector<std::string>*>(data)->emplace_back(name);
          return 0;
        },
        &names);
    for (const std::string& name : names) verify_array(name);
    Checksum sum;
    std::vector<std::string> attrs;
    H5Aiterate2(
        file_.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
          static_cast<std::vector<std::string>*>(data)->emplace_back(name);
          return 0;
        },
        &attrs);
    bool have = false;
    std::uint64_t stored = 0;
    for (const std::string& name : attrs) {
      const std::string what = "checkpoint " + path_ + ": cannot read the attribute " + name;
      const H5Id a(H5Aopen(file_.get(), name.c_str(), H5P_DEFAULT), H5Aclose, what);
      const H5Id type(H5Aget_type(a.get()), H5Tclose, what);
      std::string bytes(H5Tget_size(type.get()), '\0');
      h5_check(H5Aread(a.get(), type.get(), bytes.data()), what);
      if (name == "attributes_checksum") {
        if (bytes.size() == 8) std::memcpy(&stored, bytes.data(), 8);
        have = bytes.size() == 8;
        continue;
      }
      sum.add(name).add(bytes);
    }
    if (!have)
      throw std::runtime_error("checkpoint " + path_ +
                               ": no attributes_checksum (not a checkpoint, or one written before checkpoints "
                               "carried checksums)");
    if (stored != sum.value())
      throw std::runtime_error("checkpoint " + path_ +
                               ": its attributes (step, counters, time_ratio ...) do not match their checksum: the "
                               "file is corrupted");
  }
  void verify_array(const std::string& name) const {
    const std::string what = "checkpoint " + path_ + ": cannot read " + name;
    const H5Id set(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
    if (H5Aexists(set.get(), "checksum") <= 0)
      throw std::runtime_error("checkpoint " + path_ + ": " + name +
                               " has no checksum (a checkpoint written before checkpoints carried checksums)");
    std::uint64_t stored = 0;
    {
      const H5Id a(H5Aopen(set.get(), "checksum", H5P_DEFAULT), H5Aclose, what);
      h5_check(H5Aread(a.get(), H5T_NATIVE_UINT64, &stored), what);
    }
    if (stored_checksum(set.get(), what) != stored)
      throw std::runtime_error("checkpoint " + path_ + ": " + name +
                               " does not match its checksum: the file is corrupted (refused)");
  }

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
