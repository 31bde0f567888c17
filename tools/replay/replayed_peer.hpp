// cosim-replay's peer (docs/replay.md, "How it replays"): it plays the side the replayed
// server talks to, from the log, on the server's in-process bus: the logged hello_t and
// welcome_t, the peer's state messages by causality, its stop_t; it compares what the
// server publishes with the log (tools/replay/compare.hpp). The message order of the
// scheme comes from the protocol's name table (protocol/coupling_scheme.hpp), never from a
// branch on the scheme.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/text/text.hpp"
#include "protocol/coupling_scheme.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/session/peer_link.hpp"
#include "tools/replay/compare.hpp"
#include "tools/replay/log_scan.hpp"
#include "tools/replay/replay.hpp"

namespace cosim::replay {

/// Progress lines (unless quiet) at most this often.
inline constexpr auto kProgressEvery = std::chrono::seconds(2);

/// Unanswerable resend requests in a row (nothing fed in between) after which the server is
/// taken to wait for a message the log does not give: about 3 resend_after of waiting. A
/// server given everything the log holds for it asks at most once before it is fed again.
inline constexpr int kResendsBeforeGap = 3;
/// Copies of a resend_t this close together are one request round (kResendCopies at once).
inline constexpr auto kSameRound = std::chrono::milliseconds(5);

/// The transport settings of the peer the replay plays, on the replayed server's bus.
inline protocol::PeerLink::Settings link_settings(lcm::LCM& bus, const Selected& sel, Side side) {
  protocol::PeerLink::Settings s;
  s.role = side == Side::Fluid ? "solid" : "fluid";
  s.token = sel.token;
  s.channel_prefix = sel.prefix;
  s.bus = &bus;
  return s;
}

/// Plays the peer of the replayed server from the log, on the server's bus. Its handlers
/// run inside the server thread's handle calls (memq:// has one queue per lcm_t), so
/// everything below is touched by that thread only while the server runs, and read by the
/// caller after the thread joined.
///
/// The peer's messages go out by causality, with no knowledge of the scheme (docs/replay.md):
/// the logged peer's state messages in seq order (first copies; a seq missing from the log
/// ends the usable ones), each once the handshake is done and the server has published its
/// own state messages up to the highest seq the log shows before it; the peer's first
/// stop_t likewise, after the peer's messages logged before it. In a deterministic run the
/// server published those before it needed the message, so the replay never waits on
/// itself, whatever the message order of the scheme.
class Peer {
 public:
  Peer(lcm::LCM& bus, LogReader& log, const Selected& sel, Side side, const protocol::MessageOrder& order, bool quiet,
       std::ostream& err)
      : bus_(bus), log_(log), run_(*sel.run), token_(sel.token), side_(side), order_(order), quiet_(quiet), err_(err), link_(link_settings(bus, sel, side), err),
        ch_(link_.channels()) {
    const bool fluid = side_ == Side::Fluid;
    const auto& inputs = fluid ? run_.solid_states : run_.fluid_states;
    for (std::int64_t seq = 0;; ++seq) {
      const auto it = inputs.find(seq);
      if (it == inputs.end()) break;
      feed_.push_back(&it->second);
    }
    if (const auto it = run_.stops.find(peer_role()); it != run_.stops.end()) {
      stop_ = it->second.first;
      error_stop_ = it->second.second;
      for (std::size_t i = 0; stop_ && i < feed_.size(); ++i)
        if (feed_[i]->order < stop_->where.order) stop_after_ = i + 1;
    }
    // The session layer's transport (protocol/session/peer_link.hpp) on the server's bus: the
    // bytes checked before decoding, another run's token dropped; no value checks, so that
    // whatever the server publishes is compared with the log.
    subscribed_ = !link_.open() &&
                  link_.subscribe<cosimlcm::hello_t>(ch_.hello, [this](cosimlcm::hello_t&& m) { on_hello(&m); }) &&
                  link_.subscribe<cosimlcm::welcome_t>(ch_.welcome,
                                                       [this](cosimlcm::welcome_t&& m) { on_welcome(&m); }) &&
                  (fluid ? link_.subscribe<cosimlcm::fluid_state_t>(
                               ch_.fluid_state, [this](cosimlcm::fluid_state_t&& m) { on_fluid_state(&m); })
                         : link_.subscribe<cosimlcm::solid_state_t>(
                               ch_.solid_state, [this](cosimlcm::solid_state_t&& m) { on_solid_state(&m); })) &&
                  link_.subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(&m); });
  }
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;

  bool subscribed() const { return subscribed_; }

  /// After the server returned: what is left on the bus is compared, nothing more is fed.
  void finish() {
    done_ = true;
    while (bus_.handleTimeout(0) > 0) {
    }
  }

  // ---- results ----
  std::int64_t compared = 0, differing = 0, duplicates = 0, resends_answered = 0;
  std::optional<StepResult> first_different;
  std::optional<FieldDiff> max_abs, max_rel;
  std::optional<StepResult> max_abs_at, max_rel_at;  ///< the messages they are in (no diffs kept)
  std::set<std::int64_t> published;         ///< seqs the server published (first copies)
  std::vector<MessageKey> not_in_log;       ///< ... of which the log has no message
  std::optional<std::string> refused;       ///< the handshake's refusal, if any
  bool welcomed = false;                    ///< an accepted welcome_t went out or came back
  std::string log_gap;                      ///< "" or: the input the log lacks
  /// The server was given a stop_t with an error (the logged peer's, or the replay's at
  /// the log's end): the logged run may have ended before what the server published next.
  bool error_stop_given = false;
  std::string failure;                      ///< "" or: the log could not be read during the replay

 private:
  // The server's announcement: the fluid gets the logged solid's hello_t; the solid gets the
  // logged fluid's hello_t and a welcome_t from the coordinator's check (protocol/README.md
  // section 6) of the logged fluid hello_t against the server's own: the logged welcome_t if
  // accepted, else a refusal with the reason.
  void on_hello(const cosimlcm::hello_t* m) {
    if (m->token != token_ || done_) return;
    if (side_ == Side::Fluid) {
      if (m->role == "fluid") link_.publish(ch_.hello, *run_.solid_hello);
      return;
    }
    if (m->role != "solid") return;  // ours, heard back
    const bool first = !welcome_;
    if (first) {
      const protocol::HandshakeResult r = protocol::check_handshake(
          protocol::from_lcm(*run_.fluid_hello), protocol::from_lcm(*m), token_);
      welcome_ = *run_.welcome;
      if (!r.accepted) {
        welcome_->accepted = 0;
        welcome_->reason = r.reason;
        refused = r.reason;
      } else {
        welcomed = true;
      }
      link_.publish(ch_.hello, *run_.fluid_hello);
    }
    link_.publish(ch_.welcome, *welcome_);  // on every hello_t, as the coordinator does
    if (first && welcomed) {
      handshake_done_ = true;
      feed();  // the solid publishes solid_state_t(0) before it awaits anything
    }
  }

  // The fluid's coordinator decided (replaying the fluid): the peer's first messages follow
  // an accepted welcome_t; the fluid now awaits solid_state_t(0).
  void on_welcome(const cosimlcm::welcome_t* m) {
    if (side_ != Side::Fluid || m->token != token_ || seen_welcome_) return;
    seen_welcome_ = true;  // a refusal may be read only after the server returned (finish())
    if (!m->accepted) {
      refused = m->reason;
      return;
    }
    welcomed = true;
    handshake_done_ = true;
    if (feed() == 0) beyond_log(-1, 0);
  }

  void on_fluid_state(const cosimlcm::fluid_state_t* m) {
    if (m->token == token_) output(*m, run_.fluid_states);
  }

  void on_solid_state(const cosimlcm::solid_state_t* m) {
    if (m->token == token_) output(*m, run_.solid_states);
  }

  // The server asks for a peer message again (section 7): every logged one of that step it
  // was fed, bit for bit (in the implicit scheme a step has several); a step not fed yet is
  // ignored. Asked again and again with nothing fed in between, the server waits for a
  // message the log does not give it.
  void on_resend(const cosimlcm::resend_t* m) {
    if (m->token != token_ || done_) return;
    const bool fluid = side_ == Side::Fluid;
    if (m->what != (fluid ? "solid_state" : "fluid_state")) return;
    // A request round is kResendCopies copies sent at once (protocol/README.md 7): one ask.
    const std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now();
    const bool same_round = now - last_request_ < kSameRound;
    last_request_ = now;
    if (same_round) return;
    bool answered = false;
    for (std::size_t i = 0; i < next_; ++i)
      if (feed_[i]->step == m->step) {
        guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, feed_[i]->offset); });
        answered = true;
      }
    if (answered) ++resends_answered;
    if (++resends_since_feed_ >= kResendsBeforeGap && !stopped_)
      end_feeding("the " + std::string(side_name(side_)) + " server waits for a " + peer_type() + " of step " +
                  std::to_string(m->step) + " that the log does not give it (asked " +
                  std::to_string(resends_since_feed_) + " times since the last one fed" + last_fed() + ")");
  }

  /// Compares the first copy of a seq with the log, then feeds what is due.
  template <class Message>
  void output(const Message& m, const std::map<std::int64_t, Logged>& logged) {
    if (!published.insert(m.seq).second) {
      ++duplicates;
      return;
    }
    published_up_to_ = std::max(published_up_to_, m.seq);
    if (const auto it = logged.find(m.seq); it == logged.end()) {
      not_in_log.push_back({m.seq, m.step, m.iteration});
    } else {
      guarded([&] {
        const std::optional<Message> l = decode<Message>(log_.at(static_cast<std::uint64_t>(it->second.offset)));
        if (!l) throw std::runtime_error(log_.path() + ": the logged message of seq " + std::to_string(m.seq) +
                                         " (step " + std::to_string(it->second.step) + ") no longer decodes");
        StepResult r;
        r.seq = m.seq;
        r.step = m.step;
        r.iteration = m.iteration;
        compare(m, *l, r);
        record(r);
      });
    }
    progress(m.step);
    if (feed() == 0) beyond_log(m.step, m.iteration);
  }

  void record(StepResult& r) {
    ++compared;
    if (r.differing == 0) return;
    ++differing;
    if (!first_different) first_different = r;
    if (!max_abs || r.max_abs->abs > max_abs->abs) {
      max_abs = r.max_abs;
      max_abs_at = r;
    }
    if (!max_rel || r.max_rel->rel > max_rel->rel) {
      max_rel = r.max_rel;
      max_rel_at = r;
    }
  }

  /// Publishes the peer's messages that are due (class comment); returns how many.
  int feed() {
    if (done_ || stopped_ || !handshake_done_) return 0;
    const bool fluid = side_ == Side::Fluid;
    int fed = 0;
    while (next_ < feed_.size() && published_up_to_ >= trigger(*feed_[next_]) && !stopped_) {
      guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, feed_[next_]->offset); });
      ++next_;
      ++fed;
      resends_since_feed_ = 0;
    }
    if (stop_ && !stopped_ && next_ >= stop_after_ && published_up_to_ >= trigger(stop_->where)) {
      stopped_ = true;
      error_stop_given = stop_->message.exit_code != 0;
      link_.publish(ch_.stop, stop_->message);
      ++fed;
    }
    return fed;
  }

  /// The server's own seq the log shows before `m`.
  std::int64_t trigger(const Logged& m) const {
    return side_ == Side::Fluid ? m.after_fluid : m.after_solid;
  }

  /// The server published a message (of `step`, `iteration`; -1: the handshake) and nothing
  /// was due. With the log's peer messages all given and no stop_t of the peer in it, the
  /// server has gone past the log: at the solid's last message of the run, a log that lost
  /// the coordinator's stop_t gets stop_t(N, 0); otherwise the server awaits what the log
  /// does not hold.
  void beyond_log(std::int64_t step, std::int32_t iteration) {
    if (stopped_ || done_ || next_ < feed_.size() || stop_) return;
    const std::int64_t total = run_.welcome->total_steps;
    if (side_ == Side::Solid && iteration == 0 && step == order_.final_step(total)) {
      stopped_ = true;
      cosimlcm::stop_t s{};
      s.token = token_;
      s.sender = peer_role();
      s.step = total;
      s.exit_code = 0;
      link_.publish(ch_.stop, s);
      return;
    }
    end_feeding("the log has no " + awaited() + " (nor a stop_t with an error)");
  }

  /// The log gives the server nothing more: the logged run's error stop_t of the peer if
  /// there is one (the run ended there), else a stop_t(4) naming `gap`.
  void end_feeding(const std::string& gap) {
    if (stopped_ || done_) return;
    stopped_ = true;
    error_stop_given = true;
    if (error_stop_) {
      link_.publish(ch_.stop, error_stop_->message);
      return;
    }
    log_gap = gap;
    cosimlcm::stop_t s{};
    s.token = token_;
    s.sender = peer_role();
    s.step = next_ > 0 ? feed_[next_ - 1]->step : 0;
    s.exit_code = 4;
    s.reason = replay_log().prefix() + log_gap;
    link_.publish(ch_.stop, s);
  }

  /// The peer message the server awaits after the log's last usable one: by step where a
  /// step has one message, else by seq.
  std::string awaited() const {
    const std::string type = peer_type();
    if (order_.several_per_step && next_ > 0)
      return type + " of seq " + std::to_string(next_) + " (after step " + std::to_string(feed_[next_ - 1]->step) +
             ", iteration " + std::to_string(feed_[next_ - 1]->iteration) + ")";
    if (next_ > 0) return type + " of step " + std::to_string(feed_[next_ - 1]->step + 1);
    if (side_ == Side::Fluid) return type + " of step 0";
    return type + " of step " +
           std::to_string(order_.first_fluid_step(run_.welcome->rigid_steps));
  }

  std::string last_fed() const {
    if (next_ == 0) return ": none";
    const Logged& l = *feed_[next_ - 1];
    return ": step " + std::to_string(l.step) + (order_.several_per_step ? ", iteration " + std::to_string(l.iteration) : "") +
           ", seq " + std::to_string(next_ - 1);
  }

  /// The side this peer plays: the one the replayed server talks to.
  std::string peer_role() const { return side_ == Side::Fluid ? "solid" : "fluid"; }
  std::string peer_type() const { return side_ == Side::Fluid ? "solid_state_t" : "fluid_state_t"; }

  void publish_logged(const std::string& channel, long offset) {
    const LogEvent& e = log_.at(static_cast<std::uint64_t>(offset));
    // Bit for bit as logged, without the servers' MAC (the replayed server has no key).
    const std::optional<std::size_t> size =
        side_ == Side::Fluid ? message_bytes<cosimlcm::solid_state_t>(e) : message_bytes<cosimlcm::fluid_state_t>(e);
    link_.publish_bytes(channel, e.data.data(), size.value_or(e.data.size()));
  }

  /// Runs `f`; an exception (the log cannot be read again) ends the server with stop_t(1):
  /// exceptions must not cross LCM's C dispatch.
  template <class F>
  void guarded(F&& f) {
    try {
      f();
    } catch (const std::exception& e) {
      if (failure.empty()) failure = protocol::one_line(e.what());
      if (!stopped_) {
        stopped_ = true;
        error_stop_given = true;
        cosimlcm::stop_t s{};
        s.token = token_;
        s.sender = peer_role();
        s.step = next_ > 0 ? feed_[next_ - 1]->step : -1;
        s.exit_code = 1;
        s.reason = replay_log().prefix() + failure;
        link_.publish(ch_.stop, s);
      }
    }
  }

  void progress(std::int64_t step) {
    if (quiet_) return;
    const std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now();
    if (now - last_progress_ < kProgressEvery) return;
    last_progress_ = now;
    replay_log().info(err_) << "step " << step << " of " << run_.welcome->total_steps << ", "
         << compared << " compared, " << differing << " differ";
    err_.flush();
  }

  lcm::LCM& bus_;
  LogReader& log_;
  const RunTraffic& run_;
  const std::string token_;
  const Side side_;
  const protocol::MessageOrder& order_;  ///< the scheme's row of the protocol's name table
  const bool quiet_;
  std::ostream& err_;
  protocol::PeerLink link_;  ///< the session layer's transport, on the server's bus
  const protocol::Channels& ch_;
  bool subscribed_ = false;
  std::optional<cosimlcm::welcome_t> welcome_;  ///< what the solid is answered (solid side)
  /// The peer's logged state messages of seq 0, 1, 2, ... (up to the first the log lacks).
  std::vector<const Logged*> feed_;
  std::size_t next_ = 0;          ///< feed_[next_] goes out next
  std::optional<LoggedStop> stop_, error_stop_;  ///< the peer's first stop_t, first with an error
  std::size_t stop_after_ = 0;    ///< stop_ goes out after feed_[0 .. stop_after_ - 1]
  std::int64_t published_up_to_ = -1;  ///< the server's highest seq published
  int resends_since_feed_ = 0;      ///< resend request rounds since the last message fed
  std::chrono::steady_clock::time_point last_request_{};  ///< the last resend_t's arrival (a round's copies: one)
  bool seen_welcome_ = false, handshake_done_ = false, stopped_ = false, done_ = false;
  std::chrono::steady_clock::time_point last_progress_ = std::chrono::steady_clock::now();
};

}  // namespace cosim::replay
