// The stability watchdog of a coupled run (DESIGN 6; docs/stability.md): its settings (the
// scene's [watchdog] section, read and validated by both servers with the same table), a
// tripped sentinel's diagnosis, and the added-mass check of the handshake. The sentinels
// themselves are fluid/watchdog/marker_watch.hpp (the coordinator's, every LB step) and
// solid/watchdog/energy_watch.hpp (the solid's). Transport-free.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cosim::protocol {

/// [watchdog] of a scene. The defaults leave wide margins on healthy runs: docs/stability.md
/// gives the extremes each sentinel saw on the matrix's stable cases, the paper's 30 deg
/// scene among them (e.g. CGP speed 0.067 c against 0.5, energy 0.008 against 10).
struct WatchdogSettings {
  /// Fluid: the whole-grid health check (NaN, rho bounds, Mach above run.mach_limit) of every
  /// this many LB steps' state, from the extrema the next step's kernel gathers as it reads
  /// it (no pass over memory unless they break a limit: fluid/observables/flow_monitor.hpp,
  /// kernel_state_problem), besides the full check before every write. The coordinator times
  /// its watchdog (the fluid's "watchdog: ... % of the compute").
  std::int64_t health_every = 10;
  /// Fluid: density bounds, lattice units (rho_0 = 1), at the markers every step and on the
  /// whole grid every health_every steps. Mach 0.3 changes the density by about 5 %.
  double rho_min = 0.5;
  double rho_max = 1.5;
  /// Both: the largest CGP speed, in units of c = dx / dt_LB: a CGP's mean position may move
  /// at most this many dx per LB step (the coordinator), and at most this / A_T dx in one
  /// substep (the solid). 0.5 c is Mach 0.87, beyond any flow a scene may ask for
  /// (run.mach_limit <= 0.5, i.e. 0.29 c).
  double max_cgp_speed = 0.5;
  /// Coordinator: the distance of each marker to its nearest neighbour of the first state,
  /// over that first distance, must stay within [spacing_ratio_min, spacing_ratio_max].
  double spacing_ratio_min = 0.25;
  double spacing_ratio_max = 2.0;
  /// Solid: the energy of the sheets that the fluid's work does not explain (E - E_0 - W),
  /// at most this many times the energy scale so far (the largest energy reached plus the
  /// work exchanged in either direction).
  double energy_growth = 10.0;
  /// Coordinator, at the handshake: warn when the fluid's reaction relaxes the lightest CGP's
  /// velocity in fewer substeps than this (T = m / (2 rho_air dA c), Eqs. 18-20).
  double relaxation_substeps_min = 1.0;
  /// The launcher: after a sentinel that a smaller dt_CG may cure (cgp_speed, energy_growth,
  /// or a dt_CG above the solid's stable step at the handshake), run again from the newest
  /// checkpoint before the tripped step with A_T times retry_factor, at most retry_max times.
  bool retry = false;
  int retry_max = 2;
  int retry_factor = 2;
};

/// How a [watchdog] key is written in the file.
enum class WatchdogKeyType { Integer, Number, Boolean };

/// The allowed keys of [watchdog] with their types, in the order of scenes/README.md.
const std::vector<std::pair<const char*, WatchdogKeyType>>& watchdog_keys();

/// Sets `key` of `settings` to `value` (a Boolean as 0 or 1). Returns "" when the value is
/// allowed, else what is allowed ("must be a number in (0, 1): ..."), leaving settings
/// unchanged. An unknown key returns the list of allowed keys.
std::string set_watchdog_value(WatchdogSettings& settings, std::string_view key, double value);

/// The checks across keys (rho_min < 1 < rho_max, spacing_ratio_min < 1 < spacing_ratio_max),
/// "" when consistent, else one line naming both keys and values.
std::string watchdog_consistency_problem(const WatchdogSettings& settings);

/// A tripped sentinel.
struct Trip {
  std::string sentinel;  ///< "cgp_speed", "marker_spacing", "marker_density", "marker_mach", "energy_growth", "flow_health", "non_finite"
  std::int64_t step = 0;  ///< the LB step of the state that tripped it
  /// One line: "watchdog SENTINEL at step N: PLACE: VALUES, limit L; WHAT TO DO".
  std::string diagnosis;
  /// The diagnosis without its advice (what the sentinel measured), for a caller that knows
  /// the cause better (fluid/watchdog/solid_audit.hpp); empty when the diagnosis gives none.
  std::string measurement;
  bool dt_cure = false;  ///< a smaller dt_CG (a larger A_T) may cure it
};

/// The sentinels whose trip a smaller dt_CG may cure, as they appear in a diagnosis
/// ("watchdog cgp_speed", "watchdog energy_growth"): the coordinator reads a solid's stop_t
/// reason with it.
bool dt_curable(std::string_view diagnosis);

/// The added-mass numbers of the lightest CGP (the smallest m / dA), Eqs. 18-20: the
/// momentum-exchange force 2 rho (U_B - u) dA relaxes the CGP's velocity towards the fluid's
/// in T = m / (2 rho_air dA c), which is mass_ratio / 2 LB steps with
/// mass_ratio = m / (rho_air dA dx), the CGP's mass over the fluid's in its marker volume.
struct AddedMass {
  double mass_ratio = 0.0;
  double relaxation_lb_steps = 0.0;  ///< T / dt_LB
  double relaxation_substeps = 0.0;  ///< T / dt_CG
};

/// @pre every argument positive and finite
AddedMass added_mass(double cgp_mass_kg, double cgp_area_m2, double air_density_kg_m3,
                     double dx_m, int time_ratio);

/// The start-up warning (one line, without the logger's "fluid: warning: "), or "" when T is at least
/// relaxation_substeps_min substeps. Explicit substeps overshoot for T < 1 substep and
/// diverge for T < 1/2 (the drag, integrated with the force held over the substep, is
/// explicit Euler: v <- v - dt/T (v - u)); the line names the ratio, its threshold and the
/// smallest A_T that meets the setting.
std::string added_mass_warning(const AddedMass& a, double relaxation_substeps_min, int time_ratio);

}  // namespace cosim::protocol
