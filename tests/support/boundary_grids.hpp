// Small grids that between them have every boundary kind of the fluid: the kernel and ghost
// tests run on all of them (tests/fluid/test_lbm_invariants.cpp, tests/fluid/test_kernel_dispatch.cpp).
#pragma once

#include <vector>

#include "fluid/solver/fluid_solver.hpp"

namespace cosim::test {

/// Inlet with a Blasius profile, outflow on either x face, a moving wall, free slip and
/// periodic faces; rows of 21, 31 and 16 cells: not a multiple of the widest group (8
/// doubles) nor of a single-store line (16 floats; 31 = 16 - 1 mod 16), and a multiple of
/// both. tau 0.65 and a small uniform body force.
inline std::vector<fluid::FluidParams> every_boundary_grids() {
  using namespace cosim::fluid;
  std::vector<FluidParams> out;
  {
    // the paper's channel, its plate moving
    FluidParams p = blasius_channel({21, 10, 7}, 0.65, 0.05, 3.0);
    p.faces[YMin].wall_velocity = {0.01, 0.0, 0.005};
    out.push_back(p);
  }
  for (const GridShape shape : {GridShape{31, 6, 8}, GridShape{16, 9, 8}}) {
    FluidParams p;  // outflow at x_min, inlet at x_max, a wall and free slip in z
    p.shape = shape;
    p.faces[XMin].kind = FaceKind::Outflow;
    p.faces[XMin].outflow_density = 1.01;
    p.faces[XMax].kind = FaceKind::Inlet;
    p.faces[XMax].inlet_speed = 0.04;
    p.faces[ZMin].kind = FaceKind::Wall;
    p.faces[ZMax].kind = FaceKind::FreeSlip;
    out.push_back(p);
  }
  {
    FluidParams p;  // periodic box
    p.shape = {16, 8, 6};
    out.push_back(p);
  }
  for (FluidParams& p : out) {
    p.tau = 0.65;
    p.body_force = {2e-6, 0.0, -1e-6};
  }
  return out;
}

}  // namespace cosim::test
