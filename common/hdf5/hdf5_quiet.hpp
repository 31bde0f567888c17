// Scope in which the HDF5 library does not print its error stack to stderr.
#pragma once

#include <hdf5.h>

namespace cosim::protocol {

/// HDF5 prints every error stack by default; our callers get one exception line instead
/// (h5_fail). Restores the previous handler on exit. Not thread-safe (HDF5 serial).
class H5Quiet {
 public:
  H5Quiet() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~H5Quiet() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  H5Quiet(const H5Quiet&) = delete;
  H5Quiet& operator=(const H5Quiet&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

}  // namespace cosim::protocol
