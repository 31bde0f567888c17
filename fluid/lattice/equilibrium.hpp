// Moments (Eqs. 7-8) and the second-order equilibrium (Eq. 11) of the D3Q19 BGK model.
#pragma once

#include "fluid/lattice/d3q19.hpp"

namespace cosim::fluid {

/// Eq. 11: f_eq = rho E_a [1 + 3 c.u + 9/2 (c.u)^2 - 3/2 u.u], lattice units.
inline double equilibrium(int q, double rho, double ux, double uy, double uz) {
  const double cu = D3Q19::cx[q] * ux + D3Q19::cy[q] * uy + D3Q19::cz[q] * uz;
  const double uu = ux * ux + uy * uy + uz * uz;
  return rho * D3Q19::w[q] * (1.0 + 3.0 * cu + 4.5 * cu * cu - 1.5 * uu);
}

/// Zeroth and first moments of one cell's populations: rho (Eq. 7) and j = rho v (Eq. 8).
struct Moments {
  double rho = 0, jx = 0, jy = 0, jz = 0;
};

inline Moments moments(const double* f) {
  Moments m;
  for (int q = 0; q < D3Q19::Q; ++q) {
    m.rho += f[q];
    m.jx += D3Q19::cx[q] * f[q];
    m.jy += D3Q19::cy[q] * f[q];
    m.jz += D3Q19::cz[q] * f[q];
  }
  return m;
}

}  // namespace cosim::fluid
