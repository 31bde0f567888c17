// BGK collision (Eq. 10) with the second-order forcing of Guo, Zheng and Shi (2002).
#pragma once

#include "fluid/lattice/d3q19.hpp"
#include "fluid/lattice/equilibrium.hpp"

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

  /// Defined out of line (fluid/collision/bgk_guo.cpp): one compiled copy, so that every caller (the
  /// solver's forced cells, the tests' references) gets the same rounding. Inlined, the
  /// compiler may fuse multiplies and adds differently in each caller (GCC contracts across
  /// expressions by default), and two callers then differ in the last bit for some inputs.
  void collide(double* f, double Fx, double Fy, double Fz) const;
};

}  // namespace cosim::fluid
