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
  place_ = block_of(scene.params.shape, c.blocks, rank_);
  std::array<bool, kFaces> halo{};
  const FluidParams params = block_params(scene.params, place_, halo);
  halo_ = std::make_unique<BlockHalo>(comm, block_neighbours(scene.params, place_));
  block_ = std::make_unique<FluidSolver>(params, halo_.get());
  whole_params_ = scene.params;
  const GridShape& whole = scene.params.shape;
  owner_y_.resize(std::size_t(whole.ny));
  owner_z_.resize(std::size_t(whole.nz));
  for (int i = 0; i < place_.py; ++i) {
    const Slab s = slab_of(whole.ny, place_.py, i);
    for (int y = s.z0; y < s.z0 + s.nz; ++y) owner_y_[std::size_t(y)] = i;
  }
  for (int i = 0; i < place_.pz; ++i) {
    const Slab s = slab_of(whole.nz, place_.pz, i);
    for (int z = s.z0; z < s.z0 + s.nz; ++z) owner_z_[std::size_t(z)] = i;
  }
}

void DistributedFluid::initialize(const FluidScene& scene) {
  // initialize_flow's state depends on y only (rest, or the inlet profile across y), which
  // it takes from the block's origin: the same cells as the whole grid's.
  initialize_flow(*block_, scene);
}

std::string DistributedFluid::describe() const {
  const std::string blocks = "(blocks [1, " + std::to_string(place_.py) + ", " + std::to_string(place_.pz) + "])";
  if (place_.py == 1)
    return "slabs along z over " + std::to_string(ranks_) + " MPI ranks " + blocks +
           "; rank 0 adds the monitor's row sums and sums the markers' samples; each rank writes its own planes of "
           "the snapshots and checkpoints (parallel HDF5)";
  return "blocks along y and z over " + std::to_string(ranks_) + " MPI ranks " + blocks +
         "; rank 0 adds the monitor's row sums and sums the markers' samples; each rank writes its own block of "
         "the snapshots and checkpoints (parallel HDF5)";
}

// ---- snapshots and checkpoints: each rank its own share of the files (parallel HDF5) ----

