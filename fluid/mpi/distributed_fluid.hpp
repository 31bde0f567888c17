// The fluid grid of a run over MPI ranks (DESIGN 8): one slab per rank, each stepped by the
// same FluidSolver (kernel and boundary fills) as the undivided grid, with the halo exchange
// between slabs; the watchdog's extrema combined over the ranks; the whole grid gathered on
// rank 0 for the monitor and the snapshots, which the serial writers then write as they are.
#pragma once

#include <mpi.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fluid/domain/decomposition.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/mpi/mpi_world.hpp"
#include "fluid/mpi/slab_halo.hpp"

namespace cosim::fluid::mpi {

/// Bit for bit the serial run: a cell's step reads the same populations and runs the same
/// arithmetic whatever slab holds it (whole rows of x, the ghosts as in the whole grid); the
/// monitor adds the slabs' row sums on rank 0 in the serial order; the snapshots are computed
/// on rank 0 from the gathered grid with the serial code. The price of the latter: in a run
/// with snapshots rank 0 holds the whole grid's populations too (twice: FluidSolver's two
/// fields).
///
/// The immersed boundary whatever blocks a marker's kernel reaches (DESIGN 8): every rank
/// lists the nodes of the markers' stencils as the serial sample() does (the whole grid's
/// ImmersedBoundary), computes the moments of the nodes it owns, and rank 0 gathers them and
/// sums each marker in the serial order; the impulses go to every rank, which spreads all
/// markers in the serial order onto the nodes it owns, so each node adds its contributions
/// in the serial order too (a marker whose support straddles a slab edge adds to both).
/// Checkpoints: the whole grid's store gathered on rank 0; a restart's store scattered.
/// Scalar arguments (steps, schedules, limits) must be the same on every rank; the others
/// are rank 0's.
class DistributedFluid final : public FluidDomain {
 public:
  /// @throws std::invalid_argument with a one-line reason when the grid cannot be decomposed
  ///         so (choose_blocks); the same on every rank
  DistributedFluid(const FluidScene& scene, MPI_Comm comm);
  bool leads() const override { return rank_ == 0; }
  void initialize(const FluidScene& scene) override;
  void step() override { block_->step(); }
  void begin_step() override { block_->begin_step(); }
  void finish_step() override { block_->finish_step(); }
  bool bulk_before_impulses() const override { return block_->propagation() == Propagation::TwoGrid; }
  void set_row_schedule(RowSchedule schedule) override { block_->set_row_schedule(schedule); }
  void set_inlet_scale(double s) override { block_->set_inlet_scale(s); }
  std::string kernel_problem(const HealthLimits& limits) override;
  std::optional<FlowSummary> summary() override { return summary_of(false); }
  const FluidSolver* whole() override;
  std::string from_leader(const std::string& text) override { return broadcast(comm_, text); }
  std::string describe() const override;
  void sample(std::span<const Vec3> X, std::span<MarkerSample> out) override;
  void spread(std::span<const Vec3> X, std::span<const Vec3> J) override;
  void keep_state() override { kept_.keep(*block_); }
  void restore_kept(std::int64_t step) override { kept_.restore(*block_, step); }
  StoreView whole_store(bool kept) override;
  void load_store(const StoreView& from, std::int64_t step) override;

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
  /// The blocks' `from` into whole_'s state on rank 0, the reflecting ghosts next to the
  /// slab edges filled again (gather_field).
  template <class T>
  void gather_into_whole(const BasicPopulationField<T>& from);
  template <class T>
  void gather_field(const BasicPopulationField<T>& from, BasicPopulationField<T>* into);
  /// Rank 0's store of the whole grid into the blocks' `into`: each block's whole store
  /// (its ghost and halo planes included) from the whole store's values there.
  template <class T>
  void scatter_field(const T* from, BasicPopulationField<T>& into);
  /// Rank 0's markers (and impulses) on every rank.
  std::vector<Vec3> from_leader(std::span<const Vec3> values);
  /// The rank that owns plane z of the whole grid.
  int owner(int z) const { return owner_[std::size_t(z)]; }

  MPI_Comm comm_;
  int rank_ = 0, ranks_ = 1;
  Slab slab_;
  std::unique_ptr<SlabHalo> halo_;
  std::unique_ptr<FluidSolver> block_;
  FluidParams whole_params_;
  std::unique_ptr<FluidSolver> whole_;  // rank 0 only, from the first gather on
  ImmersedBoundary ib_;                 // of the whole grid
  std::vector<int> owner_;              // per plane z of the whole grid
  KeptState kept_;                      // of this rank's block
};

}  // namespace cosim::fluid::mpi
