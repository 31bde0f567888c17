// The paper's serial staggered scheme, the solid's side (DESIGN 2.1; protocol/README.md
// section 5): fluid_state_t(n) drives the interval n - 1 -> n with the fluid sample of step
// n frozen (Eqs. 18-20), answered by solid_state_t(n) with the impulses J_l (Eq. 24).
#include <memory>

#include "solid/schemes/solid_scheme.hpp"

namespace cosim::solid {

namespace {

class SerialScheme final : public SolidScheme {
 public:
  /// fluid_state_t(1) answers solid_state_t(0), the initial positions.
  const protocol::MessageOrder& order() const override { return protocol::message_order(protocol::CouplingScheme::Serial); }
  std::optional<Ending> on_fluid_state(const cosimlcm::fluid_state_t& m, SchemeContext& ctx) override {
    return ctx.interval(m, m.step);
  }
};

}  // namespace

std::unique_ptr<SolidScheme> make_serial_scheme(const protocol::SchemeSettings& /*settings*/) {
  return std::make_unique<SerialScheme>();
}

}  // namespace cosim::solid
