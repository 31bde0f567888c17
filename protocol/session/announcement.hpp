// What a peer announces in its hello_t (protocol/README.md section 6), filled alike on both
// sides: identity, protocol version, the scene's hash, the coupling scheme and the units the
// peer derived (protocol/units.hpp). Each side adds its own fields (the solid's substep,
// stable step, CGP count and added-mass fields); the coordinator compares them
// (handshake.hpp).
#pragma once

#include <string>

#include "protocol/coupling_scheme.hpp"
#include "protocol/handshake.hpp"
#include "protocol/units.hpp"

namespace cosim::protocol {

/// @throws std::runtime_error naming the scene file if it cannot be read (its hash).
inline Hello announcement(const std::string& role, const std::string& token, const std::string& model,
                          const std::string& scene_path, CouplingScheme scheme, const UnitConverter& units,
                          int time_ratio) {
  Hello h;
  h.token = token;
  h.role = role;
  h.model = model;
  h.version = std::string(kProtocolVersion);  // GCC 12: a -Wrestrict false positive on assigning the char* (bug 105329)
  h.scene_hash = scene_hash_of_file(scene_path);
  h.scheme = scheme_name(scheme);
  h.dx_m = units.dx_m();
  h.dt_lb_s = units.dt_lb_s();
  h.sound_speed_m_s = units.inputs().sound_speed_m_s;
  h.air_density_kg_m3 = units.air_density_kg_m3();
  h.time_ratio = time_ratio;
  h.dt_cg_s = units.dt_cg_s();
  return h;
}

}  // namespace cosim::protocol
