// Ownership of HDF5 C API identifiers, with HDF5 errors turned into one-line exceptions;
// the processes that write one file (WriteGroup). Writing is common/hdf5/h5_writer.hpp's.
// Internal to the .cpp files of the fluid and solid libraries: their headers do not expose
// HDF5.
#pragma once

#include <hdf5.h>

#include "common/hdf5/hdf5_quiet.hpp"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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

// ---- Files written by several processes, each its own hyperslab (DESIGN 8) ----
//
// A file of a run over MPI ranks is written in three phases, the same in one process: the
// leading process creates it (attributes, small datasets, and each large dataset created
// with its space allocated but nothing in it: reserve_dataset, common/hdf5/h5_writer.hpp);
// every process of the group opens it (open_for_hyperslabs: MPI-IO under parallel HDF5) and
// writes its own rows of the large datasets (write_rows, h5_writer.hpp, collective); the
// leading process finishes it (checksums, rename). The file's layout is the one a single process writes: every reader is unchanged.
// Built against the serial library (H5_HAVE_PARALLEL unset) a group is one process.

/// The processes that write one file together.
class WriteGroup {
 public:
  /// One process alone.
  WriteGroup() = default;
#ifdef H5_HAVE_PARALLEL
  /// The ranks of `comm` (one process when it has one rank).
  explicit WriteGroup(MPI_Comm comm) : comm_(comm) {
    MPI_Comm_rank(comm, &rank_);
    MPI_Comm_size(comm, &size_);
  }
#endif
  int rank() const { return rank_; }
  int size() const { return size_; }
  bool leads() const { return rank_ == 0; }

  /// Collective: the first non-empty `error` in rank order, on every rank ("" when none),
  /// "rank N: " before another rank's.
  std::string first_error(const std::string& error) const {
#ifdef H5_HAVE_PARALLEL
    if (size_ > 1) {
      int first = error.empty() ? size_ : rank_;
      MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm_);
      if (first == size_) return {};
      long long n = rank_ == first ? static_cast<long long>(error.size()) : 0;
      MPI_Bcast(&n, 1, MPI_LONG_LONG, first, comm_);
      std::string text = rank_ == first ? error : std::string(static_cast<std::size_t>(n), '\0');
      MPI_Bcast(text.data(), static_cast<int>(n), MPI_CHAR, first, comm_);
      return first == 0 ? text : "rank " + std::to_string(first) + ": " + text;
    }
#endif
    return error;
  }

  /// A file access property list for open_for_hyperslabs: MPI-IO over the group's ranks,
  /// or HDF5's default driver for one process.
  H5Id file_access(const std::string& what) const {
    H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, what);
#ifdef H5_HAVE_PARALLEL
    if (size_ > 1) h5_check(H5Pset_fapl_mpio(fapl.get(), comm_, MPI_INFO_NULL), what);
#endif
    return fapl;
  }
  /// A transfer property list for write_rows: each rank's rows written by itself straight
  /// from its memory (independent MPI-IO: a rank's rows of a dataset are one contiguous
  /// range of the file), the open, the close and the metadata collective. Collective
  /// transfers would have aggregator ranks collect the others' rows in buffers of their own:
  /// rank 0 then held 60 MB more than the others on a grid of 2.3 million cells
  /// (NoRankHoldsTheWholeGrid, OpenMPI 4.1's OMPIO).
  H5Id transfer(const std::string& what) const {
    H5Id dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose, what);
#ifdef H5_HAVE_PARALLEL
    if (size_ > 1) h5_check(H5Pset_dxpl_mpio(dxpl.get(), H5FD_MPIO_INDEPENDENT), what);
#endif
    return dxpl;
  }

 private:
#ifdef H5_HAVE_PARALLEL
  MPI_Comm comm_ = MPI_COMM_NULL;
#endif
  int rank_ = 0, size_ = 1;
};

/// The file the leading process created, opened for writing by every process of `group`
/// (collective under MPI-IO).
inline H5Id open_for_hyperslabs(const std::string& path, const WriteGroup& group, const std::string& what) {
  const H5Id fapl = group.file_access(what);
  return H5Id(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()), H5Fclose, what);
}

/// Writes the box [first[a], first[a] + count[a]) of the first `k` dimensions of dataset
/// `set` (every value of the others) from `data` (the box, contiguous, in the dataset's
/// order, of `mem_type`) with the transfer list `dxpl`; a box with any count 0 selects
/// nothing (a process without a part still takes part in a collective write). The one
/// hyperslab write of write_rows (h5_writer.hpp) and write_box.
inline void write_leading_box(hid_t set, hid_t mem_type, const hsize_t* first, const hsize_t* count, int k,
                              const void* data, hid_t dxpl, const std::string& what) {
  const H5Id file_space(H5Dget_space(set), H5Sclose, what);
  const int rank = H5Sget_simple_extent_ndims(file_space.get());
  if (rank < k) h5_fail(what);
  std::vector<hsize_t> dims(std::size_t(rank), 0), start(std::size_t(rank), 0);
  h5_check(H5Sget_simple_extent_dims(file_space.get(), dims.data(), nullptr), what);
  bool none = false;
  for (int a = 0; a < k; ++a) none = none || count[a] == 0;
  std::string box, of;
  for (int a = 0; a < k; ++a) {
    const hsize_t c = none ? 0 : count[a];
    box += (a ? ", " : "") + std::to_string(first[a]) + " + " + std::to_string(c);
    of += (a ? " x " : "") + std::to_string(dims[std::size_t(a)]);
    if (first[a] + c > dims[std::size_t(a)]) throw std::runtime_error(what + ": rows " + box + " of " + of);
    dims[std::size_t(a)] = c;
    start[std::size_t(a)] = first[a];
  }
  const H5Id mem_space(H5Screate_simple(rank, dims.data(), nullptr), H5Sclose, what);
  if (none) {
    h5_check(H5Sselect_none(file_space.get()), what);
    h5_check(H5Sselect_none(mem_space.get()), what);
  } else {
    h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, dims.data(), nullptr),
             what);
  }
  h5_check(H5Dwrite(set, mem_type, mem_space.get(), file_space.get(), dxpl, data), what);
}

