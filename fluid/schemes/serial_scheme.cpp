#include "fluid/schemes/serial_scheme.hpp"

#include <chrono>
#include <vector>

#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "protocol/session/interrupt.hpp"

namespace cosim::fluid {

namespace {
using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }
}  // namespace

int SerialFluidScheme::run(Coordinator& coord, FluidRun& run, std::int64_t first_step) {
  FluidDomain& fluid = run.domain();
  StepTiming& timing = run.timing();
  const auto n = static_cast<std::size_t>(coord.num_cgps());
  std::vector<Vec3> x(n), j(n);
  std::vector<MarkerSample> samples(n);
  // The bulk of the step to step + 1 needs no impulses with two grids (FluidDomain::
  // begin_step: the cells that receive them are collided again by finish_step): it runs
  // while the solid computes them, and the result is that of a whole step after the wait.
  // The in-place propagation needs the forced cells before the bulk, which overwrites the
  // state of `step`: there the whole step runs after the message, so every ending below
  // (a lost peer, a signal, a watchdog trip) still finds the state of `step` whole.
  const bool overlap = fluid.bulk_before_impulses();
  for (std::int64_t step = first_step; step < total_steps_; ++step) {
    coord.begin_step(step);
    // In the free steps the solid computes beside the bulk, on the same cores: the kernel
    // hands its rows out as its threads come free (RowSchedule::Dynamic).
    fluid.set_row_schedule(step >= rigid_steps_ ? RowSchedule::Dynamic : RowSchedule::Static);
    if (overlap) {
      const Clock::time_point tb = Clock::now();
      fluid.begin_step();
      // The flow_health sentinel on the state `step` the bulk read.
      if (auto code = run.check_step_read(step)) return *code;
      timing.compute += seconds(tb, Clock::now());
    }
    const Clock::time_point t0 = Clock::now();
    if (auto e = coord.wait_for_solid_state(step)) {
      // A clean abort (the solid lost or stopped with an error): the state at `step` is
      // whole, so it is kept for a restart (DESIGN 2.4).
      const bool keep = e->code == protocol::exit_code::peer_lost && step > first_step;
      return run.peer_ending(*e, step, keep ? run.checkpoint(step, e->reason) : "");
    }
    // SIGINT or SIGTERM: the fluid at `step` is whole and solid_state_t(step) has come (the
    // solid's checkpoint of `step` holds it in flight): both keep `step`.
    if (protocol::interrupted()) return run.interrupt(step);
    Clock::time_point t1 = Clock::now();
    timing.wait += seconds(t0, t1);
    // A message of the next step that came early is offered again, now due (in the
    // parallel scheme solid_state_t(n + 1) may overtake a lost solid_state_t(n)).
    const cosimlcm::solid_state_t m = coord.take();
    if (auto e = coord.check_solid_state(m, step)) return coord.end(*e);
    for (std::size_t l = 0; l < n; ++l) {
      x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
      j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
    }
    // The watchdog on the markers (DESIGN 6): how far each moved, how far apart they are.
    // The fluid at `step` is not touched yet: it is kept, if healthy, as the checkpoint.
    if (auto code = run.check_positions(step, x, j)) return *code;
    if (step == 0 && publishes(0)) {
      // The parallel scheme's first interval (dynamic from step 1) is driven by the fluid
      // at step 0, sampled at the initial X_l (Eq. 17) and published before the first step.
      if (auto code = run.sample_markers(0, x, samples)) return *code;
      const Clock::time_point t2 = Clock::now();
      timing.compute += seconds(t1, t2);
      coord.publish_fluid_state(0, run.bulk_velocity(), samples, samples);
      t1 = Clock::now();
      timing.publish += seconds(t2, t1);
    }
    // Eqs. 21-24 and 25-26: spread J_l at X_l, collide the cells that receive them with the
    // forcing (the rest of the step was streamed and collided in the bulk).
    run.hold_body(j);  // [held_body]: the body's impulses first (Turek and Hron's cylinder)
    fluid.spread(x, j);
    if (!overlap) fluid.begin_step();
    fluid.finish_step();
    // In place, the sentinel after the whole step (the state is not read mid-step; the
    // fluid-only loop's order): the kernel's extrema of `step`, the state now if suspect.
    if (!overlap)
      if (auto code = run.check_step_read(step)) return *code;
    const std::int64_t now = step + 1;
    const bool last = now == total_steps_;
    const bool publish = publishes(now);
    if (publish)
      if (auto code = run.sample_markers(now, x, samples)) return *code;
    const bool periodic = !last && run.checkpoint_every() > 0 && now % run.checkpoint_every() == 0;
    if (auto code = run.step_outputs(now, last, periodic)) return *code;
    if (publish) {
      const Clock::time_point t2 = Clock::now();
      timing.compute += seconds(t1, t2);
      // fluid_state_t's *_start_lb serve the implicit scheme only: a copy of the sample here.
      coord.publish_fluid_state(now, run.bulk_velocity(), samples, samples);
      timing.publish += seconds(t2, Clock::now());
      if (periodic) run.checkpoint(now, "");
    } else {
      timing.compute += seconds(t1, Clock::now());
    }
    run.progress(now);
  }
  return run.finish();
}

}  // namespace cosim::fluid
