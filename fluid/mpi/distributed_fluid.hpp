// The fluid grid of a run over MPI ranks (DESIGN 8): one block per rank (slabs along z, or
// blocks along y and z), each stepped by the
// same FluidSolver (kernel and boundary fills) as the undivided grid, with the halo exchange
// between slabs; the watchdog's extrema combined over the ranks; the monitor's row sums
// added on rank 0; the snapshots and checkpoints written by every rank, each its own planes
// (parallel HDF5): no rank holds the whole grid.
#pragma once

#include <mpi.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fluid/domain/decomposition.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/mpi/mpi_world.hpp"
#include "fluid/mpi/block_halo.hpp"

namespace cosim::fluid::mpi {

/// Bit for bit the serial run: a cell's step reads the same populations and runs the same
/// arithmetic whatever slab holds it (whole rows of x, the ghosts as in the whole grid); the
/// monitor adds the slabs' row sums on rank 0 in the serial order; each rank computes the
/// snapshots' fields of its own planes with the serial code (the vorticity with the
/// neighbours' velocity planes) and writes them into the file the serial writer writes.
///
/// The immersed boundary whatever blocks a marker's kernel reaches (DESIGN 8): every rank
/// lists the nodes of the markers' stencils as the serial sample() does (the whole grid's
/// ImmersedBoundary), computes the moments of the nodes it owns, and rank 0 gathers them and
/// sums each marker in the serial order; the impulses go to every rank, which spreads all
/// markers in the serial order onto the nodes it owns, so each node adds its contributions
/// in the serial order too (a marker whose support straddles a block edge, along y or z or
/// both, adds to each block it reaches).
/// Checkpoints: each rank writes its range of the whole grid's store into the file one
/// process writes; a restart reads each block's store (ghost and halo planes included).
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
  void write_snapshots(Snapshots& s, bool last) override;
  std::string from_leader(const std::string& text) override { return broadcast(comm_, text); }
  std::string describe() const override;
  void sample(std::span<const Vec3> X, std::span<MarkerSample> out) override;
  void spread(std::span<const Vec3> X, std::span<const Vec3> J) override;
  void keep_state() override { kept_.keep(*block_); }
  void restore_kept(std::int64_t step) override { kept_.restore(*block_, step); }
  std::string write_store(bool kept, const std::string& file, const std::string& name) override;
  std::string read_store(const std::string& file, const std::string& name, std::int64_t step) override;
  std::vector<double> peak_memory_mib() override;

  const Block& place() const { return place_; }
  const FluidSolver& block() const { return *block_; }
  const BlockHalo& halo() const { return *halo_; }

 private:
  /// The whole grid's summary on rank 0 from the slabs' partials (flow_partials): their row
  /// sums gathered in row order, their extrema merged; of the current state or (previous)
  /// of the state the last step read, at its step.
  std::optional<FlowSummary> summary_of(bool previous);
  /// part_: this block's fields for a snapshot, with the velocity planes around it.
  void fill_part();
  /// This rank's share of the whole grid's store in a checkpoint: the range it writes, or
  /// (reading) the block's whole store a restart reads.
  StoreShare share(bool reading) const;
  /// Rank 0's markers (and impulses) on every rank.
  std::vector<Vec3> from_leader(std::span<const Vec3> values);
  /// The rank that owns cell row (y, z) of the whole grid.
  int owner(int y, int z) const { return owner_z_[std::size_t(z)] * place_.py + owner_y_[std::size_t(y)]; }

  MPI_Comm comm_;
  int rank_ = 0, ranks_ = 1;
  Block place_;
  std::unique_ptr<BlockHalo> halo_;
  std::unique_ptr<FluidSolver> block_;
  FluidParams whole_params_;
  FieldPart part_;                      // kept between snapshots
  ImmersedBoundary ib_;                 // of the whole grid
  std::vector<int> owner_y_, owner_z_;  // the block's place along y (z) per row (plane)
  KeptState kept_;                      // of this rank's block
};

}  // namespace cosim::fluid::mpi
