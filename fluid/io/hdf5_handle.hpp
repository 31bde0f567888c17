// Forwards to common/hdf5/hdf5_handle.hpp (shared with the solid library): ownership of HDF5
// C API identifiers, with HDF5 errors turned into one-line exceptions. Internal to
// fluid/*.cpp: headers of the library do not expose HDF5.
#pragma once

#include "common/hdf5/hdf5_handle.hpp"

namespace cosim::fluid {

using protocol::H5Id;
using protocol::h5_check;
using protocol::h5_fail;

}  // namespace cosim::fluid
