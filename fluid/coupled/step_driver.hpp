// The fluid's step driver (DESIGN 2.1; protocol/README.md sections 5, 13, 14): the one loop
// of a coupled run's LB steps, whatever the scheme, as the solid's event loop is
// (solid/coupled/coupled_solid.cpp). It waits for the solid_state_t the scheme awaits, ends
// the run on a lost peer or a signal (with the checkpoint the scheme keeps), hands each
// message to the scheme (fluid/schemes/), times the wait, compute and publishing, and prints
// the progress; the scheme answers per message.
#pragma once

#include <cstdint>

namespace cosim::fluid {

class Coordinator;
class FluidRun;
class FluidScheme;

/// The LB steps of the run from `first_step` (0, or a restart's step) to the end, after the
/// handshake and the restore; the exit code (the coordinator ended the run).
int drive_steps(Coordinator& coordinator, FluidRun& run, FluidScheme& scheme, std::int64_t first_step);

}  // namespace cosim::fluid
