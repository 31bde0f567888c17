// Provenance and units in an HDF5 file (common/run/provenance.hpp), with the HDF5 C API:
// internal to the .cpp files of the writers (monitor.h5, solid.h5, the field, plane and
// sheet snapshots), like common/hdf5/hdf5_handle.hpp.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <string>
#include <vector>

#include "common/hdf5/h5_writer.hpp"
#include "common/run/provenance.hpp"
#include "common/run/version.hpp"

namespace cosim::protocol {

/// The run's provenance as attributes of the file's root group: program, version,
/// git_describe, git_commit, command_line, start_time_utc, host, host_cpu, scene_path and
/// scene_toml (the scene file's text).
inline void stamp_provenance(hid_t file) {
  const Provenance& p = provenance();
  put_attribute(file, "program", p.program);
  put_attribute(file, "version", version());
  put_attribute(file, "git_describe", git_describe());
  put_attribute(file, "git_commit", git_commit());
  put_attribute(file, "command_line", p.command_line);
  put_attribute(file, "start_time_utc", p.start_time_utc);
  put_attribute(file, "host", p.host);
  put_attribute(file, "host_cpu", p.host_cpu);
  put_attribute(file, "scene_path", p.scene_path);
  put_attribute(file, "scene_toml", p.scene_text);
}

/// Both: the provenance on the root, the units on every dataset (h5_writer.hpp: stamp_units).
inline void stamp_file(hid_t file) {
  stamp_provenance(file);
  stamp_units(file);
}

}  // namespace cosim::protocol
