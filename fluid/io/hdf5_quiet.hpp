// Forwards to common/hdf5/hdf5_quiet.hpp (shared with the solid library): a scope in which
// the HDF5 library does not print its error stack to stderr.
#pragma once

#include "common/hdf5/hdf5_quiet.hpp"

namespace cosim::fluid {

using protocol::H5Quiet;

}  // namespace cosim::fluid
