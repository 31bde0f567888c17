#include "fluid/observables/vorticity.hpp"

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace cosim::fluid {

namespace {

/// d/ds of `u` along one axis of n cells with stride `stride`, at position i of that axis;
/// `p` points at the cell.
inline double derivative(const double* p, int i, int n, std::ptrdiff_t stride, bool periodic) {
  if (n == 1) return 0.0;
  if (periodic) {
    const std::ptrdiff_t up = i + 1 < n ? stride : -std::ptrdiff_t(n - 1) * stride;
    const std::ptrdiff_t down = i > 0 ? -stride : std::ptrdiff_t(n - 1) * stride;
    return 0.5 * (p[up] - p[down]);
  }
  if (i > 0 && i < n - 1) return 0.5 * (p[stride] - p[-stride]);
  if (n == 2) return i == 0 ? p[stride] - p[0] : p[0] - p[-stride];
  if (i == 0) return 0.5 * (-3.0 * p[0] + 4.0 * p[stride] - p[2 * stride]);
  return 0.5 * (3.0 * p[0] - 4.0 * p[-stride] + p[-2 * stride]);
}

}  // namespace

void vorticity(const FluidSolver& solver, const MacroscopicFields& m, std::vector<double>& wx,
               std::vector<double>& wy, std::vector<double>& wz) {
  const GridShape& s = m.shape;
  const GridShape& ss = solver.shape();
  if (s.nx != ss.nx || s.ny != ss.ny || s.nz != ss.nz)
    throw std::invalid_argument("vorticity: the macroscopic fields and the solver differ in shape");
  std::array<bool, 3> periodic{};
  for (int a = 0; a < 3; ++a)
    periodic[a] = solver.boundaries().face(2 * a).kind == FaceKind::Periodic;
  vorticity(m, periodic, 0, 0, s.nz, wx, wy, wz);
}

void vorticity(const MacroscopicFields& m, const std::array<bool, 3>& periodic, int ghosts, int z0, int nz_whole,
               std::vector<double>& wx, std::vector<double>& wy, std::vector<double>& wz) {
  vorticity(m, periodic, 0, 0, m.shape.ny, ghosts, z0, nz_whole, wx, wy, wz);
}

void vorticity(const MacroscopicFields& m, const std::array<bool, 3>& periodic, int y_ghosts, int y0, int ny_whole,
               int ghosts, int z0, int nz_whole, std::vector<double>& wx, std::vector<double>& wy,
               std::vector<double>& wz) {
  const GridShape& s = m.shape;
  const int nz = s.nz - 2 * ghosts, ny = s.ny - 2 * y_ghosts;
  if (ghosts < 0 || nz < 1 || (ghosts == 0 && nz != nz_whole) || (ghosts > 0 && ghosts < 2) || z0 < 0 ||
      z0 + nz > nz_whole)
    throw std::invalid_argument("vorticity: planes " + std::to_string(z0) + " + " + std::to_string(nz) + " with " +
                                std::to_string(ghosts) + " ghost planes of a grid of " + std::to_string(nz_whole));
  if (y_ghosts < 0 || ny < 1 || (y_ghosts == 0 && ny != ny_whole) || (y_ghosts > 0 && y_ghosts < 2) || y0 < 0 ||
      y0 + ny > ny_whole)
    throw std::invalid_argument("vorticity: rows " + std::to_string(y0) + " + " + std::to_string(ny) + " with " +
                                std::to_string(y_ghosts) + " ghost rows of a grid of " + std::to_string(ny_whole));
  const std::size_t n = std::size_t(s.cells());
  if (m.ux.size() != n || m.uy.size() != n || m.uz.size() != n)
    throw std::invalid_argument("vorticity: the velocity arrays do not match the grid shape");
  wx.assign(n, 0.0);
  wy.assign(n, 0.0);
  wz.assign(n, 0.0);
  const std::ptrdiff_t sx = 1, sy = s.nx, sz = std::ptrdiff_t(s.nx) * s.ny;
  // Along z a periodic neighbour is a ghost plane where the block has them (the same value
  // the whole grid's wrap reads), else the wrap of the whole grid.
  const auto d_dz = [&](const double* p, int z) {
    if (periodic[2] && ghosts > 0 && nz_whole > 1) return 0.5 * (p[sz] - p[-sz]);
    return derivative(p, z0 + z - ghosts, nz_whole, sz, periodic[2]);
  };
  const auto d_dy = [&](const double* p, int y) {
    if (periodic[1] && y_ghosts > 0 && ny_whole > 1) return 0.5 * (p[sy] - p[-sy]);
    return derivative(p, y0 + y - y_ghosts, ny_whole, sy, periodic[1]);
  };

#pragma omp parallel for collapse(2) schedule(static)
  for (int z = ghosts; z < ghosts + nz; ++z)
    for (int y = y_ghosts; y < y_ghosts + ny; ++y)
      for (int x = 0; x < s.nx; ++x) {
        const std::size_t i = m.index(x, y, z);
        const double* ux = m.ux.data() + i;
        const double* uy = m.uy.data() + i;
        const double* uz = m.uz.data() + i;
        const double duz_dy = d_dy(uz, y);
        const double duy_dz = d_dz(uy, z);
        const double dux_dz = d_dz(ux, z);
        const double duz_dx = derivative(uz, x, s.nx, sx, periodic[0]);
        const double duy_dx = derivative(uy, x, s.nx, sx, periodic[0]);
        const double dux_dy = d_dy(ux, y);
        wx[i] = duz_dy - duy_dz;
        wy[i] = dux_dz - duz_dx;
        wz[i] = duy_dx - dux_dy;
      }
}

}  // namespace cosim::fluid
