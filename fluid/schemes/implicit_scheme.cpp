// The implicit scheme, the fluid's side (protocol/README.md section 13): solid_state_t(n, k)
// is stepped from the committed state of LB step n (kept while the step is iterated) and
// answered with fluid_state_t(n + 1, k), whose *_start_lb are the fluid before the step at
// the iterate's markers; solid_state_t(n + 1, 0) accepts the last iterate of step n, whose
// outputs are then written; solid_state_t(N, 0) accepts the last step. The solid's messages
// are ordered by its seq (several per step), and a checkpoint keeps the counters of the
// step's commit.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "protocol/message_checks.hpp"
#include "common/text/text.hpp"

#include "protocol/session/interrupt.hpp"
namespace cosim::fluid {

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

class ImplicitFluidScheme final : public FluidScheme {
 public:
  ImplicitFluidScheme(std::int64_t total_steps, std::int64_t rigid_steps)
      : total_steps_(total_steps), rigid_steps_(rigid_steps) {}

  int run(Coordinator& coord, FluidRun& run, std::int64_t first_step) override;

  /// Several messages per step: consecutive seq in lock-step.
  std::int64_t key_of(const cosimlcm::solid_state_t& m) const override { return m.seq; }
  /// solid_state_t(N, 0) accepts the last step, so step N is within the run.
  std::int64_t highest_solid_step(std::int64_t, std::int64_t awaited_step, std::int64_t total) const override {
    return std::min<std::int64_t>(awaited_step + 1 + protocol::kStepWindow, total);
  }
  /// The awaited seq is of step n (another iterate) or n + 1: both are asked for (the solid
  /// republishes what it keeps of each; copies had are dropped by seq).
  std::vector<std::int64_t> resend_steps(std::int64_t, std::int64_t awaited_step) const override {
    return {awaited_step, awaited_step + 1};
  }
  /// The solid computes a restart's step again from its start, at the run's A_T.
  bool restart_message_has_checkpoint_ratio() const override { return false; }

  /// The counters as of the step's commit (an abort may come while the step is iterated),
  /// and the solid's seq that begins the step.
  void write_checkpoint(protocol::CheckpointWriter& w, std::int64_t, const Coordinator&) const override {
    w.attr("fluid_seq", commit_.fluid_seq);
    w.attr("solid_seq_awaited", commit_.solid_seq);
  }
  std::int64_t restart_key(const protocol::CheckpointReader& r) const override {
    return r.int64_attr("solid_seq_awaited");
  }

  void summary(std::ostream& out, std::int64_t steps) const override {
    out << "fluid: implicit scheme: " << redone_steps_ << " LB steps computed again for sub-iterations, "
        << protocol::fmt("%.3g", double(steps + redone_steps_) / double(steps)) << " fluid steps per LB step\n";
  }

