// The implicit scheme, the solid's side (protocol/README.md section 13): each LB step is
// iterated with Aitken's dynamic relaxation (solid/coupling/aitken_relaxation.hpp) until the fluid
// sample the solid integrated with is the fluid before the step at the markers where that
// step's impulses are spread; the fluid's reaction is integrated at the end velocity of
// each substep (SolidCoupler::advance, implicit_reaction). Several messages per step: both
// sides order them by the peer's seq (consecutive in lock-step).
#include <algorithm>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/text/text.hpp"
#include "solid/coupling/aitken_relaxation.hpp"
#include "solid/io/solid_log.hpp"
#include "solid/schemes/solid_scheme.hpp"
#include "solid/coupled/solid_peer.hpp"
#include "solid/schemes/scheme_solid.hpp"

namespace cosim::solid {

namespace {

using protocol::fmt;

/// The fluid before the step at the iterate's markers (fluid_state_t's *_start_lb).
FluidSample start_sample_of(const cosimlcm::fluid_state_t& m) {
  return sample_from(m.rho_start_lb, m.velocity_start_lb);
}

class ImplicitScheme final : public SolidScheme {
 public:
  explicit ImplicitScheme(const protocol::ImplicitSettings& settings) : cfg_(settings) {}

  /// Ordered by seq (the fluid's first message has seq 0); the last step accepted is
  /// answered by fluid_state_t(N) and closed by solid_state_t(N).
  const protocol::MessageOrder& order() const override {
    return protocol::message_order(protocol::CouplingScheme::Implicit);
  }
  int iterations_allowed() const override { return cfg_.max_iterations; }

  /// The answer to the current iterate (another iterate, or its acceptance), then the next
  /// step: the spin-up's interval, the step's first iterate, or after the last step
  /// solid_state_t(N, 0), zero impulses, which closes the run (the fluid commits its last step
  /// on it and answers with stop_t).
  std::optional<Ending> on_fluid_state(const cosimlcm::fluid_state_t& m, SchemeContext& ctx) override {
    if (const auto e = ctx.solid.check(m)) return e;
    if (iterate_) {
      bool again = false;
      if (const auto e = answer_iterate(m, ctx, again)) return e;
      if (again) return std::nullopt;
    }
    if (m.step == ctx.solid.total_steps()) {
      ctx.publish(m.step, 0, ctx.solid.positions_lb(), Eigen::Matrix3Xd::Zero(3, ctx.solid.num_cgps()));
      return std::nullopt;
    }
    if (m.step < ctx.solid.rigid_steps()) return ctx.interval(m, m.step);  // the spin-up: nothing to iterate
    return begin_iterate(m, ctx);
  }

  /// A checkpoint of a step being iterated holds its start (the solid's kept start) and its
  /// first iterate: a restart iterates the step again from there, as the run did.
  std::optional<RestartPoint> restart_point() const override {
    if (!iterate_) return std::nullopt;
    return RestartPoint{&iterate_->first};
  }
  void save(protocol::CheckpointWriter& w, const SchemeContext& ctx) const override;
  std::int64_t restore(const protocol::CheckpointReader& r, std::int64_t step, bool ratio_changed,
                       cosimlcm::solid_state_t& in_flight, SchemeContext& ctx) override;

  void report(std::ostream& out) const override;

 private:
  /// The sub-iterations of one step (from the solid's kept start, SchemeSolid::keep_start):
  /// the fluid sample that drives the current iterate, that iterate's interval, and what a
  /// checkpoint of the step keeps.
  struct Iterate {
    std::int64_t step = 0;
    int iteration = 0;
    FluidSample drive;               ///< u^k (relaxed) and the latest rho, lattice units
    IntervalResult trial;            ///< the interval driven by it
    double start_bulk_velocity = 0;  ///< U_b of the fluid_state_t that began the step
    cosimlcm::solid_state_t first;   ///< solid_state_t(step, 0), for checkpoints
    FluidSample first_drive;         ///< its sample, for checkpoints
    std::int64_t fluid_seq_awaited = 0;  ///< the fluid seq awaited after `first`
    double residual = 0.0;           ///< |u~ - u| / |u~| of the last answer
  };

