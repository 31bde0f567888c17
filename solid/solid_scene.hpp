// Scene files (TOML) of the solid server run on its own (standalone mode: no fluid, for
// validation). Parsed and validated here into plain typed structs, so that models never see
// a TOML table (STYLE: configuration apart from physics). The schema is documented in
// scenes/README.md ("Solid scenes") and at load_solid_scene below.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "solid/solid_config.hpp"

namespace cosim::solid {

/// A solid scene file, or a command-line override of one, that cannot be run. what() is
/// one line: "FILE[:LINE]: KEY = VALUE: what is wrong and what is allowed".
class SolidSceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a standalone run does.
enum class SolidRunMode {
  /// Free vibration in vacuum from the initial perturbation ([perturbation]).
  Free,
  /// Dynamic relaxation under a uniform normal pressure ([load]) towards the static
  /// deflection.
  Static,
};

/// Limits that the validation enforces; the reasons are in solid_scene.cpp.
struct SolidSceneLimits {
  static constexpr int stages_min = 1, stages_max = 16;
  static constexpr int cgps_per_axis_max = 65536;
  static constexpr double bending_poisson_max = 0.5;  ///< exclusive
};

/// A validated standalone solid scene. Every quantity a model sees is in Hartree atomic
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

  /// [perturbation] (mode Free): normal displacement of the top row, bohr.
  double tip_displacement_bohr = 0.0;
  /// [load] (mode Static): uniform normal pressure (Pa) and the damping ratio zeta of the
  /// dynamic relaxation (damping force -2 zeta omega_1 m v).
  double pressure_Pa = 0.0;
  double damping_ratio = 1.0;

  std::string output_dir;  ///< relative paths are relative to the working directory
};

/// Reads and validates a solid scene file. Unknown keys or sections, wrong types, values
/// out of range, a missing required key, an unknown model name, TOML syntax errors and a
/// missing file all throw SolidSceneError; nothing else escapes.
SolidScene load_solid_scene(const std::string& path);

/// Command-line overrides of [run] substeps and [output] directory; validated with the
/// rules of the file and reported as "command line: --substeps = 0: ...".
struct SolidSceneOverrides {
  std::optional<std::int64_t> substeps;
  std::optional<std::string> output_dir;
};
void apply_overrides(SolidScene& scene, const SolidSceneOverrides& overrides);

/// The normal deflection of a uniformly loaded cantilever, normalised to 1 at the free end:
/// w(s) = (6 s^2 - 4 s^3 + s^4) / 3, s = height above the clamp over the free length.
double cantilever_load_shape(double s);

}  // namespace cosim::solid
