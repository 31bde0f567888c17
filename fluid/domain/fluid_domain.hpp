// The grid of a run as the run loops see it: one solver in one process, or blocks over MPI
// ranks (fluid/mpi/distributed_fluid.hpp). The fluid-only loop (fluid/app/main.cpp) and the
// coupled run (fluid/coupled/fluid_run.hpp, fluid/schemes/) step it, ask the watchdog's
// question, sample and spread at the markers, keep and restore states, sum the monitor, and
// write the snapshots and checkpoints: the same calls either way; the leading process prints
// and writes the small files, every process its own share of the snapshots and checkpoints.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fluid/observables/flow_monitor.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/config/scene_config.hpp"
#include "fluid/io/snapshots.hpp"
#include "fluid/io/store_io.hpp"

namespace cosim::fluid {

/// The state of a solver kept apart in its precision (the implicit scheme's committed state
/// while a step is iterated).
class KeptState {
 public:
  void keep(const FluidSolver& solver) {
    precision_ = solver.precision();
    with_field([&](auto& f) { solver.copy_state(f); });
  }
  void restore(FluidSolver& solver, std::int64_t step) const {
    with_field([&](const auto& f) { solver.restore_state(f, step); });
  }
  /// fn(the kept field of the solver's store).
  template <class Fn>
  void with_field(Fn&& fn) {
    stores_halves(precision_) ? fn(h_) : stores_floats(precision_) ? fn(s_) : fn(d_);
  }
  template <class Fn>
  void with_field(Fn&& fn) const {
    stores_halves(precision_) ? fn(h_) : stores_floats(precision_) ? fn(s_) : fn(d_);
  }
  /// Its first value (population 0's), as stored.
  const void* data() const {
    const void* p = nullptr;
    with_field([&](const auto& f) { p = f.q(0); });
    return p;
  }

 private:
  Precision precision_ = Precision::Double;
  PopulationField d_;
  PopulationFieldSingle s_;
  PopulationFieldHalf h_;
};

/// Every call is collective (all processes of the run make it, in the same order); the
/// arguments that matter are the leading process's, and what comes back is there.
class FluidDomain {
 public:
  virtual ~FluidDomain() = default;
  /// The process that prints and writes the outputs (rank 0; the only one of a serial run).
  virtual bool leads() const = 0;
  /// The initial state of the scene (initialize_flow).
  virtual void initialize(const FluidScene& scene) = 0;
  /// One LB step of the whole grid.
  virtual void step() = 0;
  /// The step in two parts (FluidSolver::begin_step, finish_step): the forces spread
  /// between them act on this step.
  virtual void begin_step() = 0;
  virtual void finish_step() = 0;
  /// Whether begin_step() may run before the forces of the step are spread (the bulk of a
  /// coupled step overlapping the solid's compute; fluid/schemes/serial_scheme.cpp) and leave
  /// the state of the current step whole until finish_step(): Propagation::TwoGrid. The
  /// in-place propagation needs the forced cells before the bulk and overwrites the state:
  /// it overlaps the bulk after the step's sample instead (step_near).
  virtual bool bulk_before_impulses() const = 0;
  /// The step (forces spread) of the cells that sample(X) reads, the rest by finish_rest()
  /// or by any reader of the whole state (FluidSolver::step_reading): in place, the coupled
  /// step publishes fluid_state_t before the bulk of the step, which then overlaps the
  /// solid's compute. Where the domain cannot split (two grids, a grid over MPI ranks): the
  /// whole step, finish_rest() nothing.
  virtual void step_near(std::span<const Vec3> X) {
    (void)X;
    begin_step();
    finish_step();
  }
  virtual void finish_rest() {}
  virtual void set_row_schedule(RowSchedule schedule) = 0;
  /// FluidSolver::set_inlet_scale of the whole grid (the inlet's start-up ramp), the same
  /// `s` on every process. A domain that cannot throws std::logic_error (the scene reader
  /// keeps such runs from asking).
  virtual void set_inlet_scale(double s);
  /// kernel_state_problem() of the whole grid: the same text on every process.
  virtual std::string kernel_problem(const HealthLimits& limits) = 0;
  /// summarize() of the whole grid at the current state, on the leading process (nothing on
  /// the others).
  virtual std::optional<FlowSummary> summary() = 0;
  /// Writes the snapshots due at the current state (Snapshots::write): each process its
  /// own planes of the grid into the files (parallel HDF5, DESIGN 8), no process the whole
  /// grid; `s` is each process's own Snapshots of the scene.
  virtual void write_snapshots(Snapshots& s, bool last) = 0;
  /// The leading process's `text` on every process (a verdict they all act on).
  virtual std::string from_leader(const std::string& text) = 0;
  /// The header line of the decomposition ("" for one process).
  virtual std::string describe() const { return {}; }

