// The receiving side of the lock-step protocol (DESIGN 2.2), transport-free: UDP may lose,
// duplicate or reorder messages, so every message carries its LB step, a sequence number
// and the run token. The LCM handlers ask these classes what to do with each message:
//
//   StepSequencer   which step the consumer waits for; Accept / Duplicate / Stale / Early
//   EarlyBuffer<P>  holds messages for later steps until they are due (optional helper)
//   PeerWatch       when to re-request the awaited message, when to give up on the peer
//   ForeignCounter  drops (and counts) messages that carry another run's token
//
// Time is passed in explicitly (no clock is read here), so the tests need no sleeping.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <utility>

namespace cosim::protocol {

/// Lock-step sequencing of one incoming channel.
///
/// The consumer waits for exactly expected_step(). Each arriving message is offered with its
/// step and its sequence number `seq` (the sender's message counter on that channel;
/// a resend republishes a message unchanged, its seq included; protocol/README.md 7):
///  - Accept:    step == expected_step(), the first copy: apply it (exactly once).
///  - Duplicate: step == expected_step() again after an Accept: drop it (handlers are
///               idempotent per step).
///  - Stale:     step < expected_step(): already consumed; drop it.
///  - Early:     step > expected_step(): a later message overtook the awaited one. If
///               !expected_received(), the awaited message was lost or delayed: the consumer
///               sends a resend request for expected_step() (missing_expected() says so).
///               The consumer may keep the early message (EarlyBuffer) and offer it again
///               after advance(); the sequencer itself holds no payloads.
/// A seq below the highest seq seen so far is counted as reordered() (diagnostic only: the
/// verdict depends on the step alone).
class StepSequencer {
 public:
  enum class Verdict { Accept, Duplicate, Stale, Early };

  /// @post expected_step() == first_step, expected_received() == false, all counters 0.
  explicit StepSequencer(std::int64_t first_step);

  /// Classifies one arriving message and counts it.
  /// @pre  none (any step and seq).
  /// @post Accept is returned at most once per expected step; after it,
  ///       expected_received() is true. Counters: one of accepted(), duplicates(), stale(),
  ///       early() has grown by one.
  Verdict offer(std::int64_t step, std::int64_t seq);

  /// The step the consumer waits for.
  std::int64_t expected_step() const { return expected_; }

  /// Whether Accept was returned for expected_step() (since the last advance()).
  bool expected_received() const { return received_; }

  /// Whether a later step arrived while expected_step() is still missing: the consumer
  /// should request a resend of expected_step().
  bool missing_expected() const { return !received_ && highest_step_seen_ > expected_; }

  /// Moves on after the consumer has applied expected_step().
  /// @pre  expected_received() (else std::logic_error: a step would be skipped).
  /// @post expected_step() is one larger; expected_received() is false.
  void advance();

  std::int64_t accepted() const { return accepted_; }
  std::int64_t duplicates() const { return duplicates_; }
  std::int64_t stale() const { return stale_; }
  std::int64_t early() const { return early_; }
  std::int64_t reordered() const { return reordered_; }

 private:
  std::int64_t expected_;
  bool received_ = false;
  std::int64_t highest_step_seen_;
  std::optional<std::int64_t> highest_seq_;
  std::int64_t accepted_ = 0, duplicates_ = 0, stale_ = 0, early_ = 0, reordered_ = 0;
};

/// Optional holder for messages that arrived Early, keyed by step, bounded.
///
/// Usage: on Early, store(step, msg); after advance(), if take(expected_step()) yields a
/// message, offer it to the sequencer again (it is then Accept). One copy per step is kept
/// (the first); when full, the steps nearest to being consumed win.
template <class Payload>
class EarlyBuffer {
 public:
  /// @pre capacity >= 1 (0 is treated as 1).
  explicit EarlyBuffer(std::size_t capacity = 8) : capacity_(capacity > 0 ? capacity : 1) {}

