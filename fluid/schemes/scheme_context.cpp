#include "fluid/schemes/scheme_context.hpp"

#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"

namespace cosim::fluid {

namespace {
double seconds(SchemeContext::Clock::time_point a, SchemeContext::Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}
}  // namespace

SchemeContext::SchemeContext(Coordinator& coordinator, FluidRun& fluid_run)
    : coord(coordinator), run(fluid_run), x(static_cast<std::size_t>(coordinator.num_cgps())), j(x.size()),
      samples(x.size()), start_samples(x.size()), overlap_(fluid_run.domain().bulk_before_impulses()) {}

std::optional<int> SchemeContext::read(const cosimlcm::solid_state_t& m, std::int64_t step) {
  if (auto e = coord.check_solid_state(m, step)) return coord.end(*e);
  for (std::size_t l = 0; l < x.size(); ++l) {
    x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
    j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
  }
  return std::nullopt;
}

std::optional<int> SchemeContext::outputs(std::int64_t now, bool& periodic) {
  const bool last = now == run.total_steps();
  periodic = !last && run.checkpoint_every() > 0 && now % run.checkpoint_every() == 0;
  return run.step_outputs(now, last, periodic);
}

void SchemeContext::publish(std::int64_t now, const std::vector<MarkerSample>& after,
                            const std::vector<MarkerSample>& before, int iteration) {
  charge();
  coord.publish_fluid_state(now, run.bulk_velocity(), after, before, iteration);
  run.timing().publish += seconds(mark_, Clock::now());
  mark();
}

void SchemeContext::charge() {
  const Clock::time_point t = Clock::now();
  run.timing().compute += seconds(mark_, t);
  mark_ = t;
}

// The bulk of the step overlaps the solid's compute, and every ending (a lost peer, a
// signal, a watchdog trip) still finds the state of the committed step whole (DESIGN 2.4, 7):
//  - two grids: the bulk of the step to step + 1 needs no impulses (FluidDomain::begin_step:
//    the cells that receive them are collided again by finish_step) and leaves the state of
//    `step` in the other grid: it runs here, while the solid computes the impulses.
//  - in place: the bulk overwrites the state it steps from, so it cannot run before the
//    message: the step runs after it, first near the markers only (FluidDomain::step_near:
//    the cells the sample at X_l reads, the forced ones, the faces' margins), then
//    fluid_state_t(step + 1) goes out, and the rest of the step runs while the solid
//    computes its answer (lb_step). The state is whole at every wait: the rest ran before
//    it; and nothing sees it part stepped, since every reader of the whole state (a trip's
//    checkpoint, the health check, the outputs) runs the rest first (FluidSolver::
//    step_reading). The same bits as the step run whole (SplitStepInPlaceKeepsAbortCheckpointWhole).
std::optional<int> SchemeContext::begin_step(std::int64_t step, bool free) {
  coord.begin_step(step);
  // In the free steps the solid computes beside the bulk, on the same cores: the kernel
  // hands its rows out as its threads come free (RowSchedule::Dynamic).
  run.domain().set_row_schedule(free ? RowSchedule::Dynamic : RowSchedule::Static);
  if (!overlap_) return std::nullopt;
  run.domain().begin_step();
  // The flow_health sentinel on the state `step` the bulk read.
  return run.check_step_read(step);
}

Reply SchemeContext::lb_step(const cosimlcm::solid_state_t& m, std::int64_t step, bool publish_before,
                             bool publish_after) {
  if (auto code = read(m, step)) return {code};
  // The watchdog on the markers (DESIGN 6): how far each moved, how far apart they are.
  // The fluid at `step` is not touched yet: it is kept, if healthy, as the checkpoint.
  if (auto code = run.check_positions(step, x, j)) return {code};
  if (publish_before) {
    // The parallel scheme's first interval (dynamic from step 1) is driven by the fluid at
    // step 0, sampled at the initial X_l (Eq. 17) and published before the first step.
    if (auto code = run.sample_markers(step, x, samples)) return {code};
    publish(step, samples, samples);
  }
  // Eqs. 21-24 and 25-26: spread J_l at X_l, collide the cells that receive them with the
  // forcing (the rest of the step was streamed and collided in the bulk).
  FluidDomain& fluid = run.domain();
  run.hold_body(j);  // [held_body]: the body's impulses first (Turek and Hron's cylinder)
  fluid.spread(x, j);
  const std::int64_t now = step + 1;
  // fluid_state_t(now) goes out before the outputs of `now`, unless it carries the bulk
  // velocity of the monitor row of `now` (FluidRun::monitor_due).
  bool published = false;
  if (overlap_) {
    fluid.finish_step();
  } else {
    // In place (begin_step): the step near the markers; its sample, published, sets the
    // solid going; then the rest of the step, while the solid computes.
    fluid.step_near(x);
    if (publish_after && !run.monitor_due(now)) {
      if (auto code = run.sample_markers(now, x, samples)) return {code};
      // fluid_state_t's *_start_lb serve the implicit scheme only: a copy of the sample here.
      publish(now, samples, samples);
      published = true;
    }
    fluid.finish_rest();
    // The sentinel after the whole step (the fluid-only loop's order): the kernel's
    // extrema of `step`, the state now if suspect.
    if (auto code = run.check_step_read(step)) return {code};
  }
  if (publish_after && !published)
    if (auto code = run.sample_markers(now, x, samples)) return {code};
  bool periodic = false;
  if (auto code = outputs(now, periodic)) return {code};
  if (publish_after) {
    if (!published) publish(now, samples, samples);
    if (periodic) run.checkpoint(now, "");
  }
  return {std::nullopt, now};
}

}  // namespace cosim::fluid
