// The sections both processes read with the same rules (protocol/config/scene_sections.hpp):
// [scene], [output] directory, [fluid]'s medium, [coupling] (a coupled scene) and [watchdog]
// (common/watchdog/watchdog.hpp). One parser each, for the fluid and the solid alike.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/config/coupling_settings.hpp"
#include "protocol/config/scene_reader.hpp"
#include "protocol/units.hpp"
#include "common/watchdog/watchdog.hpp"

namespace cosim::protocol::config {

/// [scene] name (default: the file name without .toml; it names the output directory) and
/// description (on one line; default "").
void read_scene_header(const SceneReader& scene, std::string& name, std::string& description);

/// [output] directory; default "out/" + the scene's name.
std::string read_output_directory(const SceneReader& scene, const std::string& scene_name);

/// [fluid] density_kg_m3 and sound_speed_m_s, both or neither: the medium when not the
/// paper's air (protocol::scene_unit_inputs). Read alike by the fluid and the solid, so
/// that both derive the same units (the handshake compares them).
std::optional<Medium> read_medium(const SceneReader& scene);

/// The keys of [coupling], in the order of scenes/README.md.
const std::vector<std::string_view>& coupling_keys();
/// The keys of [watchdog] (protocol::watchdog_keys()).
std::vector<std::string_view> watchdog_key_names();

/// [coupling] with its defaults for what the file leaves out. @pre scene.coupled()
CouplingSettings read_coupling(const SceneReader& scene);

/// [watchdog] with its defaults; all defaults when the section is absent.
WatchdogSettings read_watchdog(const SceneReader& scene);

}  // namespace cosim::protocol::config
