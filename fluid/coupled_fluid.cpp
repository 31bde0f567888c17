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
#include <type_traits>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "fluid/d3q19.hpp"
#include "fluid/flow_monitor.hpp"
#include "fluid/fluid_solver.hpp"
#include "fluid/immersed_boundary.hpp"
#include "fluid/monitor_log.hpp"
#include "fluid/snapshots.hpp"
#include "protocol/channels.hpp"
#include "protocol/checkpoint_file.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/peak_memory.hpp"
#include "protocol/marker_watch.hpp"
#include "protocol/session/exit_codes.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/session_counters.hpp"
#include "protocol/session/state_inbox.hpp"
#include "protocol/session/stop_rules.hpp"
#include "protocol/step_sequencer.hpp"
#include "protocol/text.hpp"
#include "protocol/units.hpp"
#include "protocol/watchdog.hpp"

namespace cosim::fluid {

namespace {

using Clock = std::chrono::steady_clock;
using protocol::Ending;
constexpr int kOk = protocol::exit_code::ok, kSystem = protocol::exit_code::system,
              kBadInput = protocol::exit_code::bad_input, kUnhealthy = protocol::exit_code::unhealthy,
              kPeerLost = protocol::exit_code::peer_lost;
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
  return s;
}

/// The coordinator and the fluid's side of the protocol.
class CoupledFluid {
 public:
  CoupledFluid(const FluidScene& s, const CoupledFluidOptions& o, std::ostream& out)
      : s_(s), c_(*s.coupling), o_(o), out_(out), link_(link_settings(c_, o), out),
        ch_(link_.channels()),
        inbox_(0, [this](const cosimlcm::solid_state_t& m) { return key_of(m); }, ms(c_.peer_timeout_s),
               ms(c_.resend_after_s)),
        markers_(s.watchdog, s.mach_limit, c_.time_ratio) {
    protocol::UnitInputs in;
    in.dx_m = s.dx_um * 1e-6;
    in.time_ratio = c_.time_ratio;
    units_ = protocol::UnitConverter(in);
  }

  CoupledFluid(const CoupledFluid&) = delete;
  CoupledFluid& operator=(const CoupledFluid&) = delete;
  ~CoupledFluid() = default;

  int run() {
    if (auto e = link_.open()) return end(*e);
    if (!subscribe()) return end({kSystem, "cannot subscribe to the channels " + ch_.prefix + "* on " + link_.url()});

    // A restart waits for solid_state_t(N) from the start, so that the solid's republished
    // message passes the step-window check even if it comes before the checkpoint is read
    // (an unreadable file is reported by restore(), after the handshake).
    if (!o_.restart.empty()) {
      try {
        const protocol::CheckpointReader r(o_.restart);
        inbox_.await_from(c_.scheme.implicit_scheme() ? r.int64_attr("solid_seq_awaited") : r.int64_attr("step"));
        // The in-flight solid_state_t may come during the handshake: its A_T is the checkpoint's.
        restart_ratio_ = r.has("time_ratio") ? static_cast<int>(r.int64_attr("time_ratio")) : c_.time_ratio;
        first_step_ = r.int64_attr("step");
      } catch (const std::exception&) {
      }
    }
    if (auto e = handshake()) return end(*e);
    try {
      return step_all();
    } catch (const std::exception& x) {  // output or system errors after the handshake
      return stop_and_end({kSystem, x.what()}, awaited_step_);
    }
  }

