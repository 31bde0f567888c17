#include "fluid/coupled/coordinator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "protocol/handshake.hpp"
#include "protocol/session/interrupt.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/session/announcement.hpp"
#include "protocol/session/stop_rules.hpp"
#include "common/text/text.hpp"
#include "common/watchdog/watchdog.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/schemes/fluid_scheme.hpp"

namespace cosim::fluid {

namespace {

using Clock = std::chrono::steady_clock;
using protocol::Ending;
namespace exit_code = protocol::exit_code;
constexpr const char* kFluidModel = "d3q19-bgk-guo";

std::chrono::milliseconds ms(double seconds) {
  return std::chrono::milliseconds(static_cast<long long>(seconds * 1000.0));
}

protocol::PeerLink::Settings link_settings(const CouplingSettings& c, const CoupledFluidOptions& o) {
  protocol::PeerLink::Settings s;
  s.role = "fluid";
  s.token = o.token;
  s.channel_prefix = o.channel_prefix.empty() ? c.channel_prefix : o.channel_prefix;
  s.lcm_url = o.lcm_url.empty() ? c.lcm_url : o.lcm_url;
  s.bus = o.bus;
  s.faults = o.faults;
  s.key = o.key;
  return s;
}

}  // namespace

Coordinator::Coordinator(const FluidScene& scene, const CoupledFluidOptions& options, const FluidScheme& scheme,
                         std::ostream& out)
    : s_(scene), c_(*scene.coupling), o_(options), scheme_(scheme), out_(out), link_(link_settings(c_, options), out),
      ch_(link_.channels()),
      inbox_(0, [this](const cosimlcm::solid_state_t& m) { return scheme_.key_of(m); }, ms(c_.peer_timeout_s),
             ms(c_.resend_after_s)),
      outbox_(link_, ch_.fluid_state) {
  units_ = protocol::UnitConverter(unit_inputs(scene));  // with the scene's medium and A_T
}

// ---- the states ----

void Coordinator::begin_step(std::int64_t step) { enter(step < c_.rigid_steps ? Phase::SpinUp : Phase::FreeRun); }

// ---- the handshake (section 6) ----

std::optional<Ending> Coordinator::open() {
  if (auto e = link_.open()) return e;
  if (!subscribe())
    return Ending{exit_code::system, "cannot subscribe to the channels " + ch_.prefix + "* on " + link_.url(), false};
  return std::nullopt;
}

void Coordinator::expect_restart(std::int64_t step, std::int64_t key, int time_ratio) {
  inbox_.await_from(key);
  restart_ratio_ = time_ratio;
  first_step_ = step;
}

protocol::Hello Coordinator::fluid_hello() const {
  protocol::Hello h =
      protocol::announcement("fluid", o_.token, kFluidModel, s_.path, c_.scheme.scheme, units_, c_.time_ratio);
  h.stable_dt_cg_s = 0.0;  // the solid's fields
  h.num_cgps = 0;
  return h;
}

std::optional<Ending> Coordinator::handshake() {
  const protocol::Hello mine = fluid_hello();
  link_.publish(ch_.hello, protocol::to_lcm(mine));
  const Clock::time_point deadline = Clock::now() + ms(c_.handshake_timeout_s);
  while (!solid_hello_ && !hello_refusal_) {
    if (stop_) return stop_;
    if (protocol::interrupted()) {
      const std::string why = protocol::interrupt_reason() + " before the handshake completed";
      publish_stop(0, exit_code::system, why);
      return Ending{exit_code::system, why, false};
    }
    if (Clock::now() > deadline) {
      publish_stop(0, exit_code::peer_lost, "no solid hello_t within the handshake timeout");
      return Ending{exit_code::peer_lost, "no solid announced itself on " + ch_.hello + " within " +
                                               std::to_string(c_.handshake_timeout_s) + " s",
                    false};
    }
    link_.pump(std::chrono::milliseconds(50));
  }
  // A solid whose hello_t failed the message checks kRejectedCopiesLimit times in a row
  // is refused with the reason (protocol/README.md section 8a).
  const protocol::HandshakeResult r =
      hello_refusal_ ? protocol::HandshakeResult{false, "handshake refused: " + *hello_refusal_, 0}
                     : protocol::check_handshake(mine, protocol::from_lcm(*solid_hello_), o_.token);
  welcome_ = cosimlcm::welcome_t{};
  welcome_->token = o_.token;
  welcome_->accepted = r.accepted ? 1 : 0;
  welcome_->reason = protocol::bounded_reason(r.reason);
  welcome_->total_steps = s_.steps;
  welcome_->rigid_steps = c_.rigid_steps;
  welcome_->time_ratio = r.accepted ? r.time_ratio : c_.time_ratio;
  welcome_->scheme = protocol::scheme_name(c_.scheme.scheme);
  for (int k = 0; k < 3; ++k) {
    link_.publish(ch_.welcome, *welcome_);
    if (!r.accepted) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!r.accepted) {
    if (r.stable_time_ratio > 0) announce_retry(0, c_.time_ratio, r.stable_time_ratio);
    return Ending{exit_code::bad_input, r.reason, false};
  }
  num_cgps_ = solid_hello_->num_cgps;
  time_ratio_ = r.time_ratio;
  fluid_log().info(out_) << "handshake accepted: solid model " << solid_hello_->model << ", " << num_cgps_
                         << " CGPs, A_T = " << r.time_ratio << ", " << s_.steps << " LB steps (" << c_.rigid_steps
                         << " rigid)";
  added_mass_check(r.time_ratio);
  inbox_.heard(Clock::now());
  return std::nullopt;
}

/// The added-mass check at start-up (common/watchdog/watchdog.hpp): one line with the lightest
/// CGP's numbers, a warning when the substeps cannot resolve the fluid's reaction on it.
void Coordinator::added_mass_check(int time_ratio) {
  const double m = solid_hello_->light_cgp_mass_kg, a = solid_hello_->light_cgp_area_m2;
  if (!(m > 0.0 && a > 0.0)) {
    fluid_log().info(out_) << "added mass: the solid does not report its CGPs' mass (no check)";
    return;
  }
  const protocol::AddedMass am = protocol::added_mass(m, a, units_.air_density_kg_m3(), units_.dx_m(), time_ratio);
  added_mass_ = am;
  const std::string warning = protocol::added_mass_warning(am, s_.watchdog.relaxation_substeps_min, time_ratio);
  if (!warning.empty())
    fluid_log().warning(out_) << warning;
  else
    fluid_log().info(out_) << "added mass: the lightest CGP has m / (rho_air dA dx) = "
                           << protocol::fmt("%.4g", am.mass_ratio) << "; the fluid's reaction relaxes it in "
                           << protocol::fmt("%.4g", am.relaxation_substeps)
                           << " substeps (watchdog.relaxation_substeps_min = "
                           << protocol::fmt("%g", s_.watchdog.relaxation_substeps_min) << ")";
}

double Coordinator::light_cgp_area_lb() const {
  const double a = solid_hello_ ? solid_hello_->light_cgp_area_m2 : 0.0;
  return a > 0.0 && std::isfinite(a) ? a / (units_.dx_m() * units_.dx_m()) : 0.0;
}

/// The line the launcher reads to run again with a larger A_T ([watchdog] retry): the new
/// A_T (`to`, or `from` times retry_factor), the step before which its checkpoint must be,
/// and the number of retries allowed.
void Coordinator::announce_retry(std::int64_t before, int from, int to) {
  const protocol::WatchdogSettings& w = s_.watchdog;
  if (!w.retry) return;
  const long long next = to > 0 ? to : static_cast<long long>(from) * w.retry_factor;
  if (next > 1000000) {
    fluid_log().info(out_) << "watchdog: no retry: A_T = " << next << " would exceed 1000000";
    return;
  }
  fluid_log().info(out_)
      << "watchdog retry: time_ratio = " << next << " ("
      << (to > 0 ? "the smallest stable A_T" : "A_T " + std::to_string(from) + " x " + std::to_string(w.retry_factor))
      << "), from the newest checkpoint before step " << before << ", at most " << w.retry_max
      << " retries ([watchdog] retry)";
}

// ---- receiving (sections 7, 8, 8a) ----

/// The four channels the fluid listens on, through the session's gate (peer_link.hpp):
/// handlers see only messages of this run that decode and pass the value checks.
bool Coordinator::subscribe() {
  link_.expect([this] { return expectation(); });
  link_.on_undecodable([this](const std::string& channel, const protocol::MessageHeader& h, const std::string& why) {
    // A hello_t of this run that does not decode (a solid of another protocol version): the
    // handshake is refused with the reason after kRejectedCopiesLimit copies, not waited out.
    if (channel == ch_.hello && !solid_hello_ && !hello_refusal_ &&
        ++hellos_refused_ >= protocol::kRejectedCopiesLimit)
      hello_refusal_ = "the solid's hello_t does not decode: " + why +
                       " (a solid of another protocol version? this fluid speaks protocol " +
                       std::string(protocol::kProtocolVersion) + ", protocol/README.md)";
    if (channel != ch_.solid_state) return;
    // A copy of this run that does not decode counts toward the three-copies rule of its step.
    cosimlcm::solid_state_t header{};
    header.seq = h.seq;
    header.step = h.step;
    refused_copy(scheme_.key_of(header), protocol::Rejection{protocol::RejectCategory::Undecodable, why}, nullptr);
  });
  return link_.subscribe<cosimlcm::hello_t>(
             ch_.hello, [this](cosimlcm::hello_t&& m) { on_hello(std::move(m)); },
             [this](const cosimlcm::hello_t&, const protocol::Rejection& r) {
               if (!solid_hello_ && ++hellos_refused_ >= protocol::kRejectedCopiesLimit && !hello_refusal_)
                 hello_refusal_ = r.what;
             }) &&
         link_.subscribe<cosimlcm::solid_state_t>(
             ch_.solid_state,
             [this](cosimlcm::solid_state_t&& m) {
               if (inbox_.offer(std::move(m), Clock::now()) && welcome_ && welcome_->accepted)
                 request_resend(inbox_.awaited());  // a gap: ask at once
             },
             [this](const cosimlcm::solid_state_t& m, const protocol::Rejection& r) {
               refused_copy(scheme_.key_of(m), r, &m);
             }) &&
         link_.subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(m); }) &&
         link_.subscribe<cosimlcm::stop_t>(ch_.stop, [this](cosimlcm::stop_t&& m) { on_stop(m); });
}