void DistributedFluid::fill_part() {
  // The block's macroscopic fields, in part_.m from row and plane kGhosts on (rows only
  // where the grid is cut along y); the vorticity's differences reach 2 rows and planes
  // beyond the block: those of the neighbours (or their periodic images), whichever rank
  // holds them, the velocity only (no corner: no difference reaches it).
  constexpr int kGhosts = 2;
  const FluidSolver& b = *block_;
  const GridShape& bs = b.shape();
  const GridShape& whole = whole_params_.shape;
  const int gy = place_.py > 1 ? kGhosts : 0, gz = kGhosts;
  bool periodic[3];
  for (int a = 0; a < 3; ++a) periodic[a] = whole_params_.faces[std::size_t(2 * a)].kind == FaceKind::Periodic;
  FieldPart& p = part_;
  p.m.shape = GridShape{bs.nx, bs.ny + 2 * gy, bs.nz + 2 * gz};
  const std::size_t row = std::size_t(bs.nx), n = row * std::size_t(p.m.shape.ny) * std::size_t(p.m.shape.nz);
  for (std::vector<double>* v : {&p.m.rho, &p.m.ux, &p.m.uy, &p.m.uz}) v->assign(n, 0.0);
  b.macroscopic(p.m, gy, gz);
  for (int a = 0; a < 3; ++a) p.periodic[std::size_t(a)] = periodic[a];
  p.ghosts = gz;
  p.z0 = place_.z0;
  p.nz_whole = whole.nz;
  p.y_ghosts = gy;
  p.y0 = place_.y0;
  p.ny_whole = whole.ny;
  p.step = b.step_count();

  // The rows (y, z) of the whole grid that rank r's part needs from others, in one order
  // every rank lists alike: its extended box's rows outside its block along one axis,
  // wrapped across a periodic face, none beyond the grid's other faces. `visit(y, z, wy,
  // wz)`: the row as the part places it (y, z, unwrapped) and the grid's row (wy, wz).
  const auto needed = [&](int r, const auto& visit) {
    const Block o = block_of(whole, {1, place_.py, place_.pz}, r);
    const int ey = place_.py > 1 ? kGhosts : 0;
    for (int z = o.z0 - kGhosts; z < o.z0 + o.nz + kGhosts; ++z)
      for (int y = o.y0 - ey; y < o.y0 + o.ny + ey; ++y) {
        const bool out_y = y < o.y0 || y >= o.y0 + o.ny, out_z = z < o.z0 || z >= o.z0 + o.nz;
        if (out_y == out_z) continue;  // its own, or a corner
        int wy = y, wz = z;
        if (wy < 0 || wy >= whole.ny) {
          if (!periodic[1]) continue;
          wy = ((wy % whole.ny) + whole.ny) % whole.ny;
        }
        if (wz < 0 || wz >= whole.nz) {
          if (!periodic[2]) continue;
          wz = ((wz % whole.nz) + whole.nz) % whole.nz;
        }
        visit(y, z, wy, wz);
      }
  };
  // The velocity of the part's row (ly, lz) (its own indices) into or out of a buffer.
  const auto at = [&](int ly, int lz) { return std::ptrdiff_t(p.m.index(0, ly, lz)); };
  const auto pack = [&](int wy, int wz, std::vector<double>& out) {  // a row of this block
    const std::ptrdiff_t from = at(wy - place_.y0 + gy, wz - place_.z0 + gz);
    for (const std::vector<double>* v : {&p.m.ux, &p.m.uy, &p.m.uz})
      out.insert(out.end(), v->begin() + from, v->begin() + from + std::ptrdiff_t(row));
  };
  const auto unpack = [&](int y, int z, const double* in) {
    const std::ptrdiff_t to = at(y - place_.y0 + gy, z - place_.z0 + gz), nr = std::ptrdiff_t(row);
    std::copy_n(in, row, p.m.ux.begin() + to);
    std::copy_n(in + nr, row, p.m.uy.begin() + to);
    std::copy_n(in + 2 * nr, row, p.m.uz.begin() + to);
  };
  constexpr int kTag = 400;
  std::vector<std::vector<double>> sends(static_cast<std::size_t>(ranks_)), receives(static_cast<std::size_t>(ranks_));
  // This rank's own rows first (a periodic image of its own block), then the counts.
  std::vector<std::size_t> expect(static_cast<std::size_t>(ranks_), 0);
  needed(rank_, [&](int y, int z, int wy, int wz) {
    const int o = owner(wy, wz);
    if (o == rank_) {
      std::vector<double> mine;
      pack(wy, wz, mine);
      unpack(y, z, mine.data());
    } else {
      expect[std::size_t(o)] += 3 * row;
    }
  });
  for (int r = 0; r < ranks_; ++r)
    if (r != rank_)
      needed(r, [&](int, int, int wy, int wz) {
        if (owner(wy, wz) == rank_) pack(wy, wz, sends[std::size_t(r)]);
      });
  std::vector<MPI_Request> req;
  for (int r = 0; r < ranks_; ++r) {
    if (expect[std::size_t(r)] > 0) {
      receives[std::size_t(r)].resize(expect[std::size_t(r)]);
      req.emplace_back();
      check(MPI_Irecv(receives[std::size_t(r)].data(), int(expect[std::size_t(r)]), MPI_DOUBLE, r, kTag, comm_,
                      &req.back()),
            "MPI_Irecv (velocity rows for the vorticity)");
    }
    if (!sends[std::size_t(r)].empty()) {
      req.emplace_back();
      check(MPI_Isend(sends[std::size_t(r)].data(), int(sends[std::size_t(r)].size()), MPI_DOUBLE, r, kTag, comm_,
                      &req.back()),
            "MPI_Isend (velocity rows for the vorticity)");
    }
  }
  check(MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE), "MPI_Waitall (velocity rows)");
  std::vector<std::size_t> next(static_cast<std::size_t>(ranks_), 0);
  needed(rank_, [&](int y, int z, int wy, int wz) {
    const int o = owner(wy, wz);
    if (o == rank_) return;
    unpack(y, z, receives[std::size_t(o)].data() + next[std::size_t(o)]);
    next[std::size_t(o)] += 3 * row;
  });
}

