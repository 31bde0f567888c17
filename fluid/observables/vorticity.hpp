// Vorticity omega = curl u of the macroscopic velocity (DESIGN 4.4), lattice units.
#pragma once

#include <array>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"

namespace cosim::fluid {

/// omega = curl u at every interior cell of `m` (1 / dt_LB), stored like m (x fastest).
/// Derivatives: second-order central differences, (u_{i+1} - u_{i-1}) / 2, inside;
/// wrapped at periodic faces (solver.boundaries().face(f).kind == FaceKind::Periodic);
/// second-order one-sided, (-3 u_0 + 4 u_1 - u_2) / 2, at the other faces (first order on
/// an axis of two cells, zero on an axis of one). Exact for linear fields.
/// @pre m.shape == solver.shape() and m holds solver.macroscopic() or a field of that shape.
void vorticity(const FluidSolver& solver, const MacroscopicFields& m, std::vector<double>& wx,
               std::vector<double>& wy, std::vector<double>& wz);

/// The same for planes z0 .. z0 + nz - 1 of a grid of nz_whole planes (a block of a run over
/// MPI ranks, DESIGN 8): `m` holds them from its plane `ghosts` on, with `ghosts` planes of
/// the grid either side (the neighbours' planes, periodic images across a periodic z face;
/// unused beyond a wall); wx, wy, wz are stored like m, their ghost planes left 0. Bit for
/// bit the whole grid's vorticity at those planes (the same differences of the same
/// values). `periodic`: per axis x, y, z. @pre ghosts >= 2 or nz == nz_whole and ghosts == 0
void vorticity(const MacroscopicFields& m, const std::array<bool, 3>& periodic, int ghosts, int z0, int nz_whole,
               std::vector<double>& wx, std::vector<double>& wy, std::vector<double>& wz);

/// A block cut along y too: `m` holds its rows y0 .. y0 + ny - 1 from its row `y_ghosts` on,
/// with `y_ghosts` rows of the grid either side as along z (the rows of the blocks beside it,
/// or their periodic images), for a grid of ny_whole rows. @pre y_ghosts >= 2 or
/// y_ghosts == 0 and ny == ny_whole
void vorticity(const MacroscopicFields& m, const std::array<bool, 3>& periodic, int y_ghosts, int y0, int ny_whole,
               int ghosts, int z0, int nz_whole, std::vector<double>& wx, std::vector<double>& wy,
               std::vector<double>& wz);

}  // namespace cosim::fluid
