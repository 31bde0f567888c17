// The field snapshots a scene asks for (scenes/README.md [output]): the whole grid every
// fields_every steps, and y planes every planes_every steps; nothing when neither is set.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
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
  /// The same from each process's part of the grid, written by the processes of `group`
  /// together (FieldWriter::write; collective): a run over MPI ranks, each rank with its
  /// own Snapshots of the scene.
  void write(const FieldPart& part, const protocol::WriteGroup* group, bool last);
  /// A restart at `step`: lists the snapshots an earlier run wrote up to `step` (included)
  /// in the XDMF files (FieldWriter::adopt).
  void adopt_up_to(std::int64_t step);

 private:
  static bool due(std::int64_t fields_every, std::int64_t planes_every, std::int64_t step, bool last);
  std::int64_t fields_every_, planes_every_;
  std::optional<FieldWriter> fields_;
  std::vector<FieldWriter> planes_;
  FieldPart whole_;  // the serial write's fields, kept between snapshots
};

/// The largest file a coupled fluid writes between two of its messages, while the solid
/// hears nothing from it: a field snapshot (rho, u and vorticity: 7 doubles per cell) when
/// [output] fields_every > 0, a checkpoint (one population store, 19 values per cell with
/// ghosts) when [coupling] checkpoint_every > 0; 0 bytes when neither.
struct SilentWrite {
  double bytes = 0.0;
  std::string what;
};
SilentWrite largest_silent_write(const FluidScene& scene);

/// The write speed `fluid --check` assumes for that file: 30 MB/s, the slowest seen (the
/// fault campaign of issue 30: a 380 MB snapshot took more than 10 s; scenes/README.md
/// "Liveness while writing" has this machine's figure and the command).
inline constexpr double kAssumedWriteBytesPerS = 30e6;

/// The warning of `fluid --check` for a coupled scene whose largest silent write takes
/// more than half of coupling.peer_timeout_s at kAssumedWriteBytesPerS (the solid would
/// declare the fluid lost while it writes); "" when it does not.
std::string silent_write_warning(const FluidScene& scene);

}  // namespace cosim::fluid
