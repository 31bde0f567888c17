#include "fluid/mpi/distributed_fluid.hpp"

#include <array>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "fluid/d3q19.hpp"
#include "fluid/mpi/mpi_world.hpp"

namespace cosim::fluid::mpi {

DistributedFluid::DistributedFluid(const FluidScene& scene, MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &ranks_);
  const BlockChoice c =
      choose_blocks(scene.params.shape, ranks_, scene.blocks ? &*scene.blocks : nullptr);
  if (!c.why.empty()) throw std::invalid_argument(c.why);
  slab_ = slab_of(scene.params.shape.nz, c.blocks[2], rank_);
  std::array<bool, kFaces> halo{};
  const FluidParams params = slab_params(scene.params, slab_, halo);
  halo_ = std::make_unique<SlabHalo>(comm, slab_neighbours(scene.params, slab_));
  block_ = std::make_unique<FluidSolver>(params, halo_.get());
  // Rank 0's whole grid, for the snapshots: made at the first gather (a run without
  // snapshots never holds it).
  whole_params_ = scene.params;
}

void DistributedFluid::initialize(const FluidScene& scene) {
  // initialize_flow's state depends on y only (rest, or the inlet profile across y): the
  // slab's local z gives the same cells as the whole grid's.
  initialize_flow(*block_, scene);
}

std::string DistributedFluid::describe() const {
  return "slabs along z over " + std::to_string(ranks_) + " MPI ranks (blocks [1, 1, " +
         std::to_string(slab_.count) + "]); rank 0 adds the monitor's row sums and gathers the grid for snapshots";
}

template <class T>
void DistributedFluid::gather_field(const BasicPopulationField<T>& from, BasicPopulationField<T>* into) {
  // Per population a slab's planes are contiguous, and so are they in the whole grid (same
  // nx and ny: the same rows and planes), at the slab's z0. Each slab sends its planes
  // z = 0 .. nz - 1 with their x and y ghosts, the first slab its z = -1 ghost plane too and
  // the last its z = nz one: every ghost a pull of the whole grid reads, with the bits the
  // slabs' own fills gave them, which are the undivided grid's (a refill on rank 0 would give
  // the same bits since the kernel's x-outflow ghosts come from the values as stored,
  // FusedStepMatchesGhostFillStepSingleStore, but the gathered ones need no such link). Except
  // the reflecting faces' ghosts next to a slab's edge: a wall's ghost lies in the plane of
  // its neighbour cell's neighbour, which the other slab filled; gather() redoes those.
  const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT;
  const std::ptrdiff_t plane = from.layout().plane_stride();
  const int nz_whole = into != nullptr ? into->layout().nz() : 0;
  // Planes of slab r in the whole grid's offsets (ghost plane z = -1 at offset 0).
  const auto span = [&](const Slab& s, int& first, int& planes) {
    first = s.z0 + 1 - (s.index == 0 ? 1 : 0);
    planes = s.nz + (s.index == 0 ? 1 : 0) + (s.index + 1 == s.count ? 1 : 0);
  };
  int first = 0, planes = 0;
  span(slab_, first, planes);
  const std::ptrdiff_t local_first = slab_.index == 0 ? 0 : plane;  // the slab's z = -1 or z = 0
  std::vector<int> counts, displs;
  if (rank_ == 0) {
    counts.resize(std::size_t(ranks_));
    displs.resize(std::size_t(ranks_));
    for (int r = 0; r < ranks_; ++r) {
      int f = 0, n = 0;
      span(slab_of(nz_whole, slab_.count, r), f, n);
      counts[std::size_t(r)] = int(std::ptrdiff_t(n) * plane);
      displs[std::size_t(r)] = int(std::ptrdiff_t(f) * plane);
    }
  }
  for (int q = 0; q < D3Q19::Q; ++q)
    check(MPI_Gatherv(from.q(q) + local_first, int(std::ptrdiff_t(planes) * plane), type,
                      rank_ == 0 ? into->q(q) : nullptr, counts.data(), displs.data(), type, 0, comm_),
          "MPI_Gatherv (fields to rank 0)");
}

void DistributedFluid::gather(bool previous) {
  if (rank_ == 0 && whole_ == nullptr) whole_ = std::make_unique<FluidSolver>(whole_params_);
  const FluidSolver& b = *block_;
  if (b.precision() == Precision::Double) {
    const PopulationField& from = previous ? b.previous_state() : b.state();
    gather_field(from, rank_ == 0 ? &whole_->mutable_state() : nullptr);
    if (rank_ == 0) whole_->boundaries().fill_reflect_ghosts(whole_->mutable_state());
  } else {
    const PopulationFieldSingle& from = previous ? b.previous_state_single() : b.state_single();
    gather_field(from, rank_ == 0 ? &whole_->mutable_state_single() : nullptr);
    if (rank_ == 0) whole_->boundaries().fill_reflect_ghosts(whole_->mutable_state_single());
  }
  if (rank_ == 0) whole_->set_step_count(previous ? b.step_count() - 1 : b.step_count());
}

