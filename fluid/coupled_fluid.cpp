#include "fluid/coupled_fluid.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "fluid/flow_monitor.hpp"
#include "fluid/fluid_solver.hpp"
#include "fluid/immersed_boundary.hpp"
#include "fluid/monitor_log.hpp"
#include "fluid/snapshots.hpp"
#include "protocol/channels.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/step_sequencer.hpp"
#include "protocol/text.hpp"
#include "protocol/units.hpp"

namespace cosim::fluid {

namespace {

using Clock = std::chrono::steady_clock;
constexpr int kOk = 0, kSystem = 1, kBadInput = 2, kUnhealthy = 3, kPeerLost = 4;
constexpr const char* kVersion = "1";
constexpr const char* kFluidModel = "d3q19-bgk-guo";

std::chrono::milliseconds ms(double seconds) {
  return std::chrono::milliseconds(static_cast<long long>(seconds * 1000.0));
}

/// A run-ending condition: exit code and the one-line reason.
struct Ending {
  int code;
  std::string reason;
};

/// The coordinator and the fluid's side of the protocol.
class CoupledFluid {
 public:
  CoupledFluid(const FluidScene& s, const CoupledFluidOptions& o, std::ostream& out)
      : s_(s), c_(*s.coupling), o_(o), out_(out),
        ch_(o.channel_prefix.empty() ? c_.channel_prefix : o.channel_prefix),
        own_lcm_(o.bus != nullptr ? nullptr
                                   : std::make_unique<lcm::LCM>(o.lcm_url.empty() ? c_.lcm_url : o.lcm_url)),
        lcm_(o.bus != nullptr ? *o.bus : *own_lcm_),
        foreign_(o.token, [this](const std::string& line) { out_ << "fluid: " << line << "\n"; }),
        rejections_([this](const std::string& line) { out_ << "fluid: " << line << "\n"; }),
        solid_seq_(0),
        watch_(ms(c_.peer_timeout_s), ms(c_.resend_after_s)) {
    protocol::UnitInputs in;
    in.dx_m = s.dx_um * 1e-6;
    in.time_ratio = c_.time_ratio;
    units_ = protocol::UnitConverter(in);
  }

  CoupledFluid(const CoupledFluid&) = delete;
  CoupledFluid& operator=(const CoupledFluid&) = delete;
  ~CoupledFluid() {
    for (lcm::Subscription* sub : subs_)
      if (sub != nullptr) lcm_.unsubscribe(sub);
  }

  int run() {
    if (!lcm_.good()) return end({kSystem, "cannot open LCM at " + url()});
    subs_.push_back(lcm_.subscribe(ch_.hello, &CoupledFluid::on_hello, this));
    subs_.push_back(lcm_.subscribe(ch_.solid_state, &CoupledFluid::on_solid_state, this));
    subs_.push_back(lcm_.subscribe(ch_.resend, &CoupledFluid::on_resend, this));
    subs_.push_back(lcm_.subscribe(ch_.stop, &CoupledFluid::on_stop, this));

    if (auto e = handshake()) return end(*e);
    try {
      return step_all();
    } catch (const std::exception& x) {  // output or system errors after the handshake
      return stop_and_end({kSystem, x.what()}, -1);
    }
  }

