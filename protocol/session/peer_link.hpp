// The transport of one protocol peer (DESIGN 2.2-2.3; protocol/README.md sections 5-8a),
// the one implementation that both servers, the replay tool and outside solids use:
//
//   - the LCM bus: opened from the URL under the one URL rule (lcm_url.hpp), or an
//     in-process bus lent by the caller (memq://: the replay tool, the tests);
//   - the run's six channels (channels.hpp);
//   - every publish through the fault injector (fault_injection.hpp; a test setting), with
//     the run key's MAC appended when the run has a key (message_auth.hpp);
//   - every receive through one gate: with a key, the MAC first (a message that does not
//     verify is counted as foreign and dropped, before anything else is read from it); the
//     bytes checked before the generated decode
//     (undecodable copies counted and logged once per channel; a copy whose header names
//     this run's token is reported with its seq and step, so that it counts toward the
//     three-copies rule of the awaited step), another run's token counted and dropped, and
//     the values checked against what this peer expects now (refusals counted and logged
//     once per category). Handlers see only messages of this run that passed.
//   - stop_t out, three copies 20 ms apart, naming this peer as its sender; the last one
//     kept to be published again (the coordinator's closing linger, README section 8);
//   - resend_t out, kResendCopies copies per request (docs/reliability.md: how many rounds
//     the documented fault level needs).
//
// Protocol state (which step is awaited, resends, timeouts) is not here: state_inbox.hpp.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "protocol/channels.hpp"
#include "protocol/fault_injection.hpp"
#include "protocol/message_auth.hpp"
#include "protocol/message_checks.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/step_sequencer.hpp"

namespace cosim::protocol {

/// The leading fields every state message shares (solid_state_t, fluid_state_t: token, seq,
/// step), read from bytes that do not decode as a whole.
struct MessageHeader {
  std::string token;
  std::int64_t seq = 0;
  std::int64_t step = 0;
};

/// The header of an encoded state message (8-byte fingerprint, then token, seq and step in
/// LCM's big-endian encoding), whatever follows; nothing if the bytes do not hold one.
std::optional<MessageHeader> peek_state_header(const void* data, std::size_t size);

/// Copies of each resend_t: every copy that arrives is answered, so one request round fails
/// only when every copy or its answer is lost (docs/reliability.md).
inline constexpr int kResendCopies = 8;

class PeerLink {
 public:
  struct Settings {
    std::string role;            ///< this peer: "fluid" or "solid" (stop_t.sender, log lines)
    std::string token;           ///< the run's token
    std::string channel_prefix;  ///< validated by Channels
    std::string lcm_url;         ///< opened by open() unless `bus` is lent
    lcm::LCM* bus = nullptr;     ///< an in-process bus to use instead; not owned
    FaultSettings faults;
    /// The run's key (message_auth.hpp): every message out carries its MAC, every message
    /// in must; none: no MAC sent, none expected.
    std::optional<RunKey> key;
  };
  using Clock = std::chrono::steady_clock;
  /// A message of this run whose bytes did not decode: the channel, its header, the reason.
  using UndecodableHook = std::function<void(const std::string& channel, const MessageHeader&, const std::string&)>;

  /// @throws std::invalid_argument for a channel prefix that Channels refuses.
  PeerLink(Settings settings, std::ostream& log);
  ~PeerLink();
  PeerLink(const PeerLink&) = delete;
  PeerLink& operator=(const PeerLink&) = delete;

  /// Opens the bus (the URL rule first) unless one was lent. An ending (exit code 1 for a
  /// bus that does not open, 2 for a URL the rule refuses), or nothing.
  std::optional<Ending> open();

  /// What a message of the run must satisfy now (message_checks.hpp), asked per message.
  void expect(std::function<Expectation()> source) { expectation_ = std::move(source); }
  void on_undecodable(UndecodableHook hook) { undecodable_hook_ = std::move(hook); }

  /// Subscribes `on_message` to `channel` for messages of type M that pass the gate;
  /// `on_refused` (optional) sees those of this run that fail the value checks.
  /// @return false if LCM refused the subscription.
  template <class M>
  bool subscribe(const std::string& channel, std::function<void(M&&)> on_message,
                 std::function<void(const M&, const Rejection&)> on_refused = {});

  /// Counts and logs a refusal that the caller's own rules found (a stop_t that does not
  /// fit the run, a hello_t of the wrong role): as the gate's own value checks do.
  void refuse(const std::string& channel, const Rejection& r) { rejections_.add(channel, r); }

