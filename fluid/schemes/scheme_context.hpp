// The fluid as a coupling scheme (fluid_scheme.hpp) sees it, as the solid's schemes see
// theirs (solid/schemes/scheme_context.hpp): the session (Coordinator), the fluid
// (FluidRun), the markers' rows, the publishing (timed for the step driver) and the LB step
// every scheme with one message a step builds on.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "cosimlcm/solid_state_t.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/schemes/fluid_scheme.hpp"

namespace cosim::fluid {

class SchemeContext {
 public:
  using Clock = std::chrono::steady_clock;

  SchemeContext(Coordinator& coordinator, FluidRun& run);

  Coordinator& coord;
  FluidRun& run;
  /// The markers X_l and impulses J_l of the last solid_state_t read, and the fluid sampled
  /// at them after the step (Eq. 17) and before it (*_start_lb).
  std::vector<Vec3> x, j;
  std::vector<MarkerSample> samples, start_samples;

  /// The per-step checks of solid_state_t `m` for the committed step `step` (the
  /// coordinator's), then its positions and impulses into x and j; the exit code of a
  /// refusal (the run ended).
  std::optional<int> read(const cosimlcm::solid_state_t& m, std::int64_t step);
  /// The outputs of the step `now` just reached (monitor row, snapshot, the held body's row;
  /// FluidRun::step_outputs), `periodic` set when its checkpoint is due; the exit code of a trip.
  std::optional<int> outputs(std::int64_t now, bool& periodic);
  /// fluid_state_t(now, iteration) of `after` and `before` (*_start_lb); the time since the
  /// step driver's mark counts as compute, the publishing as publish.
  void publish(std::int64_t now, const std::vector<MarkerSample>& after, const std::vector<MarkerSample>& before,
               int iteration = 0);

  // ---- one LB step driven by one solid_state_t (the serial and parallel schemes) ----
  /// Before the wait for solid_state_t(step): the phase of the step and its row schedule
  /// (`free`: the solid computes beside the bulk); with two grids the bulk of the step,
  /// which needs no impulses (FluidDomain::begin_step), and its flow_health sentinel.
  std::optional<int> begin_step(std::int64_t step, bool free);
  /// LB step `step` -> `step` + 1 driven by solid_state_t(step) `m` (Eqs. 21-26): the
  /// checks, the watchdog on the markers, the spread and the step, the sample at X_l (Eq.
  /// 17), the outputs, fluid_state_t(step + 1) if `publish_after` and its periodic
  /// checkpoint; with `publish_before`, fluid_state_t(step) of the fluid before the step
  /// first (the parallel scheme's step 0).
  Reply lb_step(const cosimlcm::solid_state_t& m, std::int64_t step, bool publish_before, bool publish_after);

  // ---- the step driver's clock ----
  /// From now, the time until the next publish() or charge() counts as compute.
  void mark() { mark_ = Clock::now(); }
  /// The time since the mark as compute; marks again.
  void charge();

 private:
  /// The fluid's bulk runs before the impulses (two grids): FluidDomain::bulk_before_impulses;
  /// else after fluid_state_t(step + 1) is out (in place: FluidDomain::step_near).
  const bool overlap_;
  Clock::time_point mark_ = Clock::now();
};

}  // namespace cosim::fluid
