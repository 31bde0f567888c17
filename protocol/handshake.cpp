#include "protocol/handshake.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <memory>
#include <random>
#include <stdexcept>

#include "protocol/coupling_scheme.hpp"

namespace cosim::protocol {

namespace {

/// Shortest text that reads back to the same double ("2.561e-07", "150").
std::string num(double v) {
  std::array<char, 32> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

/// A few significant digits, for ratios and relative differences in messages.
std::string num3(double v) {
  std::array<char, 32> buf{};
  const auto res =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::general, 3);
  return std::string(buf.data(), res.ptr);
}

std::string hex16(std::uint64_t v) {
  static constexpr char digits[] = "0123456789abcdef";
  std::string s(16, '0');
  for (int i = 15; i >= 0; --i) {
    s[static_cast<std::size_t>(i)] = digits[v & 0xfU];
    v >>= 4U;
  }
  return s;
}

HandshakeResult refuse(const std::string& why) { return {false, "handshake refused: " + why, 0, 0}; }

constexpr std::uint64_t kFnvOffsetBasis = 0xcbf29ce484222325ULL;
constexpr std::uint64_t kFnvPrime = 0x100000001b3ULL;

std::uint64_t fnv1a_64_update(std::uint64_t h, const char* data, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= kFnvPrime;
  }
  return h;
}

bool positive_finite(double v) { return v > 0.0 && std::isfinite(v); }

double rel_diff(double a, double b) {
  const double scale = std::max(std::abs(a), std::abs(b));
  return scale > 0.0 ? std::abs(a - b) / scale : 0.0;
}

struct NamedValue {
  const char* name;
  double value;
};

}  // namespace

