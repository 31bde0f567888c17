// Provenance and units in an HDF5 file (common/run/provenance.hpp), with the HDF5 C API:
// internal to the .cpp files of the writers (monitor.h5, solid.h5, the field, plane and
// sheet snapshots), like common/hdf5/hdf5_handle.hpp.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <string>
#include <vector>

#include "common/hdf5/dataset_units.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/provenance.hpp"
#include "common/run/version.hpp"

namespace cosim::protocol {

/// A scalar string attribute `name` on `object` (replaced when it exists).
inline void put_string_attribute(hid_t object, const char* name, const std::string& value) {
  const std::string what = std::string("cannot write the attribute ") + name;
  if (H5Aexists(object, name) > 0) h5_check(H5Adelete(object, name), what);
  const H5Id type(H5Tcopy(H5T_C_S1), H5Tclose, what);
  h5_check(H5Tset_size(type.get(), std::max<std::size_t>(1, value.size())), what);
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose, what);
  const H5Id attr(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, what);
  const std::string padded = value.empty() ? std::string(1, '\0') : value;
  h5_check(H5Awrite(attr.get(), type.get(), padded.data()), what);
}

/// The run's provenance as attributes of the file's root group: program, version,
/// git_describe, git_commit, command_line, start_time_utc, host, host_cpu, scene_path and
/// scene_toml (the scene file's text).
inline void stamp_provenance(hid_t file) {
  const Provenance& p = provenance();
  put_string_attribute(file, "program", p.program);
  put_string_attribute(file, "version", version());
  put_string_attribute(file, "git_describe", git_describe());
  put_string_attribute(file, "git_commit", git_commit());
  put_string_attribute(file, "command_line", p.command_line);
  put_string_attribute(file, "start_time_utc", p.start_time_utc);
  put_string_attribute(file, "host", p.host);
  put_string_attribute(file, "host_cpu", p.host_cpu);
  put_string_attribute(file, "scene_path", p.scene_path);
  put_string_attribute(file, "scene_toml", p.scene_text);
}

/// A "units" attribute (dataset_units()) on every dataset of the file's root group that has
/// none yet.
inline void stamp_units(hid_t file) {
  std::vector<std::string> datasets;
  h5_check(H5Literate(
               file, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr,
               [](hid_t group, const char* name, const H5L_info_t*, void* out) -> herr_t {
                 const hid_t object = H5Oopen(group, name, H5P_DEFAULT);
                 if (object < 0) return -1;
                 if (H5Iget_type(object) == H5I_DATASET) static_cast<std::vector<std::string>*>(out)->push_back(name);
                 return H5Oclose(object);
               },
               &datasets),
           "cannot list the datasets");
  for (const std::string& name : datasets) {
    const auto units = dataset_units(name);
    if (!units) continue;
    const H5Id dset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, "cannot open the dataset " + name);
    if (H5Aexists(dset.get(), "units") > 0) continue;
    put_string_attribute(dset.get(), "units", *units);
  }
}

/// Both: the provenance on the root, the units on every dataset.
inline void stamp_file(hid_t file) {
  stamp_provenance(file);
  stamp_units(file);
}

}  // namespace cosim::protocol