  // ---- the immersed boundary (DESIGN 2.1; Eqs. 17, 21-24) ----
  /// Eq. 17 at the markers X into `out` (ImmersedBoundary::sample, bit for bit) on the
  /// leading process. @pre out.size() == X.size() there
  virtual void sample(std::span<const Vec3> X, std::span<MarkerSample> out) = 0;
  /// Eqs. 21-24: the impulses J at X added to the forces of the next step (or of the step
  /// begun). @pre J.size() == X.size()
  virtual void spread(std::span<const Vec3> X, std::span<const Vec3> J) = 0;

  // ---- states ----
  /// Keeps the current state apart (KeptState); restore_kept() goes back to it at `step`.
  virtual void keep_state() = 0;
  virtual void restore_kept(std::int64_t step) = 0;
  /// Writes the current (or kept) state's store into dataset `name` of checkpoint `file`
  /// (the leading process's path; created there with the whole store's size, closed:
  /// protocol::CheckpointWriter::reserve and pause), each process its own share
  /// (store_io.hpp). Returns the first error of any process ("" when none).
  virtual std::string write_store(bool kept, const std::string& file, const std::string& name) = 0;
  /// The state at `step` from dataset `name` of checkpoint `file` (the leading process's
  /// path; its size checked there: 19 x the whole layout's stride in the run's precision),
  /// each process reading its own share (FluidRun's restart). Returns the first error.
  virtual std::string read_store(const std::string& file, const std::string& name, std::int64_t step) = 0;

  /// Each process's largest resident set so far in MiB (protocol::peak_rss_mib), in rank
  /// order, on the leading process (nothing on the others).
  virtual std::vector<double> peak_memory_mib() = 0;
};

/// The inlet's start-up ramp of `scene` (inlet.ramp_us; Turek and Hron) set on `domain` for
/// the step after `step`: its scale inlet_ramp(step, T) while the ramp lasts; nothing
/// without one. The fluid-only loop and the coupled run alike.
void ramp_inlet(FluidDomain& domain, const FluidScene& scene, std::int64_t step);

/// The servers' end-of-run line for `peaks` (FluidDomain::peak_memory_mib), without the
/// logger's prefix: "peak memory X MiB (largest resident set)", X the leading process's, and with several processes
/// "; per rank: A B C ... MiB" (no rank holds the whole grid, docs/scaling.md).
std::string peak_memory_line(const std::vector<double>& peaks);

/// The grid in this process: one FluidSolver.
class SerialDomain final : public FluidDomain {
 public:
  explicit SerialDomain(const FluidParams& params) : solver_(params), ib_(solver_) {}
  bool leads() const override { return true; }
  void initialize(const FluidScene& scene) override { initialize_flow(solver_, scene); }
  void step() override { solver_.step(); }
  void begin_step() override { solver_.begin_step(); }
  void finish_step() override { solver_.finish_step(); }
  bool bulk_before_impulses() const override { return solver_.propagation() == Propagation::TwoGrid; }
  void step_near(std::span<const Vec3> X) override {
    ib_.marker_nodes(X, nodes_, listed_);
    solver_.step_reading(nodes_.cells);
  }
  void finish_rest() override { solver_.finish_rest(); }
  void set_row_schedule(RowSchedule schedule) override { solver_.set_row_schedule(schedule); }
  void set_inlet_scale(double s) override { solver_.set_inlet_scale(s); }
  std::string kernel_problem(const HealthLimits& limits) override {
    return kernel_state_problem(solver_, limits);
  }
  std::optional<FlowSummary> summary() override { return summarize(solver_); }
  void write_snapshots(Snapshots& s, bool last) override { s.write(solver_, last); }
  std::string from_leader(const std::string& text) override { return text; }
  void sample(std::span<const Vec3> X, std::span<MarkerSample> out) override { ib_.sample(solver_, X, out); }
  void spread(std::span<const Vec3> X, std::span<const Vec3> J) override { ib_.spread(solver_, X, J); }
  void keep_state() override { kept_.keep(solver_); }
  void restore_kept(std::int64_t step) override { kept_.restore(solver_, step); }
  std::string write_store(bool kept, const std::string& file, const std::string& name) override;
  std::string read_store(const std::string& file, const std::string& name, std::int64_t step) override;
  std::vector<double> peak_memory_mib() override;

 private:
  FluidSolver solver_;
  ImmersedBoundary ib_;
  KeptState kept_;
  MarkerNodes nodes_;  // step_near's scratch
  std::vector<std::size_t> listed_;
};

}  // namespace cosim::fluid
