// Scene files (TOML) of the solid server: run on its own (standalone mode: no fluid, for
// validation), or coupled to the fluid over LCM (a scene with a [coupling] section, read by
// both processes; protocol/README.md). Parsed and validated here into plain typed structs,
// so that models never see a TOML table (STYLE: configuration apart from physics). The
// schema is documented in scenes/README.md ("Solid scenes", "Coupled scenes") and at
// load_solid_scene below.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>
#include <string_view>

#include "protocol/units.hpp"
#include "protocol/config/coupling_settings.hpp"
#include "protocol/config/reaction_settings.hpp"
#include "common/watchdog/watchdog.hpp"
#include "solid/model/solid_config.hpp"

namespace cosim::solid {

/// A solid scene file, or a command-line override of one, that cannot be run. what() is
/// one line: "FILE[:LINE]: KEY = VALUE: what is wrong and what is allowed".
class SolidSceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The shape of a held deflection ([perturbation] shape; solid/coupled/initial_deflection.hpp).
enum class DeflectionShape {
  Cantilever,   ///< a uniformly loaded cantilever's, tip_displacement_um at the top row
  Translation,  ///< every CGP moved by tip_displacement_um (a plate on a spring)
};

/// What a standalone run does.
enum class SolidRunMode {
  /// Free vibration in vacuum from the initial perturbation ([perturbation]).
  Free,
  /// Dynamic relaxation under a uniform normal pressure ([load]) towards the static
  /// deflection.
  Static,
};

/// Limits that the validation enforces; the reasons are in solid_scene.cpp (the models'
/// options: beside the models, e.g. solid/models/elastic_sheet/elastic_sheet_options.cpp).
struct SolidSceneLimits {
  static constexpr int cgps_per_axis_max = 65536;
  /// A CGP lumps at most this many carbon atoms (a larger count is a typo; its mass would
  /// overflow the models' arithmetic).
  static constexpr double atoms_per_cgp_max = 1e15;
  // Lengths in micrometres (dx_um, spacing_um, cutoff_um, base_um, tip_displacement_um):
  // magnitudes within protocol::config::Table::length_min_um and length_max_um, as in every
  // scene, so that every conversion to bohr and to the lattice stays a positive finite number.
};

/// [coupling] of a coupled scene: the one struct both processes read
/// (protocol/config/coupling_settings.hpp).
using CouplingSettings = protocol::config::CouplingSettings;

/// A validated solid scene, standalone or coupled. Every quantity a model sees is in Hartree atomic
/// units (inside `config`); the run settings keep the SI units of the file.
struct SolidScene {
  std::string path;         ///< the file it came from
  std::string name;         ///< [scene] name, default: the file name without .toml
  std::string description;  ///< [scene] description

  std::string model = "rcgp";  ///< [solid] model, a name of the registry
  SolidConfig config;          ///< sheets, RCGP and contact options

  SolidRunMode mode = SolidRunMode::Free;
  std::int64_t substeps = 0;
  double dt_s = 0.0;  ///< substep, seconds (default dt_CG of the paper, Eq. 16)
  bool dt_is_default = true;
  std::int64_t record_every = 100;

  /// [perturbation] (mode Free; optional in a coupled scene, and in mode Free under [solid]
  /// gravity_m_s2: 0 without it, the flat sheet released at rest): normal displacement of
  /// the top row at step 0, bohr (solid/coupled/initial_deflection.hpp).
  double tip_displacement_bohr = 0.0;
  /// [perturbation] shape: how the rows below the top one are displaced.
  DeflectionShape deflection_shape = DeflectionShape::Cantilever;
  /// [load] (mode Static): uniform normal pressure (Pa) and the damping ratio zeta of the
  /// dynamic relaxation (damping force -2 zeta omega_1 m v).
  double pressure_Pa = 0.0;
  double damping_ratio = 1.0;

  std::string output_dir;  ///< relative paths are relative to the working directory
  /// [output] sheets_every: snapshots of the CGPs with their area strain (the paper's
  /// section 3.2 and Fig. 11; solid/io/sheet_snapshots.hpp) every N LB steps of a coupled run,
  /// substeps of a standalone one, and at the first and the last; 0: none.
  std::int64_t sheets_every = 0;

