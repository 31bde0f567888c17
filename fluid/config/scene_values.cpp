#include "fluid/config/scene_values.hpp"

#include <functional>
#include <map>
#include <sstream>

#include "protocol/config/scene_reader.hpp"

namespace cosim::fluid {

std::string scene_values(const FluidScene& s, const std::string& keys) {
  using protocol::config::format_double;
  const auto coupling = [&](const std::string& key) -> const CouplingSettings& {
    if (!s.coupling)
      throw SceneError(s.path + ": --print " + key + ": the scene has no [coupling] (a fluid-only scene)");
    return *s.coupling;
  };
  const std::map<std::string, std::function<std::string(const std::string&)>> values = {
      {"coupling.lcm_url", [&](const std::string& k) { return coupling(k).lcm_url; }},
      {"coupling.handshake_timeout_s", [&](const std::string& k) { return format_double(coupling(k).handshake_timeout_s); }},
      {"coupling.peer_timeout_s", [&](const std::string& k) { return format_double(coupling(k).peer_timeout_s); }},
      {"coupling.time_ratio", [&](const std::string& k) { return std::to_string(coupling(k).time_ratio); }},
      {"coupling.channel_prefix", [&](const std::string& k) { return coupling(k).channel_prefix; }},
      {"output.directory", [&](const std::string&) { return s.output_dir; }},
      {"run.steps", [&](const std::string&) { return std::to_string(s.steps); }},
      {"run.precision", [&](const std::string&) { return std::string(precision_name(s.params.precision)); }},
      {"run.propagation", [&](const std::string&) { return std::string(propagation_name(s.params.propagation)); }},
  };
  std::string out, key;
  std::istringstream list(keys);
  while (std::getline(list, key, ',')) {
    const auto at = values.find(key);
    if (at == values.end()) {
      std::string allowed;
      for (const auto& [name, value] : values) allowed += (allowed.empty() ? "" : ", ") + name;
      throw SceneError("--print " + key + ": not a key the fluid prints (allowed: " + allowed + ")");
    }
    out += key + "=" + at->second(key) + "\n";
  }
  if (out.empty()) throw SceneError("--print \"" + keys + "\": no key (allowed: a comma-separated list)");
  return out;
}

}  // namespace cosim::fluid
