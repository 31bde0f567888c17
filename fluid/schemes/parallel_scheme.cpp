// The parallel (Jacobi) scheme, the fluid's side (DESIGN 2.1; protocol/README.md section 14):
// the serial scheme, publishing the fluid_state_t the solid's next interval needs right after
// each step: fluid_state_t(n + 1) drives solid_state_t(n + 2) (dynamic steps), so the solid
// integrates while the fluid steps. Its checkpoints also hold the fluid_state_t in flight.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid/coupled/coordinator.hpp"
#include "fluid/schemes/serial_scheme.hpp"

namespace cosim::fluid {

namespace {

class ParallelFluidScheme final : public SerialFluidScheme {
 public:
  using SerialFluidScheme::SerialFluidScheme;

  void write_checkpoint(protocol::CheckpointWriter& w, std::int64_t step, const Coordinator& c) const override {
    SerialFluidScheme::write_checkpoint(w, step, c);
    // fluid_state_t(step) is in flight too: the solid's next interval needs it.
    if (const cosimlcm::fluid_state_t* m = c.sent_state(step)) {
      std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m->getEncodedSize()));
      m->encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      w.put("in_flight_fluid_state", bytes);
    }
  }

  /// The solid's restart awaits fluid_state_t(step) from step D - 1 on; it is published
  /// again once the checkpoint is read.
  std::optional<cosimlcm::fluid_state_t> read_checkpoint(const protocol::CheckpointReader& r,
                                                         std::int64_t step) const override {
    if (!(step >= std::max<std::int64_t>(rigid_steps_, 1) - 1 && publishes(step))) return std::nullopt;
    if (!r.has("in_flight_fluid_state"))
      throw std::runtime_error("no in_flight_fluid_state (fluid_state_t of step " + std::to_string(step) +
                               "), which the parallel scheme's solid needs to continue");
    cosimlcm::fluid_state_t m{};
    const std::vector<std::uint8_t> bytes = r.bytes("in_flight_fluid_state");
    if (m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0 || m.step != step ||
        m.num_cgps != static_cast<std::int32_t>(r.int64_attr("num_cgps")))
      throw std::runtime_error("in_flight_fluid_state is not the fluid_state_t of step " + std::to_string(step));
    return m;
  }

};

}  // namespace

std::unique_ptr<FluidScheme> make_parallel_fluid_scheme(std::int64_t total_steps, std::int64_t rigid_steps) {
  return std::make_unique<ParallelFluidScheme>(protocol::message_order(protocol::CouplingScheme::Parallel), total_steps,
                                              rigid_steps);
}

}  // namespace cosim::fluid