 private:
  const std::int64_t total_steps_, rigid_steps_;
  /// The committed step with the counters a checkpoint of it keeps (the fluid's next seq,
  /// the solid's seq that begins the step's iterations).
  struct Commit {
    std::int64_t step = 0, fluid_seq = 0, solid_seq = 0;
  } commit_;
  std::int64_t redone_steps_ = 0;  ///< fluid steps taken again from a kept state
};

int ImplicitFluidScheme::run(Coordinator& coord, FluidRun& run, std::int64_t first_step) {
  FluidDomain& fluid = run.domain();
  StepTiming& timing = run.timing();
  const auto n = static_cast<std::size_t>(coord.num_cgps());
  std::vector<Vec3> x(n), j(n);
  std::vector<MarkerSample> samples(n), start_samples(n);
  const std::int64_t dynamic_from = std::max<std::int64_t>(rigid_steps_, 1);
  // The committed state of `step` while it is iterated: kept by the domain (keep_state).
  bool have_backup = false;
  protocol::MarkerWatch::Reference marker_ref;
  std::int64_t step = first_step;  // the committed step
  int iteration = -1;              // the iterate of `step` the solver holds; -1: none
  commit_ = {step, coord.fluid_seq(), coord.awaited_key()};
  for (;;) {
    const Clock::time_point t0 = Clock::now();
    if (auto e = coord.wait_for_solid_state(step)) {
      std::string note;
      if (e->code == protocol::exit_code::peer_lost && step > first_step)
        // The committed state: kept while the step is iterated, else what the solver holds
        // (a rigid step stepped once is not committed yet either: no checkpoint then).
        note = have_backup      ? run.checkpoint(step, e->reason, true)
               : iteration < 0 ? run.checkpoint(step, e->reason)
                               : "; no checkpoint (the spin-up step was not accepted yet)";
      return run.peer_ending(*e, step, note);
    }
    if (protocol::interrupted()) {  // SIGINT or SIGTERM: as a lost solid, with the committed state
      std::string reason = protocol::interrupt_reason() + " at step " + std::to_string(step);
      if (step > first_step)
        reason += have_backup      ? run.checkpoint(step, reason, true)
                  : iteration < 0 ? run.checkpoint(step, reason)
                                  : "; no checkpoint (the spin-up step was not accepted yet)";
      return coord.stop_and_end({protocol::exit_code::system, reason, false}, step);
    }
    const Clock::time_point t1 = Clock::now();
    timing.wait += seconds(t0, t1);
    const cosimlcm::solid_state_t m = coord.take();
    if (iteration >= 0 && m.step == step + 1 && m.iteration == 0) {
      // The solid accepted the iterate the solver holds: step + 1 is committed.
      ++step;
      iteration = -1;
      have_backup = false;
      const bool last = step == total_steps_;
      const bool periodic = !last && run.checkpoint_every() > 0 && step % run.checkpoint_every() == 0;
      if (auto code = run.step_outputs(step, last, periodic)) return *code;
      commit_ = {step, coord.fluid_seq(), m.seq};
      if (last) {
        if (auto e = coord.check_solid_state(m, step)) return coord.end(*e);
        break;
      }
      if (periodic) run.checkpoint(step, "");
    }
    if (m.step != step || m.iteration != iteration + 1) {
      const std::string why =
          "solid_state_t of step " + std::to_string(m.step) + ", iteration " + std::to_string(m.iteration) +
          ": expected step " + std::to_string(step) + ", iteration " + std::to_string(iteration + 1) +
          (iteration >= 0 ? " or step " + std::to_string(step + 1) + ", iteration 0" : std::string()) +
          " (the implicit scheme's order, protocol/README.md 13)";
      return coord.stop_and_end({protocol::exit_code::bad_input, why, false}, step);
    }
    if (auto e = coord.check_solid_state(m, step)) return coord.end(*e);
    for (std::size_t l = 0; l < n; ++l) {
      x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
      j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
    }
    coord.begin_step(step);
    // The spin-up is not iterated: the state of a rigid step need not be kept.
    if (m.iteration == 0 && step >= dynamic_from) {
      fluid.keep_state();
      have_backup = true;
      if (run.markers().has_reference()) marker_ref = run.markers().reference();
    } else if (m.iteration > 0) {
      coord.enter(Coordinator::Phase::Iterate);
      fluid.restore_kept(step);
      if (run.markers().has_reference()) run.markers().restore(marker_ref);
      ++redone_steps_;
    }
    iteration = m.iteration;
    if (auto code = run.check_positions(step, x, j)) return *code;
    fluid.sample(x, start_samples);  // the fluid before the step at X_l
    run.hold_body(j);  // [held_body]: the body's impulses first (Turek and Hron's cylinder)
    fluid.spread(x, j);                         // Eqs. 21-24 and 25-26
    fluid.step();
    if (auto code = run.check_step_read(step)) return *code;
    if (auto code = run.sample_markers(step + 1, x, samples)) return *code;
    const Clock::time_point t2 = Clock::now();
    timing.compute += seconds(t1, t2);
    coord.publish_fluid_state(step + 1, run.bulk_velocity(), samples, start_samples, iteration);
    timing.publish += seconds(t2, Clock::now());
    run.progress(step + 1, iteration);
  }
  return run.finish();
}

}  // namespace

std::unique_ptr<FluidScheme> make_implicit_fluid_scheme(std::int64_t total_steps, std::int64_t rigid_steps) {
  return std::make_unique<ImplicitFluidScheme>(total_steps, rigid_steps);
}

}  // namespace cosim::fluid