HandshakeResult check_handshake(const Hello& fluid, const Hello& solid,
                                const std::string& expected_token) {
  // 1. Roles.
  if (fluid.role != "fluid" || solid.role != "solid")
    return refuse("role mismatch: the fluid side announced role '" + fluid.role +
                  "' (expected 'fluid') and the solid side role '" + solid.role +
                  "' (expected 'solid')");

  // 2. The run's token, on both sides.
  if (expected_token.empty())
    return refuse("the run token is empty; the launcher must draw one (new_run_token())");
  for (const Hello* h : {&fluid, &solid})
    if (h->token != expected_token)
      return refuse("run token mismatch: the " + h->role + " sent token '" + h->token +
                    "', this run's token is '" + expected_token +
                    "' (a process of another run on the same bus?)");

  // 3. Protocol version.
  if (fluid.version != solid.version)
    return refuse("protocol version mismatch: the fluid speaks '" + fluid.version +
                  "', the solid '" + solid.version + "'");

  // 4. Scene.
  if (fluid.scene_hash != solid.scene_hash)
    return refuse("scene_hash mismatch: the fluid read a scene with hash '" + fluid.scene_hash +
                  "', the solid one with hash '" + solid.scene_hash +
                  "'; start both servers on the same scene file");
  // An empty name is the default scheme (SchemeSettings), by its name in the table.
  const auto scheme_of = [](const Hello& h) {
    return h.scheme.empty() ? std::string(scheme_name(SchemeSettings{}.scheme)) : h.scheme;
  };
  if (scheme_of(fluid) != scheme_of(solid))
    return refuse("coupling scheme mismatch: the fluid runs the '" + scheme_of(fluid) +
                  "' scheme ([coupling] scheme of the scene), the solid announced '" + scheme_of(solid) +
                  "'" + (solid.scheme.empty() ? " (hello_t.scheme empty, read as 'serial')" : std::string()) +
                  "; a solid must run the scene's scheme (protocol/README.md sections 13-14)");

  // 5. Numbers that must be positive and finite.
  const NamedValue fluid_numbers[] = {{"dx_m", fluid.dx_m},
                                      {"dt_lb_s", fluid.dt_lb_s},
                                      {"sound_speed_m_s", fluid.sound_speed_m_s},
                                      {"air_density_kg_m3", fluid.air_density_kg_m3}};
  const NamedValue solid_numbers[] = {{"dx_m", solid.dx_m},
                                      {"dt_lb_s", solid.dt_lb_s},
                                      {"sound_speed_m_s", solid.sound_speed_m_s},
                                      {"air_density_kg_m3", solid.air_density_kg_m3},
                                      {"dt_cg_s", solid.dt_cg_s},
                                      {"stable_dt_cg_s", solid.stable_dt_cg_s}};
  for (const auto& [name, value] : fluid_numbers)
    if (!positive_finite(value))
      return refuse(std::string("the fluid announced ") + name + " = " + num(value) +
                    "; it must be a positive finite number");
  for (const auto& [name, value] : solid_numbers)
    if (!positive_finite(value))
      return refuse(std::string("the solid announced ") + name + " = " + num(value) +
                    "; it must be a positive finite number");

  // 6. Units (both sides derive them from the same constants, protocol/units.hpp).
  for (std::size_t i = 0; i < std::size(fluid_numbers); ++i) {
    const double f = fluid_numbers[i].value;
    const double s = solid_numbers[i].value;
    if (rel_diff(f, s) > kUnitRelTolerance)
      return refuse(std::string("units differ: ") + fluid_numbers[i].name + " is " + num(f) +
                    " on the fluid side and " + num(s) +
                    " on the solid side (relative difference " +
                    num3(rel_diff(f, s)) + " > " + num(kUnitRelTolerance) + ")");
  }

  // 7. A_T = dt_LB / dt_CG, a whole number (Eq. 16).
  const double dt_lb = fluid.dt_lb_s;
  const double ratio = dt_lb / solid.dt_cg_s;
  if (!(ratio < static_cast<double>(INT_MAX)))
    return refuse("time-scale ratio A_T = dt_LB / dt_CG = " + num(ratio) + " (dt_LB = " +
                  num(dt_lb) + " s, dt_CG = " + num(solid.dt_cg_s) +
                  " s) is too large; dt_CG must divide dt_LB into at most " +
                  std::to_string(INT_MAX) + " substeps");
  const double whole = std::round(ratio);
  if (whole < 1.0 || std::abs(ratio - whole) > kTimeRatioRelTolerance * ratio)
    return refuse("time-scale ratio A_T = dt_LB / dt_CG = " + num(ratio) + " (dt_LB = " +
                  num(dt_lb) + " s, dt_CG = " + num(solid.dt_cg_s) +
                  " s) is not a whole number >= 1 within " + num(kTimeRatioRelTolerance) +
                  " relative: dt_CG must divide dt_LB");
  const int a_t = static_cast<int>(whole);

  // 8. The solid runs the same A_T.
  if (solid.time_ratio != a_t)
    return refuse("the solid's dt_cg_s = " + num(solid.dt_cg_s) + " s gives A_T = dt_LB / dt_CG = " +
                  std::to_string(a_t) + ", but it announced time_ratio = " + std::to_string(solid.time_ratio) +
                  "; dt_cg_s and time_ratio must agree (dt_cg_s = dt_LB / time_ratio)");
  if (fluid.time_ratio > 0 && solid.time_ratio != fluid.time_ratio)
    return refuse("time_ratio mismatch: the solid runs A_T = " + std::to_string(solid.time_ratio) + " (dt_CG = " +
                  num(solid.dt_cg_s) + " s), the fluid's scene A_T = " + std::to_string(fluid.time_ratio) +
                  " ([coupling] time_ratio, or --time-ratio); start both with the same A_T");

  // 9. Stability of the solid's integrator.
  if (solid.dt_cg_s > solid.stable_dt_cg_s) {
    const double stable_ratio = std::ceil(dt_lb / solid.stable_dt_cg_s);
    HandshakeResult r = refuse("dt_CG = " + num(solid.dt_cg_s) + " s (A_T = " + std::to_string(a_t) +
                  ") is above the solid's stable step " + num(solid.stable_dt_cg_s) +
                  " s; the largest stable A_T-compatible dt_CG is dt_LB / ceil(dt_LB / stable) = " +
                  num(dt_lb / stable_ratio) + " s (A_T = " + num(stable_ratio) + ")");
    if (stable_ratio < static_cast<double>(INT_MAX)) r.stable_time_ratio = static_cast<int>(stable_ratio);
    return r;
  }

  // 10. Something to couple.
  if (solid.num_cgps < 1)
    return refuse("the solid announced num_cgps = " + std::to_string(solid.num_cgps) +
                  "; a coupled run needs at least one CGP");

  // 11. The added-mass fields: both reported or neither.
  const double m = solid.light_cgp_mass_kg, a = solid.light_cgp_area_m2;
  if (!(std::isfinite(m) && std::isfinite(a) && ((m == 0.0 && a == 0.0) || (m > 0.0 && a > 0.0))))
    return refuse("the solid announced light_cgp_mass_kg = " + num(m) + " and light_cgp_area_m2 = " +
                  num(a) + "; both must be positive finite numbers, or both 0 (not reported)");

  return {true, "", a_t, 0};
}

std::uint64_t fnv1a_64(std::string_view bytes) {
  return fnv1a_64_update(kFnvOffsetBasis, bytes.data(), bytes.size());
}

std::string scene_hash_of_file(const std::string& path) {
  errno = 0;
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"),
                                                          &std::fclose);
  if (!f)
    throw std::runtime_error("cannot read the scene file '" + path +
                             "' to hash it: " + std::strerror(errno));
  std::uint64_t h = kFnvOffsetBasis;
  std::array<char, 65536> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), f.get())) > 0)
    h = fnv1a_64_update(h, buf.data(), n);
  if (std::ferror(f.get()))  // e.g. a directory: fopen succeeds, reading fails (EISDIR)
    throw std::runtime_error("cannot read the scene file '" + path +
                             "' to hash it: " + std::strerror(errno));
  return hex16(h);
}

std::string new_run_token() {
  std::random_device rd;
  std::uint64_t v = 0;
  // random_device yields unsigned int (32 bits here); draw until 64 bits are filled.
  for (int bits = 0; bits < 64; bits += 32) v = (v << 32U) | (rd() & 0xffffffffULL);
  return hex16(v);
}

}  // namespace cosim::protocol
