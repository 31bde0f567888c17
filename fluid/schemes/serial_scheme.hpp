// The serial staggered scheme, the paper's (DESIGN 2.1; protocol/README.md section 5): LB
// step n -> n + 1 spreads the impulses of solid_state_t(n) at its positions (Eqs. 21-26),
// then the fluid at n + 1 is sampled at them (Eq. 17) and published as fluid_state_t(n + 1),
// which drives the solid's interval n + 1 (fluid_state_t 1 .. N - 1). The parallel scheme
// (parallel_scheme.cpp) is this scheme with another set of fluid_state_t (its name table row).
#pragma once

#include <cstdint>

#include "fluid/schemes/fluid_scheme.hpp"

namespace cosim::fluid {

class SerialFluidScheme : public FluidScheme {
 public:
  SerialFluidScheme(const protocol::MessageOrder& order, std::int64_t total_steps, std::int64_t rigid_steps)
      : FluidScheme(order), total_steps_(total_steps), rigid_steps_(rigid_steps) {}

  void start(std::int64_t first_step, SchemeContext&) override { step_ = first_step; }
  std::int64_t step() const override { return step_; }
  bool done() const override { return step_ >= total_steps_; }
  std::optional<int> before_wait(SchemeContext& ctx) override;
  Reply on_solid_state(const cosimlcm::solid_state_t& m, SchemeContext& ctx) override;

 protected:
  /// Whether the fluid publishes fluid_state_t(m) (the name table's).
  bool publishes(std::int64_t m) const { return order().fluid_publishes(m, total_steps_, rigid_steps_); }

  const std::int64_t total_steps_, rigid_steps_;
  std::int64_t step_ = 0;  ///< the committed LB step
};

}  // namespace cosim::fluid
