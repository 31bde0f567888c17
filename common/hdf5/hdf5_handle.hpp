// Ownership of HDF5 C API identifiers, with HDF5 errors turned into one-line exceptions.
// Internal to the .cpp files of the fluid and solid libraries: their headers do not expose
// HDF5.
#pragma once

#include <hdf5.h>

#include "common/hdf5/hdf5_quiet.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace cosim::protocol {

/// Throws std::runtime_error("<what>: <innermost message of the HDF5 error stack>") and
/// clears the stack. Call with HDF5's automatic error printing off (H5Quiet).
[[noreturn]] inline void h5_fail(const std::string& what) {
  std::string inner;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
        if (e->desc != nullptr && e->desc[0] != '\0') *static_cast<std::string*>(data) = e->desc;
        return 0;
      },
      &inner);
  H5Eclear2(H5E_DEFAULT);
  // The sec2 driver's "file write failed: time = ..., filename = ..., errno = 28, error
  // message = 'No space left on device', buf = ..." is said by its error message alone.
  const std::string tag = "error message = '";
  if (const std::size_t at = inner.find(tag); at != std::string::npos) {
    const std::size_t end = inner.find('\'', at + tag.size());
    if (end != std::string::npos) inner = inner.substr(at + tag.size(), end - at - tag.size());
  }
  for (char& c : inner)
    if (c == '\n' || c == '\r') c = ' ';
  throw std::runtime_error(inner.empty() ? what : what + ": " + inner);
}

inline void h5_check(herr_t status, const std::string& what) {
  if (status < 0) h5_fail(what);
}

/// Owns one identifier (file, group, dataset, dataspace, datatype, attribute, property
/// list) and closes it with the matching H5?close.
class H5Id {
 public:
  using Closer = herr_t (*)(hid_t);

  H5Id() = default;
  /// Takes `id` from an HDF5 call; throws naming `what` if the call failed (id < 0).
  H5Id(hid_t id, Closer closer, const std::string& what) : id_(id), close_(closer) {
    if (id_ < 0) h5_fail(what);
  }
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  H5Id(H5Id&& o) noexcept : id_(std::exchange(o.id_, -1)), close_(o.close_) {}
  H5Id& operator=(H5Id&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, -1);
      close_ = o.close_;
    }
    return *this;
  }
  ~H5Id() { reset(); }

  hid_t get() const { return id_; }

  /// Closes now and reports a failure (a file's close writes its last metadata).
  void close(const std::string& what) {
    const hid_t id = std::exchange(id_, -1);
    if (id >= 0) h5_check(close_(id), what);
  }

 private:
  /// A close that fails here (a full disk: nothing more can be written) is not reported:
  /// the write that failed first was; HDF5's own error stack stays off stderr.
  void reset() {
    if (id_ < 0) return;
    const H5Quiet quiet;
    close_(std::exchange(id_, -1));
    H5Eclear2(H5E_DEFAULT);
  }
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

/// Call before any other HDF5 call: the library registers no clean-up at process exit. A
/// file whose close failed (a full disk) would otherwise be closed again there, which HDF5
/// 1.10 answers with "infinite loop closing library" or a crash; every file the servers
/// write is closed by its owner (H5Id) before exit.
inline void hdf5_no_exit_cleanup() { H5dont_atexit(); }

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

}  // namespace cosim::protocol
