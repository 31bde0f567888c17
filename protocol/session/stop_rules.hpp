// Which stop_t ends a run (protocol/README.md section 8; DESIGN 2.2). A stop_t of the run's
// token that passed the value checks still has to fit the run: only the coordinator (the
// fluid) ends a run with success, and only once the run reached its last step. Anything
// else that carries exit code 0 (a forged or stale copy) is refused, counted and logged,
// never applied: it would end both servers with 0 and leave the outputs cut short.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "cosimlcm/stop_t.hpp"
#include "protocol/message_checks.hpp"

namespace cosim::protocol {

/// The closing exchange (protocol/README.md section 8; docs/reliability.md): a solid that
/// has sent its part of the last step and has no stop_t asks for it (resend_t, the awaited
/// fluid_state_t's step) every kClosingAsk; the coordinator, after its success stop_t,
/// answers each such round with the stop_t again and leaves once no request came for
/// kClosingQuiet (8 rounds), or after peer_timeout_s at most.
inline constexpr std::chrono::milliseconds kClosingAsk{25};
inline constexpr std::chrono::milliseconds kClosingQuiet = 8 * kClosingAsk;

/// The role that owns the step clock and ends a run with success.
inline constexpr const char* kCoordinatorRole = "fluid";

/// Where the receiver of a stop_t stands.
struct StopContext {
  std::string own_role;          ///< "fluid" or "solid"
  std::int64_t total_steps = 0;  ///< N of the run (welcome_t); 0 before the handshake
  /// The receiver has done its part of the last step (the solid published the last
  /// solid_state_t the fluid needs); a success stop is valid from then on only.
  bool at_end = false;
};

enum class StopVerdict {
  Apply,   ///< the peer ends the run: apply it
  Refuse,  ///< does not fit the run: count and log it (the rejection says why)
};

struct StopFit {
  StopVerdict verdict = StopVerdict::Apply;
  std::optional<Rejection> rejection;  ///< set for Refuse
};

/// Decides what a received stop_t means.
/// @pre  `m` passed check(stop_t, Expectation) (sender is "fluid" or "solid").
/// @post Refuse comes with a one-line rejection naming the field, its value and what fits.
///       A stop_t naming the receiver as its sender is refused too: a side stops only after
///       it published its own, so it never reads one back.
inline StopFit fit_stop(const cosimlcm::stop_t& m, const StopContext& c) {
  const auto refuse = [&](const std::string& what) {
    return StopFit{StopVerdict::Refuse, Rejection{RejectCategory::Range, "stop_t: " + what}};
  };
  if (m.sender == c.own_role)
    return refuse("sender = '" + m.sender + "' (exit_code " + std::to_string(m.exit_code) + ", step " +
                  std::to_string(m.step) + "); allowed: the peer's role (this side is '" + c.own_role + "')");
  const std::string from = " from '" + m.sender + "' at step " + std::to_string(m.step);
  if (m.exit_code == 0) {
    if (m.sender != kCoordinatorRole)
      return refuse("exit_code = 0" + from + "; allowed: only the coordinator ('" + kCoordinatorRole +
                    "') ends a run with success");
    if (c.total_steps < 1 || m.step != c.total_steps || !c.at_end)
      return refuse("exit_code = 0" + from + "; allowed: at the run's last step (" +
                    (c.total_steps < 1 ? std::string("the handshake is not done")
                                       : "step " + std::to_string(c.total_steps) +
                                             (c.at_end ? "" : ", once this side has sent its part of it")) +
                    ")");
  } else if (c.total_steps >= 1 && m.step > c.total_steps) {
    return refuse("step = " + std::to_string(m.step) + " (exit_code " + std::to_string(m.exit_code) +
                  " from '" + m.sender + "'); allowed: -1 to " + std::to_string(c.total_steps));
  }
  return {StopVerdict::Apply, std::nullopt};
}

}  // namespace cosim::protocol
