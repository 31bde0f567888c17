// Helpers of the two-process tests: run a scene through launch/run-coupled.sh into a
// folder, read its logs, and compare the HDF5 outputs of two runs bit for bit (every
// dataset of every group; HDF5 object timestamps and attributes are not compared, no
// dataset holds a wall-clock quantity).
#pragma once

#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scene_edit.hpp"

namespace cosim::test {

namespace fs = std::filesystem;


/// A fresh, empty folder under the test's temporary directory.
inline fs::path scratch(const std::string& name) { return fresh_scratch("cosim_" + name); }


/// Runs `scene` through launch/run-coupled.sh (--no-build --quiet) into `output`, with
/// `args` appended to its command line and `env` (e.g. "COSIM_FAULTS=drop=0.01") set; the
/// launcher's own lines go to output/launcher.log. Returns the launcher's exit status.
inline int run_launcher(const fs::path& source, const fs::path& scene, const fs::path& output,
                        const std::string& args = "", const std::string& env = "") {
  fs::create_directories(output);
  const std::string cmd = (env.empty() ? "" : "env " + env + " ") + "bash " +
                          quoted((source / "launch" / "run-coupled.sh").string()) + " " +
                          quoted(scene.string()) + " --output " + quoted(output.string()) +
                          " --no-build --quiet" + (args.empty() ? "" : " " + args) + " >" +
                          quoted((output / "launcher.log").string()) + " 2>&1";
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

/// The launcher's, the servers' and the extra command's logs of a run, for a failure message.
inline std::string logs(const fs::path& out) {
  std::string s;
  for (const char* f : {"launcher.log", "fluid.log", "solid.log", "extra.log"})
    if (fs::exists(out / f)) s += std::string("--- ") + f + "\n" + slurp(out / f);
  return s;
}

/// A coupled run that completed: the launcher and both servers exited 0 (else their logs).
inline void expect_run_done(const fs::path& out, int launcher_status) {
  ASSERT_EQ(launcher_status, 0) << logs(out);
  ASSERT_EQ(slurp(out / "fluid.exit"), "0\n") << logs(out);
  ASSERT_EQ(slurp(out / "solid.exit"), "0\n") << logs(out);
}

/// One dataset read back raw: its shape, its file type's class and size, its bytes (in the
/// file's own type, so the comparison is bit for bit), and its values as doubles.
struct Dataset {
  std::vector<hsize_t> dims;
  H5T_class_t cls = H5T_NO_CLASS;
  std::size_t type_size = 0;
  std::vector<unsigned char> bytes;
  std::vector<double> values;
};

/// Every dataset of an HDF5 file (all groups), by path; empty if it cannot be opened.
inline std::map<std::string, Dataset> read_datasets(const fs::path& file) {
  std::map<std::string, Dataset> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  std::vector<std::string> names;
  H5Ovisit(
      f, H5_INDEX_NAME, H5_ITER_INC,
      [](hid_t, const char* name, const H5O_info_t* info, void* data) -> herr_t {
        if (info->type == H5O_TYPE_DATASET) static_cast<std::vector<std::string>*>(data)->push_back(name);
        return 0;
      },
      &names);
  for (const std::string& name : names) {
    Dataset d;
    const hid_t ds = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
    if (ds < 0) continue;
    const hid_t space = H5Dget_space(ds);
    const hid_t type = H5Dget_type(ds);
    const int rank = H5Sget_simple_extent_ndims(space);
    d.dims.resize(static_cast<std::size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(space, d.dims.data(), nullptr);
    const auto count = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space));
    d.cls = H5Tget_class(type);
    d.type_size = H5Tget_size(type);
    d.bytes.resize(count * d.type_size);
    if (count > 0) H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.bytes.data());
    if (d.cls == H5T_FLOAT || d.cls == H5T_INTEGER) {
      d.values.resize(count);
      if (count > 0) H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, d.values.data());
    }
    H5Tclose(type);
    H5Sclose(space);
    H5Dclose(ds);
    out.emplace(name, std::move(d));
  }
  H5Fclose(f);
  return out;
}

inline std::string shape(const std::vector<hsize_t>& dims) {
  std::string s = "[";
  for (std::size_t k = 0; k < dims.size(); ++k) s += (k ? " x " : "") + std::to_string(dims[k]);
  return s + "]";
}

