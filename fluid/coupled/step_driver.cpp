#include "fluid/coupled/step_driver.hpp"

#include <chrono>
#include <string>

#include "common/run/exit_codes.hpp"
#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "fluid/schemes/scheme_context.hpp"
#include "protocol/session/interrupt.hpp"

namespace cosim::fluid {

int drive_steps(Coordinator& coord, FluidRun& run, FluidScheme& scheme, std::int64_t first_step) {
  using Clock = std::chrono::steady_clock;
  SchemeContext ctx(coord, run);
  scheme.start(first_step, ctx);
  while (!scheme.done()) {
    const std::int64_t step = scheme.step();
    ctx.mark();
    if (auto code = scheme.before_wait(ctx)) return *code;
    ctx.charge();
    const Clock::time_point t0 = Clock::now();
    if (auto e = coord.wait_for_solid_state(step)) {
      // A clean abort (the solid lost or stopped with an error): the committed state at
      // `step` is kept for a restart (DESIGN 2.4), as the scheme keeps it.
      const bool keep = e->code == protocol::exit_code::peer_lost && step > first_step;
      return run.peer_ending(*e, step, keep ? scheme.keep(ctx, e->reason) : "");
    }
    // SIGINT or SIGTERM: as a lost solid, with the committed state at `step` (solid_state_t
    // of `step` has come: the solid's checkpoint holds it in flight), stop_t(1) naming the
    // signal.
    if (protocol::interrupted()) {
      std::string reason = protocol::interrupt_reason() + " at step " + std::to_string(step);
      if (step > first_step) reason += scheme.keep(ctx, reason);
      return coord.stop_and_end({protocol::exit_code::system, reason, false}, step);
    }
    ctx.mark();
    run.timing().wait += std::chrono::duration<double>(Clock::now() - t0).count();
    // A message of the next step that came early is offered again, now due (in the
    // parallel scheme solid_state_t(n + 1) may overtake a lost solid_state_t(n)).
    const Reply reply = scheme.on_solid_state(coord.take(), ctx);
    if (reply.exit) return *reply.exit;
    ctx.charge();
    if (reply.now >= 0) run.progress(reply.now, reply.iteration);
  }
  return run.finish();
}

}  // namespace cosim::fluid