/// What a message of the run must satisfy now: the token, the handshake's CGP count, the
/// steps from 0 to the scheme's window (within the run), A_T.
protocol::Expectation Coordinator::expectation() const {
  protocol::Expectation e;
  e.token = o_.token;
  e.num_cgps = num_cgps_;
  e.lowest_step = 0;
  e.highest_step = scheme_.highest_solid_step(inbox_.awaited(), awaited_step_, s_.steps);
  e.time_ratio = time_ratio_;
  // The restart's first solid_state_t was computed with the checkpoint's A_T
  // (check_solid_state holds it to that for its step).
  if (first_step_ > 0 && restart_ratio_ > 0 && restart_ratio_ != time_ratio_ &&
      scheme_.restart_message_has_checkpoint_ratio())
    e.restart_time_ratio = restart_ratio_;
  e.max_iterations = c_.scheme.iterations_allowed();
  return e;
}

void Coordinator::on_hello(cosimlcm::hello_t&& m) {
  if (m.role != "solid") return;  // our own announcement
  inbox_.heard(Clock::now());
  if (!solid_hello_ && !hello_refusal_) solid_hello_ = std::move(m);
  else if (welcome_) link_.publish(ch_.welcome, *welcome_);  // a lost welcome
}

/// A copy of solid_state_t that was refused (the value checks, or bytes of this run that do
/// not decode; `m` is null then): counted, never applied. A refused copy of the awaited key
/// is asked for again at once; after kRejectedCopiesLimit refused copies of a kind in a row
/// the run ends (wait_for_solid_state).
void Coordinator::refused_copy(std::int64_t key, const protocol::Rejection& r, const cosimlcm::solid_state_t* m) {
  if (!welcome_ || !welcome_->accepted || refused_state_) return;
  using Refusal = protocol::StateInbox<cosimlcm::solid_state_t>::Refusal;
  switch (inbox_.refused(key, m == nullptr)) {
    case Refusal::Ignore:
      return;
    case Refusal::AskAgain:
      request_resend(key);
      return;
    case Refusal::GiveUp:
      refused_state_.emplace(m != nullptr ? std::optional<cosimlcm::solid_state_t>(*m) : std::nullopt, r);
      return;
  }
}

