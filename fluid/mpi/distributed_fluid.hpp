// The fluid grid of a run over MPI ranks (DESIGN 8): one slab per rank, each stepped by the
// same FluidSolver (kernel and boundary fills) as the undivided grid, with the halo exchange
// between slabs; the watchdog's extrema combined over the ranks; the whole grid gathered on
// rank 0 for the monitor and the snapshots, which the serial writers then write as they are.
#pragma once

#include <mpi.h>

#include <memory>
#include <optional>
#include <string>

#include "fluid/decomposition.hpp"
#include "fluid/fluid_domain.hpp"
#include "fluid/mpi/mpi_world.hpp"
#include "fluid/mpi/slab_halo.hpp"

namespace cosim::fluid::mpi {

/// Bit for bit the serial run: a cell's step reads the same populations and runs the same
/// arithmetic whatever slab holds it (whole rows of x, the ghosts as in the whole grid); the
/// monitor adds the slabs' row sums on rank 0 in the serial order; the snapshots are computed
/// on rank 0 from the gathered grid with the serial code. The price of the latter: in a run
/// with snapshots rank 0 holds the whole grid's populations too (twice: FluidSolver's two
/// fields).
class DistributedFluid final : public FluidDomain {
 public:
  /// @throws std::invalid_argument with a one-line reason when the grid cannot be decomposed
  ///         so (choose_blocks); the same on every rank
  DistributedFluid(const FluidScene& scene, MPI_Comm comm);
  bool leads() const override { return rank_ == 0; }
  void initialize(const FluidScene& scene) override;
  void step() override { block_->step(); }
  std::string kernel_problem(const HealthLimits& limits) override;
  std::optional<FlowSummary> summary() override { return summary_of(false); }
  const FluidSolver* whole() override;
  std::string from_leader(const std::string& text) override { return broadcast(comm_, text); }
  std::string describe() const override;

  const Slab& slab() const { return slab_; }
  const FluidSolver& block() const { return *block_; }
  const SlabHalo& halo() const { return *halo_; }

 private:
  /// The whole grid's summary on rank 0 from the slabs' partials (flow_partials): their row
  /// sums gathered in row order, their extrema merged; of the current state or (previous)
  /// of the state the last step read, at its step.
  std::optional<FlowSummary> summary_of(bool previous);
  /// The blocks' current (or, previous = true, last-read) populations into whole_ on rank 0.
  void gather(bool previous);
  template <class T>
  void gather_field(const BasicPopulationField<T>& from, BasicPopulationField<T>* into);

  MPI_Comm comm_;
  int rank_ = 0, ranks_ = 1;
  Slab slab_;
  std::unique_ptr<SlabHalo> halo_;
  std::unique_ptr<FluidSolver> block_;
  FluidParams whole_params_;
  std::unique_ptr<FluidSolver> whole_;  // rank 0 only, from the first gather on
};

}  // namespace cosim::fluid::mpi
