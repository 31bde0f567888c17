// Message security (protocol/README.md section 8a): every message of a run is checked before
// it is used. Two layers, both transport-free and pure:
//
//   decode_checked<M>()  the bytes: the type's fingerprint, every string length and array
//                        count against the bytes actually there, and nothing left over,
//                        BEFORE the generated decode runs (which trusts them: a claimed
//                        num_cgps of 2^31 - 1 would allocate tens of gigabytes, a string
//                        length of 0 or below throws std::length_error from a handler);
//   check(message, Expectation)
//                        the values: the run's token, num_cgps equal to the handshake's and
//                        every array's outer size equal to it, inner sizes exactly 3, every
//                        double finite, seq >= 0, the step inside the receiver's window,
//                        substeps 0 or A_T, rho_lb > 0, string fields bounded in length.
//
// Each returns one line naming the field, its value and what is allowed, or nothing.
// MessageRejections counts what was refused, per channel and per category, and logs the
// first of each (channel, category) once, like ForeignCounter does for foreign tokens.
//
// What is not checked here: per-step consistency (the substeps and solid_time_s a given step
// must have; fluid/coupled/coordinator.cpp), and positions against the fluid's domain (the fluid
// knows it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"

namespace cosim::protocol {

/// How far ahead of the awaited step a state message may be (it is held or counted as early);
/// a step beyond is refused.
inline constexpr std::int64_t kStepWindow = 8;
/// Refused copies of the awaited step in a row after which the receiver gives up on its
/// peer with exit code 2 (3 for a non-finite number or rho <= 0), naming the field: a buggy
/// peer gets a clear error, not a timeout.
inline constexpr int kRejectedCopiesLimit = 3;
/// Longest string field, bytes: the token, role, model, version and scene_hash of hello_t
/// and the `what` of resend_t.
inline constexpr std::size_t kMaxNameLength = 64;
/// Longest `reason` of welcome_t and stop_t, bytes (senders cut theirs: bounded_reason()).
inline constexpr std::size_t kMaxReasonLength = 4096;
/// Largest exit code a stop_t may carry (a process exit status).
inline constexpr std::int32_t kMaxExitCode = 255;

/// What the receiver knows when a message arrives.
struct Expectation {
  std::string token;             ///< the run's token
  std::int32_t num_cgps = 0;     ///< the solid's hello_t.num_cgps (state messages)
  std::int64_t lowest_step = 0;  ///< the window of acceptable steps, inclusive
  std::int64_t highest_step = 0;
  std::int32_t time_ratio = 0;   ///< A_T of the run: substeps must be 0 or A_T
  /// A second A_T that substeps may equal (0: none): a restart with another A_T (the
  /// watchdog's retry) receives the checkpoint's in-flight solid_state_t, computed with the
  /// old one.
  std::int32_t restart_time_ratio = 0;
  /// Sub-iterations per step (coupling.max_iterations of the implicit scheme; 1 in the
  /// serial scheme): a state message's iteration must lie in [0, max_iterations).
  std::int32_t max_iterations = 1;
};

/// Why a message was refused, by kind (the counters' categories).
enum class RejectCategory {
  Undecodable,  ///< the bytes: fingerprint, lengths, counts (decode_checked)
  Token,        ///< another run's token
  Count,        ///< num_cgps, or an array's size against it
  NonFinite,    ///< a NaN or an infinity
  Range,        ///< seq, step, substeps, rho, exit code, a number out of its range
  Text,         ///< a string too long, with a NUL, or not one of the allowed words
};
inline constexpr int kRejectCategories = 6;

/// "undecodable", "token", "count", "non-finite", "range", "text".
const char* category_name(RejectCategory c);

struct Rejection {
  RejectCategory category;
  std::string what;  ///< one line: "<type>: <field> = <value>; <what is allowed>"

  /// `what` without its "<type>: " at the front.
  std::string detail() const {
    const std::size_t at = what.find(": ");
    return at == std::string::npos ? what : what.substr(at + 2);
  }
};

std::optional<Rejection> check(const cosimlcm::hello_t& m, const Expectation& e);
std::optional<Rejection> check(const cosimlcm::welcome_t& m, const Expectation& e);
std::optional<Rejection> check(const cosimlcm::solid_state_t& m, const Expectation& e);
std::optional<Rejection> check(const cosimlcm::fluid_state_t& m, const Expectation& e);
std::optional<Rejection> check(const cosimlcm::resend_t& m, const Expectation& e);
std::optional<Rejection> check(const cosimlcm::stop_t& m, const Expectation& e);

/// The encoded bytes of one message of type M against its layout (fingerprint, string
/// lengths >= 1 with the terminating NUL inside the bytes, array counts >= 0 that the bytes
/// can hold, no byte left over). One line naming the type and the field, or nothing.
std::optional<std::string> check_encoding(const cosimlcm::hello_t*, const void* data, std::size_t size);
std::optional<std::string> check_encoding(const cosimlcm::welcome_t*, const void* data, std::size_t size);
std::optional<std::string> check_encoding(const cosimlcm::solid_state_t*, const void* data, std::size_t size);
std::optional<std::string> check_encoding(const cosimlcm::fluid_state_t*, const void* data, std::size_t size);
std::optional<std::string> check_encoding(const cosimlcm::resend_t*, const void* data, std::size_t size);
std::optional<std::string> check_encoding(const cosimlcm::stop_t*, const void* data, std::size_t size);

/// Decodes `size` bytes into `out` after check_encoding: never throws, never allocates more
/// than the bytes can describe. @return nothing on success; else the reason (and `out` is
/// unspecified).
template <class M>
std::optional<std::string> decode_checked(const void* data, std::size_t size, M& out) {
  if (auto why = check_encoding(static_cast<const M*>(nullptr), data, size)) return why;
  const int n = out.decode(data, 0, static_cast<int>(size));  // size <= INT_MAX: checked
  if (n < 0 || static_cast<std::size_t>(n) != size)
    return std::string(M::getTypeName()) + ": the generated decode refused " +
           std::to_string(size) + " bytes";
  return std::nullopt;
}

/// A reason as a sender should publish it: one line (control characters become spaces),
/// at most kMaxReasonLength bytes.
std::string bounded_reason(const std::string& reason);

/// Counts refused messages per channel and per category. The log hook gets one line the
/// first time a (channel, category) pair refuses a message, never again for that pair.
class MessageRejections {
 public:
  using LogHook = std::function<void(const std::string& line)>;

  explicit MessageRejections(LogHook log = {}) : log_(std::move(log)) {}

  /// @post total() and count(channel) have grown by one; the first refusal of each
  ///       (channel, category) is logged: "refusing messages on channel 'C' (category): WHAT;
  ///       they are counted, never applied".
  void add(const std::string& channel, const Rejection& r);

  std::int64_t total() const { return total_; }
  std::int64_t count(const std::string& channel) const;
  std::int64_t count(RejectCategory c) const { return by_category_[static_cast<int>(c)]; }

  /// "rejected N" and, when N > 0, the categories: "rejected 3 (count 1, non-finite 2)".
  std::string summary() const;

 private:
  LogHook log_;
  std::map<std::pair<std::string, int>, std::int64_t> counts_;
  std::int64_t by_category_[kRejectCategories] = {};
  std::int64_t total_ = 0;
};

}  // namespace cosim::protocol
