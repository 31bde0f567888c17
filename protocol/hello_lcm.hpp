// hello_t (protocol/lcm/hello_t.lcm) <-> protocol::Hello (handshake.hpp): the one place the
// announcement crosses between the wire type and the transport-free handshake check.
// Header-only; link the target cosim_lcm_types.
#pragma once

#include "cosimlcm/hello_t.hpp"
#include "protocol/handshake.hpp"

namespace cosim::protocol {

inline Hello from_lcm(const cosimlcm::hello_t& m) {
  Hello h;
  h.token = m.token;
  h.role = m.role;
  h.model = m.model;
  h.version = m.version;
  h.scene_hash = m.scene_hash;
  h.scheme = m.scheme;
  h.dx_m = m.dx_m;
  h.dt_lb_s = m.dt_lb_s;
  h.sound_speed_m_s = m.sound_speed_m_s;
  h.air_density_kg_m3 = m.air_density_kg_m3;
  h.time_ratio = m.time_ratio;
  h.dt_cg_s = m.dt_cg_s;
  h.stable_dt_cg_s = m.stable_dt_cg_s;
  h.num_cgps = m.num_cgps;
  h.light_cgp_mass_kg = m.light_cgp_mass_kg;
  h.light_cgp_area_m2 = m.light_cgp_area_m2;
  return h;
}

inline cosimlcm::hello_t to_lcm(const Hello& h) {
  cosimlcm::hello_t m{};
  m.token = h.token;
  m.role = h.role;
  m.model = h.model;
  m.version = h.version;
  m.scene_hash = h.scene_hash;
  m.scheme = h.scheme;
  m.dx_m = h.dx_m;
  m.dt_lb_s = h.dt_lb_s;
  m.sound_speed_m_s = h.sound_speed_m_s;
  m.air_density_kg_m3 = h.air_density_kg_m3;
  m.time_ratio = h.time_ratio;
  m.dt_cg_s = h.dt_cg_s;
  m.stable_dt_cg_s = h.stable_dt_cg_s;
  m.num_cgps = h.num_cgps;
  m.light_cgp_mass_kg = h.light_cgp_mass_kg;
  m.light_cgp_area_m2 = h.light_cgp_area_m2;
  return m;
}

}  // namespace cosim::protocol
