// The coordinator (DESIGN 2.2; protocol/README.md sections 5-9): the fluid's side of the
// peer protocol over the session layer (protocol/session/), moving through the states of
// protocol/session/run_phase.hpp (handshake, spin-up, free run, iterate, stopping, done).
//
// It owns the step clock's messages: the solid's hello_t and the welcome_t, the lock-step
// inbox of solid_state_t (resends, the three-copies rule, the peer timeout), the solid's
// stop_t (stop_rules.hpp), every fluid_state_t and stop_t the fluid publishes, the per-step
// checks of solid_state_t (substeps, solid time, CGPs in the domain), and the counters.
// What a scheme sends when is the scheme's (fluid/schemes/); the flow is FluidRun's.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/config/scene_config.hpp"
#include "protocol/handshake.hpp"
#include "common/run/exit_codes.hpp"
#include "common/watchdog/watchdog.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/run_phase.hpp"
#include "protocol/session/state_inbox.hpp"
#include "protocol/session/state_outbox.hpp"
#include "protocol/session/session_counters.hpp"
#include "protocol/units.hpp"

namespace cosim::fluid {

class FluidScheme;

class Coordinator {
 public:
  using Phase = protocol::RunPhase;
  using Clock = std::chrono::steady_clock;

  /// @pre scene.coupling; options.token not empty (run_coupled_fluid checks both).
  Coordinator(const FluidScene& scene, const CoupledFluidOptions& options, const FluidScheme& scheme,
              std::ostream& out);
  Coordinator(const Coordinator&) = delete;
  Coordinator& operator=(const Coordinator&) = delete;

  /// Opens the transport and subscribes; an ending (exit code 1) if it cannot.
  std::optional<protocol::Ending> open();
  /// A restart awaits the checkpoint's solid_state_t (its key) from the start, with the
  /// checkpoint's A_T for it; an unreadable file is reported later, by FluidRun's restore.
  void expect_restart(std::int64_t step, std::int64_t key, int time_ratio);
  /// hello_t, the solid's hello_t, the checks of handshake.hpp, welcome_t (three copies).
  std::optional<protocol::Ending> handshake();

  // ---- the states ----
  Phase phase() const { return phases_.phase(); }
  /// Moves to `next`. @throws std::logic_error for a transition the diagram does not have.
  void enter(Phase next) { phases_.enter(next); }
  void done() { phases_.done(); }
  /// The phase of an LB step of the run: SpinUp while the sheets are held, else FreeRun.
  void begin_step(std::int64_t step);

  // ---- solid_state_t in ----
  /// Waits for the awaited solid_state_t (key: step, or the implicit scheme's seq) of the
  /// committed LB step `step`: resends after resend_after_s of silence, the peer timeout,
  /// the solid's stop_t, three refused copies. An ending (stop_t already published).
  std::optional<protocol::Ending> wait_for_solid_state(std::int64_t step);
  /// The awaited message (after wait_for_solid_state); the inbox then awaits the next key.
  cosimlcm::solid_state_t take() { return inbox_.take(); }
  std::int64_t awaited_key() const { return inbox_.awaited(); }
  /// The per-step checks of solid_state_t (section 5): CGP count, substeps and solid time
  /// for LB step `step`, finite numbers, markers inside the fluid, zero impulses at step 0.
  /// An ending (stop_t published) or nothing.
  std::optional<protocol::Ending> check_solid_state(const cosimlcm::solid_state_t& m, std::int64_t step);

  // ---- fluid_state_t and stop_t out ----
  /// fluid_state_t(step, iteration) of the samples after the step and before it (*_start_lb),
  /// with U_b (Eq. 34, lattice units) of the latest health check.
  void publish_fluid_state(std::int64_t step, double bulk_velocity_lb, const std::vector<MarkerSample>& samples,
                           const std::vector<MarkerSample>& start, int iteration = 0);
  /// A fluid_state_t of a checkpoint published again (the parallel scheme's restart).
  void republish(cosimlcm::fluid_state_t m);
  /// The message of `step` among the last ones sent, if kept.
  const cosimlcm::fluid_state_t* sent_state(std::int64_t step) const { return outbox_.find(step); }
  void publish_stop(std::int64_t step, int code, const std::string& reason);
  /// After the success stop_t (the last step): answers each resend_t of the solid with that
  /// stop_t again, until none came for protocol::kClosingQuiet (the solid has it and ended)
  /// or for at most peer_timeout_s (protocol/README.md section 8). How many copies it sent.
  int linger();
  /// Ends the run on the fluid's own error: stop_t to the solid, then end().
  int stop_and_end(const protocol::Ending& e, std::int64_t step);
  /// Ends the run: the counters (after the handshake), the reason kept for the caller.
  int end(const protocol::Ending& e);
  /// The line the launcher reads to run again with a larger A_T ([watchdog] retry).
  void announce_retry(std::int64_t before, int from, int to);

