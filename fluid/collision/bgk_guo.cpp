#include "fluid/collision/bgk_guo.hpp"

namespace cosim::fluid {

void BgkGuo::collide(double* f, double Fx, double Fy, double Fz) const {
  const Moments m = moments(f);  // Eqs. 7-8
  const double inv_rho = 1.0 / m.rho;
  const double ux = (m.jx + 0.5 * Fx) * inv_rho;
  const double uy = (m.jy + 0.5 * Fy) * inv_rho;
  const double uz = (m.jz + 0.5 * Fz) * inv_rho;
  const double src_pref = 1.0 - 0.5 * omega;
  const double uF = ux * Fx + uy * Fy + uz * Fz;
  for (int q = 0; q < D3Q19::Q; ++q) {
    const double cu = D3Q19::cx[q] * ux + D3Q19::cy[q] * uy + D3Q19::cz[q] * uz;
    const double cF = D3Q19::cx[q] * Fx + D3Q19::cy[q] * Fy + D3Q19::cz[q] * Fz;
    const double S = D3Q19::w[q] * (3.0 * (cF - uF) + 9.0 * cu * cF);  // Guo's source
    f[q] += -omega * (f[q] - equilibrium(q, m.rho, ux, uy, uz)) + src_pref * S;  // Eqs. 10-11, 26
  }
}

}  // namespace cosim::fluid
