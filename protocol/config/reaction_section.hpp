// [reaction] law of a coupled scene (protocol/config/reaction_settings.hpp): its own small
// parser, read by the solid (the fluid spreads whatever impulses the solid sends).
#pragma once

#include "protocol/config/coupling_settings.hpp"
#include "protocol/config/reaction_settings.hpp"
#include "protocol/config/scene_reader.hpp"

namespace cosim::protocol::config {

/// The keys of [reaction].
const std::vector<std::string_view>& reaction_keys();

/// [reaction] law; momentum_exchange when absent. A law other than the default with
/// coupling.scheme = "implicit" is refused (the implicit scheme's backward-Euler drag is
/// the momentum-exchange law's). @pre scene.coupled()
ReactionLaw read_reaction_law(const SceneReader& scene, const CouplingSettings& coupling);

}  // namespace cosim::protocol::config
