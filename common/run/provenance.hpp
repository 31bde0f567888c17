// Provenance of a run (DESIGN 8's outputs): what produced an output folder and every HDF5
// file in it. main() records the invocation once (program, command line, start time) and
// the scene once it is read; the writers take it from here:
//   - write_provenance_files(): OUTPUT/scene.toml (a copy of the scene file) and
//     OUTPUT/provenance_PROGRAM.toml (version, commit, command line, start time, host CPU);
//   - stamp_provenance() and stamp_units() (common/run/provenance_h5.hpp): the same as
//     attributes of an HDF5 file's root, and a "units" attribute on every dataset from
//     dataset_units() (common/hdf5/dataset_units.hpp).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace cosim::protocol {

struct Provenance {
  std::string program = "cosim";                      ///< fluid, solid, cosim-replay, ...
  std::string command_line = "(not recorded)";        ///< argv, each word quoted for sh where needed
  std::string start_time_utc;                         ///< ISO 8601, when record_invocation ran
  std::string host;                                   ///< the host name
  std::string host_cpu;                               ///< /proc/cpuinfo's model name, x logical CPUs
  std::string scene_path;                             ///< absolute path of the scene file, if any
  std::string scene_text;                             ///< its text at start-up
};

/// Records the process's invocation (call first thing in main).
void record_invocation(const std::string& program, int argc, char** argv);
/// Records the scene file the run reads (its text is kept as it was at start-up).
void record_scene(const std::string& path);
/// This process's provenance; the version and commit come from common/run/version.hpp.
const Provenance& provenance();

/// "AMD EPYC 7B12 x 2 logical CPUs" from /proc/cpuinfo; "unknown" when it cannot be read.
std::string host_cpu();
/// The provenance as key = "value" lines (TOML), version and commit included; scene_copy
/// names the copy of the scene in the output folder.
std::string provenance_toml(const std::string& scene_copy = "scene.toml");
/// Writes DIR/scene.toml (the recorded scene's text, when there is one) and
/// DIR/provenance_PROGRAM.toml, each by an atomic rename (both servers of a coupled run
/// write the same scene.toml). A run continued in its folder (--restart) keeps the earlier
/// attempts' files and writes its own as scene.N.toml / provenance_PROGRAM.N.toml (N = 2,
/// 3, ...) when its text differs. Throws std::runtime_error (one line) when it cannot.
void write_provenance_files(const std::filesystem::path& dir);

}  // namespace cosim::protocol
