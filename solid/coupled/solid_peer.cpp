#include "solid/coupled/solid_peer.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "protocol/message_checks.hpp"
#include "protocol/session/interrupt.hpp"
#include "protocol/session/stop_rules.hpp"
#include "protocol/step_sequencer.hpp"
#include "common/text/text.hpp"
#include "solid/schemes/solid_scheme.hpp"

namespace cosim::solid {

namespace {

using protocol::fmt;
using protocol::one_line;

constexpr auto kHelloEvery = std::chrono::milliseconds(200);  // section 6
constexpr auto kPoll = std::chrono::milliseconds(20);  // the longest single wait for LCM, so that timers are checked

SolidPeer::Clock::duration seconds(double s) {
  return std::chrono::duration_cast<SolidPeer::Clock::duration>(std::chrono::duration<double>(s));
}

std::chrono::milliseconds resend_after_ms(const CouplingSettings& c) {
  return std::chrono::milliseconds(std::max<long long>(1, static_cast<long long>(std::floor(c.resend_after_s * 1e3))));
}

std::chrono::milliseconds peer_timeout_ms(const CouplingSettings& c) {
  // Above resend_after_ms whenever resend_after_s < peer_timeout_s (the scene's rule).
  return std::chrono::milliseconds(std::max<long long>(resend_after_ms(c).count() + 1,
                                                       static_cast<long long>(std::ceil(c.peer_timeout_s * 1e3))));
}

}  // namespace

void set_positions_impulses(cosimlcm::solid_state_t& m, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& j) {
  const auto n = static_cast<std::size_t>(x.cols());
  m.num_cgps = static_cast<std::int32_t>(n);
  m.position_lb.assign(n, std::vector<double>(3));
  m.impulse_lb.assign(n, std::vector<double>(3));
  for (std::size_t l = 0; l < n; ++l)
    for (std::size_t c = 0; c < 3; ++c) {
      m.position_lb[l][c] = x(Eigen::Index(c), Eigen::Index(l));
      m.impulse_lb[l][c] = j(Eigen::Index(c), Eigen::Index(l));
    }
}

SolidPeer::SolidPeer(const CouplingSettings& coupling, const CoupledSolidOptions& options, const SolidScheme& scheme,
                     Check check, std::ostream& out)
    : c_(coupling), o_(options), scheme_(scheme), check_(std::move(check)), out_(out), ch_(c_.channel_prefix),
      inbox_(scheme.first_key(0), [&scheme](const cosimlcm::fluid_state_t& m) { return scheme.key(m.seq, m.step); },
             peer_timeout_ms(c_), resend_after_ms(c_)) {}

std::optional<Ending> SolidPeer::open(Eigen::Index num_cgps) {
  n_ = num_cgps;
  protocol::PeerLink::Settings ls;
  ls.role = "solid";
  ls.token = o_.token;
  ls.channel_prefix = c_.channel_prefix;
  ls.lcm_url = c_.lcm_url;
  ls.bus = o_.bus;
  ls.faults = o_.faults;
  ls.key = o_.key;
  link_.emplace(ls, out_);
  if (auto e = link_->open()) return e;
  outbox_.emplace(*link_, ch_.solid_state);
  link_->expect([this] { return expectation(); });
  link_->on_undecodable([this](const std::string& channel, const protocol::MessageHeader& h, const std::string& why) {
    if (channel != ch_.fluid_state) return;
    // A copy of this run that does not decode counts toward the three-copies rule of its key.
    refused_copy(scheme_.key(h.seq, h.step), protocol::Rejection{protocol::RejectCategory::Undecodable, why}, nullptr);
  });
  const bool subscribed =
      link_->subscribe<cosimlcm::welcome_t>(
          ch_.welcome, [this](cosimlcm::welcome_t&& m) {
            if (!welcome_) welcome_ = std::move(m);  // later copies answer our repeated hellos
          },
          [this](const cosimlcm::welcome_t&, const protocol::Rejection& r) { refused_welcome(r); }) &&
      link_->subscribe<cosimlcm::fluid_state_t>(
          ch_.fluid_state,
          [this](cosimlcm::fluid_state_t&& m) {
            if (inbox_.offer(std::move(m), Clock::now()) && welcome_) request_resend();  // a gap: ask at once
          },
          [this](const cosimlcm::fluid_state_t& m, const protocol::Rejection& r) {
            refused_copy(scheme_.key(m.seq, m.step), r, &m);
          }) &&
      link_->subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(m); }) &&
      link_->subscribe<cosimlcm::stop_t>(ch_.stop, [this](cosimlcm::stop_t&& m) { on_stop(std::move(m)); });
  if (!subscribed)
    return Ending{exit_code::system, "cannot subscribe to the channels " + ch_.prefix + "* on " + c_.lcm_url, false};
  return std::nullopt;
}

std::optional<Ending> SolidPeer::failure() const {
  if (fatal_) return fatal_;
  if (link_ && link_->fatal()) return link_->fatal();
  return std::nullopt;
}