  /// The LB steps of the run, after an accepted handshake.
  int step_all() {
    FluidSolver solver(s_.params);
    initialize_flow(solver, s_);
    const ImmersedBoundary ib(solver);
    const HealthLimits limits{s_.mach_limit, 0.0, s_.watchdog.rho_min, s_.watchdog.rho_max};
    std::filesystem::create_directories(s_.output_dir);
    const double dt_us = units_.dt_lb_s() * 1e6;
    MonitorLog log((std::filesystem::path(s_.output_dir) / "monitor.h5").string(), dt_us);
    Snapshots snapshots(s_, dt_us);
    std::int64_t first_step = 0;
    if (!o_.restart.empty()) {
      try {
        first_step = restore(solver, log, snapshots);
      } catch (const std::exception& x) {
        return stop_and_end({kBadInput, "--restart " + o_.restart + ": " + x.what()}, 0);
      }
      out_ << "fluid: restarted from " << o_.restart << " at step " << first_step << "\n";
      if (republish_) {
        // The token is this run's; the rest is the message sent before, bit for bit.
        republish_->token = o_.token;
        link_.publish(ch_.fluid_state, *republish_);
        sent_.push_back(std::move(*republish_));
        republish_.reset();
      }
    } else {
      const FlowSummary first = summarize(solver);
      mass0_ = first.mass;
      bulk_u_ = first.momentum[0] / first.mass;
      log.append(first);
      rows_.push_back(first);
      if (snapshots.due(0, false)) snapshots.write(solver, false);
    }
    first_step_ = first_step;
    const double mass0 = mass0_;

    const auto n = static_cast<std::size_t>(num_cgps_);
    std::vector<Vec3> x(n), j(n);
    std::vector<MarkerSample> samples(n);
    const Clock::time_point start = Clock::now();
    if (c_.scheme.implicit_scheme()) return step_all_implicit(solver, ib, log, snapshots, limits, first_step, start);
    Clock::time_point last_progress = start;
    // The parallel scheme (protocol/README.md 14) publishes the fluid_state_t the solid's
    // next interval needs: fluid_state_t(n + 1) drives solid_state_t(n + 2) (dynamic steps),
    // so it goes out right after the step, before solid_state_t(n + 1) is awaited, and the
    // solid integrates while the fluid steps; the serial scheme publishes 1 .. N - 1.
    const bool parallel = c_.scheme.parallel_scheme();
    const auto publishes = [&](std::int64_t m) {
      return parallel ? protocol::parallel_fluid_state_needed(m, s_.steps, c_.rigid_steps) : m >= 1 && m < s_.steps;
    };
    for (std::int64_t step = first_step; step < s_.steps; ++step) {
      // The bulk of the step to step + 1 needs no impulses (FluidSolver::begin_step: the cells
      // that receive them are collided again by finish_step): it runs while the solid computes
      // them, and the result is that of a whole step after the wait. In the free steps the
      // solid computes beside it, on the same cores: the kernel hands its rows out as its
      // threads come free (RowSchedule::Dynamic).
      const Clock::time_point tb = Clock::now();
      solver.set_row_schedule(step >= c_.rigid_steps ? RowSchedule::Dynamic : RowSchedule::Static);
      solver.begin_step();
      if (auto code = check_step_read(solver, step, limits)) return *code;
      const Clock::time_point t0 = Clock::now();
      compute_s_ += std::chrono::duration<double>(t0 - tb).count();
      awaited_step_ = step;
      if (auto e = wait_for_solid_state(step)) {
        // A clean abort (the solid lost or stopped with an error): the state at `step` is
        // whole, so it is kept for a restart (DESIGN 2.4).
        if (e->code == kPeerLost && step > first_step) e->reason += checkpoint(solver, step, e->reason);
        // The solid's watchdog tripped on a sentinel that a smaller dt_CG may cure.
        if (peer_code_ == kUnhealthy && protocol::dt_curable(e->reason)) announce_retry(step, c_.time_ratio, 0);
        return end(*e);
      }
      Clock::time_point t1 = Clock::now();
      wait_s_ += std::chrono::duration<double>(t1 - t0).count();
      // A message of the next step that came early is offered again, now due (in the
      // parallel scheme solid_state_t(n + 1) may overtake a lost solid_state_t(n)).
      const cosimlcm::solid_state_t m = inbox_.take();
      if (auto e = check_solid_state(m, step)) return end(*e);
      for (std::size_t l = 0; l < n; ++l) {
        x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
        j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
      }
      // The watchdog on the markers (DESIGN 6): how far each moved, how far apart they are.
      // The fluid at `step` is not touched yet: it is kept, if healthy, as the checkpoint.
      const Clock::time_point w0 = Clock::now();
      if (const auto t = markers_.check_positions(step, x)) return trip(*t, &solver, step, limits);
      watch_s_ += std::chrono::duration<double>(Clock::now() - w0).count();
      if (step == 0 && publishes(0)) {
        // The parallel scheme's first interval (dynamic from step 1) is driven by the fluid
        // at step 0, sampled at the initial X_l (Eq. 17) and published before the first step.
        if (auto code = sample_markers(solver, ib, 0, x, samples, limits)) return *code;
        const Clock::time_point t2 = Clock::now();
        compute_s_ += std::chrono::duration<double>(t2 - t1).count();
        publish_fluid_state(0, samples, samples);
        t1 = Clock::now();
        publish_s_ += std::chrono::duration<double>(t1 - t2).count();
      }
      // Eqs. 21-24 and 25-26: spread J_l at X_l, collide the cells that receive them with the
      // forcing (the rest of the step was streamed and collided above).
      ib.spread(solver, x, j);
      solver.finish_step();
      const std::int64_t now = step + 1;
      const bool last = now == s_.steps;
      const bool publish = publishes(now);
      if (publish)
        if (auto code = sample_markers(solver, ib, now, x, samples, limits)) return *code;
      const bool periodic = !last && c_.checkpoint_every > 0 && now % c_.checkpoint_every == 0;
      if (auto code = step_outputs(solver, now, last, periodic, log, snapshots, limits, dt_us, mass0)) return *code;
      if (publish) {
        const Clock::time_point t2 = Clock::now();
        compute_s_ += std::chrono::duration<double>(t2 - t1).count();
        // fluid_state_t's *_start_lb serve the implicit scheme only: a copy of the sample here.
        publish_fluid_state(now, samples, samples);
        publish_s_ += std::chrono::duration<double>(Clock::now() - t2).count();
        if (periodic) checkpoint(solver, now, "");
      } else {
        compute_s_ += std::chrono::duration<double>(Clock::now() - t1).count();
      }
      if (!o_.quiet && Clock::now() - last_progress > std::chrono::seconds(2)) {
        last_progress = Clock::now();
        std::fprintf(stderr, "fluid: step %lld/%lld\n", static_cast<long long>(now),
                     static_cast<long long>(s_.steps));
      }
    }
    return finish_run(start);
  }

  /// The end of a run that completed: stop_t(0) and the summary lines.
  int finish_run(Clock::time_point start) {
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
    std::snprintf(line, sizeof line,
                  "fluid: watchdog: %.4g ms per LB step, %.2g %% of the compute (the markers, the samples "
                  "and the kernel's extrema every %lld steps)\n",
                  watch_s_ * per, compute_s_ > 0 ? 100.0 * watch_s_ / compute_s_ : 0.0,
                  static_cast<long long>(s_.watchdog.health_every));
    out_ << line;
    out_ << "fluid: watchdog margins: " << markers_.margins() << "\n";
    out_ << "fluid: peak memory " << protocol::fmt("%.1f", protocol::peak_rss_mib()) << " MiB (largest resident set)\n";
    if (c_.scheme.implicit_scheme())
      out_ << "fluid: implicit scheme: " << redone_steps_ << " LB steps computed again for sub-iterations, "
           << protocol::fmt("%.3g", double(s_.steps + redone_steps_) / double(s_.steps)) << " fluid steps per LB step\n";
    return kOk;
  }

  /// Eq. 17 at X_l and the watchdog on the samples, before anything of `now` is written or
  /// published; the exit code of a trip.
  std::optional<int> sample_markers(const FluidSolver& solver, const ImmersedBoundary& ib, std::int64_t now,
                                    const std::vector<Vec3>& x, std::vector<MarkerSample>& samples,
                                    const HealthLimits& limits) {
    const std::size_t n = x.size();
    ib.sample(solver, x, samples);
    // rho_l over the kernel's weight in the fluid: the density the kernel sees, also at a
    // marker on the wall (half the kernel outside).
    const Clock::time_point w1 = Clock::now();
    std::vector<double> sample_rho(n);
    std::vector<Vec3> sample_u(n);
    for (std::size_t l = 0; l < n; ++l) {
      const double w = samples[l].weight;
      sample_rho[l] = w > 0.0 ? samples[l].rho / w : samples[l].rho;
      sample_u[l] = samples[l].u;
    }
    if (const auto t = markers_.check_samples(now, sample_rho, sample_u)) return trip(*t, nullptr, now, limits);
    watch_s_ += std::chrono::duration<double>(Clock::now() - w1).count();
    return std::nullopt;
  }

