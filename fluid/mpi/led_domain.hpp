// The grid of a coupled run over MPI ranks (DESIGN 8): the coordinator, the session and the
// coupling scheme run on rank 0 only (the LCM traffic comes from there alone, the solid sees
// no difference); rank 0 steps the grid through a LedDomain, which tells the other ranks
// each collective call of the DistributedFluid before it makes it, and the other ranks
// follow() those calls until rank 0 ends the run.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fluid/domain/fluid_domain.hpp"
#include "fluid/mpi/distributed_fluid.hpp"

namespace cosim::fluid::mpi {

/// Rank 0's view of the grid: each call is ordered to the other ranks (a broadcast on
/// `orders`, a communicator of its own) and then made collectively on `grid`.
class LedDomain final : public FluidDomain {
 public:
  LedDomain(DistributedFluid& grid, MPI_Comm orders) : grid_(grid), orders_(orders) {}
  /// Ends the followers with exit code `code` (once; the destructor does it with 1 if the
  /// run did not).
  void end(int code);
  ~LedDomain() override;
  LedDomain(const LedDomain&) = delete;
  LedDomain& operator=(const LedDomain&) = delete;

  bool leads() const override { return true; }
  void initialize(const FluidScene& scene) override;
  void step() override;
  void begin_step() override;
  void finish_step() override;
  bool bulk_before_impulses() const override { return grid_.bulk_before_impulses(); }
  void set_row_schedule(RowSchedule schedule) override;
  std::string kernel_problem(const HealthLimits& limits) override;
  std::optional<FlowSummary> summary() override;
  void write_snapshots(Snapshots& s, bool last) override;
  std::string from_leader(const std::string& text) override;
  std::string describe() const override { return grid_.describe(); }
  void sample(std::span<const Vec3> X, std::span<MarkerSample> out) override;
  void spread(std::span<const Vec3> X, std::span<const Vec3> J) override;
  void keep_state() override;
  void restore_kept(std::int64_t step) override;
  std::string write_store(bool kept, const std::string& file, const std::string& name) override;
  std::string read_store(const std::string& file, const std::string& name, std::int64_t step) override;
  std::vector<double> peak_memory_mib() override;

 private:
  DistributedFluid& grid_;
  MPI_Comm orders_;
  bool ended_ = false;
};

/// The ranks other than 0: makes the calls rank 0's LedDomain orders on `grid` (the scene's
/// initial state for Initialize, the scene's snapshots at dt_us for WriteSnapshots),
/// sleeping between orders (no busy wait while the solid computes); returns the exit code
/// rank 0 ended the run with. A snapshot or checkpoint that fails is rank 0's to report.
int follow(DistributedFluid& grid, const FluidScene& scene, double dt_us, MPI_Comm orders);

}  // namespace cosim::fluid::mpi
