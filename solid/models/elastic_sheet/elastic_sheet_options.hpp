// The options of the elastic sheet models (rcgp, corotational; solid/models/elastic_sheet/elastic_sheet_model.hpp),
// parsed beside them from a scene with the shared reader (protocol/config/scene_reader.hpp):
// the RCGP keys of [solid] and the Lennard-Jones contact of [contact]. The model itself takes
// the typed structs of solid/model/solid_config.hpp and never sees the file.
#pragma once

#include "solid/model/model_registry.hpp"

namespace cosim::solid {

/// [solid] stages, flexural_scaling, truncation_range, moment_matching, bending_poisson,
/// cache_dir -> SolidConfig::rcgp.
extern const ModelOptions kRcgpOptions;

/// [contact] epsilon_eV, cutoff_um -> SolidConfig::contact (used with two or more sheets).
extern const ModelOptions kContactOptions;

/// [solid] gravity_m_s2 -> SolidConfig::body.
extern const ModelOptions kBodyForceOptions;

/// [material] youngs_modulus_Pa, poisson_ratio, density_kg_m3, thickness_m ->
/// SolidConfig::material (all four, or no section).
extern const ModelOptions kMaterialOptions;

/// The [solid] keys of kRcgpOptions (the RCGP construction's), which a scene with
/// [material] has no use for.
std::span<const std::string_view> rcgp_option_keys();

}  // namespace cosim::solid