  /// The watchdog's flow_health sentinel every watchdog.health_every steps: the state
  /// `step` that the kernel just read, from its extrema (no pass of its own;
  /// kernel_state_problem); the exit code of a trip.
  std::optional<int> check_step_read(const FluidSolver& solver, std::int64_t step, const HealthLimits& limits) {
    if (step % s_.watchdog.health_every != 0) return std::nullopt;
    const Clock::time_point w = Clock::now();
    const std::string problem = kernel_state_problem(solver, limits);
    watch_s_ += std::chrono::duration<double>(Clock::now() - w).count();
    if (problem.empty()) return std::nullopt;
    return unhealthy(problem, step, limits);
  }

  /// The trip of flow_health at `step` for health_problem()'s line.
  int unhealthy(const std::string& problem, std::int64_t step, const HealthLimits& limits) {
    protocol::Trip t;
    t.sentinel = "flow_health";
    t.step = step;
    // health_problem names the step first ("step N: cell (...): ..."): said once here.
    const std::string prefix = "step " + std::to_string(step) + ": ";
    t.diagnosis = "watchdog flow_health at step " + std::to_string(step) + ": unhealthy flow at " +
                  (problem.rfind(prefix, 0) == 0 ? problem.substr(prefix.size()) : problem);
    return trip(t, nullptr, step, limits);
  }

  /// The whole-grid health check before every write (monitor row, snapshot, checkpoint),
  /// then the monitor row and the snapshot of step `now`; the exit code of a trip.
  std::optional<int> step_outputs(const FluidSolver& solver, std::int64_t now, bool last, bool periodic,
                                  MonitorLog& log, Snapshots& snapshots, const HealthLimits& limits, double dt_us,
                                  double mass0) {
    const bool monitor = now % s_.monitor_every == 0 || last;
    const bool snapshot = snapshots.due(now, last);
    if (monitor || snapshot || periodic) {
      const FlowSummary sum = summarize(solver);
      const std::string problem = health_problem(sum, limits);
      if (!problem.empty()) return unhealthy(problem, now, limits);
      if (monitor) {
        log.append(sum);
        rows_.push_back(sum);
        bulk_u_ = sum.momentum[0] / sum.mass;
        out_ << format_summary(sum, dt_us, mass0) << "\n";
        out_.flush();
      }
    }
    if (snapshot) snapshots.write(solver, last);
    return std::nullopt;
  }

  /// The LB steps of the implicit scheme (protocol/README.md 13): solid_state_t(n, k) is
  /// stepped from the committed state of step n (kept while the step is iterated);
  /// solid_state_t(n + 1, 0) accepts the last iterate of step n, whose outputs are then
  /// written; solid_state_t(N, 0) accepts the last step.
  int step_all_implicit(FluidSolver& solver, const ImmersedBoundary& ib, MonitorLog& log, Snapshots& snapshots,
                        const HealthLimits& limits, std::int64_t first_step, Clock::time_point start) {
    const double dt_us = units_.dt_lb_s() * 1e6;
    const auto n = static_cast<std::size_t>(num_cgps_);
    std::vector<Vec3> x(n), j(n);
    std::vector<MarkerSample> samples(n), start_samples(n);
    const std::int64_t dynamic_from = std::max<std::int64_t>(c_.rigid_steps, 1);
    KeptState backup;                     // the committed state of `step` while it is iterated
    bool have_backup = false;
    protocol::MarkerWatch::Reference marker_ref;
    std::int64_t step = first_step;       // the committed step
    int iteration = -1;                   // the iterate of `step` the solver holds; -1: none
    commit_ = {step, fluid_seq_, inbox_.awaited()};
    Clock::time_point last_progress = start;
    for (;;) {
      const Clock::time_point t0 = Clock::now();
      awaited_step_ = step;
      if (auto e = wait_for_solid_state(inbox_.awaited())) {
        if (e->code == kPeerLost && step > first_step)
          // The committed state: kept while the step is iterated, else what the solver holds
          // (a rigid step stepped once is not committed yet either: no checkpoint then).
          e->reason += have_backup      ? backup.checkpoint(*this, step, e->reason)
                       : iteration < 0 ? checkpoint(solver, step, e->reason)
                                       : "; no checkpoint (the spin-up step was not accepted yet)";
        if (peer_code_ == kUnhealthy && protocol::dt_curable(e->reason)) announce_retry(step, c_.time_ratio, 0);
        return end(*e);
      }
      const Clock::time_point t1 = Clock::now();
      wait_s_ += std::chrono::duration<double>(t1 - t0).count();
      const cosimlcm::solid_state_t m = inbox_.take();
      if (iteration >= 0 && m.step == step + 1 && m.iteration == 0) {
        // The solid accepted the iterate the solver holds: step + 1 is committed.
        ++step;
        iteration = -1;
        have_backup = false;
        const bool last = step == s_.steps;
        const bool periodic = !last && c_.checkpoint_every > 0 && step % c_.checkpoint_every == 0;
        if (auto code = step_outputs(solver, step, last, periodic, log, snapshots, limits, dt_us, mass0_)) return *code;
        commit_ = {step, fluid_seq_, m.seq};
        if (last) {
          if (auto e = check_solid_state(m, step)) return end(*e);
          break;
        }
        if (periodic) checkpoint(solver, step, "");
      }
      if (m.step != step || m.iteration != iteration + 1) {
        const std::string why = "solid_state_t of step " + std::to_string(m.step) + ", iteration " +
                                std::to_string(m.iteration) + ": expected step " + std::to_string(step) +
                                ", iteration " + std::to_string(iteration + 1) +
                                (iteration >= 0 ? " or step " + std::to_string(step + 1) + ", iteration 0" : std::string()) +
                                " (the implicit scheme's order, protocol/README.md 13)";
        return stop_and_end({kBadInput, why}, step);
      }
      if (auto e = check_solid_state(m, step)) return end(*e);
      for (std::size_t l = 0; l < n; ++l) {
        x[l] = {m.position_lb[l][0], m.position_lb[l][1], m.position_lb[l][2]};
        j[l] = {m.impulse_lb[l][0], m.impulse_lb[l][1], m.impulse_lb[l][2]};
      }
      // The spin-up is not iterated: the state of a rigid step need not be kept.
      if (m.iteration == 0 && step >= dynamic_from) {
        backup.keep(solver);
        have_backup = true;
        if (markers_.has_reference()) marker_ref = markers_.reference();
      } else if (m.iteration > 0) {
        backup.restore(solver, step);
        if (markers_.has_reference()) markers_.restore(marker_ref);
        ++redone_steps_;
      }
      iteration = m.iteration;
      const Clock::time_point w0 = Clock::now();
      if (const auto t = markers_.check_positions(step, x)) return trip(*t, &solver, step, limits);
      watch_s_ += std::chrono::duration<double>(Clock::now() - w0).count();
      ib.sample(solver, x, start_samples);  // the fluid before the step at X_l
      ib.spread(solver, x, j);              // Eqs. 21-24 and 25-26
      solver.step();
      if (auto code = check_step_read(solver, step, limits)) return *code;
      if (auto code = sample_markers(solver, ib, step + 1, x, samples, limits)) return *code;
      const Clock::time_point t2 = Clock::now();
      compute_s_ += std::chrono::duration<double>(t2 - t1).count();
      publish_fluid_state(step + 1, samples, start_samples, iteration);
      publish_s_ += std::chrono::duration<double>(Clock::now() - t2).count();
      if (!o_.quiet && Clock::now() - last_progress > std::chrono::seconds(2)) {
        last_progress = Clock::now();
        std::fprintf(stderr, "fluid: step %lld/%lld (iteration %d)\n", static_cast<long long>(step + 1),
                     static_cast<long long>(s_.steps), iteration);
      }
    }
    return finish_run(start);
  }

