// The solid's coupled checkpoints (DESIGN 2.4; protocol/README.md section 10):
// OUTPUT/checkpoints/solid_NNNNNNNN.h5 with the state after the interval of a step, the
// solid_state_t of it in flight, the watchdog's energy ledger, the rows of solid.h5 so far
// and what the coupling scheme keeps (solid/schemes/solid_scheme.hpp); and the restart from
// one (--restart), which publishes that solid_state_t again.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

#include "common/run/exit_codes.hpp"
#include "protocol/session/session_options.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::solid {

class SolidRun;
class SolidPeer;
class SolidScheme;
class ServerSolid;

class SolidCheckpoints {
 public:
  SolidCheckpoints(const SolidScene& scene, const protocol::SessionOptions& options, SolidRun& run, SolidPeer& peer,
                   SolidScheme& scheme, ServerSolid& solid, std::ostream& out)
      : s_(scene), o_(options), run_(run), peer_(peer), scheme_(scheme), solid_(solid), out_(out) {}

  /// Writes the checkpoint of the last step sent (or the scheme's restart point) and keeps
  /// the newest three; returns its path. Throws (one line) on an output error.
  std::string write(const std::string& reason);
  /// write() for `step` when [coupling] checkpoint_every says so; an ending (1) on an error.
  std::optional<protocol::Ending> write_if_due(std::int64_t step);

  /// Continues from the checkpoint `path` (after the handshake): the model's state, the
  /// clock, the rows, the watchdog, the scheme's part and the awaited key; publishes its
  /// solid_state_t again. Throws (one line) for a file that is not a checkpoint of this
  /// scene and model.
  void restore(const std::string& path);

 private:
  const SolidScene& s_;
  const protocol::SessionOptions& o_;  ///< the run id and whether a restart may change A_T
  SolidRun& run_;
  SolidPeer& peer_;
  SolidScheme& scheme_;
  ServerSolid& solid_;  ///< the run as the scheme drives it (the start of a step being iterated)
  std::ostream& out_;
};

}  // namespace cosim::solid
