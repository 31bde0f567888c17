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

/// One rank's block of a grid cut along y and z ([run] blocks = [1, py, pz]): the rows
/// y0 .. y0 + ny - 1 of the planes z0 .. z0 + nz - 1, every row of x whole, so that the kernel
/// sweeps the same rows with the same vector groups as in the undivided grid (bit-identical
/// cells). Its place (iy, iz) among py x pz blocks; the ranks run along y first
/// (rank = iz py + iy), so that [1, 1, N] is the slabs of slab_of in rank order.
struct Block {
  int y0 = 0, ny = 0, z0 = 0, nz = 0;
  int iy = 0, iz = 0, py = 1, pz = 1;
  int rank() const { return iz * py + iy; }
  int count() const { return py * pz; }
};

/// Block `rank` of `shape` cut into blocks[1] x blocks[2] (slab_of along each axis).
Block block_of(const GridShape& shape, const std::array<int, 3>& blocks, int rank);

/// The ranks of a block's four neighbours across its y and z faces (y_min, y_max, z_min,
/// z_max), -1 where the block ends the grid at a face of its own; with the axis periodic
/// the ends meet (across ranks only when the axis is cut: one block along a periodic axis
/// is its own image, filled by the periodic copy).
struct BlockNeighbours {
  int y_min = -1, y_max = -1, z_min = -1, z_max = -1;
};
BlockNeighbours block_neighbours(const FluidParams& whole, const Block& b);

/// The parameters of a block: the grid's with ny rows and nz planes, origin y0 (the
/// inlet profiles' heights); its faces the grid's where it ends the grid, halo faces (a
/// neighbour's rows or planes) elsewhere, marked in `halo`.
FluidParams block_params(const FluidParams& whole, const Block& b, std::array<bool, kFaces>& halo);

/// Empty when `blocks` (along x, y, z) can decompose `shape`, else why not: blocks along y
/// and z ([1, py, pz]), each at least one row and one plane thick.
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

/// The number of processes mpirun started this one among (its environment: OpenMPI's or a
/// PMI launcher's), 0 when mpirun did not start it. Read by a build without MPI too, to
/// refuse a run over ranks it cannot join.
int mpirun_world_size();

}  // namespace cosim::fluid
