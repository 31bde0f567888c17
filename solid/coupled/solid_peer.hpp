// The solid's side of the protocol session (protocol/README.md sections 5-9; DESIGN 2.2): a
// thin loop over the session layer (protocol/session/): the transport and the four channels
// the solid listens on, the handshake with the fluid's coordinator, waiting for the awaited
// fluid_state_t with resends and timeouts, the solid_state_t it publishes (the last two kept
// for resends), and stop_t in and out. Which fluid_state_t is awaited, and what counts as the
// run's end, is the coupling scheme's (solid/schemes/solid_scheme.hpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>

#include <Eigen/Core>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/session_counters.hpp"
#include "protocol/session/state_inbox.hpp"
#include "protocol/session/state_outbox.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::solid {

class SolidScheme;
using protocol::Ending;

/// num_cgps, position_lb and impulse_lb of `m`: the columns of x and j.
void set_positions_impulses(cosimlcm::solid_state_t& m, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j);

class SolidPeer {
 public:
  using Clock = std::chrono::steady_clock;
  using FluidInbox = protocol::StateInbox<cosimlcm::fluid_state_t>;
  /// The checks of an accepted fluid_state_t (SolidRun::check): the exit code of a copy
  /// refused too often.
  using Check = std::function<std::optional<Ending>(const cosimlcm::fluid_state_t&)>;

  SolidPeer(const CouplingSettings& coupling, const CoupledSolidOptions& options, const SolidScheme& scheme,
            Check check, std::ostream& out);
  SolidPeer(const SolidPeer&) = delete;
  SolidPeer& operator=(const SolidPeer&) = delete;

  /// Opens the transport (protocol/session/peer_link.hpp) and subscribes to welcome_t,
  /// fluid_state_t, resend_t and stop_t: handlers see only messages of this run that decode
  /// and pass the checks for a solid of `num_cgps` CGPs.
  std::optional<Ending> open(Eigen::Index num_cgps);

  /// Section 6: publishes `hello` every 200 ms until a welcome_t of the
  /// run (refused: 2; none within handshake_timeout_s: 4) and checks it against this solid.
  std::optional<Ending> handshake(const cosimlcm::hello_t& hello);
  std::int64_t total_steps() const { return total_steps_; }
  std::int64_t rigid_steps() const { return rigid_steps_; }

  /// Awaits the fluid_state_t of `key` from now on (the scheme's first, or a restart's).
  void await_from(std::int64_t key) { inbox_.await_from(key); }
  /// The peer was heard now (the start of the lock-step loop).
  void heard() { inbox_.heard(Clock::now()); }

  /// Waits until the awaited fluid_state_t is here, asking for it again after every
  /// resend_after_s of silence (calling `idle` in between); an ending on stop_t, a timeout
  /// or an LCM error.
  std::optional<Ending> wait(const std::function<void()>& idle);
  /// The awaited message (wait() first); the inbox still awaits its key until advance().
  cosimlcm::fluid_state_t awaited() { return inbox_.peek_out(); }
  /// After the awaited message was applied: a copy of the next key held early is offered again.
  void advance() { inbox_.advance(); }
  std::int64_t awaited_key() const { return inbox_.awaited(); }
  bool awaited_received() const { return inbox_.awaited_received(); }

  /// solid_state_t(step) with `substeps`, `solid_time_s`, positions x and impulses j, as
  /// iterate `iteration` (the implicit scheme's; else 0); kept for resends.
  void publish_state(std::int64_t step, int substeps, double solid_time_s, const Eigen::Matrix3Xd& x,
                     const Eigen::Matrix3Xd& j, int iteration);
  /// A restart: `in_flight`, the checkpoint's solid_state_t, published again; solid_state_t
  /// go on from seq `next_seq`.
  void resume(cosimlcm::solid_state_t in_flight, std::int64_t next_seq);
  bool sent_any() const { return outbox_ && !outbox_->empty(); }
  const cosimlcm::solid_state_t& last_sent() const { return outbox_->last(); }
  std::int64_t next_seq() const { return outbox_ ? outbox_->seq() : 0; }
  /// The step of the last solid_state_t published.
  std::int64_t last_step() const { return last_step_; }

  /// An ending found inside a handler or by the transport, if any.
  std::optional<Ending> failure() const;
  /// stop_t with `e`'s code and reason when `e` says so (this solid's own errors).
  void stop(const Ending& e);

  const std::string& token() const { return o_.token; }
  const std::string& channel_prefix() const { return ch_.prefix; }
  std::int64_t hellos() const { return hellos_; }
  /// What the session received, refused, asked for and answered.
  std::string counters() const;

 private:
  /// Dispatches what arrives within `wait` (at most kPoll at a time, never forever).
  void pump(Clock::duration wait);
  /// What a message of the run must satisfy now: the token, this solid's CGP count, the
  /// scheme's steps up to the awaited one + kStepWindow (within the run), A_T, iterations.
  protocol::Expectation expectation() const;
  void request_resend();
  void refused_welcome(const protocol::Rejection& r);
  void refused_copy(std::int64_t key, const protocol::Rejection& r, const cosimlcm::fluid_state_t* m);
  void on_resend(const cosimlcm::resend_t& m);
  void on_stop(cosimlcm::stop_t&& m);
  Ending peer_stop() const;

  const CouplingSettings c_;
  const CoupledSolidOptions& o_;
  const SolidScheme& scheme_;
  const Check check_;
  std::ostream& out_;
  const protocol::Channels ch_;
  Eigen::Index n_ = 0;

  /// The transport: every message in and out goes through it (opened after the model is
  /// built: a --check run needs no token and no bus).
  std::optional<protocol::PeerLink> link_;
  /// fluid_state_t by the scheme's key (the step, or the fluid's seq), the resend timer.
  FluidInbox inbox_;
  int welcomes_refused_ = 0;  ///< welcome_t refused by the checks before one was taken

  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<cosimlcm::stop_t> stop_;
  std::optional<Ending> fatal_;  ///< found inside a handler
  /// solid_state_t out: the token, the next seq, the last two kept for resends.
  std::optional<protocol::StateOutbox<cosimlcm::solid_state_t>> outbox_;
  std::int64_t total_steps_ = 0, rigid_steps_ = 0;
  std::int64_t last_step_ = 0;
  std::int64_t hellos_ = 0;
  protocol::ResendCounts resends_;
  Clock::time_point next_closing_ask_{};  ///< the closing exchange's next resend_t (wait())
};

}  // namespace cosim::solid