  /// The LB steps of the run, after an accepted handshake.
  int step_all() {
    FluidSolver solver(s_.params);
    initialize_flow(solver, s_);
    const ImmersedBoundary ib(solver);
    const HealthLimits limits{s_.mach_limit};
    std::filesystem::create_directories(s_.output_dir);
    const double dt_us = units_.dt_lb_s() * 1e6;
    MonitorLog log((std::filesystem::path(s_.output_dir) / "monitor.h5").string(), dt_us);
    const FlowSummary first = summarize(solver);
    const double mass0 = first.mass;
    bulk_u_ = first.momentum[0] / first.mass;
    log.append(first);
    Snapshots snapshots(s_, dt_us);
    if (snapshots.due(0, false)) snapshots.write(solver, false);

    const auto n = static_cast<std::size_t>(num_cgps_);
    std::vector<Vec3> x(n), j(n);
    std::vector<MarkerSample> samples(n);
    const Clock::time_point start = Clock::now();
    Clock::time_point last_progress = start;
    for (std::int64_t step = 0; step < s_.steps; ++step) {
      const Clock::time_point t0 = Clock::now();
      if (auto e = wait_for_solid_state(step)) return end(*e);
      const Clock::time_point t1 = Clock::now();
      wait_s_ += std::chrono::duration<double>(t1 - t0).count();
      const cosimlcm::solid_state_t& m = inbox_.at(step);
      if (auto e = check_solid_state(m, step)) return end(*e);
      for (std::size_t l = 0; l < n; ++l) {
        x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
        j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
      }
      inbox_.erase(inbox_.begin(), inbox_.upper_bound(step));
      solid_seq_.advance();
      states_refused_ = 0;
      // Eqs. 21-24 and 25-26: spread J_l at X_l, collide with the forcing, stream.
      ib.spread(solver, x, j);
      solver.step();
      const bool last = step + 1 == s_.steps;
      if ((step + 1) % s_.monitor_every == 0 || last) {
        const FlowSummary sum = summarize(solver);
        const std::string problem = health_problem(sum, limits);
        if (!problem.empty())
          return stop_and_end({kUnhealthy, "unhealthy flow after step " + std::to_string(step + 1) + ": " + problem}, step + 1);
        log.append(sum);
        bulk_u_ = sum.momentum[0] / sum.mass;
        out_ << format_summary(sum, dt_us, mass0) << "\n";
        out_.flush();
      }
      if (snapshots.due(step + 1, last)) {
        // Only a healthy state is written: check it if the monitor did not just now.
        if ((step + 1) % s_.monitor_every != 0 && !last) {
          const std::string problem = health_problem(summarize(solver), limits);
          if (!problem.empty())
            return stop_and_end({kUnhealthy, "unhealthy flow after step " + std::to_string(step + 1) + ": " + problem}, step + 1);
        }
        snapshots.write(solver, last);
      }
      if (!last) {
        ib.sample(solver, x, samples);  // Eq. 17 at X_l
        const Clock::time_point t2 = Clock::now();
        compute_s_ += std::chrono::duration<double>(t2 - t1).count();
        publish_fluid_state(step + 1, samples);
        publish_s_ += std::chrono::duration<double>(Clock::now() - t2).count();
      } else {
        compute_s_ += std::chrono::duration<double>(Clock::now() - t1).count();
      }
      if (!o_.quiet && Clock::now() - last_progress > std::chrono::seconds(2)) {
        last_progress = Clock::now();
        std::fprintf(stderr, "fluid: step %lld/%lld\n", static_cast<long long>(step + 1),
                     static_cast<long long>(s_.steps));
      }
    }
    publish_stop(s_.steps, kOk, "");
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    out_ << "fluid: coupled run done, " << s_.steps << " LB steps in " << wall << " s; "
         << counters() << "; output in " << s_.output_dir << "\n";
    const double per = 1e3 / double(s_.steps);
    char line[256];
    std::snprintf(line, sizeof line,
                  "fluid: per LB step: compute %.4g ms (spread, step, health, sample), waiting "
                  "%.4g ms (for solid_state_t), publishing %.4g ms; %.1f MLUPS while computing\n",
                  compute_s_ * per, wait_s_ * per, publish_s_ * per,
                  compute_s_ > 0 ? double(s_.params.shape.cells()) * double(s_.steps) / compute_s_ * 1e-6 : 0.0);
    out_ << line;
    return kOk;
  }

 private:
  std::string url() const { return o_.lcm_url.empty() ? c_.lcm_url : o_.lcm_url; }

