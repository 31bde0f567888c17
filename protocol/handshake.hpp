// The coordinator's handshake (DESIGN 2.2): both servers announce who they are, the scene
// they read, the units they use and the run's token; the coordinator refuses to start on
// any mismatch, with one line that names it. Transport-free: the LCM layer converts its
// HELLO messages to and from `Hello`.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace cosim::protocol {

/// The protocol version both servers announce in hello_t.version (protocol/README.md, whose
/// title names it). "3": stop_t names its sender, hello_t and welcome_t the coupling scheme.
/// ("2": solid_state_t and fluid_state_t gained `iteration`, fluid_state_t `rho_start_lb` and
/// `velocity_start_lb`.) A peer of another version is refused at the handshake, naming both.
inline constexpr const char* kProtocolVersion = "3";

/// What one server announces before the first step.
///
/// Both sides fill the identity fields and the four unit fields. The time-stepping fields
/// (`time_ratio`, `dt_cg_s`, `stable_dt_cg_s`, `num_cgps`) are the solid's: the
/// coordinator reads them from the solid's Hello only (the fluid may leave them zero).
struct Hello {
  std::string token;       ///< the run's token (new_run_token()), the same on both sides
  std::string role;        ///< "fluid" or "solid"
  std::string model;       ///< e.g. "d3q19-bgk-guo", "rcgp" (reported, not compared)
  std::string version;     ///< protocol version; both sides must agree exactly
  std::string scene_hash;  ///< scene_hash_of_file() of the scene file both read
  /// The coupling scheme the sender runs ("serial", "implicit", "parallel"; empty: "serial").
  std::string scheme;
  double dx_m = 0.0;                 ///< dx_LB = dx_CG
  double dt_lb_s = 0.0;              ///< dt_LB = dx / c
  double sound_speed_m_s = 0.0;      ///< c_s of the air
  double air_density_kg_m3 = 0.0;    ///< rho_air = n_0 m_air
  int time_ratio = 0;                ///< A_T as the solid will run it (Eq. 16)
  double dt_cg_s = 0.0;              ///< the solid's substep
  double stable_dt_cg_s = 0.0;       ///< the solid model's stable substep (2 / omega_max)
  int num_cgps = 0;                  ///< CGPs (markers) the solid will exchange
  /// The CGP with the smallest mass per area: its mass and surface element dA (Eq. 19), for
  /// the added-mass check (common/watchdog/watchdog.hpp); 0 and 0: not reported.
  double light_cgp_mass_kg = 0.0;
  double light_cgp_area_m2 = 0.0;
};

/// The coordinator's verdict.
struct HandshakeResult {
  bool accepted = false;
  std::string reason;  ///< empty when accepted; otherwise one line naming the mismatch
  int time_ratio = 0;  ///< A_T = dt_LB / dt_CG when accepted, 0 otherwise
  /// Refused for a dt_CG above the solid's stable step (check 9): the smallest stable A_T,
  /// ceil(dt_LB / stable); 0 otherwise.
  int stable_time_ratio = 0;
};

/// Relative tolerance for the unit fields, and for A_T being a whole number.
inline constexpr double kUnitRelTolerance = 1e-12;
inline constexpr double kTimeRatioRelTolerance = 1e-9;

/// Decides whether a fluid and a solid may start a coupled run.
///
/// Checks, in this order, the first failure giving the reason (one line, naming the field
/// and both values):
///  1. roles: `fluid.role == "fluid"` and `solid.role == "solid"`;
///  2. tokens: each side's token equals `expected_token` (an empty run token is refused);
///  3. `version` equal on both sides;
///  4. `scene_hash` equal on both sides; then `scheme` (empty read as "serial");
///  5. every number positive and finite (the fluid's four unit fields; the solid's unit
///     fields, `dt_cg_s` and `stable_dt_cg_s`);
///  6. units: dx_m, dt_lb_s, sound_speed_m_s, air_density_kg_m3 agree within
///     kUnitRelTolerance relative;
///  7. A_T = fluid.dt_lb_s / solid.dt_cg_s is a whole number >= 1 within
///     kTimeRatioRelTolerance relative (dt_CG must divide dt_LB);
///  8. `solid.time_ratio == A_T`, and the fluid's own A_T (`fluid.time_ratio`, when it
///     announces one, > 0): a solid with a self-consistent A_T of its own is refused;
///  9. `solid.dt_cg_s <= solid.stable_dt_cg_s`; the refusal gives the largest stable
///     A_T-compatible dt_CG, dt_LB / ceil(dt_LB / stable), and its A_T;
/// 10. `solid.num_cgps >= 1`;
/// 11. `light_cgp_mass_kg` and `light_cgp_area_m2` finite, both 0 (not reported) or both > 0.
///
/// @pre  none: any field values are allowed (bad ones are refused, never thrown).
/// @post `accepted` == reason.empty(); if accepted, `time_ratio` = A_T >= 1, else 0.
HandshakeResult check_handshake(const Hello& fluid, const Hello& solid,
                                const std::string& expected_token);

/// FNV-1a, 64 bits, of a byte string.
/// @post fnv1a_64("") == 0xcbf29ce484222325 (the offset basis).
std::uint64_t fnv1a_64(std::string_view bytes);

/// The scene hash both servers announce: FNV-1a 64 of the file's bytes, 16 lowercase hex
/// digits.
/// @pre  `path` names a readable regular file.
/// @post the result has 16 characters in [0-9a-f].
/// @throws std::runtime_error naming the file (and the system's reason) if it cannot be read.
std::string scene_hash_of_file(const std::string& path);

/// A fresh per-run token: 64 bits from std::random_device, 16 lowercase hex digits. The
/// launcher draws one per run and hands it to both servers.
/// @post the result has 16 characters in [0-9a-f].
std::string new_run_token();

}  // namespace cosim::protocol