 private:
  // ---- the stability watchdog (DESIGN 6; protocol/watchdog.hpp) ----

  /// A tripped sentinel: the diagnosis, a checkpoint of the fluid at `step` when `solver`
  /// is given and that state is healthy (else the latest periodic one stands), the retry
  /// advice for the launcher, and stop_t(3) to the solid. Nothing of the tripped state is
  /// written.
  int trip(const protocol::Trip& t, const FluidSolver* solver, std::int64_t step, const HealthLimits& limits) {
    std::string reason = t.diagnosis;
    if (solver != nullptr && step >= 1 && step > first_step_) {
      const std::string problem = health_problem(summarize(*solver), limits);
      if (problem.empty()) reason += checkpoint(*solver, step, t.diagnosis);
      else reason += "; no checkpoint of step " + std::to_string(step) + ": " + problem;
    }
    if (t.dt_cure) announce_retry(step, c_.time_ratio, 0);
    return stop_and_end({kUnhealthy, reason}, step);
  }

  /// The line the launcher reads to run again with a larger A_T ([watchdog] retry): the new
  /// A_T (`to`, or `from` times retry_factor), the step before which its checkpoint must be,
  /// and the number of retries allowed.
  void announce_retry(std::int64_t before, int from, int to) {
    const protocol::WatchdogSettings& w = s_.watchdog;
    if (!w.retry) return;
    const long long next = to > 0 ? to : static_cast<long long>(from) * w.retry_factor;
    if (next > 1000000) {
      out_ << "fluid: watchdog: no retry: A_T = " << next << " would exceed 1000000\n";
      return;
    }
    out_ << "fluid: watchdog retry: time_ratio = " << next << " ("
         << (to > 0 ? "the smallest stable A_T" : "A_T " + std::to_string(from) + " x " + std::to_string(w.retry_factor))
         << "), from the newest checkpoint before step " << before << ", at most " << w.retry_max
         << " retries ([watchdog] retry)\n";
    out_.flush();
  }

  protocol::Hello fluid_hello() const {
    protocol::Hello h;
    h.token = o_.token;
    h.role = "fluid";
    h.model = kFluidModel;
    h.version = protocol::kProtocolVersion;
    h.scene_hash = protocol::scene_hash_of_file(s_.path);
    h.scheme = protocol::scheme_name(c_.scheme.scheme);
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

  // ---- coupled checkpoints (DESIGN 2.4; protocol/README.md section 10) ----

  /// Writes OUTPUT/checkpoints/fluid_NNNNNNNN.h5 for the state at `step` (fluid_state_t(step)
  /// published, solid_state_t(step) not yet applied) and keeps the newest three. Returns
  /// what to add to an abort's reason: where the checkpoint went, or why it could not be
  /// written (for periodic checkpoints a failure throws: an output error ends the run).
  std::string checkpoint(const FluidSolver& solver, std::int64_t step, const std::string& reason) {
    return solver.precision() == Precision::Double ? checkpoint(solver.state(), step, reason)
                                                   : checkpoint(solver.state_single(), step, reason);
  }

  /// The implicit scheme's committed state of a step while it is iterated, in the solver's
  /// precision.
  class KeptState {
   public:
    void keep(const FluidSolver& solver) {
      double_ = solver.precision() == Precision::Double;
      double_ ? solver.copy_state(d_) : solver.copy_state(s_);
    }
    void restore(FluidSolver& solver, std::int64_t step) const {
      solver.precision() == Precision::Double ? solver.restore_state(d_, step) : solver.restore_state(s_, step);
    }
    std::string checkpoint(CoupledFluid& fluid, std::int64_t step, const std::string& reason) const {
      return double_ ? fluid.checkpoint(d_, step, reason) : fluid.checkpoint(s_, step, reason);
    }