  /// The first relaxation factor of the run: coupling.relaxation, else 1/2.
  double first_relaxation() const { return cfg_.relaxation > 0.0 ? cfg_.relaxation : 0.5; }

  std::optional<Ending> begin_iterate(const cosimlcm::fluid_state_t& m, SchemeContext& ctx);
  std::optional<Ending> answer_iterate(const cosimlcm::fluid_state_t& m, SchemeContext& ctx, bool& again);

  const protocol::ImplicitSettings cfg_;
  std::optional<Iterate> iterate_;  ///< the step being iterated
  std::optional<AitkenRelaxation> aitken_;
  std::int64_t implicit_steps_ = 0, iterations_redone_ = 0, unconverged_ = 0;
  int iterations_max_ = 0;
  double unconverged_residual_max_ = 0.0;
};

/// Step m.step's first iterate, driven by the fluid at the start of the step (the serial
/// scheme's sample); solid_state_t(step, 0).
std::optional<Ending> ImplicitScheme::begin_iterate(const cosimlcm::fluid_state_t& m, SchemeContext& ctx) {
  Iterate it;
  it.step = m.step;
  ctx.solid.keep_start();
  it.start_bulk_velocity = m.bulk_velocity_lb;
  it.drive = sample_of(m);
  it.first_drive = it.drive;
  if (!aitken_) aitken_.emplace(first_relaxation());
  aitken_->new_step();
  if (const auto e = ctx.solid.iterate(it.drive, it.step, it.iteration, it.trial)) return e;
  ctx.publish(it.step, it.trial.substeps, it.trial.position_lb, it.trial.impulse_lb, 0, it.trial.substeps);
  it.first = ctx.peer.last_sent();
  it.fluid_seq_awaited = ctx.peer.awaited_key() + 1;  // the sequencer advances after this
  iterate_ = std::move(it);
  ++implicit_steps_;
  return ctx.solid.checkpoint_if_due(m.step);
}

/// fluid_state_t(step + 1, k) answers iterate k with the fluid before the step at the
/// iterate's markers (the mean positions over its interval, where J was spread), u~, against
/// the u^k that drove it. Not converged (and iterations left): the next iterate,
/// u^{k+1} = u^k + omega (u~ - u^k) (Aitken), published, `again` = true. Else the iterate is
/// accepted.
std::optional<Ending> ImplicitScheme::answer_iterate(const cosimlcm::fluid_state_t& m, SchemeContext& ctx,
                                                     bool& again) {
  Iterate& it = *iterate_;
  const FluidSample answer = start_sample_of(m);
  const double r = (answer.velocity_lb - it.drive.velocity_lb).norm(), un = answer.velocity_lb.norm();
  // The round-off floor: 1e-14 of the flow's speed at the markers.
  const bool converged = r <= cfg_.tolerance * un + 1e-14 * (un + 1e-300);
  it.residual = un > 0.0 ? r / un : r;
  if (!converged && it.iteration + 1 < cfg_.max_iterations) {
    it.drive.velocity_lb = aitken_->next(it.drive.velocity_lb, answer.velocity_lb);
    it.drive.rho_lb = answer.rho_lb;
    ++it.iteration;
    ++iterations_redone_;
    if (const auto e = ctx.solid.iterate(it.drive, it.step, it.iteration, it.trial)) return e;
    ctx.publish(it.step, it.trial.substeps, it.trial.position_lb, it.trial.impulse_lb, it.iteration,
                it.trial.substeps);
    again = true;
    return std::nullopt;
  }
  // Accepted: the model holds the end of the interval whose impulses the fluid spread; the
  // row, the energy sentinel and the snapshot of the step, as the serial interval does.
  if (!converged) {
    ++unconverged_;
    unconverged_residual_max_ = std::max(unconverged_residual_max_, it.residual);
  }
  iterations_max_ = std::max(iterations_max_, it.iteration + 1);
  if (const auto e = ctx.solid.commit(it.step, it.trial, it.start_bulk_velocity)) return e;
  const std::int64_t step = it.step;
  iterate_.reset();
  return ctx.solid.snapshot(step);
}

void ImplicitScheme::save(protocol::CheckpointWriter& w, const SchemeContext& ctx) const {
  w.attr("fluid_seq_awaited", iterate_ ? iterate_->fluid_seq_awaited
                                       : ctx.peer.awaited_key() + (ctx.peer.awaited_received() ? 1 : 0));
  w.attr("aitken_start", aitken_ ? aitken_->step_start() : 0.0);
  w.attr("start_bulk_velocity_lb", iterate_ ? iterate_->start_bulk_velocity : 0.0);
  w.attr("iterating", static_cast<std::int64_t>(iterate_ ? 1 : 0));
  if (iterate_) {
    const FluidSample& d = iterate_->first_drive;
    w.put("iterate_rho_lb", d.rho_lb.data(), std::size_t(d.rho_lb.size()));
    w.put("iterate_velocity_lb", d.velocity_lb.data(), std::size_t(d.velocity_lb.size()));
    ctx.solid.save_start(w);
  }
}

/// A checkpoint of a step being iterated: the step's first iterate again, from its start,
/// with the sample it began with.
std::int64_t ImplicitScheme::restore(const protocol::CheckpointReader& r, std::int64_t step, bool ratio_changed,
                                     cosimlcm::solid_state_t& in_flight, SchemeContext& ctx) {
  const std::int64_t awaited = r.int64_attr("fluid_seq_awaited");
  if (r.int64_attr("iterating") == 0) return awaited;
  const Eigen::Index n = ctx.solid.num_cgps();
  const auto size = static_cast<std::size_t>(3 * n);
  Iterate it;
  it.step = step;
  ctx.solid.keep_start();  // the checkpoint's state: the step's start
  ctx.solid.restore_start(r);
  it.drive.rho_lb = Eigen::Map<const Eigen::VectorXd>(r.doubles("iterate_rho_lb", std::size_t(n)).data(), n);
  it.drive.velocity_lb = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("iterate_velocity_lb", size).data(), 3, n);
  it.first_drive = it.drive;
  it.start_bulk_velocity = r.double_attr("start_bulk_velocity_lb");
  it.fluid_seq_awaited = awaited;
  aitken_.emplace(first_relaxation());
  aitken_->restore_start(r.double_attr("aitken_start"));
  if (const auto e = ctx.solid.iterate(it.drive, it.step, it.iteration, it.trial))
    throw std::runtime_error("its first iterate again: " + e->reason);
  // At another A_T that iterate differs from the checkpoint's solid_state_t(step, 0): the
  // solid would continue from the one while the fluid spread the other's impulses (and,
  // converged, committed them). The recomputed iterate is published in its place (same seq),
  // as a run at this A_T from the step's start sends it (protocol/README.md 13).
  if (ratio_changed) {
    in_flight.substeps = it.trial.substeps;
    in_flight.solid_time_s = ctx.solid.solid_time_s(ctx.solid.total_substeps() + it.trial.substeps);
    set_positions_impulses(in_flight, it.trial.position_lb, it.trial.impulse_lb);
    solid_log().info(ctx.out) << "step " << step << "'s first iterate computed again at A_T = "
                              << ctx.solid.time_ratio() << " and sent in place of the checkpoint's (A_T = "
                              << r.int64_attr("time_ratio") << ")";
  }
  it.first = in_flight;
  iterate_ = std::move(it);
  ++implicit_steps_;
  return awaited;
}

void ImplicitScheme::report(std::ostream& out) const {
  if (implicit_steps_ == 0) return;
  solid_log().info(out) << "implicit scheme: " << implicit_steps_ << " steps iterated, "
      << fmt("%.3g", double(implicit_steps_ + iterations_redone_) / double(implicit_steps_))
      << " iterations a step on average, at most " << iterations_max_ << " (coupling.max_iterations = "
      << cfg_.max_iterations << ", tolerance " << fmt("%g", cfg_.tolerance) << "); " << unconverged_
      << " steps not converged"
      << (unconverged_ > 0 ? " (relative residual up to " + fmt("%.3g", unconverged_residual_max_) + ")" : std::string())
      << "; Aitken factor: first " << fmt("%.4g", first_relaxation()) << ", last "
      << fmt("%.4g", aitken_ ? aitken_->omega() : 0.0);
}

}  // namespace

std::unique_ptr<SolidScheme> make_implicit_scheme(const protocol::SchemeSettings& settings) {
  return std::make_unique<ImplicitScheme>(settings.implicit);
}

}  // namespace cosim::solid
