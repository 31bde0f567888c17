// The tests' fake peers (a fake fluid for the solid, a fake solid for the fluid) receive
// through the session layer's transport like every peer (protocol/session/peer_link.hpp):
// bytes checked before decoding, another run's token dropped. They publish on the bus
// directly, since misbehaving on purpose is their job.
#pragma once

#include <functional>
#include <sstream>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "protocol/session/peer_link.hpp"

namespace cosim::test {

/// A fake peer's receiving side on a lent bus: `role` ("fluid" or "solid"), the run's token,
/// the channel prefix. What the gate logs (undecodable, foreign) is kept in log().
class FakePeerLink {
 public:
  FakePeerLink(const std::string& role, const std::string& token, const std::string& prefix, lcm::LCM& bus)
      : link_(settings(role, token, prefix, bus), log_) {
    link_.open();
  }

  /// `handler(m)` for every message of type M on `channel` that passes the gate.
  template <class M>
  void on(const std::string& channel, std::function<void(const M&)> handler) {
    link_.subscribe<M>(channel, [handler = std::move(handler)](M&& m) { handler(m); });
  }

  std::string log() const { return log_.str(); }

 private:
  static protocol::PeerLink::Settings settings(const std::string& role, const std::string& token,
                                               const std::string& prefix, lcm::LCM& bus) {
    protocol::PeerLink::Settings s;
    s.role = role;
    s.token = token;
    s.channel_prefix = prefix;
    s.bus = &bus;
    return s;
  }

  std::ostringstream log_;
  protocol::PeerLink link_;
};

}  // namespace cosim::test