   private:
    bool double_ = true;
    PopulationField d_;
    PopulationFieldSingle s_;
  };

  /// The populations of either store (precision "double" or "single"); a restart reads them
  /// back into a run of the same precision.
  template <class T>
  std::string checkpoint(const BasicPopulationField<T>& f, std::int64_t step, const std::string& reason) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(s_.output_dir) / "checkpoints";
    const fs::path file = dir / protocol::checkpoint_name("fluid", step);
    try {
      fs::create_directories(dir);
      protocol::CheckpointWriter w(file);
      w.attr("step", step);
      // The implicit scheme: the counters as of the step's commit (an abort may come while
      // the step is iterated), and the solid's seq that begins the step.
      const bool implicit = c_.scheme.implicit_scheme();
      w.attr("fluid_seq", implicit ? commit_.fluid_seq : fluid_seq_);
      if (implicit) w.attr("solid_seq_awaited", commit_.solid_seq);
      w.attr("num_cgps", static_cast<std::int64_t>(num_cgps_));
      w.attr("bulk_velocity_lb", bulk_u_);
      w.attr("mass0", mass0_);
      w.attr("time_ratio", static_cast<std::int64_t>(c_.time_ratio));
      if (markers_.has_reference()) {
        const protocol::MarkerWatch::Reference ref = markers_.reference();
        w.put("watchdog_neighbour", ref.neighbour);
        w.put("watchdog_distance", ref.distance);
        w.put("watchdog_last_positions", ref.last_positions);
      }
      w.text("scene_hash", protocol::scene_hash_of_file(s_.path));
      w.text("reason", reason.empty() ? "every coupling.checkpoint_every steps" : reason);
      w.put("populations", f.q(0), std::size_t(D3Q19::Q) * f.layout().stride());
      w.text("precision", std::is_same_v<T, float> ? "single" : "double");
      // The parallel scheme (protocol/README.md 14): fluid_state_t(step) is in flight too,
      // the solid's next interval needs it.
      if (c_.scheme.parallel_scheme())
        for (const cosimlcm::fluid_state_t& m : sent_)
          if (m.step == step) {
            std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
            m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
            w.put("in_flight_fluid_state", bytes);
          }
      put_rows(w, rows_);
      w.commit();
      protocol::prune_checkpoints(dir, "fluid_", 3);
    } catch (const std::exception& x) {
      if (reason.empty()) throw;
      return "; no checkpoint: " + std::string(x.what());
    }
    return "; checkpoint " + file.string();
  }

  /// Loads --restart: the populations, the step, the counters and the monitor rows; lists
  /// the earlier snapshots. Returns the step the run continues from. Throws (one line) for
  /// a file that is not a checkpoint of this scene.
  std::int64_t restore(FluidSolver& solver, MonitorLog& log, Snapshots& snapshots) {
    const protocol::CheckpointReader r(o_.restart);
    if (r.text("scene_hash") != protocol::scene_hash_of_file(s_.path))
      throw std::runtime_error("a checkpoint of another scene file (scene_hash differs from " + s_.path + ")");
    const std::int64_t step = r.int64_attr("step");
    if (step < 1 || step >= s_.steps)
      throw std::runtime_error("step = " + std::to_string(step) + ", allowed: 1 to " +
                               std::to_string(s_.steps - 1) + " (run.steps = " + std::to_string(s_.steps) + ")");
    if (r.int64_attr("num_cgps") != num_cgps_)
      throw std::runtime_error("num_cgps = " + std::to_string(r.int64_attr("num_cgps")) +
                               ", but the solid announced " + std::to_string(num_cgps_));
    // The populations in the store's precision (its "precision" text): the scene hash above
    // ties the checkpoint to this scene file, run.precision included.
    const std::size_t size = std::size_t(D3Q19::Q) * solver.layout().stride();
    if (solver.precision() == Precision::Double) {
      const std::vector<double> pop = r.doubles("populations", size);
      std::copy(pop.begin(), pop.end(), solver.mutable_state().q(0));
    } else {
      const std::vector<float> pop = r.floats("populations", size);
      std::copy(pop.begin(), pop.end(), solver.mutable_state_single().q(0));
    }
    solver.refresh_ghosts();
    solver.set_step_count(step);
    fluid_seq_ = r.int64_attr("fluid_seq");
    bulk_u_ = r.double_attr("bulk_velocity_lb");
    mass0_ = r.double_attr("mass0");
    // The in-flight solid_state_t(step) was computed with the checkpoint's A_T; a retry may
    // run another (the fluid's state does not depend on it).
    restart_ratio_ = r.has("time_ratio") ? static_cast<int>(r.int64_attr("time_ratio")) : c_.time_ratio;
    if (r.has("watchdog_neighbour")) {
      protocol::MarkerWatch::Reference ref;
      ref.neighbour = r.int64s("watchdog_neighbour");
      ref.distance = r.doubles("watchdog_distance");
      ref.last_positions = r.doubles("watchdog_last_positions");
      if (std::ssize(ref.neighbour) != num_cgps_)
        throw std::runtime_error("watchdog_neighbour has " + std::to_string(ref.neighbour.size()) +
                                 " markers, the solid announced " + std::to_string(num_cgps_));
      markers_.restore(ref);
    }
    // The parallel scheme: the solid's restart awaits fluid_state_t(step) from step D - 1 on
    // (protocol/README.md 14); it is published again once the checkpoint is read.
    if (c_.scheme.parallel_scheme() && step >= std::max<std::int64_t>(c_.rigid_steps, 1) - 1 &&
        protocol::parallel_fluid_state_needed(step, s_.steps, c_.rigid_steps)) {
      if (!r.has("in_flight_fluid_state"))
        throw std::runtime_error("no in_flight_fluid_state (fluid_state_t of step " + std::to_string(step) +
                                 "), which the parallel scheme's solid needs to continue");
      cosimlcm::fluid_state_t m{};
      const std::vector<std::uint8_t> bytes = r.bytes("in_flight_fluid_state");
      if (m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0 || m.step != step || m.num_cgps != num_cgps_)
        throw std::runtime_error("in_flight_fluid_state is not the fluid_state_t of step " + std::to_string(step));
      republish_ = std::move(m);
    }
    rows_ = get_rows(r);
    for (const FlowSummary& row : rows_) log.append(row);
    snapshots.adopt_up_to(step);
    // The solid republishes its solid_state_t(step) once the handshake is done; it may have
    // arrived while this checkpoint was read (classified by the sequencer of step 0): offer
    // what the inbox holds to the sequencer of the restart.
    inbox_.await_from(c_.scheme.implicit_scheme() ? r.int64_attr("solid_seq_awaited") : step);
    return step;
  }