const FluidSolver* DistributedFluid::whole() {
  gather(false);
  return whole_.get();
}

std::string DistributedFluid::kernel_problem(const HealthLimits& limits) {
  // min, max and "and" are exact in any order: the extrema of the whole grid.
  const KernelExtrema& e = block_->last_step_extrema();
  double lo[2] = {e.rho_min, -e.rho_max}, hi[1] = {e.u2_max};
  int finite = e.finite ? 1 : 0;
  check(MPI_Allreduce(MPI_IN_PLACE, lo, 2, MPI_DOUBLE, MPI_MIN, comm_), "MPI_Allreduce");
  check(MPI_Allreduce(MPI_IN_PLACE, hi, 1, MPI_DOUBLE, MPI_MAX, comm_), "MPI_Allreduce");
  check(MPI_Allreduce(MPI_IN_PLACE, &finite, 1, MPI_INT, MPI_LAND, comm_), "MPI_Allreduce");
  KernelExtrema all;
  all.rho_min = lo[0];
  all.rho_max = -lo[1];
  all.u2_max = hi[0];
  all.finite = finite != 0;
  if (!kernel_extrema_suspect(all, limits)) return {};
  // A closer look, as kernel_state_problem: the state the last step read, summarised whole.
  const std::optional<FlowSummary> s = summary_of(!block_->mid_step());
  return broadcast(comm_, s ? health_problem(*s, limits) : std::string());
}

std::optional<FlowSummary> DistributedFluid::summary_of(bool previous) {
  const GridShape& block = block_->shape();
  const std::int64_t first_cell = std::int64_t(slab_.z0) * block.nx * block.ny;
  FlowPartials mine = flow_partials(*block_, previous, first_cell);
  // Extrema and first non-finite cell: 11 numbers per rank (indices below 2^53: exact).
  const auto pack = [](const FlowPartials& p) {
    return std::array<double, 11>{p.u2_max, double(p.u2_max_cell), p.rho_min, double(p.rho_min_cell),
                                  p.rho_max, double(p.rho_max_cell), double(p.nan_cell), p.nan_state.rho,
                                  p.nan_state.ux, p.nan_state.uy, p.nan_state.uz};
  };
  const auto index = [](double v) {
    return v >= 9.2e18 ? FlowPartials::kNone : static_cast<std::int64_t>(v);
  };
  const std::array<double, 11> packed = pack(mine);
  std::vector<double> all_packed(rank_ == 0 ? 11 * std::size_t(ranks_) : 0);
  check(MPI_Gather(packed.data(), 11, MPI_DOUBLE, all_packed.data(), 11, MPI_DOUBLE, 0, comm_), "MPI_Gather");
  // Row sums: the slabs' rows in rank order are the grid's rows in order.
  const int rows = int(mine.row_sums.size());
  std::vector<int> counts, displs;
  FlowPartials whole;
  if (rank_ == 0) {
    counts.resize(std::size_t(ranks_));
    displs.resize(std::size_t(ranks_));
    int at = 0;
    for (int r = 0; r < ranks_; ++r) {
      counts[std::size_t(r)] = 4 * slab_of(whole_params_.shape.nz, slab_.count, r).nz * block.ny;
      displs[std::size_t(r)] = at;
      at += counts[std::size_t(r)];
    }
    whole.row_sums.resize(std::size_t(at / 4));
  }
  check(MPI_Gatherv(mine.row_sums.data(), 4 * rows, MPI_DOUBLE, rank_ == 0 ? whole.row_sums.data() : nullptr,
                    counts.data(), displs.data(), MPI_DOUBLE, 0, comm_),
        "MPI_Gatherv (row sums)");
  if (rank_ != 0) return std::nullopt;
  for (int r = 0; r < ranks_; ++r) {
    const double* v = all_packed.data() + 11 * r;
    FlowPartials p;
    p.u2_max = v[0], p.u2_max_cell = index(v[1]);
    p.rho_min = v[2], p.rho_min_cell = index(v[3]);
    p.rho_max = v[4], p.rho_max_cell = index(v[5]);
    p.nan_cell = index(v[6]);
    p.nan_state = {v[7], v[8], v[9], v[10]};
    whole.merge_extrema(p);
  }
  const std::int64_t step = previous ? block_->step_count() - 1 : block_->step_count();
  return flow_summary(whole, whole_params_.shape, step);
}

}  // namespace cosim::fluid::mpi
