// The incoming state channel of a peer in lock-step (protocol/README.md sections 7-8a;
// DESIGN 2.2), the one implementation both servers use: which key is awaited (the step, or
// in the implicit scheme the peer's seq), the copies held until due, refused copies of the
// awaited key (kRejectedCopiesLimit in a row end the run, naming the field), and when to ask
// for a resend or give up on a silent peer. Transport-free: the session's handlers offer
// what passed the gate (peer_link.hpp), and time is passed in.
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

#include "protocol/message_checks.hpp"
#include "protocol/step_sequencer.hpp"

namespace cosim::protocol {

template <class Message>
class StateInbox {
 public:
  using Clock = std::chrono::steady_clock;
  /// What the sequencer orders a message by: its step, or its seq (several per step).
  using KeyOf = std::function<std::int64_t(const Message&)>;
  /// What a refused copy of the awaited key asks for.
  enum class Refusal { Ignore, AskAgain, GiveUp };

  static constexpr std::size_t kHeld = 8;  ///< copies held until due, the nearest keys first

  StateInbox(std::int64_t first_key, KeyOf key_of, std::chrono::milliseconds timeout,
             std::chrono::milliseconds resend_after)
      : seq_(first_key), key_of_(std::move(key_of)), watch_(timeout, resend_after) {}

  /// Awaits `key` from now on (a restart, or the first key once the scheme is known): held
  /// copies below it are dropped, the rest offered again.
  void await_from(std::int64_t key) {
    seq_ = StepSequencer(key);
    held_.drop_before(key);
    for (const auto& [k, m] : held_.held()) seq_.offer(k, m.seq);
    refused_ = undecodable_ = 0;
  }

  /// A message that passed the checks, at `now`. @return true when a later key arrived
  /// while the awaited one is missing: ask for it at once.
  bool offer(Message m, Clock::time_point now) {
    watch_.heard(now);
    const std::int64_t key = key_of_(m);
    const StepSequencer::Verdict v = seq_.offer(key, m.seq);
    if (v == StepSequencer::Verdict::Accept || v == StepSequencer::Verdict::Early) held_.store(key, std::move(m));
    return v == StepSequencer::Verdict::Early && seq_.missing_expected();
  }

  /// A refused copy of `key`: one that failed the value checks, or (`undecodable`) bytes
  /// whose header names this run but that do not decode. Counted when it is the awaited
  /// key, not had yet, each kind in its own tally; the kRejectedCopiesLimit-th of a kind in
  /// a row gives up (the caller ends the run naming the field), so a peer that answers
  /// every resend with bytes that do not decode gets a clear error, not a silent timeout.
  Refusal refused(std::int64_t key, bool undecodable = false) {
    if (key != seq_.expected_step() || seq_.expected_received()) return Refusal::Ignore;
    int& tally = undecodable ? undecodable_ : refused_;
    return ++tally >= kRejectedCopiesLimit ? Refusal::GiveUp : Refusal::AskAgain;
  }

  /// Whether the awaited message is here.
  bool ready() const { return held_.held().count(seq_.expected_step()) != 0; }

  /// The awaited message (ready() first); the inbox then awaits the next key, and a copy of
  /// it held early is offered again, now due.
  Message take() {
    Message m = std::move(*held_.find(seq_.expected_step()));
    advance();
    return m;
  }

  /// The awaited message (ready() first), moved out while the sequencer still awaits its
  /// key (a checkpoint written while it is applied counts it as received); advance() next.
  Message peek_out() { return std::move(*held_.find(seq_.expected_step())); }

  /// Moves on after the awaited message was applied (see take()).
  void advance() {
    held_.drop_before(seq_.expected_step() + 1);
    seq_.advance();
    refused_ = undecodable_ = 0;
    if (const Message* next = held_.find(seq_.expected_step())) seq_.offer(seq_.expected_step(), next->seq);
  }

  /// Silence: Resend after every resend_after without news, GiveUp after the timeout.
  PeerWatch::Action poll(Clock::time_point now) { return watch_.poll(now); }
  void heard(Clock::time_point now) { watch_.heard(now); }

  std::int64_t awaited() const { return seq_.expected_step(); }
  bool awaited_received() const { return seq_.expected_received(); }
  const StepSequencer& sequencer() const { return seq_; }
  const PeerWatch& watch() const { return watch_; }

  /// "duplicates N, stale N, early N".
  std::string counters() const {
    return "duplicates " + std::to_string(seq_.duplicates()) + ", stale " + std::to_string(seq_.stale()) +
           ", early " + std::to_string(seq_.early());
  }

 private:
  StepSequencer seq_;
  KeyOf key_of_;
  PeerWatch watch_;
  EarlyBuffer<Message> held_{kHeld};  ///< copies held until due, the nearest keys first
  int refused_ = 0, undecodable_ = 0;  ///< refused copies of the awaited key, by kind
};

}  // namespace cosim::protocol