  /// The monitor rows as flat arrays (what monitor.h5 holds), and back.
  static void put_rows(protocol::CheckpointWriter& w, const std::vector<FlowSummary>& rows) {
    std::vector<std::int64_t> steps, cells;
    std::vector<double> values;
    for (const FlowSummary& r : rows) {
      steps.push_back(r.step);
      for (const double v : {r.mass, r.momentum[0], r.momentum[1], r.momentum[2], r.max_mach,
                             r.rho_min, r.rho_max})
        values.push_back(v);
      for (const CellIndex& c : {r.max_mach_cell, r.rho_min_cell, r.rho_max_cell, r.nan_cell})
        for (const int v : {c.x, c.y, c.z}) cells.push_back(v);
      cells.push_back(r.has_nan ? 1 : 0);
    }
    w.put("monitor_step", steps);
    w.put("monitor_values", values);
    w.put("monitor_cells", cells);
  }
  static std::vector<FlowSummary> get_rows(const protocol::CheckpointReader& r) {
    const std::vector<std::int64_t> steps = r.int64s("monitor_step"), cells = r.int64s("monitor_cells");
    const std::vector<double> values = r.doubles("monitor_values");
    if (values.size() != 7 * steps.size() || cells.size() != 13 * steps.size())
      throw std::runtime_error("the monitor rows have inconsistent sizes");
    std::vector<FlowSummary> rows(steps.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      FlowSummary& s = rows[k];
      const double* v = &values[7 * k];
      const std::int64_t* c = &cells[13 * k];
      s.step = steps[k];
      s.mass = v[0];
      s.momentum = {v[1], v[2], v[3]};
      s.max_mach = v[4];
      s.rho_min = v[5];
      s.rho_max = v[6];
      CellIndex* idx[4] = {&s.max_mach_cell, &s.rho_min_cell, &s.rho_max_cell, &s.nan_cell};
      for (int i = 0; i < 4; ++i) *idx[i] = {int(c[3 * i]), int(c[3 * i + 1]), int(c[3 * i + 2])};
      s.has_nan = c[12] != 0;
    }
    return rows;
  }

  std::optional<Ending> handshake() {
    const protocol::Hello mine = fluid_hello();
    const cosimlcm::hello_t own = protocol::to_lcm(mine);
    link_.publish(ch_.hello, own);
    const Clock::time_point deadline = Clock::now() + ms(c_.handshake_timeout_s);
    while (!solid_hello_ && !hello_refusal_) {
      if (stop_) return stop_;
      if (Clock::now() > deadline) {
        publish_stop(0, kPeerLost, "no solid hello_t within the handshake timeout");
        return Ending{kPeerLost, "no solid announced itself on " + ch_.hello + " within " +
                                     std::to_string(c_.handshake_timeout_s) + " s"};
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
      return Ending{kBadInput, r.reason};
    }
    num_cgps_ = solid_hello_->num_cgps;
    time_ratio_ = r.time_ratio;
    out_ << "fluid: handshake accepted: solid model " << solid_hello_->model << ", "
         << num_cgps_ << " CGPs, A_T = " << r.time_ratio << ", " << s_.steps
         << " LB steps (" << c_.rigid_steps << " rigid)" << std::endl;
    added_mass_check(r.time_ratio);
    inbox_.heard(Clock::now());
    return std::nullopt;
  }

  /// The added-mass check at start-up (protocol/watchdog.hpp): one line with the lightest
  /// CGP's numbers, a warning when the substeps cannot resolve the fluid's reaction on it.
  void added_mass_check(int time_ratio) {
    const double m = solid_hello_->light_cgp_mass_kg, a = solid_hello_->light_cgp_area_m2;
    if (!(m > 0.0 && a > 0.0)) {
      out_ << "fluid: added mass: the solid does not report its CGPs' mass (no check)\n";
      return;
    }
    const protocol::AddedMass am =
        protocol::added_mass(m, a, units_.air_density_kg_m3(), units_.dx_m(), time_ratio);
    const std::string warning = protocol::added_mass_warning(am, s_.watchdog.relaxation_substeps_min, time_ratio);
    if (!warning.empty())
      out_ << "fluid: " << warning << "\n";
    else
      out_ << "fluid: added mass: the lightest CGP has m / (rho_air dA dx) = " << protocol::fmt("%.4g", am.mass_ratio)
           << "; the fluid's reaction relaxes it in " << protocol::fmt("%.4g", am.relaxation_substeps)
           << " substeps (watchdog.relaxation_substeps_min = " << protocol::fmt("%g", s_.watchdog.relaxation_substeps_min)
           << ")\n";
    out_.flush();
  }

  /// Asks the solid to publish the awaited solid_state_t again: the step (serial); the
  /// implicit scheme awaits the next seq, of step n (another iterate) or n + 1, and asks for
  /// both (the solid republishes what it keeps of each; copies had are dropped by seq).
  void request_resend(std::int64_t key) {
    const bool implicit = c_.scheme.implicit_scheme();
    for (std::int64_t step : {implicit ? awaited_step_ : key, awaited_step_ + 1}) {
      cosimlcm::resend_t r{};
      r.token = o_.token;
      r.step = step;
      r.what = "solid_state";
      link_.publish(ch_.resend, r);
      ++resends_.asked;
      if (!implicit) break;
    }
  }

  /// Waits for the awaited solid_state_t: `step` (serial) or the solid's seq (implicit).
  std::optional<Ending> wait_for_solid_state(std::int64_t step) {
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
          request_resend(step);
          break;
        case protocol::PeerWatch::Action::GiveUp: {
          const std::string why = "the solid was silent for " +
                                  std::to_string(c_.peer_timeout_s) +
                                  " s while the fluid waited for solid_state_t of step " +
                                  std::to_string(awaited_step_);
          publish_stop(awaited_step_, kPeerLost, why);  // the step, also where `step` is the solid's seq
          return Ending{kPeerLost, why};
        }
      }
    }
    return std::nullopt;
  }

