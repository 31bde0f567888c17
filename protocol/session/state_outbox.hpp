// The outgoing state channel of a peer in lock-step (protocol/README.md section 7), the one
// implementation both servers use: each message gets the run's token and the next seq
// (consecutive per sender and channel; a resend keeps it), goes out through the transport,
// and the last ones are kept to answer the peer's resend_t, unchanged, bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <utility>

#include "protocol/session/peer_link.hpp"

namespace cosim::protocol {

template <class Message>
class StateOutbox {
 public:
  static constexpr std::size_t kKept = 2;  ///< section 7: at least the last two

  StateOutbox(PeerLink& link, std::string channel) : link_(link), channel_(std::move(channel)) {}

  /// A message of `step` (and `iteration`) with this run's token and the next seq.
  Message next(std::int64_t step, int iteration = 0) {
    Message m{};
    m.token = link_.token();
    m.seq = seq_++;
    m.step = step;
    m.iteration = iteration;
    return m;
  }
  /// Publishes `m` and keeps it for resends.
  void publish(Message m) {
    link_.publish(channel_, m);  // an LCM error ends the run (PeerLink::fatal)
    sent_.push_back(std::move(m));
    while (sent_.size() > kKept) sent_.pop_front();
  }
  /// A message of a checkpoint published again, this run's token, its seq and content
  /// unchanged; the next seq continues from `next_seq`.
  void republish(Message m, std::int64_t next_seq) {
    m.token = link_.token();
    seq_ = next_seq;
    publish(std::move(m));
  }
  /// The peer's resend_t for `step`: every kept message of it again (the implicit scheme's
  /// iterates of one step share it; the peer drops copies it has had by their seq). How many.
  int answer_resend(std::int64_t step) {
    int n = 0;
    for (const Message& m : sent_)
      if (m.step == step) {
        link_.publish(channel_, m);
        ++n;
      }
    return n;
  }

  /// The kept message of `step`, if any.
  const Message* find(std::int64_t step) const {
    for (const Message& m : sent_)
      if (m.step == step) return &m;
    return nullptr;
  }
  bool empty() const { return sent_.empty(); }
  const Message& last() const { return sent_.back(); }
  /// The seq of the next message.
  std::int64_t seq() const { return seq_; }
  void set_seq(std::int64_t seq) { seq_ = seq; }

 private:
  PeerLink& link_;
  std::string channel_;
  std::int64_t seq_ = 0;
  std::deque<Message> sent_;
};

}  // namespace cosim::protocol