void DistributedFluid::write_snapshots(Snapshots& s, bool last) {
  if (!s.due(block_->step_count(), last)) return;
  fill_part();
  const protocol::WriteGroup group(comm_);
  s.write(part_, &group, last);
}

StoreShare DistributedFluid::share(bool reading) const {
  // Per population a block's rows of a plane are contiguous, and so are they in the whole
  // grid (same nx: the same rows), at the block's y0 in plane z0 + z.
  const GridLayout& lay = block_->layout();
  const GridLayout whole = layout_of(whole_params_.shape, whole_params_.precision);
  const std::ptrdiff_t sx = lay.row_stride(), plane = lay.plane_stride(), whole_plane = whole.plane_stride();
  // In the single store's compact rows a row's x = nx ghost is the next row's first value
  // (never a value of that row's own): a run of rows then begins one value into its first
  // row and ends one value into the row after its last.
  const std::ptrdiff_t shift = lay.front_pad() + lay.nx() >= sx ? 1 : 0;
  // The offset of row y of plane z (the block's own indices) in the block's store, and in
  // the whole grid's.
  const auto local = [&](int y, int z) { return std::ptrdiff_t(z + 1) * plane + std::ptrdiff_t(y + 1) * sx; };
  const auto global = [&](int y, int z) {
    return std::ptrdiff_t(place_.z0 + z + 1) * whole_plane + std::ptrdiff_t(place_.y0 + y + 1) * sx;
  };
  StoreShare sh;
  sh.value_bytes = bytes_per_value(block_->precision());
  sh.whole_stride = whole.stride();
  sh.local_stride = lay.stride();
  sh.whole_chunk_stride = std::size_t(whole_plane);
  sh.local_chunk_stride = std::size_t(plane);
  if (reading) {
    // A restart: each block's rows and planes with their ghosts, y = -1 .. ny of z = -1 .. nz,
    // are the whole grid's from the block's row -1 of its plane -1 on: every value a block's
    // step reads is the one the undivided grid's step reads there. The blocks' ranges overlap.
    sh.first = std::size_t(global(-1, -1) + shift);
    sh.local_first = std::size_t(local(-1, -1) + shift);
    sh.count = std::size_t(std::ptrdiff_t(lay.ny() + 2) * sx);
    sh.chunks = std::size_t(lay.nz() + 2);
    return sh;
  }
  // A checkpoint: the blocks' ranges part the whole store. Each block writes its rows of
  // its planes with their x ghosts, and the grid's ghost rows and planes where it ends the
  // grid (y = -1 for the first along y, ...): every ghost a pull of the whole grid reads,
  // with the bits the blocks' own fills gave them, which are the undivided grid's.
  const Block& b = place_;
  const int ylo = b.iy == 0 ? -1 : 0, yhi = b.iy + 1 == b.py ? b.ny : b.ny - 1;
  const int zlo = b.iz == 0 ? -1 : 0, zhi = b.iz + 1 == b.pz ? b.nz : b.nz - 1;
  sh.first = std::size_t(global(ylo, zlo) + shift);
  sh.local_first = std::size_t(local(ylo, zlo) + shift);
  sh.count = std::size_t(std::ptrdiff_t(yhi - ylo + 1) * sx);
  sh.chunks = std::size_t(zhi - zlo + 1);
  return sh;
}