/// Asks the solid to publish the awaited solid_state_t again (the scheme says which steps).
void Coordinator::request_resend(std::int64_t key) {
  for (const std::int64_t step : scheme_.resend_steps(key, awaited_step_)) {
    cosimlcm::resend_t r{};
    r.token = o_.token;
    r.step = step;
    r.what = "solid_state";
    link_.publish_request(r);
    ++resends_.asked;
  }
}

void Coordinator::on_resend(const cosimlcm::resend_t& m) {
  // Our own requests come back on the bus. A peer's request is not news of progress
  // (protocol/README.md 7-8): silence counts from the last message applied.
  if (m.what != "fluid_state") return;
  ++resends_.requests;
  if (!lingering_) {
    resends_.answered += outbox_.answer_resend(m.step);
    return;
  }
  // After the success stop_t the solid asks only because it has none: each copy of the
  // request is answered with one copy of the stop_t (docs/reliability.md).
  last_request_ = Clock::now();
  link_.republish_stop();
  ++resends_.answered;
  ++stops_again_;
}

int Coordinator::linger() {
  lingering_ = true;
  const Clock::time_point start = Clock::now(), limit = start + ms(c_.peer_timeout_s);
  last_request_ = start;
  for (;;) {
    const Clock::time_point now = Clock::now();
    if (now - last_request_ >= protocol::kClosingQuiet || now >= limit || link_.fatal()) break;
    link_.pump(std::chrono::milliseconds(5));
  }
  lingering_ = false;
  return stops_again_;
}

