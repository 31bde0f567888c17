// Scene files (TOML) of a fluid-only run: parsed and validated here into plain typed
// structs, so that the solver never sees a TOML table (STYLE: configuration apart from
// physics). The schema is documented in scenes/README.md and at load_scene below.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid/ib/held_body.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "protocol/units.hpp"
#include "protocol/config/coupling_settings.hpp"
#include "protocol/config/reaction_settings.hpp"
#include "common/watchdog/watchdog.hpp"

namespace cosim::fluid {

/// A scene file, or a command-line override of one, that cannot be run. what() is one
/// line: "FILE[:LINE]: KEY = VALUE: what is wrong and what is allowed".
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How the interior is initialised before step 0 (rho = 1 everywhere).
enum class InitialFlow {
  Rest,   ///< u = 0
  Inlet,  ///< the inlet profile of the (first) inlet face, extended through the domain
};

/// Limits that the validation enforces; the reasons are in scene_config.cpp.
struct SceneLimits {
  static constexpr double tau_min = 0.5;      ///< exclusive
  static constexpr double tau_max = 2.0;      ///< inclusive
  static constexpr double mach_limit_max = 0.5;
  static constexpr double default_mach_limit = 0.3;
  static constexpr int grid_min = 8;
  static constexpr int grid_max = 65536;
  static constexpr int threads_max = 1024;
  /// run.duration_us converted: at most 1e12 LB steps (more is a typo of the unit).
  static constexpr double steps_max = 1e12;
  static constexpr double paper_dx_um = 0.2561;  ///< Table 1
  // Lengths in micrometres (dx_um, reference_length_um) lie within
  // protocol::config::Table::length_min_um and length_max_um, as in every scene.
};

/// [coupling] of a coupled scene: the one struct both processes read
/// (protocol/config/coupling_settings.hpp).
using CouplingSettings = protocol::config::CouplingSettings;

/// [fluid] density_kg_m3 and sound_speed_m_s: the medium of a scene in another fluid than
/// the paper's air (Table 1), e.g. Turek and Hron's benchmark (1000 kg/m^3); shared with the
/// solid of a coupled scene (protocol/units.hpp Medium).
using FluidMedium = protocol::Medium;

/// [held_body] (fluid/ib/held_body.hpp): a rigid body the fluid holds at rest itself.
struct HeldBodySettings {
  HeldBodyShape shape;               ///< lattice units
  std::int64_t record_every = 10;    ///< a row of held_body.csv every N steps (the mean force over them)
};

/// A validated fluid-only scene: the solver's parameters plus what the run needs.
struct FluidScene {
  std::string path;         ///< the file it came from
  std::string name;         ///< [scene] name, default: the file name without .toml
  std::string description;  ///< [scene] description

  FluidParams params;  ///< shape, tau, faces, body force (lattice units)
  double dx_um = SceneLimits::paper_dx_um;  ///< physical cell size

  /// Reynolds number U L / nu when a reference length (and a reference speed: the inlet
  /// u_max, else the fastest wall) is given; else empty.
  std::optional<double> reynolds;
  double reference_length_um = 0.0;  ///< 0 if not given
  double reference_speed = 0.0;      ///< lattice units (U / c); 0 if the flow has none

  /// The medium when not the paper's air (unit_inputs).
  std::optional<FluidMedium> medium;
  /// inlet.ramp_us in LB steps: the inlet's velocity times inlet_ramp(step, T) (Turek and
  /// Hron's start-up); 0: none.
  double inlet_ramp_steps = 0.0;
  std::optional<HeldBodySettings> held_body;

  InitialFlow initial = InitialFlow::Rest;
  std::int64_t steps = 0;
  /// The keys given in physical units and what they became in lattice units, one line each
  /// ("run.duration_us = 30 us -> run.steps = ..."), for the header at start-up.
  std::vector<std::string> unit_conversions;
  std::int64_t monitor_every = 100;
  std::int64_t fields_every = 0;  ///< 0: no field output
  /// Snapshots of rho, u and vorticity on y planes (the paper's Figs. 9, 12): every
  /// planes_every steps (0: none), at heights planes_y (fractions of ny; the nearest cell).
  std::int64_t planes_every = 0;
  std::vector<double> planes_y;
  std::string output_dir;         ///< relative paths are relative to the working directory
  double mach_limit = SceneLimits::default_mach_limit;
  int threads = 0;  ///< 0: OpenMP's default (OMP_NUM_THREADS or all cores)
  /// [run] blocks: the blocks of an MPI run along x, y, z (fluid/domain/decomposition.hpp); empty:
  /// chosen from the number of ranks. A run of one process takes the grid whole.
  std::optional<std::array<int, 3>> blocks;
  /// Present in a coupled scene: the fluid then runs with a solid process over LCM.
  std::optional<CouplingSettings> coupling;
  /// [watchdog] (common/watchdog/watchdog.hpp; defaults when absent): a fluid-only run uses
  /// health_every and the density bounds, a coupled run every sentinel.
  protocol::WatchdogSettings watchdog;
  /// The solid's [reaction] law (the solid applies it; the coordinator's audit of the
  /// solid's impulses reads them by it: fluid/watchdog/solid_audit.hpp).
  protocol::config::ReactionLaw reaction_law = protocol::config::ReactionLaw::MomentumExchange;
};

/// Reads and validates a scene file. Unknown keys or sections, wrong types, values out of
/// range, a missing required key, inconsistent boundaries, TOML syntax errors and a missing
/// file all throw SceneError; nothing else escapes.
FluidScene load_scene(const std::string& path);

/// Command-line overrides of the [run] and [output] settings; each is validated with the
/// same rules as in the file and reported as "command line: --steps = 0: ...".
struct SceneOverrides {
  std::optional<std::int64_t> steps, monitor_every, fields_every;
  /// [coupling] time_ratio of a coupled scene (the launcher's retry with a larger A_T).
  std::optional<std::int64_t> time_ratio;
  /// [coupling] lcm_url (--lcm-url): the rule of protocol/lcm_url.hpp, checked with any
  /// scene; a fluid-only scene does not use it.
  std::optional<std::string> lcm_url;
  std::optional<std::string> output_dir;
  std::optional<int> threads;
};
void apply_overrides(FluidScene& scene, const SceneOverrides& overrides);

/// The scene's lattice units: dx from [grid], the medium's density and sound speed (the
/// paper's air unless [fluid] gives them) and, in a coupled scene, [coupling] time_ratio:
/// protocol::scene_unit_inputs, the rule the solid applies too.
protocol::UnitInputs unit_inputs(const FluidScene& scene);

/// Initial state of a scene's run: rho = 1 with u = 0 (run.initial = "rest"), or the inlet
/// profile of the first inlet face extended through the domain ("inlet").
void initialize_flow(FluidSolver& solver, const FluidScene& scene);

/// Bytes of the population grids (19 values per cell, with ghosts and padding): two, one for
/// the in-place propagation.
std::size_t population_bytes(const GridShape& shape, Precision precision = Precision::Double,
                             Propagation propagation = Propagation::InPlace);

/// Fastest boundary speed in lattice units: the inlet u_max, else the fastest wall.
double reference_speed(const FluidParams& params);

}  // namespace cosim::fluid
