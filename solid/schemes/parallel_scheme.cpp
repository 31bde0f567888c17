// The parallel (Jacobi) scheme of DESIGN 2.1, the solid's side (protocol/README.md section
// 14): both sides compute the same LB step at once with a one-step lag, the rigid spin-up in
// the serial order.
#include <algorithm>
#include <memory>

#include "solid/schemes/solid_scheme.hpp"
#include "solid/coupled/solid_peer.hpp"
#include "solid/schemes/scheme_solid.hpp"

namespace cosim::solid {

namespace {

class ParallelScheme final : public SolidScheme {
 public:
  /// First fluid_state_t(0) when the sheets are free from step 1, else fluid_state_t(1).
  const protocol::MessageOrder& order() const override {
    return protocol::message_order(protocol::CouplingScheme::Parallel);
  }
  /// The awaited step itself: fluid_state_t(m) drives solid_state_t(m + 1) once free.
  std::int64_t awaited_step(std::int64_t awaited_key, std::int64_t /*last_step*/) const override {
    return awaited_key;
  }
  std::int64_t lowest_fluid_step() const override { return 0; }
  std::string announcement() const override { return ", parallel scheme"; }

  /// What fluid_state_t(m) drives, with D = max(rigid_steps, 1): the spin-up's
  /// solid_state_t(m) for 1 <= m < D, as in the serial scheme (no substeps: there is nothing
  /// to overlap, and a held sheet's direct forcing (Eqs. 18-20) is deadbeat only without the
  /// lag); then, for m + 1 >= D, the interval m -> m + 1 with the sample of the fluid at m,
  /// solid_state_t(m + 1), which the fluid spreads while stepping m + 1 -> m + 2 (Eqs.
  /// 21-24): the fluid receives exactly the J its CGPs received the opposite of, one step
  /// after the interval, as in the serial scheme. fluid_state_t(D - 1) drives both.
  std::optional<Ending> on_fluid_state(const cosimlcm::fluid_state_t& m, SchemeContext& ctx) override {
    const std::int64_t dynamic_from = std::max<std::int64_t>(ctx.solid.rigid_steps(), 1);
    // (A restart at step D - 1 has published solid_state_t(D - 1) already.)
    if (m.step >= 1 && m.step < dynamic_from && ctx.peer.last_step() < m.step)
      if (const auto e = ctx.interval(m, m.step)) return e;
    if (m.step + 1 >= dynamic_from && m.step + 1 <= ctx.solid.total_steps() - 1) return ctx.interval(m, m.step + 1);
    return ctx.solid.check(m);
  }

  /// From step D - 1 on, a restart awaits fluid_state_t(step) (it drives the interval
  /// step -> step + 1), which the fluid publishes again.
  std::int64_t restore(const protocol::CheckpointReader& /*r*/, std::int64_t step, bool /*ratio_changed*/,
                       cosimlcm::solid_state_t& /*in_flight*/, SchemeContext& ctx) override {
    return step >= std::max<std::int64_t>(ctx.solid.rigid_steps(), 1) - 1 ? step : step + 1;
  }
};

}  // namespace

std::unique_ptr<SolidScheme> make_parallel_scheme(const protocol::SchemeSettings& /*settings*/) {
  return std::make_unique<ParallelScheme>();
}

}  // namespace cosim::solid
