// Vorticity omega = curl u of the macroscopic velocity (DESIGN 4.4), lattice units.
#pragma once

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

}  // namespace cosim::fluid
