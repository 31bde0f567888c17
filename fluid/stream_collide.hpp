// The fused stream-and-collide kernel: pull streaming (Eq. 9) and BGK collision with Guo
// forcing (Eqs. 10-11, 26) over all interior cells of a block.
#pragma once

#include <array>

#include "fluid/population_field.hpp"

namespace cosim::fluid {

/// dst(x) = collide(f_q(x) = src_q(x - c_q)), for every interior cell, with a force
/// density F (lattice units) that is uniform over the block. `src` holds post-collision
/// populations with its ghost layer filled (BoundaryConditions::fill_ghosts); `dst` gets
/// the post-collision populations of the next step. Two grids, structure of arrays,
/// OpenMP over rows of x, vectorised along x.
void stream_collide(const PopulationField& src, PopulationField& dst, double tau,
                    const std::array<double, 3>& force);

}  // namespace cosim::fluid
