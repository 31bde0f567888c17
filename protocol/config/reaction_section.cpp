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
  // The schemes that run one law only (the name table's any_reaction_law).
  const protocol::MessageOrder& order = protocol::message_order(coupling.scheme.scheme);
  if (law != ReactionLaw::MomentumExchange && !order.any_reaction_law) {
    std::string others;
    for (const protocol::MessageOrder& o : protocol::kMessageOrders)
      if (o.any_reaction_law) others += (others.empty() ? "" : " or ") + std::string(o.name);
    sec.bad("law", std::string("only \"momentum_exchange\" with coupling.scheme = \"") + order.name +
                       "\" (its backward-Euler drag is that law's); use the " + others + " scheme");
  }
  return law;
}

}  // namespace cosim::protocol::config
