// LCM channel names of one run: a prefix (default "COSIM_", or a per-run one from the scene
// or the command line, so that two runs on one host never cross) followed by the message
// name. The protocol is protocol/README.md.
#pragma once

#include <cstddef>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

#include "protocol/text.hpp"

namespace cosim::protocol {

inline constexpr std::string_view default_channel_prefix = "COSIM_";
inline constexpr std::size_t max_channel_prefix_length = 32;

/// Checks a channel prefix: non-empty, at most 32 characters, letters, digits and '_' only.
/// @post returns normally, or throws std::invalid_argument with a one-line message that
///       names the prefix (non-printable characters escaped) and what is allowed.
inline void validate_channel_prefix(std::string_view prefix) {
  const auto quoted = [prefix] { return escaped(prefix); };
  const std::string allowed =
      "; a channel prefix is 1 to " + std::to_string(max_channel_prefix_length) +
      " characters from A-Z, a-z, 0-9 and '_'";
  if (prefix.empty()) throw std::invalid_argument("channel prefix is empty" + allowed);
  if (prefix.size() > max_channel_prefix_length)
    throw std::invalid_argument("channel prefix " + quoted() + " has " +
                                std::to_string(prefix.size()) + " characters" + allowed);
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const char ch = prefix[i];
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') ||
                    (ch >= '0' && ch <= '9') || ch == '_';
    if (!ok)
      throw std::invalid_argument("channel prefix " + quoted() + " has a character not allowed" +
                                  " at position " + std::to_string(i) + allowed);
  }
}

/// The six channels of one run, prefix + message name (protocol/README.md, "Channels").
struct Channels {
  /// @pre prefix passes validate_channel_prefix (throws std::invalid_argument otherwise)
  explicit Channels(std::string_view prefix_ = default_channel_prefix)
      : prefix(validated(prefix_)),
        hello(prefix + "HELLO"),
        welcome(prefix + "WELCOME"),
        solid_state(prefix + "SOLID_STATE"),
        fluid_state(prefix + "FLUID_STATE"),
        resend(prefix + "RESEND"),
        stop(prefix + "STOP") {}

  std::string prefix;
  std::string hello;        ///< hello_t, both sides
  std::string welcome;      ///< welcome_t, coordinator (fluid process) -> solid
  std::string solid_state;  ///< solid_state_t, solid -> fluid
  std::string fluid_state;  ///< fluid_state_t, fluid -> solid
  std::string resend;       ///< resend_t, either side
  std::string stop;         ///< stop_t, either side

 private:
  static std::string validated(std::string_view p) {
    validate_channel_prefix(p);
    return std::string(p);
  }
};

}  // namespace cosim::protocol
