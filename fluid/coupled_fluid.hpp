// The fluid server's coupled run (protocol/README.md sections 5-9; DESIGN 2.1-2.2): the
// coordinator (handshake, step clock, checks, timeouts) and the fluid's side of the serial
// staggered scheme, over LCM.
#pragma once

#include <ostream>
#include <string>

#include "fluid/scene_config.hpp"
#include "protocol/fault_injection.hpp"

namespace lcm {
class LCM;
}

namespace cosim::fluid {

struct CoupledFluidOptions {
  std::string token;           ///< the run's token (16 hex digits)
  std::string channel_prefix;  ///< overrides [coupling] channel_prefix when not empty
  std::string lcm_url;         ///< overrides [coupling] lcm_url when not empty
  bool quiet = false;
  /// A bus to use instead of opening one (lcm_url is then ignored): an in-process peer on
  /// one memq:// bus (the replay tool, tests). Not owned; the subscriptions made on it are
  /// removed before run_coupled_fluid returns.
  lcm::LCM* bus = nullptr;
  /// Faults injected into what this side publishes (protocol/fault_injection.hpp; tests).
  protocol::FaultSettings faults;
  /// A checkpoint file (OUTPUT/checkpoints/fluid_NNNNNNNN.h5) to continue from; the solid
  /// restarts from its own checkpoint of the same step (DESIGN 2.4).
  std::string restart;
};

/// Runs a coupled scene (scene.coupling present) to the end. Returns the exit code of
/// protocol/README.md section 9 (0 done, 1 system, 2 bad input / refused handshake /
/// malformed message, 3 unhealthy, 4 peer lost) after printing one line on `err` for any
/// non-zero code.
int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options,
                      std::ostream& out, std::ostream& err);

}  // namespace cosim::fluid
