// Valid messages of every type for the message tests (protocol/message_checks.hpp): the
// run's token and A_T, the expectation a receiver checks them against, and their bytes as
// LCM encodes them. Test support only.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/handshake.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/units.hpp"

namespace cosim::test::messages {

using cosim::protocol::Expectation;

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr const char* kToken = "0123456789abcdef";
inline constexpr int kTimeRatio = 150;

inline Expectation expect_state(std::int32_t n = 4) {
  Expectation e;
  e.token = kToken;
  e.num_cgps = n;
  e.lowest_step = 0;
  e.highest_step = 12;
  e.time_ratio = kTimeRatio;
  return e;
}

inline cosimlcm::solid_state_t valid_solid_state(std::int32_t n = 4) {
  cosimlcm::solid_state_t m{};
  m.token = kToken;
  m.seq = 3;
  m.step = 4;
  m.substeps = kTimeRatio;
  m.solid_time_s = 1.5e-9;
  m.num_cgps = n;
  for (std::int32_t l = 0; l < n; ++l) {
    m.position_lb.push_back({1.0 + l, 2.0, 3.0});
    m.impulse_lb.push_back({-1e-3, 0.0, 2e-4});
  }
  return m;
}

inline cosimlcm::fluid_state_t valid_fluid_state(std::int32_t n = 4) {
  cosimlcm::fluid_state_t m{};
  m.token = kToken;
  m.seq = 3;
  m.step = 4;
  m.bulk_velocity_lb = 0.01;
  m.num_cgps = n;
  m.rho_lb.assign(static_cast<std::size_t>(n), 1.001);
  m.velocity_lb.assign(static_cast<std::size_t>(n), std::vector<double>{0.01, 0.0, -1e-4});
  m.rho_start_lb = m.rho_lb;
  m.velocity_start_lb = m.velocity_lb;
  return m;
}

inline cosimlcm::hello_t valid_hello() {
  const cosim::protocol::UnitConverter u;
  cosimlcm::hello_t m{};
  m.token = kToken;
  m.role = "solid";
  m.model = "rcgp";
  m.version = cosim::protocol::kProtocolVersion;
  m.scene_hash = "0123456789abcdef";
  m.dx_m = u.dx_m();
  m.dt_lb_s = u.dt_lb_s();
  m.sound_speed_m_s = u.inputs().sound_speed_m_s;
  m.air_density_kg_m3 = u.air_density_kg_m3();
  m.time_ratio = kTimeRatio;
  m.dt_cg_s = u.dt_cg_s();
  m.stable_dt_cg_s = 1e-11;
  m.num_cgps = 4;
  return m;
}

inline cosimlcm::welcome_t valid_welcome() {
  cosimlcm::welcome_t m{};
  m.token = kToken;
  m.accepted = 1;
  m.total_steps = 200;
  m.rigid_steps = 50;
  m.time_ratio = kTimeRatio;
  return m;
}

inline cosimlcm::resend_t valid_resend() {
  cosimlcm::resend_t m{};
  m.token = kToken;
  m.step = 4;
  m.what = "fluid_state";
  return m;
}

inline cosimlcm::stop_t valid_stop() {
  cosimlcm::stop_t m{};
  m.token = kToken;
  m.sender = "fluid";
  m.step = 200;
  m.exit_code = 0;
  return m;
}

template <class M>
inline std::vector<std::uint8_t> encode(const M& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

inline void put_i32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) b[at + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(v >> (24 - 8 * k));
}

/// One malformed message: what to break, the category and a piece of the one-line reason.

}  // namespace cosim::test::messages
