// The fluid's force on a CGP, one component, as the readings of the paper's Eqs. 18-20 that
// its text admits ([reaction] law; protocol/config/reaction_settings.hpp). Each returns
// g dA in lattice units (force x LB step over the marker, per LB step): the CGP gets -g dA
// (Eq. 20) and the fluid the same impulse with the opposite sign (Eqs. 21, 24), so that
// every law conserves momentum between the phases. two_rho_da = 2 rho_l dA_l, U_B the CGP's
// velocity and u the fluid's at the marker (Eq. 17), lattice units.
#pragma once

#include "protocol/config/reaction_settings.hpp"

namespace cosim::solid {

using protocol::config::ReactionLaw;

/// Eqs. 14, 18 (as f~_beta - f_beta) and 19: g = 2 rho (U_B - u) (Niu et al. 2006;
/// the derivation: fluid/ib/immersed_boundary.hpp, momentum_exchange_force).
constexpr double momentum_exchange_g_da(double two_rho_da, double U_B, double u) {
  return two_rho_da * (U_B - u);
}

/// Eq. 19 with Eq. 14's U_B left out: g = -2 rho u, the reaction of a wall at rest.
constexpr double omit_boundary_velocity_g_da(double two_rho_da, double u) { return -(two_rho_da * u); }

/// Eq. 19's impulse per substep, g dA dtau, read with dtau = dt_CG = 1 / A_T in LB time
/// units (Eq. 16): the momentum-exchange reaction scaled by 1 / A_T.
constexpr double per_substep_over_time_ratio_g_da(double two_rho_da, double U_B, double u, int time_ratio) {
  return two_rho_da * (U_B - u) / static_cast<double>(time_ratio);
}

/// Eq. 18 as printed, delta f_beta = f~_beta - f_alpha = -2 rho E_alpha c_alpha . U_B / c_s^2
/// (Eq. 14), summed by Eq. 19 with sum_a E_a c_a c_a = c_s^2 I (Eq. 12): g = 2 rho U_B.
constexpr double eq18_literal_g_da(double two_rho_da, double U_B) { return two_rho_da * U_B; }

/// The law's g dA (see above).
constexpr double reaction_g_da(ReactionLaw law, double two_rho_da, double U_B, double u, int time_ratio) {
  switch (law) {
    case ReactionLaw::MomentumExchange: return momentum_exchange_g_da(two_rho_da, U_B, u);
    case ReactionLaw::OmitBoundaryVelocity: return omit_boundary_velocity_g_da(two_rho_da, u);
    case ReactionLaw::PerSubstepOverTimeRatio:
      return per_substep_over_time_ratio_g_da(two_rho_da, U_B, u, time_ratio);
    case ReactionLaw::Eq18Literal: return eq18_literal_g_da(two_rho_da, U_B);
  }
  return momentum_exchange_g_da(two_rho_da, U_B, u);
}

}  // namespace cosim::solid
