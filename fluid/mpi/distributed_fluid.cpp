#include "fluid/mpi/distributed_fluid.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/peak_memory.hpp"
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
         "]); rank 0 adds the monitor's row sums and sums the markers' samples; each rank writes its own planes of "
         "the snapshots and checkpoints (parallel HDF5)";
}

// ---- snapshots and checkpoints: each rank its own share of the files (parallel HDF5) ----

void DistributedFluid::fill_part() {
  // The block's macroscopic fields, in part_.m from plane kGhosts on; the vorticity's
  // differences along z reach 2 planes beyond the block: those of the neighbours (or their
  // periodic images), whichever rank holds them, the velocity only.
  constexpr int kGhosts = 2;
  const FluidSolver& b = *block_;
  const GridShape& bs = b.shape();
  const int nz_whole = whole_params_.shape.nz;
  const bool periodic_z = whole_params_.faces[ZMin].kind == FaceKind::Periodic;
  FieldPart& p = part_;
  p.m.shape = GridShape{bs.nx, bs.ny, bs.nz + 2 * kGhosts};
  const std::size_t plane = std::size_t(bs.nx) * std::size_t(bs.ny), n = plane * std::size_t(p.m.shape.nz);
  for (std::vector<double>* v : {&p.m.rho, &p.m.ux, &p.m.uy, &p.m.uz}) v->assign(n, 0.0);
  b.macroscopic(p.m, kGhosts);
  for (int a = 0; a < 3; ++a) p.periodic[std::size_t(a)] = whole_params_.faces[std::size_t(2 * a)].kind == FaceKind::Periodic;
  p.ghosts = kGhosts;
  p.z0 = slab_.z0;
  p.nz_whole = nz_whole;
  p.step = b.step_count();

  // The ghost planes a rank needs (slot 0..3: z0 - 2, z0 - 1, z0 + nz, z0 + nz + 1), as
  // planes of the whole grid, -1 where the grid has none (beyond a wall).
  const auto needed = [&](int rank, int slot) {
    const Slab s = slab_of(nz_whole, slab_.count, rank);
    int z = slot < 2 ? s.z0 - 2 + slot : s.z0 + s.nz + (slot - 2);
    if (periodic_z) return ((z % nz_whole) + nz_whole) % nz_whole;
    return z >= 0 && z < nz_whole ? z : -1;
  };
  const auto pack = [&](int z_local, std::vector<double>& out) {  // a plane of the block's u
    out.resize(3 * plane);
    const std::ptrdiff_t from = std::ptrdiff_t(plane) * (z_local + kGhosts);
    std::copy_n(p.m.ux.begin() + from, plane, out.begin());
    std::copy_n(p.m.uy.begin() + from, plane, out.begin() + std::ptrdiff_t(plane));
    std::copy_n(p.m.uz.begin() + from, plane, out.begin() + std::ptrdiff_t(2 * plane));
  };
  const auto unpack = [&](int slot, const std::vector<double>& in) {
    const int z = slot < 2 ? slot : kGhosts + bs.nz + (slot - 2);
    const std::ptrdiff_t to = std::ptrdiff_t(plane) * z, np = std::ptrdiff_t(plane);
    std::copy_n(in.begin(), plane, p.m.ux.begin() + to);
    std::copy_n(in.begin() + np, plane, p.m.uy.begin() + to);
    std::copy_n(in.begin() + 2 * np, plane, p.m.uz.begin() + to);
  };
  constexpr int kTag = 400;  // + slot
  std::vector<std::vector<double>> sends, receives(4);
  std::vector<MPI_Request> req;
  sends.reserve(std::size_t(4 * ranks_));
  for (int slot = 0; slot < 4; ++slot) {
    const int z = needed(rank_, slot);
    if (z < 0) continue;
    if (owner(z) == rank_) {
      std::vector<double> mine;
      pack(z - slab_.z0, mine);
      unpack(slot, mine);
    } else {
      receives[std::size_t(slot)].resize(3 * plane);
      req.emplace_back();
      check(MPI_Irecv(receives[std::size_t(slot)].data(), int(3 * plane), MPI_DOUBLE, owner(z), kTag + slot, comm_,
                      &req.back()),
            "MPI_Irecv (velocity planes for the vorticity)");
    }
  }
  for (int r = 0; r < ranks_; ++r) {
    if (r == rank_) continue;
    for (int slot = 0; slot < 4; ++slot) {
      const int z = needed(r, slot);
      if (z < 0 || owner(z) != rank_) continue;
      sends.emplace_back();
      pack(z - slab_.z0, sends.back());
      req.emplace_back();
      check(MPI_Isend(sends.back().data(), int(3 * plane), MPI_DOUBLE, r, kTag + slot, comm_, &req.back()),
            "MPI_Isend (velocity planes for the vorticity)");
    }
  }
  check(MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE), "MPI_Waitall (velocity planes)");
  for (int slot = 0; slot < 4; ++slot)
    if (const int z = needed(rank_, slot); z >= 0 && owner(z) != rank_) unpack(slot, receives[std::size_t(slot)]);
}

