#include "fluid/schemes/serial_scheme.hpp"

#include "fluid/schemes/scheme_context.hpp"

namespace cosim::fluid {

/// The bulk of the step while the solid computes its impulses (with two grids).
std::optional<int> SerialFluidScheme::before_wait(SchemeContext& ctx) {
  return ctx.begin_step(step_, step_ >= rigid_steps_);
}

/// solid_state_t(n) drives LB step n -> n + 1 and fluid_state_t(n + 1); in the parallel
/// scheme fluid_state_t(0) goes out first when its first interval is dynamic.
Reply SerialFluidScheme::on_solid_state(const cosimlcm::solid_state_t& m, SchemeContext& ctx) {
  const std::int64_t step = step_++;
  return ctx.lb_step(m, step, step == 0 && publishes(0), publishes(step + 1));
}

}  // namespace cosim::fluid