  /// Publishes `m` through the fault injector; on an LCM error, fatal() is set (exit code 1).
  template <class M>
  bool publish(const std::string& channel, const M& m) {
    const int size = m.getEncodedSize();
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size > 0 ? size : 0));
    const bool encoded = size >= 0 && m.encode(bytes.data(), 0, size) == size;
    if (encoded && s_.key) append_mac(*s_.key, channel, bytes);
    if (encoded && net_->publish_encoded(channel, std::move(bytes)) == 0) return true;
    if (!fatal_) fatal_ = Ending{exit_code::system, "cannot publish on " + channel + " (LCM at " + url() + ")", true};
    return false;
  }

  /// Bytes published as they are (a logged message replayed bit for bit: cosim-replay), past
  /// the fault injector; on an LCM error, fatal() is set (exit code 1).
  bool publish_bytes(const std::string& channel, const void* data, std::size_t size);

  /// stop_t(step, code, reason) from this peer, three copies 20 ms apart (best effort: the
  /// run ends either way), then whatever the fault injector still holds.
  void publish_stop(std::int64_t step, int code, const std::string& reason);
  /// The last stop_t of publish_stop once more (one copy), if there was one.
  void republish_stop();
  /// resend_t `r` on the RESEND channel, kResendCopies copies (one request round).
  void publish_request(const cosimlcm::resend_t& r);

  /// Sends what the fault injector holds that is due, and dispatches what arrives within
  /// `wait` (never longer). An LCM failure sets fatal() (exit code 1).
  void pump(std::chrono::milliseconds wait);

  const std::optional<Ending>& fatal() const { return fatal_; }
  const Channels& channels() const { return channels_; }
  const std::string& role() const { return s_.role; }
  const std::string& token() const { return s_.token; }
  std::string url() const { return s_.bus != nullptr ? std::string("(an in-process bus)") : s_.lcm_url; }

  std::int64_t foreign() const { return foreign_.total(); }
  std::int64_t undecodable() const;
  const MessageRejections& rejections() const { return rejections_; }
  /// "undecodable N, rejected N (...)" and "; injected faults: ..." when faults are injected.
  std::string counters() const;

 private:
  template <class M>
  struct Subscriber {
    PeerLink* link;
    std::string channel;
    std::function<void(M&&)> on_message;
    std::function<void(const M&, const Rejection&)> on_refused;
  };
  template <class M>
  static void dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Subscriber<M>* s);
  void count_undecodable(const std::string& channel, const char* type, const std::string& why,
                         const void* data, std::size_t size);

  Settings s_;
  std::ostream& log_;
  Channels channels_;
  std::unique_ptr<lcm::LCM> own_bus_;
  lcm::LCM* bus_ = nullptr;
  std::optional<FaultyTransport> net_;
  std::vector<lcm::Subscription*> subs_;
  std::vector<std::shared_ptr<void>> subscribers_;
  ForeignCounter foreign_;
  MessageRejections rejections_;
  std::map<std::string, std::int64_t> undecodable_;
  std::function<Expectation()> expectation_;
  UndecodableHook undecodable_hook_;
  std::optional<Ending> fatal_;
  std::optional<cosimlcm::stop_t> last_stop_;
};

template <class M>
void PeerLink::dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Subscriber<M>* s) {
  PeerLink& link = *s->link;
  std::size_t size = rbuf->data_size;
  if (link.s_.key) {
    // Not signed with the run's key: a forger's (or a peer's without the key), never read.
    const std::optional<std::size_t> n = verified_size(*link.s_.key, channel, rbuf->data, size);
    if (!n) {
      link.foreign_.unauthenticated(channel);
      return;
    }
    size = *n;
  }
  M m{};
  if (const auto why = decode_checked(rbuf->data, size, m)) {
    link.count_undecodable(channel, M::getTypeName(), *why, rbuf->data, size);
    return;
  }
  if (!link.foreign_.admit(channel, m.token)) return;
  if (link.expectation_)
    if (const auto r = check(m, link.expectation_())) {
      link.rejections_.add(channel, *r);
      if (s->on_refused) s->on_refused(m, *r);
      return;
    }
  s->on_message(std::move(m));
}

template <class M>
bool PeerLink::subscribe(const std::string& channel, std::function<void(M&&)> on_message,
                         std::function<void(const M&, const Rejection&)> on_refused) {
  auto s = std::make_shared<Subscriber<M>>(Subscriber<M>{this, channel, std::move(on_message), std::move(on_refused)});
  lcm::Subscription* sub = bus_->subscribeFunction(channel, &PeerLink::dispatch<M>, s.get());
  subscribers_.push_back(s);
  subs_.push_back(sub);
  return sub != nullptr;
}

}  // namespace cosim::protocol
