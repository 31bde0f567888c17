// LCM channel names of one run: a prefix (default "COSIM_", or a per-run one from the scene
// or the command line, so that two runs on one host never cross) followed by the message
// name. The protocol is protocol/README.md.
#pragma once

#include <array>
#include <cstddef>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "common/text/text.hpp"

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

/// The six messages of a run, one channel each.
enum class MessageKind { Hello, Welcome, SolidState, FluidState, Resend, Stop };
inline constexpr std::size_t kMessageKinds = 6;

/// The channel name of each message after the prefix, in MessageKind's order.
inline constexpr std::array<std::string_view, kMessageKinds> kChannelNames = {
    "HELLO", "WELCOME", "SOLID_STATE", "FLUID_STATE", "RESEND", "STOP"};

inline std::string_view channel_name(MessageKind k) { return kChannelNames[std::size_t(k)]; }

/// What a channel of a run is: its prefix and the message it carries.
struct ChannelKind {
  std::string prefix;
  MessageKind kind;
};

/// The prefix and message of `channel` when it is a run's channel (a prefix that passes
/// validate_channel_prefix, then one of kChannelNames); nullopt for any other channel.
inline std::optional<ChannelKind> classify_channel(std::string_view channel) {
  for (std::size_t k = 0; k < kMessageKinds; ++k) {
    const std::string_view name = kChannelNames[k];
    if (channel.size() <= name.size() || !channel.ends_with(name)) continue;
    const std::string_view prefix = channel.substr(0, channel.size() - name.size());
    try {
      validate_channel_prefix(prefix);
    } catch (const std::invalid_argument&) {
      continue;
    }
    return ChannelKind{std::string(prefix), static_cast<MessageKind>(k)};
  }
  return std::nullopt;
}

/// The six channels of one run, prefix + message name (protocol/README.md, "Channels").
struct Channels {
  /// @pre prefix passes validate_channel_prefix (throws std::invalid_argument otherwise)
  explicit Channels(std::string_view prefix_ = default_channel_prefix)
      : prefix(validated(prefix_)),
        hello(named(MessageKind::Hello)),
        welcome(named(MessageKind::Welcome)),
        solid_state(named(MessageKind::SolidState)),
        fluid_state(named(MessageKind::FluidState)),
        resend(named(MessageKind::Resend)),
        stop(named(MessageKind::Stop)) {}

  std::string prefix;
  std::string hello;        ///< hello_t, both sides
  std::string welcome;      ///< welcome_t, coordinator (fluid process) -> solid
  std::string solid_state;  ///< solid_state_t, solid -> fluid
  std::string fluid_state;  ///< fluid_state_t, fluid -> solid
  std::string resend;       ///< resend_t, either side
  std::string stop;         ///< stop_t, either side

 private:
  std::string named(MessageKind k) const { return prefix + std::string(channel_name(k)); }
  static std::string validated(std::string_view p) {
    validate_channel_prefix(p);
    return std::string(p);
  }
};

}  // namespace cosim::protocol