  // ---- what the run knows ----
  const protocol::UnitConverter& units() const { return units_; }
  std::int32_t num_cgps() const { return num_cgps_; }
  std::int64_t fluid_seq() const { return outbox_.seq(); }
  void set_fluid_seq(std::int64_t seq) { outbox_.set_seq(seq); }
  int peer_code() const { return peer_code_; }
  std::int64_t first_step() const { return first_step_; }
  /// The committed LB step whose solid_state_t is (or was last) awaited.
  std::int64_t awaited_step() const { return awaited_step_; }
  void set_first_step(std::int64_t step) { first_step_ = step; }
  std::string counters() const { return protocol::session_counters(link_, inbox_, resends_); }
  const std::string& last_reason() const { return last_reason_; }
  /// The handshake's added-mass numbers of the lightest CGP; none when the solid does not
  /// report its CGPs' mass.
  const std::optional<protocol::AddedMass>& added_mass() const { return added_mass_; }
  /// dA of the lightest CGP (hello_t), dx^2; 0 when not reported.
  double light_cgp_area_lb() const;
  /// Where margins and summaries go ("fluid: ..." lines).
  std::ostream& out() { return out_; }
  /// Called by end() before the counters: the watchdog's margins line, when FluidRun has one.
  void on_end(std::function<void(std::ostream&)> hook) { end_hook_ = std::move(hook); }

 private:
  bool subscribe();
  protocol::Expectation expectation() const;
  void on_hello(cosimlcm::hello_t&& m);
  void on_resend(const cosimlcm::resend_t& m);
  void on_stop(const cosimlcm::stop_t& m);
  void refused_copy(std::int64_t key, const protocol::Rejection& r, const cosimlcm::solid_state_t* m);
  void request_resend(std::int64_t key);
  protocol::Ending refused_ending();
  void added_mass_check(int time_ratio);
  protocol::Hello fluid_hello() const;

  const FluidScene& s_;
  const CouplingSettings& c_;
  const CoupledFluidOptions& o_;
  const FluidScheme& scheme_;
  std::ostream& out_;
  protocol::PeerLink link_;
  const protocol::Channels& ch_;
  protocol::StateInbox<cosimlcm::solid_state_t> inbox_;
  /// fluid_state_t out: the token, the next seq, the last two kept for resends.
  protocol::StateOutbox<cosimlcm::fluid_state_t> outbox_;
  protocol::UnitConverter units_;
  protocol::PhaseMachine phases_;

  std::optional<cosimlcm::hello_t> solid_hello_;
  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<protocol::Ending> stop_;
  int hellos_refused_ = 0;                    ///< solid hello_t refused by the checks
  std::optional<std::string> hello_refusal_;  ///< set after kRejectedCopiesLimit of them
  /// The last refused copy (null when the copies did not decode) once kRejectedCopiesLimit
  /// were refused in a row, and why.
  std::optional<std::pair<std::optional<cosimlcm::solid_state_t>, protocol::Rejection>> refused_state_;
  std::int32_t time_ratio_ = 0;  ///< A_T agreed in the handshake
  std::int32_t num_cgps_ = 0;
  std::int64_t first_step_ = 0;    ///< 0, or the step of --restart
  int restart_ratio_ = 0;          ///< the A_T of the --restart checkpoint
  int peer_code_ = 0;              ///< the exit code of the solid's stop_t
  std::int64_t awaited_step_ = 0;  ///< the committed LB step whose solid_state_t is awaited
  protocol::ResendCounts resends_;
  std::function<void(std::ostream&)> end_hook_;
  std::string last_reason_;
  std::optional<protocol::AddedMass> added_mass_;
  bool lingering_ = false;                   ///< in linger(): resend_t are answered with the stop_t
  Clock::time_point last_request_{};  ///< the solid's last resend_t in linger()
  int stops_again_ = 0;
};

}  // namespace cosim::fluid