// ---- the handshake (section 6) ----

std::optional<Ending> SolidPeer::handshake(const cosimlcm::hello_t& hello) {
  const Clock::time_point deadline = Clock::now() + seconds(c_.handshake_timeout_s);
  Clock::time_point next_hello = Clock::now();
  while (!welcome_) {
    if (const auto e = failure()) return e;
    if (stop_) return peer_stop();
    if (protocol::interrupted())
      return Ending{exit_code::system, protocol::interrupt_reason() + " before the handshake completed", true};
    const Clock::time_point now = Clock::now();
    if (now >= deadline)
      return Ending{exit_code::peer_lost,
                    "no welcome_t on " + ch_.welcome + " within handshake_timeout_s = " +
                        fmt("%g", c_.handshake_timeout_s) + " s (" + std::to_string(hellos_) +
                        " hello_t sent); is the fluid running with the same token, channel "
                        "prefix and LCM URL?",
                    true};
    if (now >= next_hello) {
      link_->publish(ch_.hello, hello);
      ++hellos_;
      next_hello = now + kHelloEvery;
    }
    pump(std::min(next_hello, deadline) - Clock::now());
  }
  const cosimlcm::welcome_t& w = *welcome_;
  if (!w.accepted) {
    const std::string why = one_line(w.reason);
    return Ending{exit_code::bad_input, why.rfind("handshake refused", 0) == 0 ? why : "handshake refused: " + why};
  }
  const auto malformed = [&](const std::string& what) { return Ending{exit_code::bad_input, "welcome_t: " + what, true}; };
  if (w.time_ratio != c_.time_ratio)
    return malformed("time_ratio = " + std::to_string(w.time_ratio) + ", but this solid runs A_T = " +
                     std::to_string(c_.time_ratio) + " ([coupling] time_ratio)");
  const std::string own_scheme(scheme_.name());
  if (!w.scheme.empty() && w.scheme != own_scheme)
    return malformed("scheme = '" + w.scheme + "', but this solid runs the '" + own_scheme +
                     "' coupling scheme ([coupling] scheme)");
  if (w.total_steps < 1) return malformed("total_steps = " + std::to_string(w.total_steps) + ", expected >= 1");
  if (w.rigid_steps < 0) return malformed("rigid_steps = " + std::to_string(w.rigid_steps) + ", expected >= 0");
  total_steps_ = w.total_steps;
  rigid_steps_ = w.rigid_steps;
  return std::nullopt;
}

// ---- the lock-step loop (sections 5, 7, 8) ----

std::optional<Ending> SolidPeer::wait(const std::function<void()>& idle) {
  while (!inbox_.ready()) {
    if (const auto e = failure()) return e;
    if (stop_) return peer_stop();
    // SIGINT or SIGTERM to the solid alone (run-coupled.sh interrupts the fluid, whose
    // stop_t then ends this side at the same step): stop here, after the last step sent.
    if (protocol::interrupted())
      return Ending{exit_code::system, protocol::interrupt_reason() + " after step " + std::to_string(last_step_),
                    true};
    // Its part of the last step sent, the solid awaits only the coordinator's stop_t: it
    // asks every kClosingAsk (the coordinator lingers while asked; docs/reliability.md).
    const bool closing = scheme_.at_end(last_step_, total_steps_);
    pump(closing ? std::chrono::duration_cast<Clock::duration>(protocol::kClosingAsk / 5) : kPoll);
    if (inbox_.ready() || stop_ || failure()) continue;
    if (closing && Clock::now() >= next_closing_ask_) {
      if (next_closing_ask_ != Clock::time_point{}) request_resend();
      next_closing_ask_ = Clock::now() + protocol::kClosingAsk;
    }
    switch (inbox_.poll(Clock::now())) {
      case protocol::PeerWatch::Action::Wait:
        break;
      case protocol::PeerWatch::Action::Resend:
        request_resend();
        break;
      case protocol::PeerWatch::Action::GiveUp:
        return Ending{exit_code::peer_lost,
                      "the fluid was silent for " + fmt("%g", c_.peer_timeout_s) +
                          " s (peer_timeout_s) while the solid waited for fluid_state_t of step " +
                          std::to_string(scheme_.awaited_step(inbox_.awaited(), last_step_)) + " on " +
                          ch_.fluid_state + " (" + std::to_string(inbox_.watch().resends_since_heard()) +
                          " resend_t sent)",
                      true};
    }
    idle();
  }
  return std::nullopt;
}

void SolidPeer::pump(Clock::duration wait) {
  link_->pump(std::clamp(std::chrono::duration_cast<std::chrono::milliseconds>(wait), std::chrono::milliseconds(0), kPoll));
}