/// The solid's stop_t, if it fits the run (protocol/session/stop_rules.hpp): the solid never
/// ends a run with success; an error code ends it with 4.
void Coordinator::on_stop(const cosimlcm::stop_t& m) {
  // Our own success stop_t, heard back while lingering after it (linger()).
  if (lingering_ && m.sender == "fluid" && m.exit_code == exit_code::ok && m.step == s_.steps && m.reason.empty())
    return;
  const protocol::StopFit fit = protocol::fit_stop(m, {"fluid", s_.steps, false});
  if (fit.verdict == protocol::StopVerdict::Refuse) {
    link_.refuse(ch_.stop, *fit.rejection);
    return;
  }
  if (stop_) return;
  peer_code_ = m.exit_code;
  stop_ = Ending{exit_code::peer_lost,
                 "the solid stopped at step " + std::to_string(m.step) + " with exit code " +
                     std::to_string(m.exit_code) + ": " + protocol::one_line(m.reason),
                 false};
}

std::optional<Ending> Coordinator::wait_for_solid_state(std::int64_t step) {
  awaited_step_ = step;
  while (!inbox_.ready()) {
    if (stop_) return stop_;
    if (refused_state_) return refused_ending();
    if (link_.fatal()) {
      publish_stop(step, link_.fatal()->code, link_.fatal()->reason);
      return link_.fatal();
    }
    link_.pump(std::chrono::milliseconds(10));
    if (inbox_.ready()) break;
    switch (inbox_.poll(Clock::now())) {
      case protocol::PeerWatch::Action::Wait:
        break;
      case protocol::PeerWatch::Action::Resend:
        request_resend(inbox_.awaited());
        break;
      case protocol::PeerWatch::Action::GiveUp: {
        const std::string why = "the solid was silent for " + std::to_string(c_.peer_timeout_s) +
                                " s while the fluid waited for solid_state_t of step " + std::to_string(step);
        publish_stop(step, exit_code::peer_lost, why);
        return Ending{exit_code::peer_lost, why, false};
      }
    }
  }
  return std::nullopt;
}

