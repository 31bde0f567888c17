// The fluid server's coupled run (protocol/README.md sections 5-9; DESIGN 2.1-2.2): the
// coordinator (fluid/coupled/coordinator.hpp: handshake, step clock, checks, timeouts) and
// the fluid's side of the scene's coupling scheme (fluid/schemes/), over LCM.
#pragma once

#include <ostream>
#include <string>

#include "fluid/config/scene_config.hpp"
#include "protocol/session/session_options.hpp"

namespace lcm {
class LCM;
}

namespace cosim::fluid {

class FluidDomain;

/// The run's token, quiet, an in-process bus (lcm_url is then ignored), faults, --restart
/// (protocol/session/session_options.hpp), and:
struct CoupledFluidOptions : protocol::SessionOptions {
  std::string channel_prefix;  ///< overrides [coupling] channel_prefix when not empty
  std::string lcm_url;         ///< overrides [coupling] lcm_url when not empty
};

/// Runs a coupled scene (scene.coupling present) to the end. Returns the exit code of
/// protocol/README.md section 9 (0 done, 1 system, 2 bad input / refused handshake /
/// malformed message, 3 unhealthy, 4 peer lost) after printing one line on `err` for any
/// non-zero code.
int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options,
                      std::ostream& out, std::ostream& err);
/// The same on `domain`: the grid in this process, or over the ranks of an MPI run led from
/// this one (fluid/mpi/led_domain.hpp; the coordinator and the session live here only).
int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options,
                      std::ostream& out, std::ostream& err, FluidDomain& domain);

}  // namespace cosim::fluid
