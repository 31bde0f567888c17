#include "protocol/message_checks.hpp"

#include <array>
#include <charconv>
#include <climits>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace cosim::protocol {

namespace {

using Rows3 = std::vector<std::vector<double>>;

/// Shortest text that reads back to the same double ("nan", "inf", "2.5e-07").
std::string num(double v) {
  std::array<char, 32> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

/// A string as it may appear in a one-line message: quoted, non-printable bytes as \xNN,
/// at most 40 bytes of it.
std::string quoted(const std::string& s) {
  constexpr std::size_t shown = 40;
  std::string q = "'";
  for (std::size_t i = 0; i < s.size() && i < shown; ++i) {
    const auto b = static_cast<unsigned char>(s[i]);
    if (b >= 0x20 && b != 0x7f && b != '\'' && b != '\\') {
      q += s[i];
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned>(b));
      q += hex;
    }
  }
  q += s.size() > shown ? "'..." : "'";
  return q;
}

Rejection reject(RejectCategory c, const char* type, const std::string& what) {
  return Rejection{c, std::string(type) + ": " + what};
}

/// A string field: at most `max` bytes, no NUL.
std::optional<Rejection> text(const char* type, const char* field, const std::string& s,
                              std::size_t max) {
  if (s.size() > max)
    return reject(RejectCategory::Text, type,
                  std::string(field) + " = " + quoted(s) + " has " + std::to_string(s.size()) +
                      " bytes; at most " + std::to_string(max) + " are allowed");
  if (s.find('\0') != std::string::npos)
    return reject(RejectCategory::Text, type,
                  std::string(field) + " = " + quoted(s) +
                      " contains a NUL byte; strings are UTF-8 without NUL");
  return std::nullopt;
}

std::optional<Rejection> token(const char* type, const std::string& got, const Expectation& e) {
  if (got == e.token) return std::nullopt;
  return reject(RejectCategory::Token, type,
                "token = " + quoted(got) + "; this run's token is " + quoted(e.token));
}

std::optional<Rejection> finite(const char* type, const std::string& field, double v) {
  if (std::isfinite(v)) return std::nullopt;
  return reject(RejectCategory::NonFinite, type,
                field + " = " + num(v) + "; every number must be finite");
}

std::optional<Rejection> seq_ok(const char* type, std::int64_t seq) {
  if (seq >= 0) return std::nullopt;
  return reject(RejectCategory::Range, type,
                "seq = " + std::to_string(seq) + "; allowed: 0 or more (the sender's counter)");
}

std::optional<Rejection> iteration_ok(const char* type, std::int32_t iteration, const Expectation& e) {
  if (iteration >= 0 && iteration < std::max(e.max_iterations, 1)) return std::nullopt;
  return reject(RejectCategory::Range, type,
                "iteration = " + std::to_string(iteration) + "; allowed: 0 to " +
                    std::to_string(std::max(e.max_iterations, 1) - 1) +
                    " (coupling.max_iterations - 1; 0 in the serial scheme)");
}

std::optional<Rejection> step_ok(const char* type, std::int64_t step, const Expectation& e) {
  if (step >= e.lowest_step && step <= e.highest_step) return std::nullopt;
  return reject(RejectCategory::Range, type,
                "step = " + std::to_string(step) + "; allowed: " + std::to_string(e.lowest_step) +
                    " to " + std::to_string(e.highest_step) +
                    " (up to the awaited step + " + std::to_string(kStepWindow) +
                    ", within the run)");
}

std::optional<Rejection> count_ok(const char* type, std::int32_t n, const Expectation& e) {
  if (n == e.num_cgps) return std::nullopt;
  return reject(RejectCategory::Count, type,
                "num_cgps = " + std::to_string(n) + "; expected " + std::to_string(e.num_cgps) +
                    " (the solid's hello_t)");
}

/// An array double[num_cgps][3]: its outer size, each inner size, every entry finite.
std::optional<Rejection> rows3(const char* type, const char* field, const Rows3& rows,
                               std::int32_t num_cgps) {
  if (rows.size() != static_cast<std::size_t>(num_cgps))
    return reject(RejectCategory::Count, type,
                  std::string(field) + " has " + std::to_string(rows.size()) +
                      " rows; expected num_cgps = " + std::to_string(num_cgps));
  for (std::size_t l = 0; l < rows.size(); ++l)
    if (rows[l].size() != 3)
      return reject(RejectCategory::Count, type,
                    std::string(field) + "[" + std::to_string(l) + "] has " +
                        std::to_string(rows[l].size()) + " entries; expected 3 (x, y, z)");
  for (std::size_t l = 0; l < rows.size(); ++l)
    for (std::size_t c = 0; c < 3; ++c)
      if (auto r = finite(type, std::string(field) + "[" + std::to_string(l) + "][" +
                                    std::to_string(c) + "]",
                          rows[l][c]))
        return r;
  return std::nullopt;
}

// ---- the bytes ----

/// Reads an LCM encoding (big-endian) and checks it against a layout.
class Bytes {
 public:
  Bytes(const char* type, const void* data, std::size_t size)
      : type_(type), p_(static_cast<const unsigned char*>(data)), size_(size) {}

