// The counters line both servers print at the end of a coupled run (and when it stops
// after the handshake): what the session received, refused, asked for and answered.
#pragma once

#include <cstdint>
#include <string>

#include "protocol/session/peer_link.hpp"
#include "protocol/session/state_inbox.hpp"

namespace cosim::protocol {

struct ResendCounts {
  std::int64_t asked = 0;     ///< resend_t this side published for the awaited message
  std::int64_t requests = 0;  ///< the peer's resend_t for this side's messages
  std::int64_t answered = 0;  ///< messages published again for them
};

/// "foreign N, duplicates N, stale N, early N, resends asked N, resend requests N answered N,
/// undecodable N, rejected N (...)" and "; injected faults: ..." when faults are injected.
template <class Message>
std::string session_counters(const PeerLink& link, const StateInbox<Message>& inbox, const ResendCounts& r) {
  return "foreign " + std::to_string(link.foreign()) + ", " + inbox.counters() + ", resends asked " +
         std::to_string(r.asked) + ", resend requests " + std::to_string(r.requests) + " answered " +
         std::to_string(r.answered) + ", " + link.counters();
}

}  // namespace cosim::protocol
