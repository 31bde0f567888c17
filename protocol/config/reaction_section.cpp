#include "protocol/config/reaction_section.hpp"

#include <string>
#include <vector>

namespace cosim::protocol::config {

const std::vector<std::string_view>& reaction_keys() {
  static const std::vector<std::string_view> keys = {"law"};
  return keys;
}

ReactionLaw read_reaction_law(const SceneReader& scene, const CouplingSettings& coupling) {
  const Table sec = scene.section("reaction");
  std::vector<const char*> names;
  for (const std::string_view n : kReactionLawNames) names.push_back(n.data());
  const auto i = sec.choice("law", names);
  if (!i) return ReactionLaw::MomentumExchange;
  const auto law = static_cast<ReactionLaw>(*i);
  if (law != ReactionLaw::MomentumExchange && coupling.scheme.scheme == protocol::CouplingScheme::Implicit)
    sec.bad("law", "only \"momentum_exchange\" with coupling.scheme = \"implicit\" (its backward-Euler "
                   "drag is that law's); use the serial or parallel scheme");
  return law;
}

}  // namespace cosim::protocol::config
