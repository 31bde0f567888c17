// [reaction] of a coupled scene: which reading of the paper's Eqs. 18-20 gives the fluid's
// force on the CGPs (and, with the opposite sign, the CGPs' impulse on the fluid). The
// physics of each law is solid/coupling/reaction_law.hpp; the parser protocol/config/reaction_section.hpp.
// Transport-free and TOML-free.
#pragma once

#include <array>
#include <string_view>

namespace cosim::protocol::config {

enum class ReactionLaw {
  /// g = 2 rho (U_B - u): Eq. 18 read as f~_beta - f_beta, summed by Eq. 19 (Niu et al.
  /// 2006; fluid/ib/immersed_boundary.hpp derives it). The default.
  MomentumExchange,
  /// g = -2 rho u: the reaction with the boundary velocity U_B left out (the wall at rest
  /// of Eq. 14 with U_B = 0, whatever the CGP does).
  OmitBoundaryVelocity,
  /// g = 2 rho (U_B - u) / A_T: the reaction of each substep scaled by 1 / A_T, Eq. 19's
  /// impulse g dA dtau read with dtau = dt_CG in LB time units (Eq. 16).
  PerSubstepOverTimeRatio,
  /// g = 2 rho U_B: Eq. 18 as printed, delta f_beta = f~_beta - f_alpha, summed by Eq. 19.
  Eq18Literal,
};

/// The names a scene file uses, in the order of the enum.
inline constexpr std::array<std::string_view, 4> kReactionLawNames = {
    "momentum_exchange", "omit_boundary_velocity", "per_substep_over_time_ratio", "eq18_literal"};

inline constexpr std::string_view reaction_law_name(ReactionLaw law) {
  return kReactionLawNames[static_cast<std::size_t>(law)];
}

}  // namespace cosim::protocol::config
