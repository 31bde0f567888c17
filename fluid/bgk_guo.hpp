// BGK collision (Eq. 10) with the second-order forcing of Guo, Zheng and Shi (2002).
#pragma once

#include "fluid/d3q19.hpp"
#include "fluid/equilibrium.hpp"

namespace cosim::fluid {

/// One-cell BGK collision with Guo forcing, written as the paper's Eq. 26 is read:
///
///   u    = (sum_a c_a f_a + F/2) / rho                          (Guo's velocity)
///   f*_a = f_a - (f_a - f_eq_a(rho, u)) / tau + (1 - 1/(2 tau)) S_a
///   S_a  = E_a [ 3 (c_a - u).F + 9 (c_a.u)(c_a.F) ]
///
/// Relation to Eq. 26: the paper evaluates f_eq at the velocity shifted by half the force
/// and adds the source ((2 phi - 1) / (2 phi)) (3/2) E_a c_a.F. That is the lowest-order
/// (first moment only) part of Guo's S_a with the factor (1 - 1/(2 tau)); Guo's extra
/// terms -3 u.F + 9 (c.u)(c.F) remove the O(u F) error in the momentum flux, which makes
/// the scheme second-order for a non-uniform force (Guo et al., PRE 65, 046308, 2002).
/// tau is the paper's phi; nu = (tau - 1/2) / 3 (Eq. 13).
///
/// `f` holds the 19 pre-collision populations; the post-collision values are written back.
struct BgkGuo {
  double omega;  ///< 1 / tau

  explicit BgkGuo(double tau) : omega(1.0 / tau) {}

  void collide(double* f, double Fx, double Fy, double Fz) const {
    const Moments m = moments(f);
    const double inv_rho = 1.0 / m.rho;
    const double ux = (m.jx + 0.5 * Fx) * inv_rho;
    const double uy = (m.jy + 0.5 * Fy) * inv_rho;
    const double uz = (m.jz + 0.5 * Fz) * inv_rho;
    const double src_pref = 1.0 - 0.5 * omega;
    const double uF = ux * Fx + uy * Fy + uz * Fz;
    for (int q = 0; q < D3Q19::Q; ++q) {
      const double cu = D3Q19::cx[q] * ux + D3Q19::cy[q] * uy + D3Q19::cz[q] * uz;
      const double cF = D3Q19::cx[q] * Fx + D3Q19::cy[q] * Fy + D3Q19::cz[q] * Fz;
      const double S = D3Q19::w[q] * (3.0 * (cF - uF) + 9.0 * cu * cF);
      f[q] += -omega * (f[q] - equilibrium(q, m.rho, ux, uy, uz)) + src_pref * S;
    }
  }
};

}  // namespace cosim::fluid