  std::optional<std::string> problem() const { return problem_; }
  std::size_t left() const { return size_ - pos_; }

  /// The first bytes: the fingerprint of the type.
  void hash(std::int64_t expected) {
    if (size_ > static_cast<std::size_t>(INT_MAX))
      return fail("the message has " + std::to_string(size_) + " bytes; at most " +
                  std::to_string(INT_MAX) + " are allowed");
    const std::optional<std::uint64_t> h = read(8, "the type fingerprint");
    if (h && static_cast<std::int64_t>(*h) != expected) {
      char got[32], want[32];
      std::snprintf(got, sizeof got, "0x%016llx", static_cast<unsigned long long>(*h));
      std::snprintf(want, sizeof want, "0x%016llx", static_cast<unsigned long long>(expected));
      fail(std::string("fingerprint = ") + got + "; expected " + want +
           " (another message type or another version of it)");
    }
  }

  std::optional<std::int64_t> i64(const char* field) {
    const auto v = read(8, field);
    return v ? std::optional<std::int64_t>(static_cast<std::int64_t>(*v)) : std::nullopt;
  }
  std::optional<std::int32_t> i32(const char* field) {
    const auto v = read(4, field);
    return v ? std::optional<std::int32_t>(static_cast<std::int32_t>(static_cast<std::uint32_t>(*v)))
             : std::nullopt;
  }
  void i8(const char* field) { read(1, field); }
  void f64(const char* field) { read(8, field); }

  /// An LCM string: int32 length (the NUL included), then the bytes, the last one NUL.
  void string(const char* field) {
    const std::optional<std::int32_t> n = i32(field);
    if (!n) return;
    if (*n < 1)
      return fail(std::string(field) + ": string length = " + std::to_string(*n) +
                  "; at least 1 (the terminating NUL)");
    if (static_cast<std::size_t>(*n) > left())
      return fail(std::string(field) + ": string length = " + std::to_string(*n) + ", but " +
                  std::to_string(left()) + " bytes are left");
    if (p_[pos_ + static_cast<std::size_t>(*n) - 1] != 0)
      return fail(std::string(field) + ": the string of " + std::to_string(*n) +
                  " bytes does not end with a NUL");
    pos_ += static_cast<std::size_t>(*n);
  }

