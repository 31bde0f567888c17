#include "fluid/mpi/distributed_fluid.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/mpi/mpi_world.hpp"

namespace cosim::fluid::mpi {

DistributedFluid::DistributedFluid(const FluidScene& scene, MPI_Comm comm) : comm_(comm), ib_(scene.params) {
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
  owner_.resize(std::size_t(scene.params.shape.nz));
  for (int r = 0; r < slab_.count; ++r) {
    const Slab s = slab_of(scene.params.shape.nz, slab_.count, r);
    for (int z = s.z0; z < s.z0 + s.nz; ++z) owner_[std::size_t(z)] = r;
  }
}

void DistributedFluid::initialize(const FluidScene& scene) {
  // initialize_flow's state depends on y only (rest, or the inlet profile across y): the
  // slab's local z gives the same cells as the whole grid's.
  initialize_flow(*block_, scene);
}

std::string DistributedFluid::describe() const {
  return "slabs along z over " + std::to_string(ranks_) + " MPI ranks (blocks [1, 1, " +
         std::to_string(slab_.count) +
         "]); rank 0 adds the monitor's row sums, gathers the grid for snapshots and checkpoints and sums the "
         "markers' samples";
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
  // In values: a plane's last row may end one value into the next plane (the single store's
  // compact rows: x = nx of row y = ny at the next plane's offset 0, never a value of that
  // plane's own), so each slab's range begins one value into its first plane and ends one
  // value into the plane after its last; the last slab's runs to the end of the store.
  const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT;
  const std::ptrdiff_t plane = from.layout().plane_stride();
  const int nz_whole = whole_params_.shape.nz;
  const std::ptrdiff_t whole_stride = std::ptrdiff_t(layout_of(whole_params_.shape, whole_params_.precision).stride());
  // Slab r's range [begin, end) in the whole store (ghost plane z = -1 at offset 0).
  const auto range = [&](int r, std::ptrdiff_t& begin, std::ptrdiff_t& end) {
    const Slab s = slab_of(nz_whole, slab_.count, r);
    begin = r == 0 ? 0 : std::ptrdiff_t(s.z0 + 1) * plane + 1;
    if (r + 1 < slab_.count) {
      end = std::ptrdiff_t(s.z0 + s.nz + 1) * plane + 1;
    } else {
      const GridShape shape{whole_params_.shape.nx, whole_params_.shape.ny, s.nz};
      end = std::min(whole_stride, std::ptrdiff_t(s.z0) * plane +
                                       std::ptrdiff_t(layout_of(shape, whole_params_.precision).stride()));
    }
  };
  std::ptrdiff_t begin = 0, end = 0;
  range(rank_, begin, end);
  const std::ptrdiff_t local_begin = begin - std::ptrdiff_t(slab_.z0) * plane;  // the slab's plane z = -1 at 0
  std::vector<int> counts, displs;
  if (rank_ == 0) {
    counts.resize(std::size_t(ranks_));
    displs.resize(std::size_t(ranks_));
    for (int r = 0; r < ranks_; ++r) {
      std::ptrdiff_t b = 0, e = 0;
      range(r, b, e);
      counts[std::size_t(r)] = int(e - b);
      displs[std::size_t(r)] = int(b);
    }
  }
  for (int q = 0; q < D3Q19::Q; ++q)
    check(MPI_Gatherv(from.q(q) + local_begin, int(end - begin), type, rank_ == 0 ? into->q(q) : nullptr,
                      counts.data(), displs.data(), type, 0, comm_),
          "MPI_Gatherv (fields to rank 0)");
}

template <class T>
void DistributedFluid::gather_into_whole(const BasicPopulationField<T>& from) {
  if (rank_ == 0 && whole_ == nullptr) whole_ = std::make_unique<FluidSolver>(whole_params_);
  if constexpr (std::is_same_v<T, double>) {
    gather_field(from, rank_ == 0 ? &whole_->mutable_state() : nullptr);
    if (rank_ == 0) whole_->boundaries().fill_reflect_ghosts(whole_->mutable_state());
  } else {
    gather_field(from, rank_ == 0 ? &whole_->mutable_state_single() : nullptr);
    if (rank_ == 0) whole_->boundaries().fill_reflect_ghosts(whole_->mutable_state_single());
  }
}

void DistributedFluid::gather(bool previous) {
  const FluidSolver& b = *block_;
  if (b.precision() == Precision::Double)
    gather_into_whole(previous ? b.previous_state() : b.state());
  else
    gather_into_whole(previous ? b.previous_state_single() : b.state_single());
  if (rank_ == 0) whole_->set_step_count(previous ? b.step_count() - 1 : b.step_count());
}

StoreView DistributedFluid::whole_store(bool kept) {
  const FluidSolver& b = *block_;
  if (b.precision() == Precision::Double)
    gather_into_whole(kept ? kept_.field() : b.state());
  else
    gather_into_whole(kept ? kept_.field_single() : b.state_single());
  if (rank_ != 0) return {};
  return b.precision() == Precision::Double ? store_view(whole_->state()) : store_view(whole_->state_single());
}

template <class T>
void DistributedFluid::scatter_field(const T* from, BasicPopulationField<T>& into) {
  // Each block's whole store, ghost and halo planes included, is the whole grid's store
  // from the block's plane z = -1 on (and the values after its plane z = nz that its rows
  // reach): every value a block's step reads is the one the undivided grid's step reads
  // there. Sent from rank 0 point to point (the blocks' ranges overlap).
  const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT;
  const std::ptrdiff_t plane = into.layout().plane_stride();
  const std::ptrdiff_t whole_stride = std::ptrdiff_t(layout_of(whole_params_.shape, whole_params_.precision).stride());
  const auto range = [&](int rank, std::ptrdiff_t local_stride, std::ptrdiff_t& begin, std::ptrdiff_t& count) {
    begin = std::ptrdiff_t(slab_of(whole_params_.shape.nz, slab_.count, rank).z0) * plane;
    count = std::min(local_stride, whole_stride - begin);
  };
  constexpr int kTag = 300;  // + q
  if (rank_ == 0) {
    std::vector<MPI_Request> req;
    for (int r = 1; r < ranks_; ++r) {
      const Slab s = slab_of(whole_params_.shape.nz, slab_.count, r);
      const GridShape shape{whole_params_.shape.nx, whole_params_.shape.ny, s.nz};
      std::ptrdiff_t begin = 0, count = 0;
      range(r, std::ptrdiff_t(layout_of(shape, whole_params_.precision).stride()), begin, count);
      for (int q = 0; q < D3Q19::Q; ++q) {
        req.emplace_back();
        check(MPI_Isend(from + q * whole_stride + begin, int(count), type, r, kTag + q, comm_, &req.back()),
              "MPI_Isend (a checkpoint to the ranks)");
      }
    }
    std::ptrdiff_t begin = 0, count = 0;
    range(0, std::ptrdiff_t(into.layout().stride()), begin, count);
    for (int q = 0; q < D3Q19::Q; ++q) std::copy(from + q * whole_stride + begin, from + q * whole_stride + begin + count, into.q(q));
    check(MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE), "MPI_Waitall (a checkpoint to the ranks)");
  } else {
    std::ptrdiff_t begin = 0, count = 0;
    range(rank_, std::ptrdiff_t(into.layout().stride()), begin, count);
    for (int q = 0; q < D3Q19::Q; ++q)
      check(MPI_Recv(into.q(q), int(count), type, 0, kTag + q, comm_, MPI_STATUS_IGNORE),
            "MPI_Recv (a checkpoint from rank 0)");
  }
}

