#include "protocol/session/peer_link.hpp"

#include <algorithm>
#include <cstring>
#include <thread>

#include "cosimlcm/stop_t.hpp"
#include "protocol/handshake.hpp"
#include "protocol/lcm_url.hpp"

namespace cosim::protocol {

namespace {

constexpr int kStopCopies = 3;  // protocol/README.md section 8
constexpr auto kStopSpacing = std::chrono::milliseconds(20);

std::int64_t big_endian(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | p[k];
  if (bytes == 4) return static_cast<std::int32_t>(static_cast<std::uint32_t>(v));
  return static_cast<std::int64_t>(v);
}

}  // namespace

std::optional<MessageHeader> peek_state_header(const void* data, std::size_t size) {
  const auto* b = static_cast<const unsigned char*>(data);
  std::size_t at = 8;  // the type's fingerprint
  if (size < at + 4) return std::nullopt;
  const std::int64_t length = big_endian(b + at, 4);  // the token's bytes with its NUL
  at += 4;
  if (length < 1 || length > std::int64_t(kMaxNameLength) + 1 || size < at + std::size_t(length) + 16)
    return std::nullopt;
  if (b[at + std::size_t(length) - 1] != 0) return std::nullopt;
  MessageHeader h;
  h.token.assign(reinterpret_cast<const char*>(b + at), std::size_t(length) - 1);
  if (h.token.find('\0') != std::string::npos) return std::nullopt;
  at += std::size_t(length);
  h.seq = big_endian(b + at, 8);
  h.step = big_endian(b + at + 8, 8);
  return h;
}

PeerLink::PeerLink(Settings settings, std::ostream& log)
    : s_(std::move(settings)), log_(log), channels_(s_.channel_prefix),
      foreign_(s_.token, [this](const std::string& line) { log_ << s_.role << ": " << line << "\n"; }),
      rejections_([this](const std::string& line) { log_ << s_.role << ": " << line << "\n"; }) {}

PeerLink::~PeerLink() {
  if (bus_ != nullptr)
    for (lcm::Subscription* sub : subs_)
      if (sub != nullptr) bus_->unsubscribe(sub);
}

std::optional<Ending> PeerLink::open() {
  if (s_.bus != nullptr) {
    bus_ = s_.bus;
  } else {
    // The one URL rule (lcm_url.hpp): the parsers refuse a bad URL first; this keeps any
    // other caller from opening one (tcpq:// aborts inside LCM, a ttl above 0 leaves the host).
    if (const auto why = lcm_url_problem(s_.lcm_url))
      return Ending{exit_code::bad_input, "LCM URL \"" + s_.lcm_url + "\": " + *why, false};
    own_bus_ = std::make_unique<lcm::LCM>(s_.lcm_url);
    if (!own_bus_->good())
      return Ending{exit_code::system,
                    "cannot open LCM at " + s_.lcm_url + " (for udpm: is the loopback interface up with a multicast route?)",
                    false};
    bus_ = own_bus_.get();
  }
  net_.emplace(*bus_, s_.faults, s_.role);
  return std::nullopt;
}

void PeerLink::count_undecodable(const std::string& channel, const char* type, const std::string& why,
                                 const void* data, std::size_t size) {
  if (undecodable_[channel]++ == 0)
    log_ << s_.role << ": a message on " << channel << " does not decode as " << type << " (" << why
         << "; another protocol version on this channel?); such messages are counted and ignored\n";
  if (!undecodable_hook_) return;
  // A copy of this run (its header names the run's token) that does not decode is a refused
  // copy of its step: the receiver counts it toward the three-copies rule.
  if (const auto h = peek_state_header(data, size); h && h->token == s_.token) undecodable_hook_(channel, *h, why);
}

bool PeerLink::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  if (bus_->publish(channel, data, static_cast<unsigned int>(size)) == 0) return true;
  if (!fatal_) fatal_ = Ending{exit_code::system, "cannot publish on " + channel + " (LCM at " + url() + ")", true};
  return false;
}

void PeerLink::publish_stop(std::int64_t step, int code, const std::string& reason) {
  if (!net_) return;
  cosimlcm::stop_t m{};
  m.token = s_.token;
  m.sender = s_.role;
  m.step = step;
  m.exit_code = code;
  m.reason = bounded_reason(reason);
  for (int k = 0; k < kStopCopies; ++k) {
    if (k > 0) std::this_thread::sleep_for(kStopSpacing);
    net_->pump();
    publish(channels_.stop, m);
  }
  net_->flush();
  last_stop_ = std::move(m);
}

void PeerLink::republish_stop() {
  if (!net_ || !last_stop_) return;
  publish(channels_.stop, *last_stop_);
  net_->flush();
}

void PeerLink::publish_request(const cosimlcm::resend_t& r) {
  for (int k = 0; k < kResendCopies; ++k) publish(channels_.resend, r);
}

void PeerLink::pump(std::chrono::milliseconds wait) {
  net_->pump();
  const int timeout = static_cast<int>(std::max<std::chrono::milliseconds::rep>(0, wait.count()));
  if (bus_->handleTimeout(timeout) < 0 && !fatal_)
    fatal_ = Ending{exit_code::system, "LCM failed while receiving on " + url(), true};
}

std::int64_t PeerLink::undecodable() const {
  std::int64_t n = 0;
  for (const auto& [channel, k] : undecodable_) n += k;
  return n;
}

std::string PeerLink::counters() const {
  return "undecodable " + std::to_string(undecodable()) + ", " +
         (s_.key ? "unauthenticated " + std::to_string(foreign_.unauthenticated_total()) + " (of foreign), " : "") +
         rejections_.summary() + (net_ && net_->active() ? "; " + net_->summary() : std::string());
}

}  // namespace cosim::protocol