  /// num_cgps and the arrays after it: `doubles_per_cgp` doubles for each.
  void count_and_arrays(std::size_t doubles_per_cgp) {
    const std::optional<std::int32_t> n = i32("num_cgps");
    if (!n) return;
    if (*n < 0)
      return fail("num_cgps = " + std::to_string(*n) + "; allowed: 0 or more");
    const std::size_t need = static_cast<std::size_t>(*n) * doubles_per_cgp * 8;
    if (need > left())
      return fail("num_cgps = " + std::to_string(*n) + " needs " + std::to_string(need) +
                  " bytes of arrays, but " + std::to_string(left()) + " are left (from byte " +
                  std::to_string(pos_) + ")");
    pos_ += need;
  }

  /// Nothing may follow the last field.
  void end() {
    at_ = pos_;
    if (!problem_ && left() != 0)
      fail(std::to_string(left()) + " bytes follow the last field");
  }

 private:
  /// The problem, and where decoding failed: the first byte of the field that did not fit.
  void fail(const std::string& what) {
    if (!problem_)
      problem_ = std::string(type_) + ": " + what + " (decoding failed at byte " + std::to_string(at_) + " of " +
                 std::to_string(size_) + ")";
  }

  std::optional<std::uint64_t> read(std::size_t n, const char* field) {
    if (problem_) return std::nullopt;
    at_ = pos_;
    if (left() < n) {
      fail(std::string(field) + ": the message ends after " + std::to_string(size_) +
           " bytes (" + std::to_string(n) + " more needed)");
      return std::nullopt;
    }
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v = (v << 8U) | p_[pos_ + i];
    pos_ += n;
    return v;
  }

  const char* type_;
  const unsigned char* p_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::size_t at_ = 0;  ///< where the field being read starts
  std::optional<std::string> problem_;
};

}  // namespace

const char* category_name(RejectCategory c) {
  switch (c) {
    case RejectCategory::Undecodable: return "undecodable";
    case RejectCategory::Token: return "token";
    case RejectCategory::Count: return "count";
    case RejectCategory::NonFinite: return "non-finite";
    case RejectCategory::Range: return "range";
    case RejectCategory::Text: return "text";
  }
  return "unknown";
}

// ---- values ----

std::optional<Rejection> check(const cosimlcm::hello_t& m, const Expectation& e) {
  const char* type = "hello_t";
  if (auto r = token(type, m.token, e)) return r;
  if (m.role != "fluid" && m.role != "solid")
    return reject(RejectCategory::Text, type,
                  "role = " + quoted(m.role) + "; allowed: 'fluid', 'solid'");
  const std::pair<const char*, const std::string*> texts[] = {
      {"model", &m.model}, {"version", &m.version}, {"scene_hash", &m.scene_hash}, {"scheme", &m.scheme}};
  for (const auto& [field, value] : texts)
    if (auto r = text(type, field, *value, kMaxNameLength)) return r;
  const std::pair<const char*, double> positive[] = {{"dx_m", m.dx_m},
                                                     {"dt_lb_s", m.dt_lb_s},
                                                     {"sound_speed_m_s", m.sound_speed_m_s},
                                                     {"air_density_kg_m3", m.air_density_kg_m3},
                                                     {"dt_cg_s", m.dt_cg_s}};
  for (const auto& [field, value] : positive) {
    if (auto r = finite(type, field, value)) return r;
    if (!(value > 0.0))
      return reject(RejectCategory::Range, type,
                    std::string(field) + " = " + num(value) + "; allowed: a number > 0");
  }
  if (auto r = finite(type, "stable_dt_cg_s", m.stable_dt_cg_s)) return r;
  if (!(m.stable_dt_cg_s >= 0.0))
    return reject(RejectCategory::Range, type,
                  "stable_dt_cg_s = " + num(m.stable_dt_cg_s) +
                      "; allowed: a number >= 0 (the fluid sends 0)");
  if (m.time_ratio < 1)
    return reject(RejectCategory::Range, type,
                  "time_ratio = " + std::to_string(m.time_ratio) + "; allowed: 1 or more (A_T)");
  if (m.num_cgps < 0)
    return reject(RejectCategory::Count, type,
                  "num_cgps = " + std::to_string(m.num_cgps) +
                      "; allowed: 0 or more (the fluid sends 0)");
  // The added-mass figures of the solid's lightest CGP (protocol/README.md section 12).
  const std::pair<const char*, double> light[] = {{"light_cgp_mass_kg", m.light_cgp_mass_kg},
                                                  {"light_cgp_area_m2", m.light_cgp_area_m2}};
  for (const auto& [field, value] : light) {
    if (auto r = finite(type, field, value)) return r;
    if (!(value >= 0.0))
      return reject(RejectCategory::Range, type,
                    std::string(field) + " = " + num(value) +
                        "; allowed: a number >= 0 (0: not reported; the fluid sends 0)");
  }
  return std::nullopt;
}