  /// The A_T of the solid_state_t of a restart's step (protocol/README.md 10, 13): the
  /// checkpoint's for the republished message of the serial and parallel schemes; the run's
  /// in the implicit scheme, whose solid computes the step's iterates again from its start
  /// (the fluid must spread the impulses the solid continues from).
  int restart_ratio_of_step() const { return c_.scheme.implicit_scheme() ? c_.time_ratio : restart_ratio_; }

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
    const int ratio = step == first_step_ && first_step_ > 0 ? restart_ratio_of_step() : c_.time_ratio;
    // The implicit scheme's last message, solid_state_t(N, 0), takes no substeps.
    const bool closing = step == s_.steps;
    const int substeps = step < dynamic_from || closing ? 0 : ratio;
    if (m.substeps != substeps)
      return bad(kBadInput, "substeps = " + std::to_string(m.substeps) + ", expected " +
                                std::to_string(substeps));
    const double t = double(std::max<std::int64_t>(0, step - dynamic_from + (closing ? 0 : 1))) * units_.dt_lb_s();
    if (std::abs(m.solid_time_s - t) > 1e-9 * std::max(t, units_.dt_lb_s()))
      return bad(kBadInput, "solid_time_s = " + protocol::fmt("%.17g", m.solid_time_s) + " s, expected " +
                                protocol::fmt("%.17g", t) + " s (the solid's substeps times dt_CG, within 1e-9 relative)");
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
    // Step n -> n + 1 spreads the impulses of solid_state_t(n) (protocol/README.md 5); no
    // interval precedes step 0, so its impulses are 0 (a restart's first message is the
    // checkpoint's in-flight one, whatever its step).
    if (step == 0 && first_step_ == 0)
      for (std::int32_t l = 0; l < num_cgps_; ++l)
        for (std::size_t c = 0; c < 3; ++c)
          if (const double v = m.impulse_lb[static_cast<std::size_t>(l)][c]; v != 0.0)
            return bad(kBadInput, "impulse_lb[" + std::to_string(l) + "][" + std::to_string(c) + "] = " +
                                      protocol::fmt("%.17g", v) +
                                      "; allowed: 0 at step 0 (no interval precedes it; protocol/README.md 5)");
    return std::nullopt;
  }

  /// The solid sent only refused copies of the awaited step (kRejectedCopiesLimit in a row):
  /// the run ends naming the field, with check_solid_state's code where it applies (2, or 3
  /// for a non-finite number), else 2.
  Ending refused_ending() {
    // The refused copy's own step (in the implicit scheme the awaited key is the solid's seq).
    const std::int64_t step = refused_state_->first ? refused_state_->first->step : awaited_step_;
    if (refused_state_->first)
      if (auto e = check_solid_state(*refused_state_->first, step)) return *e;
    const std::string why = "solid_state_t of step " + std::to_string(step) + ": " +
                            refused_state_->second.detail() + " (" +
                            std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)";
    publish_stop(step, kBadInput, why);
    return Ending{kBadInput, why, false};
  }

  void publish_fluid_state(std::int64_t step, const std::vector<MarkerSample>& samples,
                           const std::vector<MarkerSample>& start, int iteration = 0) {
    cosimlcm::fluid_state_t m{};
    m.token = o_.token;
    m.seq = fluid_seq_++;
    m.step = step;
    m.iteration = iteration;
    m.bulk_velocity_lb = bulk_u_;
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
    link_.publish(ch_.fluid_state, m);
    sent_.push_back(std::move(m));
    while (sent_.size() > 2) sent_.pop_front();
  }

  void publish_stop(std::int64_t step, int code, const std::string& reason) { link_.publish_stop(step, code, reason); }

  /// The four channels the fluid listens on, through the session's gate (peer_link.hpp):
  /// handlers see only messages of this run that decode and pass the value checks.
  bool subscribe() {
    link_.expect([this] { return expectation(); });
    link_.on_undecodable([this](const std::string& channel, const protocol::MessageHeader& h, const std::string& why) {
      if (channel != ch_.solid_state) return;
      // A copy of this run that does not decode counts toward the three-copies rule of its step.
      refused_copy(c_.scheme.implicit_scheme() ? h.seq : h.step, h.step,
                   protocol::Rejection{protocol::RejectCategory::Undecodable, why}, nullptr);
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
                 refused_copy(key_of(m), m.step, r, &m);
               }) &&
           link_.subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(m); }) &&
           link_.subscribe<cosimlcm::stop_t>(ch_.stop, [this](cosimlcm::stop_t&& m) { on_stop(m); });
  }

  /// What a message of the run must satisfy now: the token, the handshake's CGP count, the
  /// steps from 0 to the awaited one + kStepWindow (within the run), A_T.
  protocol::Expectation expectation() const {
    protocol::Expectation e;
    e.token = o_.token;
    e.num_cgps = num_cgps_;
    e.lowest_step = 0;
    const bool implicit = c_.scheme.implicit_scheme();
    // The implicit scheme also sends solid_state_t(N, 0) (N = run.steps) to accept the last step.
    e.highest_step = std::min<std::int64_t>((implicit ? awaited_step_ + 1 : inbox_.awaited()) +
                                                protocol::kStepWindow,
                                            s_.steps - (implicit ? 0 : 1));
    e.time_ratio = time_ratio_;
    // The restart's first solid_state_t was computed with the checkpoint's A_T (check_solid_state
    // holds it to that for its step); not in the implicit scheme (restart_ratio_of_step).
    if (first_step_ > 0 && restart_ratio_ > 0 && restart_ratio_ != time_ratio_ && !c_.scheme.implicit_scheme())
      e.restart_time_ratio = restart_ratio_;
    e.max_iterations = c_.scheme.iterations_allowed();
    return e;
  }

  void on_hello(cosimlcm::hello_t&& m) {
    if (m.role != "solid") return;  // our own announcement
    inbox_.heard(Clock::now());
    if (!solid_hello_ && !hello_refusal_) solid_hello_ = std::move(m);
    else if (welcome_) link_.publish(ch_.welcome, *welcome_);  // a lost welcome
  }

  /// A copy of solid_state_t that was refused (the value checks, or bytes of this run that
  /// do not decode; `m` is null then): counted, never applied. A refused copy of the awaited
  /// step is asked for again at once; after kRejectedCopiesLimit refused copies in a row the
  /// run ends (wait_for_solid_state).
  void refused_copy(std::int64_t key, std::int64_t step, const protocol::Rejection& r,
                    const cosimlcm::solid_state_t* m) {
    if (!welcome_ || !welcome_->accepted || refused_state_) return;
    switch (inbox_.refused(key, m == nullptr)) {
      case protocol::StateInbox<cosimlcm::solid_state_t>::Refusal::Ignore:
        return;
      case protocol::StateInbox<cosimlcm::solid_state_t>::Refusal::AskAgain:
        request_resend(step);
        return;
      case protocol::StateInbox<cosimlcm::solid_state_t>::Refusal::GiveUp:
        refused_state_.emplace(m != nullptr ? std::optional<cosimlcm::solid_state_t>(*m) : std::nullopt, r);
        return;
    }
  }

  /// What the sequencer orders solid_state_t by: the step (serial), the solid's seq
  /// (implicit: several messages per step, consecutive seq in lock-step).
  std::int64_t key_of(const cosimlcm::solid_state_t& m) const {
    return c_.scheme.implicit_scheme() ? m.seq : m.step;
  }

  void on_resend(const cosimlcm::resend_t& m) {
    // Our own requests come back on the bus. A peer's request is not news of progress
    // (protocol/README.md 7-8): silence counts from the last message applied.
    if (m.what != "fluid_state") return;
    ++resends_.requests;
    for (const cosimlcm::fluid_state_t& f : sent_)
      if (f.step == m.step) {
        link_.publish(ch_.fluid_state, f);
        ++resends_.answered;
      }
  }

  /// The solid's stop_t, if it fits the run (protocol/session/stop_rules.hpp): the solid
  /// never ends a run with success; an error code ends it with 4.
  void on_stop(const cosimlcm::stop_t& m) {
    const protocol::StopFit fit = protocol::fit_stop(m, {"fluid", s_.steps, false});
    if (fit.verdict == protocol::StopVerdict::Refuse) {
      link_.refuse(ch_.stop, *fit.rejection);
      return;
    }
    if (stop_) return;
    peer_code_ = m.exit_code;
    stop_ = Ending{kPeerLost,
                   "the solid stopped at step " + std::to_string(m.step) + " with exit code " +
                       std::to_string(m.exit_code) + ": " + protocol::one_line(m.reason),
                   false};
  }

  std::string counters() const {
    return protocol::session_counters(link_, inbox_, resends_);
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
    if (markers_.has_reference()) out_ << "fluid: watchdog margins: " << markers_.margins() << "\n";
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
  protocol::PeerLink link_;  ///< the transport: every message in and out goes through it
  const protocol::Channels& ch_;
  /// solid_state_t by step (by the solid's seq in the implicit scheme), the resend timer.
  protocol::StateInbox<cosimlcm::solid_state_t> inbox_;
  protocol::MarkerWatch markers_;  ///< the watchdog's per-step sentinels (DESIGN 6)
  protocol::UnitConverter units_;
  std::optional<cosimlcm::hello_t> solid_hello_;
  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<Ending> stop_;
  int hellos_refused_ = 0;                    ///< solid hello_t refused by the checks
  std::optional<std::string> hello_refusal_;  ///< set after kRejectedCopiesLimit of them
  /// The last refused copy once kRejectedCopiesLimit were refused in a row, and why.
  /// (null when the copies did not decode).
  std::optional<std::pair<std::optional<cosimlcm::solid_state_t>, protocol::Rejection>> refused_state_;
  std::int32_t time_ratio_ = 0;  ///< A_T agreed in the handshake
  std::deque<cosimlcm::fluid_state_t> sent_;
  /// The parallel scheme's restart: the checkpoint's fluid_state_t in flight, published again.
  std::optional<cosimlcm::fluid_state_t> republish_;
  std::int32_t num_cgps_ = 0;
  std::int64_t first_step_ = 0;  ///< 0, or the step of --restart
  int restart_ratio_ = 0;        ///< the A_T of the --restart checkpoint
  int peer_code_ = 0;            ///< the exit code of the solid's stop_t
  std::int64_t fluid_seq_ = 0;
  /// The implicit scheme: the committed step with the counters a checkpoint of it keeps
  /// (the fluid's next seq, the solid's seq that begins the step's iterations).
  struct Commit {
    std::int64_t step = 0, fluid_seq = 0, solid_seq = 0;
  } commit_;
  std::int64_t awaited_step_ = 0;  ///< implicit: the committed step (the solid sends it or the next)
  std::int64_t redone_steps_ = 0;  ///< implicit: fluid steps taken again from a kept state
  protocol::ResendCounts resends_;
  double compute_s_ = 0.0, wait_s_ = 0.0, publish_s_ = 0.0;  ///< per-step timing (DESIGN 7)
  double watch_s_ = 0.0;  ///< the watchdog's share of compute_s_
  double bulk_u_ = 0.0;  ///< U_b of the latest health check (Eq. 34), lattice units
  double mass0_ = 0.0;   ///< the fluid's mass at step 0 (for the drift)
  std::vector<FlowSummary> rows_;  ///< monitor.h5's rows so far (for checkpoints)
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
