// `fluid SCENE --print KEYS`: the values the fluid resolved from a scene (defaults applied,
// TOML read by the one parser), for the launcher, which never parses TOML itself.
#pragma once

#include <string>

#include "fluid/config/scene_config.hpp"

namespace cosim::fluid {

/// One "KEY=VALUE" line per key of the comma-separated `keys`, in their order. Keys:
/// coupling.lcm_url, coupling.handshake_timeout_s, coupling.peer_timeout_s,
/// coupling.time_ratio, coupling.channel_prefix, output.directory, run.steps, run.precision,
/// run.propagation.
/// @throws SceneError naming the key and the allowed ones, or a coupling key of a scene
///         without [coupling]
std::string scene_values(const FluidScene& scene, const std::string& keys);

}  // namespace cosim::fluid
