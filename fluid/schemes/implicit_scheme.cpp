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

#include "common/text/text.hpp"
#include "fluid/coupled/coordinator.hpp"
#include "fluid/coupled/fluid_run.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "fluid/schemes/scheme_context.hpp"
#include "protocol/message_checks.hpp"

namespace cosim::fluid {

namespace {

class ImplicitFluidScheme final : public FluidScheme {
 public:
  ImplicitFluidScheme(std::int64_t total_steps, std::int64_t rigid_steps)
      : FluidScheme(protocol::message_order(protocol::CouplingScheme::Implicit)), total_steps_(total_steps),
        rigid_steps_(rigid_steps) {}

  void start(std::int64_t first_step, SchemeContext& ctx) override {
    step_ = first_step;
    commit_ = {step_, ctx.coord.fluid_seq(), ctx.coord.awaited_key()};
  }
  std::int64_t step() const override { return step_; }
  bool done() const override { return done_; }
  Reply on_solid_state(const cosimlcm::solid_state_t& m, SchemeContext& ctx) override;
  /// The committed state: kept while the step is iterated, else what the solver holds (a
  /// rigid step stepped once is not committed yet either: no checkpoint then).
  std::string keep(SchemeContext& ctx, const std::string& reason) override {
    return have_backup_     ? ctx.run.checkpoint(step_, reason, true)
           : iteration_ < 0 ? ctx.run.checkpoint(step_, reason)
                            : "; no checkpoint (the spin-up step was not accepted yet)";
  }

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
    fluid_log().info(out) << "implicit scheme: " << redone_steps_ << " LB steps computed again for sub-iterations, "
                          << protocol::fmt("%.3g", double(steps + redone_steps_) / double(steps))
                          << " fluid steps per LB step";
  }

 private:
  const std::int64_t total_steps_, rigid_steps_;
  /// The committed step with the counters a checkpoint of it keeps (the fluid's next seq,
  /// the solid's seq that begins the step's iterations).
  struct Commit {
    std::int64_t step = 0, fluid_seq = 0, solid_seq = 0;
  } commit_;
  std::int64_t redone_steps_ = 0;  ///< fluid steps taken again from a kept state
  std::int64_t step_ = 0;          ///< the committed step
  int iteration_ = -1;             ///< the iterate of step_ the solver holds; -1: none
  /// The committed state of step_ is kept by the domain (keep_state) while it is iterated.
  bool have_backup_ = false;
  bool done_ = false;  ///< solid_state_t(N, 0) accepted the last step
  protocol::MarkerWatch::Reference marker_ref_;
};

Reply ImplicitFluidScheme::on_solid_state(const cosimlcm::solid_state_t& m, SchemeContext& ctx) {
  Coordinator& coord = ctx.coord;
  FluidRun& run = ctx.run;
  FluidDomain& fluid = run.domain();
  if (iteration_ >= 0 && m.step == step_ + 1 && m.iteration == 0) {
    // The solid accepted the iterate the solver holds: step + 1 is committed.
    ++step_;
    iteration_ = -1;
    have_backup_ = false;
    bool periodic = false;
    if (auto code = ctx.outputs(step_, periodic)) return {code};
    commit_ = {step_, coord.fluid_seq(), m.seq};
    if (step_ == total_steps_) {
      done_ = true;
      if (auto e = coord.check_solid_state(m, step_)) return {coord.end(*e)};
      return {};
    }
    if (periodic) run.checkpoint(step_, "");
  }
  if (m.step != step_ || m.iteration != iteration_ + 1) {
    const std::string why =
        "solid_state_t of step " + std::to_string(m.step) + ", iteration " + std::to_string(m.iteration) +
        ": expected step " + std::to_string(step_) + ", iteration " + std::to_string(iteration_ + 1) +
        (iteration_ >= 0 ? " or step " + std::to_string(step_ + 1) + ", iteration 0" : std::string()) +
        " (the implicit scheme's order, protocol/README.md 13)";
    return {coord.stop_and_end({protocol::exit_code::bad_input, why, false}, step_)};
  }
  if (auto code = ctx.read(m, step_)) return {code};
  coord.begin_step(step_);
  // The spin-up is not iterated: the state of a rigid step need not be kept.
  if (m.iteration == 0 && step_ >= std::max<std::int64_t>(rigid_steps_, 1)) {
    fluid.keep_state();
    have_backup_ = true;
    if (run.markers().has_reference()) marker_ref_ = run.markers().reference();
  } else if (m.iteration > 0) {
    coord.enter(Coordinator::Phase::Iterate);
    fluid.restore_kept(step_);
    if (run.markers().has_reference()) run.markers().restore(marker_ref_);
    ++redone_steps_;
  }
  iteration_ = m.iteration;
  if (auto code = run.check_positions(step_, ctx.x, ctx.j)) return {code};
  fluid.sample(ctx.x, ctx.start_samples);  // the fluid before the step at X_l
  run.hold_body(ctx.j);  // [held_body]: the body's impulses first (Turek and Hron's cylinder)
  fluid.spread(ctx.x, ctx.j);                // Eqs. 21-24 and 25-26
  fluid.step();
  if (auto code = run.check_step_read(step_)) return {code};
  if (auto code = run.sample_markers(step_ + 1, ctx.x, ctx.samples)) return {code};
  ctx.publish(step_ + 1, ctx.samples, ctx.start_samples, iteration_);
  return {std::nullopt, step_ + 1, iteration_};
}

}  // namespace

std::unique_ptr<FluidScheme> make_implicit_fluid_scheme(std::int64_t total_steps, std::int64_t rigid_steps) {
  return std::make_unique<ImplicitFluidScheme>(total_steps, rigid_steps);
}

}  // namespace cosim::fluid