void DistributedFluid::load_store(const StoreView& from, std::int64_t step) {
  FluidSolver& b = *block_;
  const bool dbl = b.precision() == Precision::Double;
  if (rank_ == 0) {
    const std::size_t size = std::size_t(D3Q19::Q) * layout_of(whole_params_.shape, whole_params_.precision).stride();
    if (from.size != size || (dbl ? from.d == nullptr : from.s == nullptr))
      throw std::invalid_argument("DistributedFluid::load_store: " + std::to_string(from.size) +
                                  " values of the other precision or size; " + std::to_string(size) + " expected");
  }
  if (dbl)
    scatter_field(from.d, b.mutable_state());
  else
    scatter_field(from.s, b.mutable_state_single());
  b.set_step_count(step);
}

std::vector<Vec3> DistributedFluid::from_leader(std::span<const Vec3> values) {
  long long n = rank_ == 0 ? static_cast<long long>(values.size()) : 0;
  check(MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, comm_), "MPI_Bcast");
  std::vector<Vec3> out(std::size_t(n), Vec3{});
  if (rank_ == 0) std::copy(values.begin(), values.end(), out.begin());
  if (n > 0) check(MPI_Bcast(out.data(), int(3 * n), MPI_DOUBLE, 0, comm_), "MPI_Bcast (markers)");
  return out;
}

