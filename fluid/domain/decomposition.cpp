#include "fluid/domain/decomposition.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace cosim::fluid {

std::string blocks_problem(const GridShape& shape, const std::array<int, 3>& blocks) {
  char buf[160];
  if (blocks[0] != 1 || blocks[1] < 1 || blocks[2] < 1) {
    std::snprintf(buf, sizeof buf, "blocks along y and z only: [1, py, pz] with py in [1, %d], pz in [1, %d]",
                  shape.ny, shape.nz);
    return buf;
  }
  if (blocks[1] > shape.ny) {
    std::snprintf(buf, sizeof buf, "more blocks along y than the %d rows; py at most %d: [1, %d, %d]", shape.ny,
                  shape.ny, shape.ny, blocks[2]);
    return buf;
  }
  if (blocks[2] > shape.nz) {
    std::snprintf(buf, sizeof buf, "more blocks along z than the %d planes; pz at most %d: [1, %d, %d]", shape.nz,
                  shape.nz, blocks[1], shape.nz);
    return buf;
  }
  return {};
}

BlockChoice choose_blocks(const GridShape& shape, int ranks, const std::array<int, 3>* requested) {
  BlockChoice c;
  char buf[160];
  if (requested != nullptr) {
    c.blocks = *requested;
    const long long n = 1LL * c.blocks[0] * c.blocks[1] * c.blocks[2];
    std::snprintf(buf, sizeof buf, "run.blocks = [%d, %d, %d]: ", c.blocks[0], c.blocks[1], c.blocks[2]);
    c.why = buf;
    if (n != ranks) {
      std::snprintf(buf, sizeof buf, "%lld blocks for %d MPI ranks; give one block per rank, or leave run.blocks out",
                    n, ranks);
      c.why += buf;
    } else if (const std::string p = blocks_problem(shape, c.blocks); !p.empty()) {
      c.why += p;
    } else {
      c.why.clear();
    }
    return c;
  }
  c.blocks = {1, 1, ranks};
  if (const std::string p = blocks_problem(shape, c.blocks); !p.empty()) {
    std::snprintf(buf, sizeof buf, "%d MPI ranks: ", ranks);
    c.why = buf + p;
  }
  return c;
}

Block block_of(const GridShape& shape, const std::array<int, 3>& blocks, int rank) {
  Block b;
  b.py = blocks[1];
  b.pz = blocks[2];
  b.iy = rank % b.py;
  b.iz = rank / b.py;
  const Slab y = slab_of(shape.ny, b.py, b.iy), z = slab_of(shape.nz, b.pz, b.iz);
  b.y0 = y.z0;
  b.ny = y.nz;
  b.z0 = z.z0;
  b.nz = z.nz;
  return b;
}

BlockNeighbours block_neighbours(const FluidParams& whole, const Block& b) {
  // Along one axis of `count` blocks: the neighbours' places, -1 at a grid's end.
  const auto along = [](bool periodic, int index, int count, int& lo, int& hi) {
    lo = hi = -1;
    if (count == 1) return;
    if (index > 0) lo = index - 1;
    else if (periodic) lo = count - 1;
    if (index + 1 < count) hi = index + 1;
    else if (periodic) hi = 0;
  };
  int ylo, yhi, zlo, zhi;
  along(whole.faces[YMin].kind == FaceKind::Periodic, b.iy, b.py, ylo, yhi);
  along(whole.faces[ZMin].kind == FaceKind::Periodic, b.iz, b.pz, zlo, zhi);
  BlockNeighbours n;
  if (ylo >= 0) n.y_min = b.iz * b.py + ylo;
  if (yhi >= 0) n.y_max = b.iz * b.py + yhi;
  if (zlo >= 0) n.z_min = zlo * b.py + b.iy;
  if (zhi >= 0) n.z_max = zhi * b.py + b.iy;
  return n;
}

FluidParams block_params(const FluidParams& whole, const Block& b, std::array<bool, kFaces>& halo) {
  FluidParams p = whole;
  p.shape.ny = b.ny;
  p.shape.nz = b.nz;
  p.y_origin = b.y0;
  const BlockNeighbours n = block_neighbours(whole, b);
  halo = {};
  halo[YMin] = n.y_min >= 0;
  halo[YMax] = n.y_max >= 0;
  halo[ZMin] = n.z_min >= 0;
  halo[ZMax] = n.z_max >= 0;
  return p;
}

Slab slab_of(int nz, int count, int index) {
  const int base = nz / count, extra = nz % count;
  Slab s;
  s.index = index;
  s.count = count;
  s.nz = base + (index < extra ? 1 : 0);
  s.z0 = index * base + (index < extra ? index : extra);
  return s;
}

int mpirun_world_size() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
    if (const char* n = std::getenv(v)) return std::max(1, std::atoi(n));
  return 0;
}

}  // namespace cosim::fluid
