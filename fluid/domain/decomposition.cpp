#include "fluid/domain/decomposition.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace cosim::fluid {

std::string blocks_problem(const GridShape& shape, const std::array<int, 3>& blocks) {
  if (blocks[0] != 1 || blocks[1] != 1)
    return "only slabs along z are built: blocks = [1, 1, N]";
  if (blocks[2] > shape.nz) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "more slabs than the %d planes along z; at most [1, 1, %d]", shape.nz, shape.nz);
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

Slab slab_of(int nz, int count, int index) {
  const int base = nz / count, extra = nz % count;
  Slab s;
  s.index = index;
  s.count = count;
  s.nz = base + (index < extra ? 1 : 0);
  s.z0 = index * base + (index < extra ? index : extra);
  return s;
}

SlabNeighbours slab_neighbours(const FluidParams& whole, const Slab& slab) {
  SlabNeighbours n;
  if (slab.count == 1) return n;
  const bool periodic = whole.faces[ZMin].kind == FaceKind::Periodic;
  if (slab.index > 0) n.below = slab.index - 1;
  else if (periodic) n.below = slab.count - 1;
  if (slab.index + 1 < slab.count) n.above = slab.index + 1;
  else if (periodic) n.above = 0;
  return n;
}

FluidParams slab_params(const FluidParams& whole, const Slab& slab, std::array<bool, kFaces>& halo) {
  FluidParams p = whole;
  p.shape.nz = slab.nz;
  const SlabNeighbours n = slab_neighbours(whole, slab);
  halo = {};
  halo[ZMin] = n.below >= 0;
  halo[ZMax] = n.above >= 0;
  return p;
}

int mpirun_world_size() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
    if (const char* n = std::getenv(v)) return std::max(1, std::atoi(n));
  return 0;
}

}  // namespace cosim::fluid