void DistributedFluid::write_snapshots(Snapshots& s, bool last) {
  if (!s.due(block_->step_count(), last)) return;
  fill_part();
  const protocol::WriteGroup group(comm_);
  s.write(part_, &group, last);
}

StoreShare DistributedFluid::share(bool reading) const {
  // Per population a slab's planes are contiguous, and so are they in the whole grid (same
  // nx and ny: the same rows and planes), at the slab's z0.
  const std::ptrdiff_t plane = block_->layout().plane_stride();
  StoreShare sh;
  sh.value_bytes = bytes_per_value(block_->precision());
  sh.whole_stride = layout_of(whole_params_.shape, whole_params_.precision).stride();
  sh.local_stride = block_->layout().stride();
  const std::ptrdiff_t whole_stride = std::ptrdiff_t(sh.whole_stride);
  if (reading) {
    // A restart: each block's whole store, ghost and halo planes included, is the whole
    // grid's store from the block's plane z = -1 on (and the values after its plane z = nz
    // that its rows reach): every value a block's step reads is the one the undivided
    // grid's step reads there. The blocks' ranges overlap.
    sh.first = std::size_t(std::ptrdiff_t(slab_.z0) * plane);
    sh.local_first = 0;
    sh.count = std::size_t(std::min(std::ptrdiff_t(sh.local_stride), whole_stride - std::ptrdiff_t(sh.first)));
    return sh;
  }
  // A checkpoint: the ranges of the blocks part the whole store. Each slab writes its
  // planes z = 0 .. nz - 1 with their x and y ghosts, the first slab its z = -1 ghost plane
  // too and the last its z = nz one: every ghost a pull of the whole grid reads, with the
  // bits the slabs' own fills gave them, which are the undivided grid's. In values: a
  // plane's last row may end one value into the next plane (the single store's compact
  // rows: x = nx of row y = ny at the next plane's offset 0, never a value of that plane's
  // own), so each slab's range begins one value into its first plane and ends one value
  // into the plane after its last; the last slab's runs to the end of the store.
  const Slab& s = slab_;
  const std::ptrdiff_t begin = s.index == 0 ? 0 : std::ptrdiff_t(s.z0 + 1) * plane + 1;
  std::ptrdiff_t end = 0;
  if (s.index + 1 < s.count) {
    end = std::ptrdiff_t(s.z0 + s.nz + 1) * plane + 1;
  } else {
    const GridShape shape{whole_params_.shape.nx, whole_params_.shape.ny, s.nz};
    end = std::min(whole_stride, std::ptrdiff_t(s.z0) * plane +
                                     std::ptrdiff_t(layout_of(shape, whole_params_.precision).stride()));
  }
  sh.first = std::size_t(begin);
  sh.local_first = std::size_t(begin - std::ptrdiff_t(s.z0) * plane);  // the slab's plane z = -1 at 0
  sh.count = std::size_t(end - begin);
  return sh;
}

std::string DistributedFluid::write_store(bool kept, const std::string& file, const std::string& name) {
  const std::string path = broadcast(comm_, file), set = broadcast(comm_, name);
  FluidSolver& b = *block_;
  // The wall ghosts in this block's edge planes that the neighbour blocks' cells fill in the
  // undivided grid, as they fill them (this block's steps never read them; not across the
  // periodic wrap, where the undivided grid's sources are ghosts): the file holds the
  // undivided grid's store.
  const bool below = slab_.index > 0, above = slab_.index + 1 < slab_.count;
  const void* store = nullptr;
  if (!kept) {
    b.fill_wall_ghosts_of_halo_cells(below, above);
    store = b.state_data();
  } else {
    kept_.with_field([&](auto& f) { b.boundaries().fill_wall_ghosts_of_halo_cells(f, below, above); });
    store = kept_.data();
  }
  const protocol::WriteGroup group(comm_);
  return write_store_share(path, set, store, share(false), &group);
}

std::string DistributedFluid::read_store(const std::string& file, const std::string& name, std::int64_t step) {
  const std::string path = broadcast(comm_, file), set = broadcast(comm_, name);
  FluidSolver& b = *block_;
  void* store = b.mutable_state_data();
  const std::string error = protocol::WriteGroup(comm_).first_error(read_store_share(path, set, store, share(true)));
  if (error.empty()) b.set_step_count(step);
  return error;
}

std::vector<double> DistributedFluid::peak_memory_mib() {
  const double mine = protocol::peak_rss_mib();
  std::vector<double> all(rank_ == 0 ? std::size_t(ranks_) : 0);
  check(MPI_Gather(&mine, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, 0, comm_), "MPI_Gather (peak memory)");
  return all;
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