std::optional<Rejection> check(const cosimlcm::welcome_t& m, const Expectation& e) {
  const char* type = "welcome_t";
  if (auto r = token(type, m.token, e)) return r;
  if (m.accepted != 0 && m.accepted != 1)
    return reject(RejectCategory::Range, type,
                  "accepted = " + std::to_string(m.accepted) + "; allowed: 0 (false), 1 (true)");
  if (auto r = text(type, "reason", m.reason, kMaxReasonLength)) return r;
  if (auto r = text(type, "scheme", m.scheme, kMaxNameLength)) return r;
  if (m.accepted == 0) return std::nullopt;  // refused: the numbers are not used
  if (m.total_steps < 1)
    return reject(RejectCategory::Range, type,
                  "total_steps = " + std::to_string(m.total_steps) + "; allowed: 1 or more");
  if (m.rigid_steps < 0)
    return reject(RejectCategory::Range, type,
                  "rigid_steps = " + std::to_string(m.rigid_steps) + "; allowed: 0 or more");
  if (m.time_ratio < 1)
    return reject(RejectCategory::Range, type,
                  "time_ratio = " + std::to_string(m.time_ratio) + "; allowed: 1 or more (A_T)");
  return std::nullopt;
}

std::optional<Rejection> check(const cosimlcm::solid_state_t& m, const Expectation& e) {
  const char* type = "solid_state_t";
  if (auto r = token(type, m.token, e)) return r;
  if (auto r = seq_ok(type, m.seq)) return r;
  if (auto r = step_ok(type, m.step, e)) return r;
  if (auto r = iteration_ok(type, m.iteration, e)) return r;
  if (auto r = count_ok(type, m.num_cgps, e)) return r;
  if (auto r = rows3(type, "position_lb", m.position_lb, m.num_cgps)) return r;
  if (auto r = rows3(type, "impulse_lb", m.impulse_lb, m.num_cgps)) return r;
  if (e.time_ratio > 0 ? m.substeps != 0 && m.substeps != e.time_ratio &&
                             (e.restart_time_ratio <= 0 || m.substeps != e.restart_time_ratio)
                       : m.substeps < 0)
    return reject(RejectCategory::Range, type,
                  "substeps = " + std::to_string(m.substeps) + "; allowed: 0 or A_T = " +
                      std::to_string(e.time_ratio) +
                      (e.restart_time_ratio > 0 ? " (or the restart's " + std::to_string(e.restart_time_ratio) + ")"
                                                : std::string()));
  if (auto r = finite(type, "solid_time_s", m.solid_time_s)) return r;
  if (!(m.solid_time_s >= 0.0))
    return reject(RejectCategory::Range, type,
                  "solid_time_s = " + num(m.solid_time_s) + "; allowed: a number >= 0");
  return std::nullopt;
}

