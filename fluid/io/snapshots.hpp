// The field snapshots a scene asks for (scenes/README.md [output]): the whole grid every
// fields_every steps, and y planes every planes_every steps; nothing when neither is set.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "fluid/io/field_writer.hpp"
#include "fluid/config/scene_config.hpp"

namespace cosim::fluid {

class Snapshots {
 public:
  Snapshots(const FluidScene& scene, double dt_us);
  /// Whether a snapshot falls on `step` (step 0 and the last step included).
  bool due(std::int64_t step, bool last) const { return due(fields_every_, planes_every_, step, last); }
  /// The same from the scene, without a writer (the ranks of an MPI run that write nothing).
  static bool due(const FluidScene& scene, std::int64_t step, bool last) {
    return due(scene.fields_every, scene.planes_every, step, last);
  }
  /// Writes the snapshots due at the solver's step. @pre the state is healthy
  void write(const FluidSolver& solver, bool last);
  /// A restart at `step`: lists the snapshots an earlier run wrote up to `step` (included)
  /// in the XDMF files (FieldWriter::adopt).
  void adopt_up_to(std::int64_t step);

 private:
  static bool due(std::int64_t fields_every, std::int64_t planes_every, std::int64_t step, bool last);
  std::int64_t fields_every_, planes_every_;
  std::optional<FieldWriter> fields_;
  std::vector<FieldWriter> planes_;
};

}  // namespace cosim::fluid