/// write_rows of the box [first, first + count) x [first1, first1 + count1) of the first two
/// dimensions (every value of the others): a block of a grid cut along z and y (DESIGN 8).
/// `data` holds the box in the dataset's order; `count` = 0 for a process that has none.
inline void write_box(hid_t file, const std::string& name, hid_t mem_type, hsize_t first, hsize_t count,
                      hsize_t first1, hsize_t count1, const void* data, const WriteGroup& group,
                      const std::string& what) {
  const H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const H5Id dxpl = group.transfer(what);
  const hsize_t f[2] = {first, first1}, c[2] = {count, count1};
  write_leading_box(set.get(), mem_type, f, c, 2, data, dxpl.get(), what);
}

/// Values of the one-dimensional dataset `name` in `chunks` runs of `block` values, the
/// first at `first` and each `stride` after the one before, to or from memory where they
/// lie `mem_stride` apart from `data`: a block's share of a checkpoint's store, a run of
/// rows of each of its planes (DESIGN 8). Writing is collective over `group` (chunks = 0 for
/// a process that has none); reading is each process's own.
inline void strided_values(hid_t file, const std::string& name, hid_t mem_type, hsize_t first, hsize_t stride,
                           hsize_t chunks, hsize_t block, hsize_t mem_stride, void* data, const WriteGroup* group,
                           const std::string& what) {
  const H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const H5Id file_space(H5Dget_space(set.get()), H5Sclose, what);
  if (H5Sget_simple_extent_ndims(file_space.get()) != 1) throw std::runtime_error(what + ": not one-dimensional");
  hsize_t n = 0;
  h5_check(H5Sget_simple_extent_dims(file_space.get(), &n, nullptr), what);
  if (chunks == 0 || block == 0) chunks = block = 0;
  if (chunks > 0 && first + (chunks - 1) * stride + block > n)
    throw std::runtime_error(what + ": values to " + std::to_string(first + (chunks - 1) * stride + block) + " of " +
                             std::to_string(n));
  const hsize_t mem_n = chunks == 0 ? 1 : (chunks - 1) * mem_stride + block;
  const H5Id mem_space(H5Screate_simple(1, &mem_n, nullptr), H5Sclose, what);
  if (chunks == 0) {
    h5_check(H5Sselect_none(file_space.get()), what);
    h5_check(H5Sselect_none(mem_space.get()), what);
  } else {
    const hsize_t fs = chunks > 1 ? stride : 1, ms = chunks > 1 ? mem_stride : 1, zero = 0;
    h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &first, &fs, &chunks, &block), what);
    h5_check(H5Sselect_hyperslab(mem_space.get(), H5S_SELECT_SET, &zero, &ms, &chunks, &block), what);
  }
  if (group != nullptr) {
    const H5Id dxpl = group->transfer(what);
    h5_check(H5Dwrite(set.get(), mem_type, mem_space.get(), file_space.get(), dxpl.get(), data), what);
  } else if (chunks > 0) {
    h5_check(H5Dread(set.get(), mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, data), what);
  }
}

/// Reads values [first, first + count) of the one-dimensional dataset `name` into `data`
/// (a restart's share of a checkpoint's store, read by each process on its own).
inline void read_values(hid_t file, const std::string& name, hid_t mem_type, hsize_t first, hsize_t count,
                        void* data, const std::string& what) {
  const H5Id set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const H5Id file_space(H5Dget_space(set.get()), H5Sclose, what);
  if (H5Sget_simple_extent_ndims(file_space.get()) != 1) throw std::runtime_error(what + ": not one-dimensional");
  hsize_t n = 0;
  h5_check(H5Sget_simple_extent_dims(file_space.get(), &n, nullptr), what);
  if (first + count > n)
    throw std::runtime_error(what + ": values " + std::to_string(first) + " to " + std::to_string(first + count) +
                             " of " + std::to_string(n));
  if (count == 0) return;
  h5_check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &first, nullptr, &count, nullptr), what);
  const H5Id mem_space(H5Screate_simple(1, &count, nullptr), H5Sclose, what);
  h5_check(H5Dread(set.get(), mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, data), what);
}

}  // namespace cosim::protocol