std::optional<Rejection> check(const cosimlcm::fluid_state_t& m, const Expectation& e) {
  const char* type = "fluid_state_t";
  if (auto r = token(type, m.token, e)) return r;
  if (auto r = seq_ok(type, m.seq)) return r;
  if (auto r = step_ok(type, m.step, e)) return r;
  if (auto r = iteration_ok(type, m.iteration, e)) return r;
  if (auto r = count_ok(type, m.num_cgps, e)) return r;
  if (m.rho_lb.size() != static_cast<std::size_t>(m.num_cgps))
    return reject(RejectCategory::Count, type,
                  "rho_lb has " + std::to_string(m.rho_lb.size()) +
                      " entries; expected num_cgps = " + std::to_string(m.num_cgps));
  if (auto r = rows3(type, "velocity_lb", m.velocity_lb, m.num_cgps)) return r;
  if (m.rho_start_lb.size() != static_cast<std::size_t>(m.num_cgps))
    return reject(RejectCategory::Count, type,
                  "rho_start_lb has " + std::to_string(m.rho_start_lb.size()) +
                      " entries; expected num_cgps = " + std::to_string(m.num_cgps));
  if (auto r = rows3(type, "velocity_start_lb", m.velocity_start_lb, m.num_cgps)) return r;
  if (auto r = finite(type, "bulk_velocity_lb", m.bulk_velocity_lb)) return r;
  for (const auto& [name, rho] : {std::pair{"rho_lb", &m.rho_lb}, std::pair{"rho_start_lb", &m.rho_start_lb}})
    for (std::size_t l = 0; l < rho->size(); ++l) {
      const std::string field = std::string(name) + "[" + std::to_string(l) + "]";
      if (auto r = finite(type, field, (*rho)[l])) return r;
      if (!((*rho)[l] > 0.0))
        return reject(RejectCategory::Range, type,
                      field + " = " + num((*rho)[l]) + "; allowed: a density > 0");
    }
  return std::nullopt;
}

std::optional<Rejection> check(const cosimlcm::resend_t& m, const Expectation& e) {
  const char* type = "resend_t";
  if (auto r = token(type, m.token, e)) return r;
  if (m.step < 0)
    return reject(RejectCategory::Range, type,
                  "step = " + std::to_string(m.step) + "; allowed: 0 or more");
  if (m.what != "solid_state" && m.what != "fluid_state")
    return reject(RejectCategory::Text, type,
                  "what = " + quoted(m.what) + "; allowed: 'solid_state', 'fluid_state'");
  return std::nullopt;
}

std::optional<Rejection> check(const cosimlcm::stop_t& m, const Expectation& e) {
  const char* type = "stop_t";
  if (auto r = token(type, m.token, e)) return r;
  if (m.sender != "fluid" && m.sender != "solid")
    return reject(RejectCategory::Text, type, "sender = " + quoted(m.sender) + "; allowed: 'fluid', 'solid'");
  if (m.step < -1)
    return reject(RejectCategory::Range, type,
                  "step = " + std::to_string(m.step) +
                      "; allowed: -1 (before the first step) or more");
  if (m.exit_code < 0 || m.exit_code > kMaxExitCode)
    return reject(RejectCategory::Range, type,
                  "exit_code = " + std::to_string(m.exit_code) + "; allowed: 0 to " +
                      std::to_string(kMaxExitCode));
  if (auto r = text(type, "reason", m.reason, kMaxReasonLength)) return r;
  return std::nullopt;
}

// ---- the bytes ----

std::optional<std::string> check_encoding(const cosimlcm::hello_t*, const void* data,
                                          std::size_t size) {
  Bytes b("hello_t", data, size);
  b.hash(cosimlcm::hello_t::getHash());
  for (const char* f : {"token", "role", "model", "version", "scene_hash", "scheme"}) b.string(f);
  for (const char* f : {"dx_m", "dt_lb_s", "sound_speed_m_s", "air_density_kg_m3"}) b.f64(f);
  b.i32("time_ratio");
  b.f64("dt_cg_s");
  b.f64("stable_dt_cg_s");
  b.i32("num_cgps");
  b.f64("light_cgp_mass_kg");
  b.f64("light_cgp_area_m2");
  b.end();
  return b.problem();
}

