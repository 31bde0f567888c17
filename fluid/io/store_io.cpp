#include "fluid/io/store_io.hpp"

#include <exception>

#include "fluid/io/hdf5_handle.hpp"
#include "fluid/io/hdf5_quiet.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "fluid/lattice/d3q19.hpp"

namespace cosim::fluid {

namespace {

/// The values in memory: doubles, floats, or the half store's 16-bit codes (as unsigned
/// integers: their bits, fluid/lattice/half.hpp).
hid_t memory_type(const StoreShare& share) {
  return share.value_bytes == 8 ? H5T_NATIVE_DOUBLE : share.value_bytes == 4 ? H5T_NATIVE_FLOAT : H5T_NATIVE_UINT16;
}

}  // namespace

std::string write_store_share(const std::string& file, const std::string& name, const void* store,
                              const StoreShare& share, const protocol::WriteGroup* group) {
  const protocol::WriteGroup alone;
  const protocol::WriteGroup& g = group != nullptr ? *group : alone;
  const H5Quiet quiet;
  const std::string what = "checkpoint " + file + ": cannot write " + name;
  const hid_t mem_type = memory_type(share);
  const std::size_t size = share.value_bytes;
  std::string error;
  // Every process makes the same collective calls even after a failure of its own (the
  // open, one write per population, the close), so that none waits for it.
  H5Id f;
  try {
    f = protocol::open_for_hyperslabs(file, g, what);
  } catch (const std::exception& x) {
    error = x.what();
  }
  if (!(error = g.first_error(error)).empty()) return error;
  for (int q = 0; q < D3Q19::Q; ++q) {
    const auto* from = static_cast<const unsigned char*>(store) + (q * share.local_stride + share.local_first) * size;
    try {
      protocol::strided_values(f.get(), name, mem_type, hsize_t(q * share.whole_stride + share.first),
                               hsize_t(share.whole_chunk_stride), hsize_t(share.chunks), hsize_t(share.count),
                               hsize_t(share.local_chunk_stride), const_cast<unsigned char*>(from), &g, what);
    } catch (const std::exception& x) {
      if (error.empty()) error = x.what();
    }
  }
  try {
    f.close(what);
  } catch (const std::exception& x) {
    if (error.empty()) error = x.what();
  }
  return g.first_error(error);
}

std::string read_store_share(const std::string& file, const std::string& name, void* store, const StoreShare& share) {
  const H5Quiet quiet;
  const std::string what = "checkpoint " + file + ": cannot read " + name;
  const hid_t mem_type = memory_type(share);
  const std::size_t size = share.value_bytes;
  try {
    const H5Id f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, what);
    for (int q = 0; q < D3Q19::Q; ++q) {
      auto* into = static_cast<unsigned char*>(store) + (q * share.local_stride + share.local_first) * size;
      protocol::strided_values(f.get(), name, mem_type, hsize_t(q * share.whole_stride + share.first),
                               hsize_t(share.whole_chunk_stride), hsize_t(share.chunks), hsize_t(share.count),
                               hsize_t(share.local_chunk_stride), into, nullptr, what);
    }
  } catch (const std::exception& x) {
    return x.what();
  }
  return {};
}

}  // namespace cosim::fluid