protocol::Expectation SolidPeer::expectation() const {
  protocol::Expectation e;
  e.token = o_.token;
  e.num_cgps = static_cast<std::int32_t>(n_);
  e.lowest_step = scheme_.lowest_fluid_step();
  e.highest_step = std::min<std::int64_t>(last_step_ + 1 + protocol::kStepWindow, scheme_.final_step(total_steps_));
  e.time_ratio = c_.time_ratio;
  e.max_iterations = scheme_.iterations_allowed();
  return e;
}

// ---- publishing ----

void SolidPeer::publish_state(std::int64_t step, int substeps, double solid_time_s, const Eigen::Matrix3Xd& x,
                              const Eigen::Matrix3Xd& j, int iteration) {
  cosimlcm::solid_state_t m = outbox_->next(step, iteration);
  m.substeps = substeps;
  m.solid_time_s = solid_time_s;
  set_positions_impulses(m, x, j);
  outbox_->publish(std::move(m));  // an LCM error ends the run (failure())
  last_step_ = step;
}

void SolidPeer::resume(cosimlcm::solid_state_t in_flight, std::int64_t next_seq) {
  last_step_ = in_flight.step;
  outbox_->republish(std::move(in_flight), next_seq);
}

void SolidPeer::request_resend() {
  cosimlcm::resend_t r{};
  r.token = o_.token;
  r.step = scheme_.awaited_step(inbox_.awaited(), last_step_);
  r.what = "fluid_state";
  link_->publish_request(r);
  ++resends_.asked;
}

void SolidPeer::stop(const Ending& e) {
  if (e.publish_stop && link_) link_->publish_stop(last_step_, e.code, one_line(e.reason));
}

// ---- receiving ----

/// The coordinator answers every hello_t with its welcome_t: only refused copies
/// (kRejectedCopiesLimit in a row) end the run, naming the field.
void SolidPeer::refused_welcome(const protocol::Rejection& r) {
  if (!welcome_ && ++welcomes_refused_ >= protocol::kRejectedCopiesLimit && !fatal_)
    fatal_ = Ending{exit_code::bad_input,
                    r.what + " (" + std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)", true};
}

/// A copy of fluid_state_t that was refused (the value checks, or bytes of this run that do
/// not decode; `m` is null then): counted, never applied. A refused copy of the awaited key is
/// asked for again at once; after kRejectedCopiesLimit refused copies in a row the run ends,
/// naming the field, with the check's code where it applies (2, or 3 for a non-finite number
/// or rho <= 0), else 2.
void SolidPeer::refused_copy(std::int64_t key, const protocol::Rejection& r, const cosimlcm::fluid_state_t* m) {
  if (!welcome_ || !welcome_->accepted || fatal_) return;
  switch (inbox_.refused(key, m == nullptr)) {
    case FluidInbox::Refusal::Ignore:
      return;
    case FluidInbox::Refusal::AskAgain:
      request_resend();
      return;
    case FluidInbox::Refusal::GiveUp:
      break;
  }
  if (m != nullptr)
    if (auto e = check_(*m)) {
      fatal_ = *e;
      return;
    }
  fatal_ = Ending{exit_code::bad_input,
                  "fluid_state_t of step " + std::to_string(m != nullptr ? m->step : key) + ": " + r.detail() + " (" +
                      std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)",
                  true};
}

void SolidPeer::on_resend(const cosimlcm::resend_t& m) {
  if (m.what != "solid_state") return;  // our own request for fluid_state, heard back
  ++resends_.requests;
  // Every kept message of that step (the implicit scheme's iterates of one step share it;
  // the fluid drops the copies it has had by their seq).
  resends_.answered += outbox_->answer_resend(m.step);  // unchanged: same seq, bit for bit
  // A step not reached yet (it comes when ready) or no longer kept: ignored.
}

/// The coordinator's stop_t, if it fits the run (protocol/session/stop_rules.hpp): exit code 0
/// only at the run's last step, once this solid has sent its part of it (the scheme's end).
void SolidPeer::on_stop(cosimlcm::stop_t&& m) {
  const bool at_end = scheme_.at_end(last_step_, total_steps_);
  const protocol::StopFit fit = protocol::fit_stop(m, {"solid", total_steps_, at_end});
  if (fit.verdict == protocol::StopVerdict::Refuse) {
    link_->refuse(ch_.stop, *fit.rejection);
    return;
  }
  if (!stop_) stop_ = std::move(m);
}

Ending SolidPeer::peer_stop() const {
  const cosimlcm::stop_t& m = *stop_;
  if (m.exit_code == exit_code::ok) return Ending{exit_code::ok, "", false};
  return Ending{exit_code::peer_lost,
                "the fluid stopped the run at step " + std::to_string(m.step) + " with exit code " +
                    std::to_string(m.exit_code) + ": " +
                    (m.reason.empty() ? std::string("(no reason given)") : one_line(m.reason)),
                false};
}

std::string SolidPeer::counters() const {
  if (!link_) return "no transport opened";
  return protocol::session_counters(*link_, inbox_, resends_);
}

}  // namespace cosim::solid
