// The bench's yardsticks (fluid/app/bench.cpp), compiled once per instruction-set level like the
// kernel (fluid/collision/kernel_dispatch.hpp) and run at the level the kernel runs at:
//  - the STREAM copy that gives the roofline, with the widest loads and stores of the level;
//  - the peer pattern: a minimal D3Q19 BGK kernel that propagates in place with the AA
//    pattern (Bailey et al. 2009; the fastest public D3Q19 kernels on this kind of machine,
//    e.g. the RRZE lbm-benchmark-kernels' aa-vec-sl-soa), one array of 19 populations
//    (structure of arrays) on the bench grid's layout. No forcing, no boundary conditions
//    (what leaves through the ghost layer comes back two steps later), no extrema: only the
//    propagation and collision whose speed the project's kernel is compared with.
#pragma once

#include <cstddef>

#include "fluid/lattice/population_field.hpp"

namespace cosim::fluid {

struct BenchKernels {
  /// b[i] = a[i] for n doubles (n a multiple of 8, 64-byte aligned arrays), OpenMP static
  /// schedule; `streaming`: non-temporal stores.
  void (*copy)(const double* a, double* b, std::ptrdiff_t n, bool streaming);
  /// `steps` (even) AA-pattern steps of BGK with relaxation time tau on f, in place (OpenMP
  /// over rows): an even step collides each cell where it is and stores the result in the
  /// opposite directions' slots; an odd step reads each cell's populations from its
  /// neighbours' slots and writes the collided ones back to them.
  void (*peer_double)(PopulationField& f, double tau, int steps);
  void (*peer_single)(PopulationFieldSingle& f, double tau, int steps);
  /// peer_single computed in float groups twice as wide (the project's single store computes
  /// in double, fluid/lattice/lanes.hpp): how fast the single store would go with float arithmetic.
  void (*peer_single_float)(PopulationFieldSingle& f, double tau, int steps);
};

/// The yardsticks of the active kernel level (fluid/collision/kernel_dispatch.hpp).
const BenchKernels& bench_kernels();

}  // namespace cosim::fluid