/// The solid sent only refused copies of the awaited step (kRejectedCopiesLimit in a row):
/// the run ends naming the field, with check_solid_state's code where it applies (2, or 3
/// for a non-finite number), else 2.
Ending Coordinator::refused_ending() {
  // The refused copy's own step (in the implicit scheme the awaited key is the solid's seq).
  const std::int64_t step = refused_state_->first ? refused_state_->first->step : awaited_step_;
  if (refused_state_->first)
    if (auto e = check_solid_state(*refused_state_->first, step)) return *e;
  const std::string why = "solid_state_t of step " + std::to_string(step) + ": " + refused_state_->second.detail() +
                          " (" + std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)";
  publish_stop(step, exit_code::bad_input, why);
  return Ending{exit_code::bad_input, why, false};
}

std::optional<Ending> Coordinator::check_solid_state(const cosimlcm::solid_state_t& m, std::int64_t step) {
  const auto bad = [&](int code, const std::string& what) {
    const std::string why = "solid_state_t of step " + std::to_string(step) + ": " + what;
    publish_stop(step, code, why);
    return Ending{code, why, false};
  };
  if (m.num_cgps != num_cgps_ || std::ssize(m.position_lb) != num_cgps_ || std::ssize(m.impulse_lb) != num_cgps_)
    return bad(exit_code::bad_input,
               "num_cgps = " + std::to_string(m.num_cgps) + ", expected " + std::to_string(num_cgps_));
  const std::int64_t dynamic_from = std::max<std::int64_t>(c_.rigid_steps, 1);
  // The A_T of a restart's first message: the checkpoint's for the message in flight
  // (protocol/README.md 10); the run's where the solid computes the step again (13).
  const int ratio = step == first_step_ && first_step_ > 0 && scheme_.restart_message_has_checkpoint_ratio()
                        ? restart_ratio_
                        : c_.time_ratio;
  // The implicit scheme's last message, solid_state_t(N, 0), takes no substeps.
  const bool closing = step == s_.steps;
  const int substeps = step < dynamic_from || closing ? 0 : ratio;
  if (m.substeps != substeps)
    return bad(exit_code::bad_input,
               "substeps = " + std::to_string(m.substeps) + ", expected " + std::to_string(substeps));
  const double t = double(std::max<std::int64_t>(0, step - dynamic_from + (closing ? 0 : 1))) * units_.dt_lb_s();
  if (std::abs(m.solid_time_s - t) > 1e-9 * std::max(t, units_.dt_lb_s()))
    return bad(exit_code::bad_input, "solid_time_s = " + protocol::fmt("%.17g", m.solid_time_s) + " s, expected " +
                                         protocol::fmt("%.17g", t) +
                                         " s (the solid's substeps times dt_CG, within 1e-9 relative)");
  const int n_axis[3] = {s_.params.shape.nx, s_.params.shape.ny, s_.params.shape.nz};
  for (std::int32_t l = 0; l < num_cgps_; ++l) {
    const auto& p = m.position_lb[static_cast<std::size_t>(l)];
    const auto& i = m.impulse_lb[static_cast<std::size_t>(l)];
    if (p.size() != 3 || i.size() != 3)
      return bad(exit_code::bad_input, "CGP " + std::to_string(l) + " has a vector of the wrong size");
    for (std::size_t c = 0; c < 3; ++c)
      if (!std::isfinite(p[c]) || !std::isfinite(i[c]))
        return bad(exit_code::unhealthy, "a non-finite position or impulse at CGP " + std::to_string(l));
    // A marker must stay in the fluid along the non-periodic axes (cells span
    // [-1/2, n - 1/2]); outside, its kernel finds no fluid and the sample is empty.
    for (int c = 0; c < 3; ++c) {
      if (s_.params.faces[static_cast<std::size_t>(2 * c)].kind == FaceKind::Periodic) continue;
      const double v = p[static_cast<std::size_t>(c)];
      if (v < -0.5 - 1e-9 || v > n_axis[c] - 0.5)
        return bad(exit_code::unhealthy, "CGP " + std::to_string(l) + " left the fluid domain: " + "xyz"[c] + " = " +
                                             std::to_string(v) + " cells, the domain spans [-0.5, " +
                                             std::to_string(n_axis[c] - 0.5) + "] (a deflection larger than the " +
                                             "domain: a larger domain, or the corotational model)");
    }
  }
  // Step n -> n + 1 spreads the impulses of solid_state_t(n) (protocol/README.md 5); no
  // interval precedes step 0, so its impulses are 0 (a restart's first message is the
  // checkpoint's in-flight one, whatever its step).
  if (step == 0 && first_step_ == 0)
    for (std::int32_t l = 0; l < num_cgps_; ++l)
      for (std::size_t c = 0; c < 3; ++c)
        if (const double v = m.impulse_lb[static_cast<std::size_t>(l)][c]; v != 0.0)
          return bad(exit_code::bad_input, "impulse_lb[" + std::to_string(l) + "][" + std::to_string(c) +
                                               "] = " + protocol::fmt("%.17g", v) +
                                               "; allowed: 0 at step 0 (no interval precedes it; protocol/README.md 5)");
  return std::nullopt;
}

