// A whole grid's population store in a checkpoint file, each process its own share
// (DESIGN 2.4 and 8): written collectively into the dataset the leading process created
// (common/hdf5/hdf5_handle.hpp: create_dataset, write_rows), read back by each process.
// The file holds the store as one process holds it (19 x stride values, ghosts included,
// FluidSolver's layout): a checkpoint of any rank count restarts on any other.
#pragma once

#include <cstddef>
#include <string>

namespace cosim::protocol {
class WriteGroup;
}

namespace cosim::fluid {

/// One process's share of a whole grid's store: per population q, `chunks` runs of `count`
/// values, the first [first, first + count) of the whole store's q at local_first of its own
/// store's q, each next run whole_chunk_stride (in the whole store) and local_chunk_stride
/// (in its own) further on: a block's rows of each of its planes (DESIGN 8).
struct StoreShare {
  std::size_t value_bytes = sizeof(double);  ///< 8 (double), 4 (float) or 2 (the half store's codes)
  std::size_t whole_stride = 0;  ///< values per population, the whole grid's layout
  std::size_t local_stride = 0;  ///< the same for this process's store
  std::size_t first = 0, local_first = 0, count = 0;
  std::size_t chunks = 1, whole_chunk_stride = 0, local_chunk_stride = 0;
};

/// Writes this process's share of its store (`store`: population 0's first value, the
/// others local_stride apart) into dataset `name` of `file`; every process of `group` calls
/// it (nullptr: this process alone). Returns the first error of any process ("" when
/// none), on every process.
std::string write_store_share(const std::string& file, const std::string& name, const void* store,
                              const StoreShare& share, const protocol::WriteGroup* group);

/// Reads this process's share of dataset `name` of `file` into `store` (a restart);
/// "" or the error, naming the file.
std::string read_store_share(const std::string& file, const std::string& name, void* store, const StoreShare& share);

}  // namespace cosim::fluid
