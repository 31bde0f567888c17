// The units the solid server reports in (solid.h5, its log lines): micrometres and joules,
// from the models' Hartree atomic units (protocol/units.hpp).
#pragma once

#include "protocol/units.hpp"

namespace cosim::solid {

inline constexpr double kMicrometre = 1e-6;

inline double um_from_bohr(double bohr) { return bohr * protocol::PhysicalConstants::bohr_m / kMicrometre; }

inline double joule_from_hartree(double e) {
  return e * protocol::UnitConverter::force_au_N() * protocol::PhysicalConstants::bohr_m;  // E_h = F_AU l_AU
}

}  // namespace cosim::solid