std::string DistributedFluid::write_store(bool kept, const std::string& file, const std::string& name) {
  const std::string path = broadcast(comm_, file), set = broadcast(comm_, name);
  FluidSolver& b = *block_;
  // The wall ghosts in this block's edge rows and planes that the neighbour blocks' cells
  // fill in the undivided grid, as they fill them (this block's steps never read them; not
  // across the periodic wrap, where the undivided grid's sources are ghosts): the file
  // holds the undivided grid's store.
  std::array<bool, kFaces> cells{};
  cells[YMin] = place_.iy > 0;
  cells[YMax] = place_.iy + 1 < place_.py;
  cells[ZMin] = place_.iz > 0;
  cells[ZMax] = place_.iz + 1 < place_.pz;
  const void* store = nullptr;
  if (!kept) {
    b.fill_wall_ghosts_of_halo_cells(cells);
    store = b.state_data();
  } else {
    kept_.with_field([&](auto& f) { b.boundaries().fill_wall_ghosts_of_halo_cells(f, cells); });
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
    if (owner(nodes.cells[i][1], nodes.cells[i][2]) == rank_) mine.push_back(i);
  std::vector<NodeMoments> values(mine.size());
  const std::ptrdiff_t m = std::ptrdiff_t(mine.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t t = 0; t < m; ++t) {
    const std::array<int, 3>& c = nodes.cells[mine[std::size_t(t)]];
    values[std::size_t(t)] = node_moments(*block_, c[0], c[1] - place_.y0, c[2] - place_.z0);
  }
  // Rank 0: every rank's moments in its order of the list, back into the list's order.
  std::vector<int> counts, displs;
  std::vector<NodeMoments> all;
  if (rank_ == 0) {
    counts.assign(std::size_t(ranks_), 0);
    displs.assign(std::size_t(ranks_), 0);
    for (const std::array<int, 3>& c : nodes.cells) counts[std::size_t(owner(c[1], c[2]))] += 4;
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
  for (std::size_t i = 0; i < nodes.cells.size(); ++i)
    ordered[i] = all[next[std::size_t(owner(nodes.cells[i][1], nodes.cells[i][2]))]++];
  ib_.sum_samples(nodes, ordered, out);
}

void DistributedFluid::spread(std::span<const Vec3> X, std::span<const Vec3> J) {
  const std::vector<Vec3> x = from_leader(X), j = from_leader(J);
  FluidSolver& b = *block_;
  const int y0 = place_.y0, z0 = place_.z0;
  ib_.spread(std::span<const Vec3>(x), std::span<const Vec3>(j), [&](int cx, int cy, int cz, const Vec3& F) {
    if (owner(cy, cz) == rank_) b.add_force(cx, cy - y0, cz - z0, F[0], F[1], F[2]);
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
  const GridShape& whole_shape = whole_params_.shape;
  const std::int64_t first_cell =
      (std::int64_t(place_.z0) * whole_shape.ny + place_.y0) * std::int64_t(whole_shape.nx);
  FlowPartials mine = flow_partials(*block_, previous, first_cell, whole_shape.ny);
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
  // Row sums: each block's rows in its order, put in the grid's row order on rank 0.
  const int rows = int(mine.row_sums.size());
  std::vector<int> counts, displs;
  FlowPartials whole;
  if (rank_ == 0) {
    counts.resize(std::size_t(ranks_));
    displs.resize(std::size_t(ranks_));
    int at = 0;
    for (int r = 0; r < ranks_; ++r) {
      const Block o = block_of(whole_shape, {1, place_.py, place_.pz}, r);
      counts[std::size_t(r)] = 4 * o.nz * o.ny;
      displs[std::size_t(r)] = at;
      at += counts[std::size_t(r)];
    }
    whole.row_sums.resize(std::size_t(at / 4));
  }
  std::vector<std::array<double, 4>> gathered(rank_ == 0 ? whole.row_sums.size() : 0);
  check(MPI_Gatherv(mine.row_sums.data(), 4 * rows, MPI_DOUBLE, rank_ == 0 ? gathered.data() : nullptr,
                    counts.data(), displs.data(), MPI_DOUBLE, 0, comm_),
        "MPI_Gatherv (row sums)");
  if (rank_ != 0) return std::nullopt;
  for (int r = 0; r < ranks_; ++r) {
    const Block o = block_of(whole_shape, {1, place_.py, place_.pz}, r);
    std::size_t k = std::size_t(displs[std::size_t(r)] / 4);
    for (int z = o.z0; z < o.z0 + o.nz; ++z)
      for (int y = o.y0; y < o.y0 + o.ny; ++y) whole.row_sums[std::size_t(z) * std::size_t(whole_shape.ny) + std::size_t(y)] = gathered[k++];
  }
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
