// The serial staggered scheme, the paper's (DESIGN 2.1; protocol/README.md section 5): LB
// step n -> n + 1 spreads the impulses of solid_state_t(n) at its positions (Eqs. 21-26),
// then the fluid at n + 1 is sampled at them (Eq. 17) and published as fluid_state_t(n + 1),
// which drives the solid's interval n + 1 (fluid_state_t 1 .. N - 1). The parallel scheme
// (parallel_scheme.cpp) is this loop with another set of fluid_state_t.
#pragma once

#include <cstdint>

#include "fluid/schemes/fluid_scheme.hpp"

namespace cosim::fluid {

class SerialFluidScheme : public FluidScheme {
 public:
  SerialFluidScheme(std::int64_t total_steps, std::int64_t rigid_steps)
      : total_steps_(total_steps), rigid_steps_(rigid_steps) {}

  int run(Coordinator& coordinator, FluidRun& run, std::int64_t first_step) override;

 protected:
  /// Whether the fluid publishes fluid_state_t(m).
  virtual bool publishes(std::int64_t m) const { return m >= 1 && m < total_steps_; }

  const std::int64_t total_steps_, rigid_steps_;
};

}  // namespace cosim::fluid
