// The fluid's coupling schemes by name (protocol/coupling_scheme.hpp): one line each. A new
// scheme is a file here, its line below, and its solid side (solid/schemes/).
#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "fluid/schemes/scheme_context.hpp"
#include "fluid/schemes/serial_scheme.hpp"
#include "protocol/message_checks.hpp"

namespace cosim::fluid {

std::unique_ptr<FluidScheme> make_parallel_fluid_scheme(std::int64_t total_steps, std::int64_t rigid_steps);
std::unique_ptr<FluidScheme> make_implicit_fluid_scheme(std::int64_t total_steps, std::int64_t rigid_steps);

std::int64_t FluidScheme::highest_solid_step(std::int64_t awaited_key, std::int64_t, std::int64_t total_steps) const {
  return std::min<std::int64_t>(awaited_key + protocol::kStepWindow, total_steps - 1);
}

std::string FluidScheme::keep(SchemeContext& ctx, const std::string& reason) {
  return ctx.run.checkpoint(step(), reason);
}

void FluidScheme::write_checkpoint(protocol::CheckpointWriter& w, std::int64_t, const Coordinator& c) const {
  w.attr("fluid_seq", c.fluid_seq());
}

std::unique_ptr<FluidScheme> make_fluid_scheme(const protocol::SchemeSettings& settings, std::int64_t total_steps,
                                               std::int64_t rigid_steps) {
  switch (settings.scheme) {
    case protocol::CouplingScheme::Serial:
      return std::make_unique<SerialFluidScheme>(protocol::message_order(settings.scheme), total_steps, rigid_steps);
    case protocol::CouplingScheme::Parallel: return make_parallel_fluid_scheme(total_steps, rigid_steps);
    case protocol::CouplingScheme::Implicit: return make_implicit_fluid_scheme(total_steps, rigid_steps);
  }
  throw std::invalid_argument(std::string("no fluid side for the coupling scheme '") +
                              protocol::scheme_name(settings.scheme) + "'");
}

}  // namespace cosim::fluid