/// Bit-for-bit comparison of every dataset of `file` in two output folders. Returns "" when
/// identical; otherwise one line per difference (for numbers: how many entries differ and
/// the largest absolute and relative difference).
inline std::string compare_h5(const fs::path& a_dir, const fs::path& b_dir, const std::string& file) {
  const auto a = read_datasets(a_dir / file), b = read_datasets(b_dir / file);
  std::ostringstream r;
  if (a.empty()) r << file << ": no datasets in " << (a_dir / file) << "\n";
  if (b.empty()) r << file << ": no datasets in " << (b_dir / file) << "\n";
  for (const auto& [name, da] : a) {
    const auto it = b.find(name);
    if (it == b.end()) {
      r << file << " " << name << ": missing in " << b_dir << "\n";
      continue;
    }
    const Dataset& db = it->second;
    if (da.dims != db.dims || da.cls != db.cls || da.type_size != db.type_size) {
      r << file << " " << name << ": shape " << shape(da.dims) << " vs " << shape(db.dims)
        << " (type class " << da.cls << "/" << db.cls << ", size " << da.type_size << "/"
        << db.type_size << ")\n";
      continue;
    }
    if (da.bytes == db.bytes) continue;
    std::size_t differ = 0;
    double max_abs = 0.0, max_rel = 0.0;
    for (std::size_t k = 0; k < da.values.size(); ++k) {
      const double x = da.values[k], y = db.values[k];
      if (std::memcmp(&da.bytes[k * da.type_size], &db.bytes[k * db.type_size], da.type_size) == 0)
        continue;
      ++differ;
      const double d = std::abs(x - y);
      max_abs = std::max(max_abs, d);
      if (std::max(std::abs(x), std::abs(y)) > 0.0)
        max_rel = std::max(max_rel, d / std::max(std::abs(x), std::abs(y)));
    }
    r << file << " " << name << " " << shape(da.dims) << ": " << differ << " of "
      << da.values.size() << " entries differ, max |diff| " << max_abs << ", max rel " << max_rel
      << "\n";
  }
  for (const auto& [name, db] : b)
    if (!a.count(name)) r << file << " " << name << ": missing in " << a_dir << "\n";
  return r.str();
}

/// The *.h5 files of a folder (not recursive), sorted.
inline std::vector<std::string> h5_files(const fs::path& dir) {
  std::vector<std::string> names;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && e.path().extension() == ".h5") names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// Every HDF5 output of two runs compared bit for bit: "" when both folders hold the same
/// *.h5 files with identical datasets; otherwise what differs. `count` (if given) gets the
/// number of files compared.
inline std::string compare_outputs(const fs::path& a, const fs::path& b, std::size_t* count = nullptr) {
  const std::vector<std::string> fa = h5_files(a), fb = h5_files(b);
  std::string r;
  const std::set<std::string> sa(fa.begin(), fa.end()), sb(fb.begin(), fb.end());
  for (const std::string& f : fa)
    if (!sb.count(f)) r += f + ": only in " + a.string() + "\n";
  for (const std::string& f : fb)
    if (!sa.count(f)) r += f + ": only in " + b.string() + "\n";
  std::size_t n = 0;
  for (const std::string& f : fa)
    if (sb.count(f)) {
      r += compare_h5(a, b, f);
      ++n;
    }
  if (count != nullptr) *count = n;
  return r;
}

/// Flips one bit in the middle of dataset `name` of an HDF5 file (contiguous storage).
inline void flip_bit(const fs::path& file, const std::string& name) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0) << file;
  const hid_t d = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
  ASSERT_GE(d, 0) << name;
  const haddr_t offset = H5Dget_offset(d);
  const hsize_t size = H5Dget_storage_size(d);
  H5Dclose(d);
  H5Fclose(f);
  ASSERT_NE(offset, HADDR_UNDEF);
  std::fstream io(file, std::ios::in | std::ios::out | std::ios::binary);
  io.seekg(static_cast<std::streamoff>(offset + size / 2));
  char c = 0;
  io.read(&c, 1);
  c = static_cast<char>(c ^ 0x10);
  io.seekp(static_cast<std::streamoff>(offset + size / 2));
  io.write(&c, 1);
}

/// Every regular file under `dir` (logs, pid and exit files, the traffic log included), by
/// relative path, with its bytes.
inline std::map<std::string, std::string> every_file(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = slurp(e.path());
  return files;
}

/// The names of the files that differ between two listings (changed, added or gone).
inline std::string changed_files(const std::map<std::string, std::string>& before,
                          const std::map<std::string, std::string>& after) {
  std::string names;
  for (const auto& [name, bytes] : before) {
    const auto it = after.find(name);
    if (it == after.end()) names += name + " (gone) ";
    else if (it->second != bytes) names += name + " (" + std::to_string(bytes.size()) + " -> " +
                                           std::to_string(it->second.size()) + " bytes) ";
  }
  for (const auto& [name, bytes] : after)
    if (!before.count(name)) names += name + " (new) ";
  return names;
}

}  // namespace cosim::test