  protocol::Hello fluid_hello() const {
    protocol::Hello h;
    h.token = o_.token;
    h.role = "fluid";
    h.model = kFluidModel;
    h.version = kVersion;
    h.scene_hash = protocol::scene_hash_of_file(s_.path);
    h.dx_m = units_.dx_m();
    h.dt_lb_s = units_.dt_lb_s();
    h.sound_speed_m_s = units_.inputs().sound_speed_m_s;
    h.air_density_kg_m3 = units_.air_density_kg_m3();
    h.time_ratio = c_.time_ratio;
    h.dt_cg_s = units_.dt_cg_s();
    h.stable_dt_cg_s = 0.0;
    h.num_cgps = 0;
    return h;
  }

  std::optional<Ending> handshake() {
    const protocol::Hello mine = fluid_hello();
    const cosimlcm::hello_t own = protocol::to_lcm(mine);
    lcm_.publish(ch_.hello, &own);
    const Clock::time_point deadline = Clock::now() + ms(c_.handshake_timeout_s);
    while (!solid_hello_ && !hello_refusal_) {
      if (stop_) return stop_;
      if (Clock::now() > deadline) {
        publish_stop(0, kPeerLost, "no solid hello_t within the handshake timeout");
        return Ending{kPeerLost, "no solid announced itself on " + ch_.hello + " within " +
                                     std::to_string(c_.handshake_timeout_s) + " s"};
      }
      lcm_.handleTimeout(50);
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
    for (int k = 0; k < 3; ++k) {
      lcm_.publish(ch_.welcome, &*welcome_);
      if (!r.accepted) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!r.accepted) return Ending{kBadInput, r.reason};
    num_cgps_ = solid_hello_->num_cgps;
    time_ratio_ = r.time_ratio;
    out_ << "fluid: handshake accepted: solid model " << solid_hello_->model << ", "
         << num_cgps_ << " CGPs, A_T = " << r.time_ratio << ", " << s_.steps
         << " LB steps (" << c_.rigid_steps << " rigid)" << std::endl;
    watch_.heard(Clock::now());
    return std::nullopt;
  }

  std::optional<Ending> wait_for_solid_state(std::int64_t step) {
    while (!inbox_.count(step)) {
      if (stop_) return stop_;
      if (refused_state_) return refused_ending(step);
      lcm_.handleTimeout(10);
      if (inbox_.count(step)) break;
      switch (watch_.poll(Clock::now())) {
        case protocol::PeerWatch::Action::Wait:
          break;
        case protocol::PeerWatch::Action::Resend: {
          cosimlcm::resend_t r{};
          r.token = o_.token;
          r.step = step;
          r.what = "solid_state";
          lcm_.publish(ch_.resend, &r);
          ++resends_asked_;
          break;
        }
        case protocol::PeerWatch::Action::GiveUp: {
          const std::string why = "the solid was silent for " +
                                  std::to_string(c_.peer_timeout_s) +
                                  " s while the fluid waited for solid_state_t of step " +
                                  std::to_string(step);
          publish_stop(step, kPeerLost, why);
          return Ending{kPeerLost, why};
        }
      }
    }
    return std::nullopt;
  }

  std::optional<Ending> check_solid_state(const cosimlcm::solid_state_t& m, std::int64_t step) {
    const auto bad = [&](int code, const std::string& what) {
      const std::string why = "solid_state_t of step " + std::to_string(step) + ": " + what;
      publish_stop(step, code, why);
      return Ending{code, why};
    };
    if (m.num_cgps != num_cgps_ || std::ssize(m.position_lb) != num_cgps_ ||
        std::ssize(m.impulse_lb) != num_cgps_)
      return bad(kBadInput, "num_cgps = " + std::to_string(m.num_cgps) + ", expected " +
                                std::to_string(num_cgps_));
    const std::int64_t dynamic_from = std::max<std::int64_t>(c_.rigid_steps, 1);
    const int substeps = step < dynamic_from ? 0 : c_.time_ratio;
    if (m.substeps != substeps)
      return bad(kBadInput, "substeps = " + std::to_string(m.substeps) + ", expected " +
                                std::to_string(substeps));
    const double t = double(std::max<std::int64_t>(0, step - dynamic_from + 1)) * units_.dt_lb_s();
    if (std::abs(m.solid_time_s - t) > 1e-9 * std::max(t, units_.dt_lb_s()))
      return bad(kBadInput, "solid_time_s = " + std::to_string(m.solid_time_s) + ", expected " +
                                std::to_string(t));
    for (std::int32_t l = 0; l < num_cgps_; ++l) {
      const auto& p = m.position_lb[static_cast<std::size_t>(l)];
      const auto& i = m.impulse_lb[static_cast<std::size_t>(l)];
      if (p.size() != 3 || i.size() != 3)
        return bad(kBadInput, "CGP " + std::to_string(l) + " has a vector of the wrong size");
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(p[static_cast<std::size_t>(c)]) || !std::isfinite(i[static_cast<std::size_t>(c)]))
          return bad(kUnhealthy, "a non-finite position or impulse at CGP " + std::to_string(l));
      // A marker must stay in the fluid along the non-periodic axes (cells span
      // [-1/2, n - 1/2]); outside, its kernel finds no fluid and the sample is empty.
      const int n_axis[3] = {s_.params.shape.nx, s_.params.shape.ny, s_.params.shape.nz};
      for (int c = 0; c < 3; ++c) {
        if (s_.params.faces[static_cast<std::size_t>(2 * c)].kind == FaceKind::Periodic) continue;
        const double v = p[static_cast<std::size_t>(c)];
        if (v < -0.5 - 1e-9 || v > n_axis[c] - 0.5)
          return bad(kUnhealthy, "CGP " + std::to_string(l) + " left the fluid domain: " +
                                     "xyz"[c] + " = " + std::to_string(v) + " cells, the domain spans [-0.5, " +
                                     std::to_string(n_axis[c] - 0.5) + "] (a deflection larger than the " +
                                     "domain: a larger domain, or the corotational model)");
      }
    }
    return std::nullopt;
  }

