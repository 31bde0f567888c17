// What an accepted scene must hold beyond the parsers' own rules: every number finite and
// every unit positive (a conversion of a finite input may overflow or underflow). Shared by
// the seeded fuzzing of test_fuzz_inputs and the libFuzzer target fuzz/fuzz_scenes.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "fluid/config/scene_config.hpp"
#include "protocol/units.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::test {

/// A field of an accepted scene that is not a finite number (a conversion that overflowed),
/// or a unit that is not positive; "" if none.
inline std::string non_finite(const cosim::fluid::FluidScene& s) {
  const auto bad = [](double v) { return !std::isfinite(v); };
  if (bad(s.params.tau) || !(s.params.tau > 0.5)) return "tau (or it is not above 1/2)";
  if (!(s.dx_um * 1e-6 > 0.0) || bad(s.dx_um)) return "dx_um";
  for (const double f : s.params.body_force)
    if (bad(f)) return "body_force";
  for (const auto& f : s.params.faces) {
    if (bad(f.inlet_speed) || bad(f.boundary_layer) || bad(f.inlet_density) || bad(f.outflow_density))
      return "an inlet or outflow setting";
    for (const double u : f.wall_velocity)
      if (bad(u)) return "wall_velocity";
  }
  if (s.reynolds && bad(*s.reynolds)) return "the Reynolds number";
  if (bad(s.reference_length_um) || bad(s.reference_speed) || bad(s.mach_limit)) return "a reference value";
  for (const double y : s.planes_y)
    if (bad(y)) return "planes_y";
  cosim::protocol::UnitInputs in;
  in.dx_m = s.dx_um * 1e-6;
  try {
    const cosim::protocol::UnitConverter u(in);
    if (!(u.dt_lb_s() > 0.0) || bad(u.dt_lb_s())) return "dt_LB";
  } catch (const std::invalid_argument& e) {
    return std::string("unit (") + e.what() + ")";
  }
  return "";
}

inline std::string non_finite(const cosim::solid::SolidScene& s) {
  const auto bad = [](double v) { return !std::isfinite(v); };
  for (const auto& sh : s.config.sheets)
    if (bad(sh.width_spacing_bohr) || bad(sh.height_spacing_bohr) || bad(sh.cgp_mass_me) ||
        bad(sh.theta_deg) || !sh.base_bohr.allFinite())
      return "a sheet";
  if (bad(s.config.contact.epsilon_eV) || bad(s.config.contact.cutoff_bohr)) return "contact";
  if (bad(s.config.rcgp.bending_poisson)) return "bending_poisson";
  if (bad(s.dt_s) || !(s.dt_s > 0.0)) return "dt_s";
  if (bad(s.tip_displacement_bohr)) return "tip_displacement";
  if (bad(s.pressure_Pa) || bad(s.damping_ratio)) return "load";
  if (bad(s.dx_m) || !(s.dx_m > 0.0)) return "dx_m";
  if (s.coupled()) {
    try {
      const cosim::protocol::UnitConverter u(s.unit_inputs());
      if (!(u.dt_cg_s() > 0.0) || bad(u.dt_lb_s())) return "dt_CG";
    } catch (const std::invalid_argument& e) {
      return std::string("unit (") + e.what() + ")";
    }
  }
  return "";
}

}  // namespace cosim::test
