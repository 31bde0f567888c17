#include "common/watchdog/watchdog.hpp"

#include <cmath>
#include <cstdio>
#include <string>

#include "common/text/text.hpp"

// Why the ranges of [watchdog] are what they are:
//  - health_every >= 1 LB step: the check reads the extrema the kernel gathered of the state
//    it streamed, a few comparisons; 1 checks every step at no measurable cost. The default 10
//    is that of the earlier whole-grid pass (which read the populations once more).
//  - 0 < rho_min < 1 < rho_max: rho_0 = 1 must be healthy; rho <= 0 is unphysical.
//  - max_cgp_speed in (0, 1]: the lattice carries no information faster than c = dx/dt_LB;
//    a sheet faster than that has left the immersed boundary's reach in one step.
//  - 0 < spacing_ratio_min < 1 < spacing_ratio_max: the first state is healthy.
//  - energy_growth > 0.
//  - relaxation_substeps_min >= 0 (0 turns the warning off).
//  - retry_max 1..10, retry_factor 2..16 (an integer: A_T stays a whole number).

namespace cosim::protocol {

namespace {

std::string number(double v) { return fmt("%.6g", v); }

}  // namespace

const std::vector<std::pair<const char*, WatchdogKeyType>>& watchdog_keys() {
  static const std::vector<std::pair<const char*, WatchdogKeyType>> keys = {
      {"health_every", WatchdogKeyType::Integer},
      {"rho_min", WatchdogKeyType::Number},
      {"rho_max", WatchdogKeyType::Number},
      {"max_cgp_speed", WatchdogKeyType::Number},
      {"spacing_ratio_min", WatchdogKeyType::Number},
      {"spacing_ratio_max", WatchdogKeyType::Number},
      {"energy_growth", WatchdogKeyType::Number},
      {"relaxation_substeps_min", WatchdogKeyType::Number},
      {"retry", WatchdogKeyType::Boolean},
      {"retry_max", WatchdogKeyType::Integer},
      {"retry_factor", WatchdogKeyType::Integer},
  };
  return keys;
}

std::string set_watchdog_value(WatchdogSettings& s, std::string_view key, double v) {
  if (!std::isfinite(v)) return "must be a finite number";
  if (key == "health_every") {
    if (v < 1.0) return "must be an integer >= 1 (LB steps between whole-grid health checks)";
    s.health_every = static_cast<std::int64_t>(v);
  } else if (key == "rho_min") {
    if (!(v > 0.0 && v < 1.0)) return "must be in (0, 1): the lowest healthy density, lattice units (rho_0 = 1)";
    s.rho_min = v;
  } else if (key == "rho_max") {
    if (!(v > 1.0)) return "must be > 1: the highest healthy density, lattice units (rho_0 = 1)";
    s.rho_max = v;
  } else if (key == "max_cgp_speed") {
    if (!(v > 0.0 && v <= 1.0))
      return "must be in (0, 1]: the largest CGP speed in units of c = dx / dt_LB (dx per LB step)";
    s.max_cgp_speed = v;
  } else if (key == "spacing_ratio_min") {
    if (!(v > 0.0 && v < 1.0))
      return "must be in (0, 1): the smallest marker distance over its first value";
    s.spacing_ratio_min = v;
  } else if (key == "spacing_ratio_max") {
    if (!(v > 1.0)) return "must be > 1: the largest marker distance over its first value";
    s.spacing_ratio_max = v;
  } else if (key == "energy_growth") {
    if (!(v > 0.0))
      return "must be > 0: the largest unexplained energy of the sheets over their energy scale";
    s.energy_growth = v;
  } else if (key == "relaxation_substeps_min") {
    if (!(v >= 0.0))
      return "must be >= 0: substeps within which the fluid's reaction may relax a CGP (0: no warning)";
    s.relaxation_substeps_min = v;
  } else if (key == "retry") {
    s.retry = v != 0.0;
  } else if (key == "retry_max") {
    if (v < 1.0 || v > 10.0) return "must be an integer from 1 to 10 (runs again after a trip)";
    s.retry_max = static_cast<int>(v);
  } else if (key == "retry_factor") {
    if (v < 2.0 || v > 16.0) return "must be an integer from 2 to 16 (A_T is multiplied by it at each retry)";
    s.retry_factor = static_cast<int>(v);
  } else {
    std::string allowed;
    for (const auto& [name, type] : watchdog_keys()) allowed += (allowed.empty() ? "" : ", ") + std::string(name);
    return "unknown key in [watchdog]; allowed: " + allowed;
  }
  return "";
}

std::string watchdog_consistency_problem(const WatchdogSettings& s) {
  if (!(s.rho_min < 1.0 && 1.0 < s.rho_max))
    return "watchdog.rho_min = " + number(s.rho_min) + ", watchdog.rho_max = " + number(s.rho_max) +
           ": the bounds must enclose rho_0 = 1";
  if (!(s.spacing_ratio_min < 1.0 && 1.0 < s.spacing_ratio_max))
    return "watchdog.spacing_ratio_min = " + number(s.spacing_ratio_min) +
           ", watchdog.spacing_ratio_max = " + number(s.spacing_ratio_max) + ": the bounds must enclose 1";
  return "";
}

bool dt_curable(std::string_view diagnosis) {
  return diagnosis.find("watchdog cgp_speed") != std::string_view::npos ||
         diagnosis.find("watchdog energy_growth") != std::string_view::npos;
}

AddedMass added_mass(double cgp_mass_kg, double cgp_area_m2, double air_density_kg_m3, double dx_m,
                     int time_ratio) {
  AddedMass a;
  // Eqs. 18-20: the CGP feels -2 rho (U_B - u) dA in lattice force units rho_0 c^2 dx^2, so
  // m dU/dt = -2 rho_air dA c (U - u) and T = m / (2 rho_air dA c); with c dt_LB = dx,
  // T / dt_LB = m / (2 rho_air dA dx).
  a.mass_ratio = cgp_mass_kg / (air_density_kg_m3 * cgp_area_m2 * dx_m);
  a.relaxation_lb_steps = 0.5 * a.mass_ratio;
  a.relaxation_substeps = a.relaxation_lb_steps * time_ratio;
  return a;
}

std::string added_mass_warning(const AddedMass& a, double relaxation_substeps_min, int time_ratio) {
  if (!(a.relaxation_substeps < relaxation_substeps_min)) return "";
  const double threshold = 2.0 * relaxation_substeps_min / time_ratio;
  const double needed = std::ceil(2.0 * relaxation_substeps_min / a.mass_ratio);
  return "added mass: the lightest CGP has m / (rho_air dA dx) = " + fmt("%.4g", a.mass_ratio) +
         ", below 2 x relaxation_substeps_min / A_T = " + fmt("%.4g", threshold) +
         ": the fluid's reaction (Eqs. 18-20) relaxes its velocity in T = m / (2 rho_air dA c) = " +
         fmt("%.3g", a.relaxation_substeps) + " substeps (" + fmt("%.3g", a.relaxation_lb_steps) +
         " LB steps); the explicit substeps overshoot below 1 substep and diverge below 0.5" +
         (a.relaxation_substeps < 0.5 ? " (expect the watchdog to stop this run)" : "") +
         ": raise coupling.time_ratio to at least " + fmt("%.0f", needed) +
         " or make the CGPs heavier ([[sheet]] atoms_per_cgp)";
}

}  // namespace cosim::protocol