  /// @post returns true if `payload` is now held for `step`; false if a copy for that step
  ///       was already held, or the buffer is full of nearer steps.
  bool store(std::int64_t step, Payload payload) {
    if (held_.count(step) != 0) return false;
    if (held_.size() >= capacity_) {
      const auto last = std::prev(held_.end());
      if (last->first < step) return false;
      held_.erase(last);
    }
    held_.emplace(step, std::move(payload));
    return true;
  }

  /// @post the message for `step` (if any) is returned and no longer held.
  std::optional<Payload> take(std::int64_t step) {
    const auto it = held_.find(step);
    if (it == held_.end()) return std::nullopt;
    std::optional<Payload> out(std::move(it->second));
    held_.erase(it);
    return out;
  }

  /// The message held for `step`, still held; null if none.
  Payload* find(std::int64_t step) {
    const auto it = held_.find(step);
    return it == held_.end() ? nullptr : &it->second;
  }

  /// @post no message for a step below `step` is held.
  void drop_before(std::int64_t step) { held_.erase(held_.begin(), held_.lower_bound(step)); }

  /// What is held, by step.
  const std::map<std::int64_t, Payload>& held() const { return held_; }

  std::size_t size() const { return held_.size(); }

 private:
  std::size_t capacity_;
  std::map<std::int64_t, Payload> held_;
};

/// Watches one peer for silence.
///
/// poll() answers Resend each time `resend_after` passes without news (counted from the
/// last heard() or the last Resend), and GiveUp once `timeout` has passed since the last
/// heard(); GiveUp persists until heard() again. The clock starts at the first heard() or,
/// if poll() comes first, at the first poll().
class PeerWatch {
 public:
  using clock = std::chrono::steady_clock;
  using time_point = clock::time_point;
  enum class Action { Wait, Resend, GiveUp };

  /// @pre  0 < resend_after < timeout (else std::invalid_argument naming both).
  PeerWatch(std::chrono::milliseconds timeout, std::chrono::milliseconds resend_after);

  /// A message from the peer arrived at `now`.
  /// @post the silence counts from `now`; resends_since_heard() == 0.
  void heard(time_point now);

  /// What to do at `now`.
  /// @pre  `now` does not go back in time from earlier calls.
  /// @post Resend at most once per resend_after of silence; GiveUp iff
  ///       now - (last heard) >= timeout.
  Action poll(time_point now);

  /// Resend answers since the last heard().
  int resends_since_heard() const { return resends_; }

  std::chrono::milliseconds timeout() const { return timeout_; }
  std::chrono::milliseconds resend_after() const { return resend_after_; }

 private:
  std::chrono::milliseconds timeout_;
  std::chrono::milliseconds resend_after_;
  std::optional<time_point> last_heard_;
  time_point next_resend_{};
  int resends_ = 0;
};

/// Counts messages that carry another run's token (DESIGN 2.2: ignored and counted, never
/// applied), per channel. The log hook gets one line the first time a channel sees a
/// foreign token, and never again for that channel.
class ForeignCounter {
 public:
  using LogHook = std::function<void(const std::string& line)>;

  /// @pre  `run_token` is not empty (else std::invalid_argument).
  explicit ForeignCounter(std::string run_token, LogHook log = {});

  /// @return true if `token` is this run's (apply the message); false if it is foreign
  ///         (drop it).
  /// @post   a foreign message adds one to count(channel) and total(); the log hook is called
  ///         once per channel, on its first foreign message.
  bool admit(const std::string& channel, const std::string& token);

  /// A message whose MAC does not verify under the run's key (message_auth.hpp): counted
  /// as foreign; the log hook is called once per channel, on the first such message.
  void unauthenticated(const std::string& channel);

  std::int64_t count(const std::string& channel) const;
  std::int64_t total() const { return total_; }
  /// Of total(): the messages refused for their MAC.
  std::int64_t unauthenticated_total() const { return unauthenticated_; }
  const std::map<std::string, std::int64_t>& by_channel() const { return counts_; }

 private:
  std::string run_token_;
  LogHook log_;
  std::map<std::string, std::int64_t> counts_;
  std::map<std::string, std::int64_t> unauthenticated_by_channel_;
  std::int64_t total_ = 0, unauthenticated_ = 0;
};

}  // namespace cosim::protocol
