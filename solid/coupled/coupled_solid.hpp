// The solid server's coupled run (protocol/README.md sections 5-9; DESIGN 2.1-2.2): the
// handshake with the fluid's coordinator, then the solid's side of the serial staggered
// scheme in lock-step over LCM: for every fluid_state_t(m), one LB interval of the sheets
// (SolidCoupler) and solid_state_t(m) back, with resends, timeouts, foreign tokens and
// stop_t as the protocol says. The `solid` executable is a thin wrapper around
// run_coupled_solid; the tests call it in-process over memq://.
//
// Inside: the solid's physics (solid_run.hpp), its session with the coordinator
// (solid_peer.hpp), its output (coupled_series.hpp, solid_checkpoints.hpp) and the coupling
// scheme's side, chosen by name ([coupling] scheme) from solid/schemes/registry.cpp.
#pragma once

#include <ostream>
#include <string>

#include "protocol/fault_injection.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/session_options.hpp"
#include "solid/config/solid_scene.hpp"

namespace lcm {
class LCM;
}

namespace cosim::solid {

/// Exit codes of both servers (protocol/README.md section 9), defined once in the session layer.
namespace exit_code = protocol::exit_code;

/// The run's token (required unless check_only), quiet, an in-process bus, faults, --restart
/// (protocol/session/session_options.hpp), and:
struct CoupledSolidOptions : protocol::SessionOptions {
  /// Build the model, print the header and return 0: no LCM, no token needed.
  bool check_only = false;
};

/// Runs a coupled scene (scene.coupled()) to its end and returns the exit code of
/// protocol/README.md section 9.
///
/// Builds the model named by the scene (model_registry), a SolidCoupler with
/// marker_areas_lb and origin_lb = (0, -1/2, 0); publishes hello_t every 200 ms until a
/// welcome_t of the run (refused: 2; none within handshake_timeout_s: stop_t(4), 4); then
/// solid_state_t(0) (initial positions, zero impulses) and, for every fluid_state_t(m) of
/// the run, checks it (sizes: 2; non-finite or rho <= 0: 3), advances one LB interval
/// (rigid while m < welcome_t.rigid_steps) and publishes solid_state_t(m). Answers
/// resend_t("solid_state") from its last two messages; asks resend_t("fluid_state") after
/// resend_after_s of silence; gives up after peer_timeout_s (stop_t(4) three times, 4).
/// A stop_t of the run ends it: 0 for exit code 0, else 4. On its own errors it publishes
/// stop_t with its code and reason. Writes OUTPUT/solid.h5 (one row per LB step) whenever
/// the run got past the handshake, and prints the counters on `out`.
///
/// @pre  scene.coupled(); options.token not empty unless check_only.
/// @post the header and a summary went to `out`; a non-zero code printed one line naming
///       the reason (and the step) on `err`. Exceptions do not escape.
int run_coupled_solid(const SolidScene& scene, const CoupledSolidOptions& options,
                      std::ostream& out, std::ostream& err);

}  // namespace cosim::solid