  /// The solid sent only refused copies of the awaited step (kRejectedCopiesLimit in a row):
  /// the run ends naming the field, with check_solid_state's code where it applies (2, or 3
  /// for a non-finite number), else 2.
  Ending refused_ending(std::int64_t step) {
    if (auto e = check_solid_state(refused_state_->first, step)) return *e;
    const std::string why = "solid_state_t of step " + std::to_string(step) + ": " +
                            refused_state_->second.detail() + " (" +
                            std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)";
    publish_stop(step, kBadInput, why);
    return Ending{kBadInput, why};
  }

  void publish_fluid_state(std::int64_t step, const std::vector<MarkerSample>& samples) {
    cosimlcm::fluid_state_t m{};
    m.token = o_.token;
    m.seq = fluid_seq_++;
    m.step = step;
    m.bulk_velocity_lb = bulk_u_;
    m.num_cgps = num_cgps_;
    m.rho_lb.resize(samples.size());
    m.velocity_lb.resize(samples.size());
    for (std::size_t l = 0; l < samples.size(); ++l) {
      m.rho_lb[l] = samples[l].rho;
      m.velocity_lb[l] = {samples[l].u[0], samples[l].u[1], samples[l].u[2]};
    }
    lcm_.publish(ch_.fluid_state, &m);
    sent_.push_back(std::move(m));
    while (sent_.size() > 2) sent_.pop_front();
  }