std::optional<std::string> check_encoding(const cosimlcm::welcome_t*, const void* data,
                                          std::size_t size) {
  Bytes b("welcome_t", data, size);
  b.hash(cosimlcm::welcome_t::getHash());
  b.string("token");
  b.i8("accepted");
  b.string("reason");
  b.i64("total_steps");
  b.i64("rigid_steps");
  b.i32("time_ratio");
  b.string("scheme");
  b.end();
  return b.problem();
}

std::optional<std::string> check_encoding(const cosimlcm::solid_state_t*, const void* data,
                                          std::size_t size) {
  Bytes b("solid_state_t", data, size);
  b.hash(cosimlcm::solid_state_t::getHash());
  b.string("token");
  b.i64("seq");
  b.i64("step");
  b.i32("iteration");
  b.i32("substeps");
  b.f64("solid_time_s");
  b.count_and_arrays(6);  // position_lb[n][3], impulse_lb[n][3]
  b.end();
  return b.problem();
}

std::optional<std::string> check_encoding(const cosimlcm::fluid_state_t*, const void* data,
                                          std::size_t size) {
  Bytes b("fluid_state_t", data, size);
  b.hash(cosimlcm::fluid_state_t::getHash());
  b.string("token");
  b.i64("seq");
  b.i64("step");
  b.i32("iteration");
  b.f64("bulk_velocity_lb");
  // rho_lb[n], velocity_lb[n][3], rho_start_lb[n], velocity_start_lb[n][3]: LCM encodes
  // each array whole, one after the other, so the bytes needed are the same as per CGP.
  b.count_and_arrays(8);
  b.end();
  return b.problem();
}

std::optional<std::string> check_encoding(const cosimlcm::resend_t*, const void* data,
                                          std::size_t size) {
  Bytes b("resend_t", data, size);
  b.hash(cosimlcm::resend_t::getHash());
  b.string("token");
  b.i64("step");
  b.string("what");
  b.end();
  return b.problem();
}

std::optional<std::string> check_encoding(const cosimlcm::stop_t*, const void* data,
                                          std::size_t size) {
  Bytes b("stop_t", data, size);
  b.hash(cosimlcm::stop_t::getHash());
  b.string("token");
  b.string("sender");
  b.i64("step");
  b.i32("exit_code");
  b.string("reason");
  b.end();
  return b.problem();
}

std::string bounded_reason(const std::string& reason) {
  std::string s = reason;
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  if (s.size() > kMaxReasonLength) {
    std::size_t cut = kMaxReasonLength;
    // Not inside a UTF-8 sequence: back up over continuation bytes (10xxxxxx).
    while (cut > 0 && (static_cast<unsigned char>(s[cut]) & 0xC0U) == 0x80U) --cut;
    s.resize(cut);
  }
  return s;
}

// ---- counters ----

void MessageRejections::add(const std::string& channel, const Rejection& r) {
  const int c = static_cast<int>(r.category);
  ++total_;
  ++by_category_[c];
  if (++counts_[{channel, c}] == 1 && log_)
    log_("refusing messages on channel '" + channel + "' (" + category_name(r.category) +
         "): " + r.what + "; such messages are counted, never applied");
}

std::int64_t MessageRejections::count(const std::string& channel) const {
  std::int64_t n = 0;
  for (const auto& [key, k] : counts_)
    if (key.first == channel) n += k;
  return n;
}

std::string MessageRejections::summary() const {
  std::string s = "rejected " + std::to_string(total_);
  if (total_ == 0) return s;
  std::string parts;
  for (int c = 0; c < kRejectCategories; ++c)
    if (by_category_[c] > 0)
      parts += (parts.empty() ? "" : ", ") +
               std::string(category_name(static_cast<RejectCategory>(c))) + " " +
               std::to_string(by_category_[c]);
  return s + " (" + parts + ")";
}

}  // namespace cosim::protocol