  /// [coupling]: set iff the file has that section (a coupled scene). Then mode, substeps,
  /// record_every, pressure_Pa and damping_ratio are unused (the
  /// scene's [run] is the fluid's) and dt_s is dt_CG = dt_LB / A_T.
  std::optional<CouplingSettings> coupling;
  /// [grid] dx_um (coupled scenes): dx_LB = dx_CG, metres.
  double dx_m = 0.2561e-6;
  /// [fluid] density_kg_m3 and sound_speed_m_s (coupled scenes): the medium when not the
  /// paper's air, read as the fluid reads it (protocol/config/shared_sections.hpp).
  std::optional<protocol::Medium> medium;
  /// [watchdog] (coupled scenes; common/watchdog/watchdog.hpp): the solid uses max_cgp_speed (per
  /// substep) and energy_growth; every key is validated.
  protocol::WatchdogSettings watchdog;
  /// [reaction] law (coupled scenes): the fluid's force on the CGPs (solid/coupling/reaction_law.hpp).
  protocol::config::ReactionLaw reaction_law = protocol::config::ReactionLaw::MomentumExchange;

  bool coupled() const { return coupling.has_value(); }
  /// The unit inputs both servers announce in hello_t: dx from [grid] dx_um, A_T from
  /// [coupling] time_ratio, the medium of [fluid] (the air of Table 1 when absent): the
  /// fluid's rule (protocol::scene_unit_inputs). @pre coupled()
  protocol::UnitInputs unit_inputs() const;
};

/// Reads and validates a solid scene file. Unknown keys or sections, wrong types, values
/// out of range, a missing required key, an unknown model name, an option the chosen model
/// does not read (solid/model/model_registry.hpp), TOML syntax errors and a missing file all throw
/// SolidSceneError; nothing else escapes.
///
/// A scene with a [coupling] section is coupled: the solid reads [scene], [solid],
/// [[sheet]], [contact], [output] directory and sheets_every, [grid] dx_um, [fluid]
/// density_kg_m3 and sound_speed_m_s, [coupling] and [watchdog] (which process owns which section: protocol/config/scene_sections.cpp);
/// the fluid's sections and keys ([grid] nx/ny/nz, [fluid]'s others, [inlet], [boundaries], [wall_velocity],
/// [body_force], [run], [output] fields_every, planes_every, planes_y) are left to the
/// fluid, unread; [perturbation] is optional (the sheets start deflected and at rest, held
/// through the rigid steps, then released); [load] belongs to standalone runs and is refused.
SolidScene load_solid_scene(const std::string& path);

/// The sections of the scene at `path` that only the solid server's models read ([solid],
/// [contact], [material], [perturbation] and the models' own option sections), in that
/// order, as "[name]": what a solid from outside (the solid library) leaves unread.
/// @pre load_solid_scene(path) succeeded
std::vector<std::string> model_sections_present(const std::string& path);

/// Command-line overrides of [run] substeps (standalone), [output] directory, and
/// [coupling] channel_prefix, lcm_url and time_ratio (coupled); validated with the rules of the file and
/// reported as "command line: --substeps = 0: ...". An override for the other kind of
/// scene is refused the same way.
struct SolidSceneOverrides {
  std::optional<std::int64_t> substeps;
  std::optional<std::string> output_dir;
  std::optional<std::string> channel_prefix;
  std::optional<std::string> lcm_url;
  /// [coupling] time_ratio (coupled): the launcher's retry with a larger A_T.
  std::optional<std::int64_t> time_ratio;
};
void apply_overrides(SolidScene& scene, const SolidSceneOverrides& overrides);

/// The normal deflection of a uniformly loaded cantilever, normalised to 1 at the free end:
/// w(s) = (6 s^2 - 4 s^3 + s^4) / 3, s = height above the clamp over the free length.
double cantilever_load_shape(double s);

}  // namespace cosim::solid