// ---- publishing ----

void Coordinator::publish_fluid_state(std::int64_t step, double bulk_velocity_lb,
                                      const std::vector<MarkerSample>& samples,
                                      const std::vector<MarkerSample>& start, int iteration) {
  cosimlcm::fluid_state_t m = outbox_.next(step, iteration);
  m.bulk_velocity_lb = bulk_velocity_lb;
  m.num_cgps = num_cgps_;
  m.rho_lb.resize(samples.size());
  m.velocity_lb.resize(samples.size());
  for (std::size_t l = 0; l < samples.size(); ++l) {
    m.rho_lb[l] = samples[l].rho;
    m.velocity_lb[l] = {samples[l].u[0], samples[l].u[1], samples[l].u[2]};
  }
  m.rho_start_lb.resize(start.size());
  m.velocity_start_lb.resize(start.size());
  for (std::size_t l = 0; l < start.size(); ++l) {
    m.rho_start_lb[l] = start[l].rho;
    m.velocity_start_lb[l] = {start[l].u[0], start[l].u[1], start[l].u[2]};
  }
  outbox_.publish(std::move(m));
}

void Coordinator::republish(cosimlcm::fluid_state_t m) {
  // The token is this run's; the rest is the message sent before, bit for bit.
  outbox_.republish(std::move(m), outbox_.seq());
}

void Coordinator::publish_stop(std::int64_t step, int code, const std::string& reason) {
  phases_.stop();
  link_.publish_stop(step, code, reason);
}

int Coordinator::stop_and_end(const Ending& e, std::int64_t step) {
  publish_stop(step, e.code, e.reason);
  return end(e);
}

int Coordinator::end(const Ending& e) {
  // A run that stops after the handshake still reports what it received and refused.
  if (e.code != exit_code::ok && welcome_ && welcome_->accepted)
    fluid_log().info(out_) << "coupled run stopped; " << counters();
  if (end_hook_) end_hook_(out_);
  out_.flush();
  last_reason_ = e.reason;
  phases_.done();
  return e.code;
}

}  // namespace cosim::fluid
