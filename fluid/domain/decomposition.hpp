// The decomposition of the fluid grid into blocks over MPI ranks (DESIGN 8): which cells a
// rank owns and how its block's faces meet the others. Pure functions, no MPI: the exchange
// is fluid/mpi/.
#pragma once

#include <array>
#include <string>

#include "fluid/solver/fluid_solver.hpp"

namespace cosim::fluid {

/// One rank's part of the grid: the planes z0 .. z0 + nz - 1 with the whole x and y extent.
/// Slabs along z keep every row of x whole, so the kernel sweeps the same rows with the same
/// vector groups as in the undivided grid (bit-identical cells).
struct Slab {
  int z0 = 0, nz = 0;
  int index = 0, count = 1;  ///< this slab's place among `count` slabs along z
};

/// Empty when `blocks` (along x, y, z) can decompose `shape`, else why not: only slabs
/// along z ([1, 1, N]) are built, each at least one plane thick.
std::string blocks_problem(const GridShape& shape, const std::array<int, 3>& blocks);

/// The blocks of a run on `ranks` processes: `requested` ([run] blocks) when given, which
/// must hold `ranks` blocks, else [1, 1, ranks]. Empty `why` when that works; else the reason
/// (one line, naming run.blocks where the scene set it).
struct BlockChoice {
  std::array<int, 3> blocks{1, 1, 1};
  std::string why;
};
BlockChoice choose_blocks(const GridShape& shape, int ranks, const std::array<int, 3>* requested);

/// Slab `index` of `count` along nz planes: the first nz % count slabs one plane thicker.
Slab slab_of(int nz, int count, int index);

/// The parameters of a slab's block: the grid's, with nz planes; its z faces are the grid's
/// where the slab ends the grid (and z is not periodic over several slabs), halo faces (a
/// neighbour's plane) elsewhere, marked in `halo`.
FluidParams slab_params(const FluidParams& whole, const Slab& slab, std::array<bool, kFaces>& halo);

/// The ranks of the slabs below and above `slab` (z - 1 and z + nz neighbours), -1 where the
/// slab ends the grid at a face of its own; with z periodic the ends meet.
struct SlabNeighbours {
  int below = -1, above = -1;
};
SlabNeighbours slab_neighbours(const FluidParams& whole, const Slab& slab);

/// The number of processes mpirun started this one among (its environment: OpenMPI's or a
/// PMI launcher's), 0 when mpirun did not start it. Read by a build without MPI too, to
/// refuse a run over ranks it cannot join.
int mpirun_world_size();

}  // namespace cosim::fluid