  void publish_stop(std::int64_t step, int code, const std::string& reason) {
    cosimlcm::stop_t m{};
    m.token = o_.token;
    m.step = step;
    m.exit_code = code;
    m.reason = protocol::bounded_reason(reason);
    for (int k = 0; k < 3; ++k) {
      lcm_.publish(ch_.stop, &m);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  /// Decodes a message of the run after checking its bytes (protocol/message_checks.hpp);
  /// false (counted) if it does not decode or carries another run's token.
  template <class Message>
  bool receive(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Message& m) {
    if (const auto why = protocol::decode_checked(rbuf->data, rbuf->data_size, m)) {
      if (undecodable_[channel]++ == 0)
        out_ << "fluid: a message on " << channel << " does not decode as "
             << Message::getTypeName() << " (" << *why
             << "); such messages are counted and ignored\n";
      return false;
    }
    return foreign_.admit(channel, m.token);
  }

  /// What a message of the run must satisfy now: the token, the handshake's CGP count, the
  /// steps from 0 to the awaited one + kStepWindow (within the run), A_T.
  protocol::Expectation expectation() const {
    protocol::Expectation e;
    e.token = o_.token;
    e.num_cgps = num_cgps_;
    e.lowest_step = 0;
    e.highest_step = std::min<std::int64_t>(solid_seq_.expected_step() + protocol::kStepWindow,
                                            s_.steps - 1);
    e.time_ratio = time_ratio_;
    return e;
  }

  void on_hello(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    cosimlcm::hello_t m{};
    if (!receive(rbuf, channel, m)) return;
    if (const auto r = protocol::check(m, expectation())) {
      rejections_.add(channel, *r);
      if (!solid_hello_ && ++hellos_refused_ >= protocol::kRejectedCopiesLimit && !hello_refusal_)
        hello_refusal_ = r->what;
      return;
    }
    if (m.role != "solid") return;  // our own announcement
    watch_.heard(Clock::now());
    if (!solid_hello_ && !hello_refusal_) solid_hello_ = m;
    else if (welcome_) lcm_.publish(ch_.welcome, &*welcome_);  // a lost welcome
  }

  void on_solid_state(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    cosimlcm::solid_state_t m{};
    if (!receive(rbuf, channel, m)) return;
    if (const auto r = protocol::check(m, expectation())) {
      refuse_state(channel, m, *r);
      return;
    }
    watch_.heard(Clock::now());
    switch (solid_seq_.offer(m.step, m.seq)) {
      case protocol::StepSequencer::Verdict::Accept:
      case protocol::StepSequencer::Verdict::Early:
        if (m.step < s_.steps + 1 && inbox_.size() < 8) inbox_.emplace(m.step, std::move(m));
        break;
      default:
        break;
    }
  }

  /// A solid_state_t that failed the checks: counted, never applied. A refused copy of the
  /// awaited step is asked for again at once; after kRejectedCopiesLimit refused copies in
  /// a row the run ends (wait_for_solid_state).
  void refuse_state(const std::string& channel, const cosimlcm::solid_state_t& m,
                    const protocol::Rejection& r) {
    rejections_.add(channel, r);
    if (!welcome_ || !welcome_->accepted || m.step != solid_seq_.expected_step() ||
        solid_seq_.expected_received() || refused_state_)
      return;
    if (++states_refused_ >= protocol::kRejectedCopiesLimit) {
      refused_state_.emplace(m, r);
      return;
    }
    cosimlcm::resend_t q{};
    q.token = o_.token;
    q.step = m.step;
    q.what = "solid_state";
    lcm_.publish(ch_.resend, &q);
    ++resends_asked_;
  }

  void on_resend(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    cosimlcm::resend_t m{};
    if (!receive(rbuf, channel, m)) return;
    if (const auto r = protocol::check(m, expectation())) {
      rejections_.add(channel, *r);
      return;
    }
    // Our own requests come back on the bus. A peer's request is not news of progress
    // (protocol/README.md 7-8): silence counts from the last message applied.
    if (m.what != "fluid_state") return;
    for (const cosimlcm::fluid_state_t& f : sent_)
      if (f.step == m.step) {
        lcm_.publish(ch_.fluid_state, &f);
        ++resends_answered_;
      }
  }

  void on_stop(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    cosimlcm::stop_t m{};
    if (!receive(rbuf, channel, m)) return;
    if (const auto r = protocol::check(m, expectation())) {
      rejections_.add(channel, *r);
      return;
    }
    if (stop_) return;
    stop_ = Ending{m.exit_code == 0 ? kOk : kPeerLost,
                   "the solid stopped at step " + std::to_string(m.step) + " with exit code " +
                       std::to_string(m.exit_code) + ": " + protocol::one_line(m.reason)};
  }

  std::string counters() const {
    return "foreign " + std::to_string(foreign_.total()) + ", duplicates " +
           std::to_string(solid_seq_.duplicates()) + ", stale " + std::to_string(solid_seq_.stale()) +
           ", early " + std::to_string(solid_seq_.early()) + ", resends asked " +
           std::to_string(resends_asked_) + " answered " + std::to_string(resends_answered_) +
           ", undecodable " + std::to_string(undecodable()) + ", " + rejections_.summary();
  }

  std::int64_t undecodable() const {
    std::int64_t n = 0;
    for (const auto& [channel, k] : undecodable_) n += k;
    return n;
  }

  /// Ends the run on the fluid's own error: the solid is told (stop_t) before we go.
  int stop_and_end(const Ending& e, std::int64_t step) {
    publish_stop(step, e.code, e.reason);
    return end(e);
  }

  int end(const Ending& e) {
    // A run that stops after the handshake still reports what it received and refused.
    if (e.code != kOk && welcome_ && welcome_->accepted)
      out_ << "fluid: coupled run stopped; " << counters() << "\n";
    out_.flush();
    last_reason_ = e.reason;
    return e.code;
  }

 public:
  std::string last_reason_;

 private:
  const FluidScene& s_;
  const CouplingSettings c_;
  const CoupledFluidOptions& o_;
  std::ostream& out_;
  protocol::Channels ch_;
  std::unique_ptr<lcm::LCM> own_lcm_;  ///< null when the options bring a bus
  lcm::LCM& lcm_;
  std::vector<lcm::Subscription*> subs_;
  protocol::ForeignCounter foreign_;
  protocol::MessageRejections rejections_;
  std::map<std::string, std::int64_t> undecodable_;
  protocol::StepSequencer solid_seq_;
  protocol::PeerWatch watch_;
  protocol::UnitConverter units_;
  std::optional<cosimlcm::hello_t> solid_hello_;
  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<Ending> stop_;
  int hellos_refused_ = 0;                    ///< solid hello_t refused by the checks
  std::optional<std::string> hello_refusal_;  ///< set after kRejectedCopiesLimit of them
  int states_refused_ = 0;                    ///< refused copies of the awaited step
  /// The last refused copy once kRejectedCopiesLimit were refused in a row, and why.
  std::optional<std::pair<cosimlcm::solid_state_t, protocol::Rejection>> refused_state_;
  std::int32_t time_ratio_ = 0;  ///< A_T agreed in the handshake
  std::map<std::int64_t, cosimlcm::solid_state_t> inbox_;
  std::deque<cosimlcm::fluid_state_t> sent_;
  std::int32_t num_cgps_ = 0;
  std::int64_t fluid_seq_ = 0;
  std::int64_t resends_asked_ = 0, resends_answered_ = 0;
  double compute_s_ = 0.0, wait_s_ = 0.0, publish_s_ = 0.0;  ///< per-step timing (DESIGN 7)
  double bulk_u_ = 0.0;  ///< U_b of the latest health check (Eq. 34), lattice units
};

}  // namespace

int run_coupled_fluid(const FluidScene& scene, const CoupledFluidOptions& options,
                      std::ostream& out, std::ostream& err) {
  if (!scene.coupling) {
    err << "fluid: " << scene.path << ": not a coupled scene (no [coupling] section)\n";
    return kBadInput;
  }
  if (options.token.empty()) {
    err << "fluid: a coupled run needs the run's token: --token TOKEN or COSIM_RUN_TOKEN\n";
    return kBadInput;
  }
  CoupledFluid run(scene, options, out);
  const int code = run.run();
  if (code != kOk) err << "fluid: coupled run stopped: " << run.last_reason_ << "\n";
  return code;
}

}  // namespace cosim::fluid