void DistributedFluid::sample(std::span<const Vec3> X, std::span<MarkerSample> out) {
  const std::vector<Vec3> x = from_leader(X);
  if (rank_ == 0 && out.size() != x.size())
    throw std::invalid_argument("DistributedFluid::sample: " + std::to_string(out.size()) + " outputs for " +
                                std::to_string(x.size()) + " markers");
  // The nodes every marker reaches, listed on every rank as the serial sample() lists them.
  const MarkerNodes nodes = ib_.marker_nodes(x);
  std::vector<std::size_t> mine;
  for (std::size_t i = 0; i < nodes.cells.size(); ++i)
    if (owner(nodes.cells[i][2]) == rank_) mine.push_back(i);
  std::vector<NodeMoments> values(mine.size());
  const std::ptrdiff_t m = std::ptrdiff_t(mine.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t t = 0; t < m; ++t) {
    const std::array<int, 3>& c = nodes.cells[mine[std::size_t(t)]];
    values[std::size_t(t)] = node_moments(*block_, c[0], c[1], c[2] - slab_.z0);
  }
  // Rank 0: every rank's moments in its order of the list, back into the list's order.
  std::vector<int> counts, displs;
  std::vector<NodeMoments> all;
  if (rank_ == 0) {
    counts.assign(std::size_t(ranks_), 0);
    displs.assign(std::size_t(ranks_), 0);
    for (const std::array<int, 3>& c : nodes.cells) counts[std::size_t(owner(c[2]))] += 4;
    for (int r = 1; r < ranks_; ++r) displs[std::size_t(r)] = displs[std::size_t(r - 1)] + counts[std::size_t(r - 1)];
    all.resize(nodes.cells.size());
  }
  check(MPI_Gatherv(values.data(), int(4 * values.size()), MPI_DOUBLE, rank_ == 0 ? all.data() : nullptr,
                    counts.data(), displs.data(), MPI_DOUBLE, 0, comm_),
        "MPI_Gatherv (node moments)");
  if (rank_ != 0) return;
  std::vector<NodeMoments> ordered(nodes.cells.size());
  std::vector<std::size_t> next(static_cast<std::size_t>(ranks_));
  for (int r = 0; r < ranks_; ++r) next[std::size_t(r)] = std::size_t(displs[std::size_t(r)] / 4);
  for (std::size_t i = 0; i < nodes.cells.size(); ++i) ordered[i] = all[next[std::size_t(owner(nodes.cells[i][2]))]++];
  ib_.sum_samples(nodes, ordered, out);
}

void DistributedFluid::spread(std::span<const Vec3> X, std::span<const Vec3> J) {
  const std::vector<Vec3> x = from_leader(X), j = from_leader(J);
  FluidSolver& b = *block_;
  const int z0 = slab_.z0;
  ib_.spread(std::span<const Vec3>(x), std::span<const Vec3>(j), [&](int cx, int cy, int cz, const Vec3& F) {
    if (owner(cz) == rank_) b.add_force(cx, cy, cz - z0, F[0], F[1], F[2]);
  });
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
  // A closer look, as kernel_state_problem: the state the last step read, summarised whole
  // (the state now mid-step, or where no previous state is kept: the in-place propagation).
  const std::optional<FlowSummary> s = summary_of(!block_->mid_step() && block_->has_previous_state());
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
