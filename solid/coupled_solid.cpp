#include "solid/coupled_solid.hpp"

#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "protocol/checkpoint_file.hpp"
#include "protocol/energy_watch.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hdf5_handle.hpp"
#include "protocol/hdf5_quiet.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/peak_memory.hpp"
#include "protocol/session/exit_codes.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/session_counters.hpp"
#include "protocol/session/state_inbox.hpp"
#include "protocol/session/stop_rules.hpp"
#include "protocol/step_sequencer.hpp"
#include "protocol/text.hpp"
#include "protocol/units.hpp"
#include "solid/aitken_relaxation.hpp"
#include "solid/model_registry.hpp"
#include "solid/sheet_snapshots.hpp"
#include "solid/sheet_spec.hpp"
#include "solid/solid_coupler.hpp"
#include "solid/solid_h5.hpp"
#include "solid/solid_model.hpp"

namespace cosim::solid {

namespace {

using Clock = std::chrono::steady_clock;
using protocol::fmt;
using protocol::indent;
using protocol::one_line;
using protocol::PhysicalConstants;
using protocol::UnitConverter;
using Rows3 = std::vector<std::vector<double>>;

constexpr auto kHelloEvery = std::chrono::milliseconds(200);  // section 6
constexpr std::size_t kKeptMessages = 2;  // section 7: at least the last two
constexpr auto kPoll = std::chrono::milliseconds(20);  // the longest single wait for LCM, so that timers are checked
constexpr auto kProgressEvery = std::chrono::seconds(1);
constexpr double kMicrometre = 1e-6;

/// The solid's frame on the lattice: its plate surface y = 0 is the fluid's half-way
/// bounce-back wall at lattice y = -1/2; x and z: lattice = physical / dx
/// (protocol/README.md section 4).
const Eigen::Vector3d kOriginLb(0.0, -0.5, 0.0);

double um_from_bohr(double bohr) { return bohr * PhysicalConstants::bohr_m / kMicrometre; }
double joule_from_hartree(double e) {
  return e * UnitConverter::force_au_N() * PhysicalConstants::bohr_m;  // E_h = F_AU l_AU
}

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

using protocol::Ending;
using FluidInbox = protocol::StateInbox<cosimlcm::fluid_state_t>;

/// The time series of OUTPUT/solid.h5, one row per LB step (step 0 included), kept in
/// memory and written once at the end.
struct CoupledSeries {
  int sheets = 0;
  std::vector<std::int64_t> step;
  std::vector<double> time_s, solid_time_s, displacement_um, normal_um, fluid_force_N, kinetic_J,
      elastic_J, total_J;
  /// U_b (Eq. 34) of the fluid_state_t behind each row, m/s; 0 at step 0.
  std::vector<double> bulk_velocity_m_s;
  /// C_x, C_y, C_z of each sheet (Eq. 33: F / (rho_f U_b^2 W H / 2)); C_D = C_x, and the
  /// lift is C_z (span-wise) for a sheet turned about y, C_y normal to the plate.
  std::vector<double> force_coefficients;
  /// Area strain at the bottom, middle and top of each sheet's leading edge (Figs. 11, 14).
  std::vector<double> edge_strain;
  std::size_t rows() const { return step.size(); }
};

class CoupledSolid {
 public:
  CoupledSolid(const SolidScene& scene, const CoupledSolidOptions& options, std::ostream& out,
               std::ostream& err)
      : s_(scene), c_(*scene.coupling), o_(options), out_(out), err_(err),
        ch_(c_.channel_prefix), units_(scene.unit_inputs()),
        // fluid_state_t(1) is the first the solid waits for; the implicit scheme sends several
        // messages per step: both sides then wait for the peer's next sequence number
        // (consecutive in lock-step) instead of the next step.
        inbox_(c_.scheme.implicit_scheme() ? 0 : 1, [this](const cosimlcm::fluid_state_t& m) { return key_of(m); },
               peer_timeout_ms(c_), resend_after_ms(c_)) {}

  CoupledSolid(const CoupledSolid&) = delete;
  CoupledSolid& operator=(const CoupledSolid&) = delete;

  ~CoupledSolid() = default;

  int run() {
    if (const auto e = build()) return report(*e);
    print_header();
    if (o_.check_only) return exit_code::ok;
    if (const auto e = open_output()) return report(*e);
    if (const auto e = open_bus()) return report(*e);
    if (const auto e = handshake()) return finish(*e);
    out_ << "solid: handshake accepted: " << total_steps_ << " LB steps (" << rigid_steps_
         << " rigid), A_T = " << c_.time_ratio << (parallel_ ? ", parallel scheme" : "") << "\n";
    // The parallel scheme's first fluid_state_t is of step 0 when the sheets are free from
    // step 1 (section 14).
    if (parallel_) inbox_.await_from(protocol::parallel_first_fluid_state(rigid_steps_));
    out_.flush();
    start_ = last_progress_ = Clock::now();

    if (!o_.restart.empty()) {
      // Continue from a checkpoint at step N: the state after the interval of step N and
      // the solid_state_t(N) it sent, which is published again (the in-flight impulses).
      try {
        restore();
      } catch (const std::exception& e) {
        return finish(Ending{exit_code::bad_input, "--restart " + o_.restart + ": " + one_line(e.what()), true});
      }
      out_ << "solid: restarted from " << o_.restart << " at step " << last_step_ << "\n";
    } else {
      // Step 0: the initial positions, zero impulses (section 5).
      publish_state(0, 0, coupler_->positions_lb(), Eigen::Matrix3Xd::Zero(3, n_));
      record(0, nullptr);
      energy_watch_->check(0, sheet_energy_J(), 0.0);  // the reference E(0)
      if (const auto e = snapshot(0)) return finish(*e);
    }
    first_step_ = last_step_;
    inbox_.heard(Clock::now());
    for (;;) {
      const Clock::time_point t0 = Clock::now();
      if (const auto e = wait_for_fluid_state()) return finish(*e);
      const Clock::time_point t1 = Clock::now();
      const cosimlcm::fluid_state_t m = inbox_.peek_out();
      if (const auto e = on_fluid_state(m)) return finish(*e);
      wait_s_ += std::chrono::duration<double>(t1 - t0).count();
      compute_s_ += std::chrono::duration<double>(Clock::now() - t1).count();
      ++timed_steps_;
      // A copy of the next step held early is offered again, now due.
      inbox_.advance();
      progress();
      if (const auto e = failure()) return finish(*e);
    }
  }

 private:
  static std::chrono::milliseconds resend_after_ms(const CouplingSettings& c) {
    return std::chrono::milliseconds(
        std::max<long long>(1, static_cast<long long>(std::floor(c.resend_after_s * 1e3))));
  }
  static std::chrono::milliseconds peer_timeout_ms(const CouplingSettings& c) {
    // Above resend_after_ms whenever resend_after_s < peer_timeout_s (the scene's rule).
    return std::chrono::milliseconds(
        std::max<long long>(resend_after_ms(c).count() + 1,
                            static_cast<long long>(std::ceil(c.peer_timeout_s * 1e3))));
  }

  // ---- set-up ----

  std::optional<Ending> build() {
    try {
      model_ = make_solid_model(s_.model, s_.config);
    } catch (const std::invalid_argument& e) {
      return Ending{exit_code::bad_input, s_.path + ": solid.model = \"" + s_.model + "\": " + e.what()};
    } catch (const std::runtime_error& e) {
      return Ending{exit_code::bad_input, s_.path + ": solid.model = \"" + s_.model +
                                              "\": the construction failed: " + e.what()};
    }
    n_ = model_->num_cgps();
    if (n_ < 1 || n_ > std::numeric_limits<std::int32_t>::max())
      return Ending{exit_code::bad_input,
                    s_.path + ": " + std::to_string(n_) +
                        " CGPs; a coupled run exchanges 1 to 2^31 - 1 markers (int32 num_cgps)"};
    coupler_ = std::make_unique<SolidCoupler>(*model_, units_, marker_areas_lb(s_.config.sheets, units_),
                                              kOriginLb);
    // The watchdog (DESIGN 6; protocol/watchdog.hpp): a CGP's speed after every substep, the
    // energy after every interval. The energy floor: the sheets at 1e-6 c.
    coupler_->set_speed_limit(s_.watchdog.max_cgp_speed);
    coupler_->set_held(held_cgps());
    const double mass_kg = model_->masses().sum() * PhysicalConstants::electron_mass_kg;
    const double c = units_.dx_m() / units_.dt_lb_s();
    energy_watch_.emplace(s_.watchdog.energy_growth, 0.5 * mass_kg * c * c * 1e-12);
    return std::nullopt;
  }

  /// The CGP with the smallest mass per area, for hello_t's added-mass fields (kg, m^2);
  /// 0, 0 for a model without dynamics (nothing the fluid could accelerate).
  std::pair<double, double> light_cgp() const {
    if (!std::isfinite(model_->stable_time_step())) return {0.0, 0.0};
    const std::vector<double> area = marker_areas_lb(s_.config.sheets, units_);
    double best_m = 0.0, best_a = 0.0;
    for (Eigen::Index l = 0; l < n_; ++l) {
      const double m = model_->masses()[l] * PhysicalConstants::electron_mass_kg;
      const double a = area[static_cast<std::size_t>(l)] * units_.dx_m() * units_.dx_m();
      if (best_a == 0.0 || m / a < best_m / best_a) best_m = m, best_a = a;
    }
    return {best_m, best_a};
  }

  /// The fastest CGP and its speed in c, for a diagnosis.
  std::string fastest_cgp() const {
    Eigen::Index l = 0;
    const double v2 = model_->velocities().colwise().squaredNorm().maxCoeff(&l);
    return "fastest " + describe_cgp(s_.config, l) + " at " + fmt("%.4g", units_.velocity_ratio() * std::sqrt(v2)) + " c";
  }

  /// The model's stable substep in seconds; a model without dynamics (rigid: +infinity)
  /// announces the largest double, since hello_t carries positive finite numbers only.
  double stable_dt_cg_s() const {
    const double s = model_->stable_time_step() * PhysicalConstants::time_au_s;
    return std::isfinite(s) ? s : std::numeric_limits<double>::max();
  }

  void print_header() {
    out_ << "solid: coupled scene " << s_.name << (s_.description.empty() ? "" : ": ")
         << s_.description << " (" << s_.path << ")\n";
    out_ << indent(model_->startup_report());
    out_ << "  sheets   " << s_.config.sheets.size() << " sheet(s), " << n_ << " CGPs (markers)\n";
    for (std::size_t k = 0; k < s_.config.sheets.size(); ++k) {
      const SheetSpec& sh = s_.config.sheets[k];
      char line[512];
      std::snprintf(line, sizeof line,
                    "    sheet %zu: %d x %d CGPs, spacing %.4g x %.4g um = %.4g x %.4g dx, "
                    "theta %.4g deg, %d clamped row(s), base (%.4g, %.4g, %.4g) um\n",
                    k, sh.nx_cg, sh.ny_cg, um_from_bohr(sh.width_spacing_bohr),
                    um_from_bohr(sh.height_spacing_bohr), units_.length_lb_from_bohr(sh.width_spacing_bohr),
                    units_.length_lb_from_bohr(sh.height_spacing_bohr), sh.theta_deg, sh.clamped_rows,
                    um_from_bohr(sh.base_bohr[0]), um_from_bohr(sh.base_bohr[1]),
                    um_from_bohr(sh.base_bohr[2]));
      out_ << line;
    }
    const double stable = model_->stable_time_step() * PhysicalConstants::time_au_s;
    out_ << "  units    dx = " << fmt("%.6g", units_.dx_m() / kMicrometre)
         << " um, dt_LB = " << fmt("%.6g", units_.dt_lb_s()) << " s, A_T = " << c_.time_ratio
         << ", dt_CG = " << fmt("%.6g", units_.dt_cg_s()) << " s; stable step of the model "
         << (std::isfinite(stable) ? fmt("%.6g s", stable) + " (dt_CG is " +
                                         fmt("%.3g", units_.dt_cg_s() / stable) + " of it" +
                                         (units_.dt_cg_s() > stable ? ": the coordinator will refuse it)" : ")")
                                   : std::string("none (no dynamics)"))
         << "\n";
    out_ << "  coupling channels " << ch_.prefix << "*, LCM " << c_.lcm_url
         << ", rigid_steps " << c_.rigid_steps << " (the welcome_t's count), timeouts: handshake "
         << fmt("%g", c_.handshake_timeout_s) << " s, peer " << fmt("%g", c_.peer_timeout_s)
         << " s, resend after " << fmt("%g", c_.resend_after_s) << " s; output " << s_.output_dir
         << (s_.sheets_every > 0 ? ", sheet snapshots every " + std::to_string(s_.sheets_every) +
                                       " LB steps (sheets.xmf)"
                                 : std::string())
         << "\n";
    out_.flush();
  }

  std::optional<Ending> open_output() {
    std::error_code ec;
    std::filesystem::create_directories(s_.output_dir, ec);
    if (ec)
      return Ending{exit_code::system,
                    "cannot create the output directory " + s_.output_dir + ": " + ec.message()};
    if (s_.sheets_every > 0) {
      try {
        snapshots_ = std::make_unique<SheetSnapshotWriter>(s_.output_dir, s_.config);
      } catch (const std::exception& e) {
        return Ending{exit_code::system, one_line(e.what())};
      }
    }
    return std::nullopt;
  }

  /// The session's transport (protocol/session/peer_link.hpp) and the four channels the
  /// solid listens on: handlers see only messages of this run that decode and pass the checks.
  std::optional<Ending> open_bus() {
    protocol::PeerLink::Settings ls;
    ls.role = "solid";
    ls.token = o_.token;
    ls.channel_prefix = c_.channel_prefix;
    ls.lcm_url = c_.lcm_url;
    ls.bus = o_.bus;
    ls.faults = o_.faults;
    link_.emplace(ls, out_);
    if (auto e = link_->open()) return e;
    link_->expect([this] { return expectation(); });
    link_->on_undecodable([this](const std::string& channel, const protocol::MessageHeader& h, const std::string& why) {
      if (channel != ch_.fluid_state) return;
      // A copy of this run that does not decode counts toward the three-copies rule of its step.
      refused_copy(implicit_ ? h.seq : h.step, protocol::Rejection{protocol::RejectCategory::Undecodable, why}, nullptr);
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
            [this](const cosimlcm::fluid_state_t& m, const protocol::Rejection& r) { refused_copy(key_of(m), r, &m); }) &&
        link_->subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(m); }) &&
        link_->subscribe<cosimlcm::stop_t>(ch_.stop, [this](cosimlcm::stop_t&& m) { on_stop(std::move(m)); });
    if (!subscribed)
      return Ending{exit_code::system, "cannot subscribe to the channels " + ch_.prefix + "* on " + c_.lcm_url, false};
    return std::nullopt;
  }

  /// An ending found inside a handler or by the transport, if any.
  std::optional<Ending> failure() const {
    if (fatal_) return fatal_;
    if (link_ && link_->fatal()) return link_->fatal();
    return std::nullopt;
  }

  // ---- the handshake (section 6) ----

  cosimlcm::hello_t make_hello() const {
    cosimlcm::hello_t h{};
    h.token = o_.token;
    h.role = "solid";
    h.model = s_.model;
    h.version = protocol::kProtocolVersion;
    h.scene_hash = protocol::scene_hash_of_file(s_.path);
    h.scheme = protocol::scheme_name(c_.scheme.scheme);
    h.dx_m = units_.dx_m();
    h.dt_lb_s = units_.dt_lb_s();
    h.sound_speed_m_s = units_.inputs().sound_speed_m_s;
    h.air_density_kg_m3 = units_.air_density_kg_m3();
    h.time_ratio = c_.time_ratio;
    h.dt_cg_s = units_.dt_cg_s();
    h.stable_dt_cg_s = stable_dt_cg_s();
    h.num_cgps = static_cast<std::int32_t>(n_);
    std::tie(h.light_cgp_mass_kg, h.light_cgp_area_m2) = light_cgp();
    return h;
  }

  std::optional<Ending> handshake() {
    cosimlcm::hello_t hello{};
    try {
      hello = make_hello();
    } catch (const std::runtime_error& e) {  // the scene file cannot be hashed
      return Ending{exit_code::system, e.what()};
    }
    const Clock::time_point deadline = Clock::now() + seconds(c_.handshake_timeout_s);
    Clock::time_point next_hello = Clock::now();
    while (!welcome_) {
      if (const auto e = failure()) return e;
      if (stop_) return peer_stop();
      const Clock::time_point now = Clock::now();
      if (now >= deadline)
        return Ending{exit_code::peer_lost,
                      "no welcome_t on " + ch_.welcome + " within handshake_timeout_s = " +
                          fmt("%g", c_.handshake_timeout_s) + " s (" + std::to_string(hellos_) +
                          " hello_t sent); is the fluid running with the same token, channel "
                          "prefix and LCM URL?",
                      true};
      if (now >= next_hello) {
        publish(ch_.hello, hello);
        ++hellos_;
        next_hello = now + kHelloEvery;
      }
      pump(std::min(next_hello, deadline) - Clock::now());
    }
    const cosimlcm::welcome_t& w = *welcome_;
    if (!w.accepted) {
      const std::string why = one_line(w.reason);
      return Ending{exit_code::bad_input,
                    why.rfind("handshake refused", 0) == 0 ? why : "handshake refused: " + why};
    }
    const auto malformed = [&](const std::string& what) {
      return Ending{exit_code::bad_input, "welcome_t: " + what, true};
    };
    if (w.time_ratio != c_.time_ratio)
      return malformed("time_ratio = " + std::to_string(w.time_ratio) +
                       ", but this solid runs A_T = " + std::to_string(c_.time_ratio) +
                       " ([coupling] time_ratio)");
    const std::string own_scheme = protocol::scheme_name(c_.scheme.scheme);
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

  /// Waits until the awaited fluid_state_t is accepted (pending_), asking for it again
  /// after every resend_after_s of silence; an ending on stop_t, a timeout or an LCM error.
  std::optional<Ending> wait_for_fluid_state() {
    while (!inbox_.ready()) {
      if (const auto e = failure()) return e;
      if (stop_) return peer_stop();
      pump(kPoll);
      if (inbox_.ready() || stop_ || failure()) continue;
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
                            std::to_string(parallel_ ? inbox_.awaited() : last_step_ + 1) + " on " +
                            ch_.fluid_state + " (" +
                            std::to_string(inbox_.watch().resends_since_heard()) + " resend_t sent)",
                        true};
      }
      progress();
    }
    return std::nullopt;
  }

  /// The checks of section 5 on an accepted fluid_state_t: sizes (2), finite and rho > 0 (3).
  std::optional<Ending> check_fluid_state(const cosimlcm::fluid_state_t& m) const {
    const std::string where = "fluid_state_t of step " + std::to_string(m.step) + ": ";
    const auto malformed = [&](const std::string& what) {
      return Ending{exit_code::bad_input, where + what, true};
    };
    if (m.step >= total_steps_ + (implicit_ ? 1 : 0))
      return malformed("the run has total_steps = " + std::to_string(total_steps_) +
                       " (welcome_t); the last fluid_state_t is for step " +
                       std::to_string(total_steps_ - 1));
    if (m.num_cgps != n_)
      return malformed("num_cgps = " + std::to_string(m.num_cgps) + ", expected " +
                       std::to_string(n_) + " (the solid's hello_t)");
    if (std::ssize(m.rho_lb) != n_ || std::ssize(m.velocity_lb) != n_)
      return malformed("rho_lb has " + std::to_string(m.rho_lb.size()) + " and velocity_lb " +
                       std::to_string(m.velocity_lb.size()) + " entries, expected " +
                       std::to_string(n_));
    for (std::size_t l = 0; l < m.velocity_lb.size(); ++l)
      if (m.velocity_lb[l].size() != 3)
        return malformed("velocity_lb[" + std::to_string(l) + "] has " +
                         std::to_string(m.velocity_lb[l].size()) + " components, expected 3");
    if (!std::isfinite(m.bulk_velocity_lb))
      return Ending{exit_code::unhealthy,
                    where + "bulk_velocity_lb = " + fmt("%g", m.bulk_velocity_lb) + " is not finite",
                    true};
    for (std::size_t l = 0; l < m.rho_lb.size(); ++l) {
      const auto unhealthy = [&](const std::string& what) {
        return Ending{exit_code::unhealthy,
                      where + describe_cgp(s_.config, static_cast<Eigen::Index>(l)) + ": " + what,
                      true};
      };
      if (!std::isfinite(m.rho_lb[l]))
        return unhealthy("rho_lb = " + fmt("%g", m.rho_lb[l]) + " is not finite");
      if (!(m.rho_lb[l] > 0.0))
        return unhealthy("rho_lb = " + fmt("%g", m.rho_lb[l]) + "; the density must be > 0");
      for (std::size_t c = 0; c < 3; ++c)
        if (!std::isfinite(m.velocity_lb[l][c]))
          return unhealthy("velocity_lb[" + std::to_string(c) + "] = " +
                           fmt("%g", m.velocity_lb[l][c]) + " is not finite");
    }
    return std::nullopt;
  }

  /// What fluid_state_t(m) asks for: the serial scheme's interval; in the implicit scheme the
  /// answer to the current iterate (another iterate, or its acceptance), then the next step.
  std::optional<Ending> on_fluid_state(const cosimlcm::fluid_state_t& m) {
    if (parallel_) return parallel_intervals(m);
    if (!implicit_) return interval(m);
    if (const auto e = check_fluid_state(m)) return e;
    if (iterate_) {
      bool again = false;
      if (const auto e = answer_iterate(m, again)) return e;
      if (again) return std::nullopt;
    }
    if (m.step == total_steps_) {
      // The last step accepted: solid_state_t(N, 0), zero impulses, closes the run (the
      // fluid commits its last step on it and answers with stop_t).
      publish_state(m.step, 0, coupler_->positions_lb(), Eigen::Matrix3Xd::Zero(3, n_));
      return std::nullopt;
    }
    if (m.step < rigid_steps_) return interval(m);  // the spin-up: nothing to iterate
    return begin_iterate(m);
  }

  // ---- the parallel scheme (protocol/README.md 14) ----

  /// What fluid_state_t(m) drives in the parallel scheme, with D = max(rigid_steps, 1): the
  /// spin-up's solid_state_t(m) for 1 <= m < D, as in the serial scheme (no substeps: there
  /// is nothing to overlap, and a held sheet's direct forcing (Eqs. 18-20) is deadbeat only
  /// without the lag); then, for m + 1 >= D, the interval m -> m + 1 with the sample of the
  /// fluid at m, solid_state_t(m + 1), which the fluid spreads while stepping m + 1 -> m + 2
  /// (Eqs. 21-24): the fluid receives exactly the J its CGPs received the opposite of, one
  /// step after the interval, as in the serial scheme. fluid_state_t(D - 1) drives both.
  std::optional<Ending> parallel_intervals(const cosimlcm::fluid_state_t& m) {
    const std::int64_t dynamic_from = std::max<std::int64_t>(rigid_steps_, 1);
    // (A restart at step D - 1 has published solid_state_t(D - 1) already.)
    if (m.step >= 1 && m.step < dynamic_from && last_step_ < m.step)
      if (const auto e = interval(m, m.step)) return e;
    if (m.step + 1 >= dynamic_from && m.step + 1 <= total_steps_ - 1) return interval(m, m.step + 1);
    return check_fluid_state(m);
  }

  // ---- the implicit scheme (protocol/README.md 13) ----

  /// The sub-iterations of one step: the state at its start, the fluid sample that drives
  /// the current iterate, that iterate's interval, and what a checkpoint of the step keeps.
  struct Iterate {
    std::int64_t step = 0;
    int iteration = 0;
    SolidState start;                ///< the committed state at the start of the interval
    SolidCoupler::ReactionMemory start_memory;  ///< the implicit reaction's, at the start
    FluidSample drive;               ///< u^k (relaxed) and the latest rho, lattice units
    IntervalResult trial;            ///< the interval driven by it
    double start_bulk_velocity = 0;  ///< U_b of the fluid_state_t that began the step
    cosimlcm::solid_state_t first;   ///< solid_state_t(step, 0), for checkpoints
    FluidSample first_drive;         ///< its sample, for checkpoints
    std::int64_t fluid_seq_awaited = 0;  ///< the fluid seq awaited after `first`
    double residual = 0.0;           ///< |u~ - u| / |u~| of the last answer
  };

  /// rho_l and u_l of a message's arrays as a FluidSample (sizes checked by check_fluid_state).
  static FluidSample sample_from(const std::vector<double>& rho, const std::vector<std::vector<double>>& u) {
    FluidSample sample;
    const auto n = static_cast<Eigen::Index>(rho.size());
    sample.rho_lb.resize(n);
    sample.velocity_lb.resize(3, n);
    for (Eigen::Index l = 0; l < n; ++l) {
      const auto k = static_cast<std::size_t>(l);
      sample.rho_lb[l] = rho[k];
      for (Eigen::Index c = 0; c < 3; ++c) sample.velocity_lb(c, l) = u[k][static_cast<std::size_t>(c)];
    }
    return sample;
  }
  /// The fluid after the step (the serial scheme's sample; the start of the next step).
  static FluidSample sample_of(const cosimlcm::fluid_state_t& m) { return sample_from(m.rho_lb, m.velocity_lb); }
  /// The fluid before the step at the iterate's markers (fluid_state_t's *_start_lb).
  static FluidSample start_sample_of(const cosimlcm::fluid_state_t& m) {
    return sample_from(m.rho_start_lb, m.velocity_start_lb);
  }

  /// The first relaxation factor of the run: coupling.relaxation, else 1/2.
  double first_relaxation() const {
    return c_.scheme.implicit.relaxation > 0.0 ? c_.scheme.implicit.relaxation : 0.5;
  }

  /// The CGPs the model holds (solid_coupler.hpp set_held): clamped rows; all of a model
  /// without dynamics.
  std::vector<bool> held_cgps() const {
    std::vector<bool> held(static_cast<std::size_t>(n_), !std::isfinite(model_->stable_time_step()));
    Eigen::Index first = 0;
    for (const SheetSpec& sheet : s_.config.sheets) {
      for (Eigen::Index k = 0; k < sheet.num_cgps() && first + k < n_; ++k)
        if (sheet.is_clamped(k)) held[static_cast<std::size_t>(first + k)] = true;
      first += sheet.num_cgps();
    }
    return held;
  }

  /// Step m.step's first iterate, driven by the fluid at the start of the step (the serial
  /// scheme's sample); solid_state_t(step, 0).
  std::optional<Ending> begin_iterate(const cosimlcm::fluid_state_t& m) {
    Iterate it;
    it.step = m.step;
    it.start = model_->state();
    it.start_memory = coupler_->reaction_memory();
    it.start_bulk_velocity = m.bulk_velocity_lb;
    it.drive = sample_of(m);
    it.first_drive = it.drive;
    if (!aitken_) aitken_.emplace(first_relaxation());
    aitken_->new_step();
    if (const auto e = run_iterate(it)) return e;
    publish_state(it.step, it.trial.substeps, it.trial.position_lb, it.trial.impulse_lb, 0, it.trial.substeps);
    it.first = sent_.back();
    it.fluid_seq_awaited = inbox_.awaited() + 1;  // the sequencer advances after this
    iterate_ = std::move(it);
    ++implicit_steps_;
    if (c_.checkpoint_every > 0 && m.step % c_.checkpoint_every == 0) {
      try {
        checkpoint("");
      } catch (const std::exception& e) {
        return Ending{exit_code::system, "checkpoint of step " + std::to_string(m.step) + ": " +
                                             one_line(e.what()), true};
      }
    }
    return std::nullopt;
  }

  /// The interval driven by it.drive from it.start (the model holds it.start), with the
  /// reaction integrated exactly over each substep.
  std::optional<Ending> run_iterate(Iterate& it) {
    const std::string where = "iteration " + std::to_string(it.iteration) + " of step " + std::to_string(it.step);
    try {
      coupler_->set_reaction_memory(it.start_memory);
      it.trial = coupler_->advance(it.drive, false, true);
    } catch (const std::exception& e) {
      return Ending{exit_code::unhealthy, "the implicit scheme's " + where + ": " + one_line(e.what()), true};
    }
    if (it.trial.overspeed) {
      Ending e = overspeed(it.step, *it.trial.overspeed);
      e.reason += " (the implicit scheme's " + where + ")";
      return e;
    }
    std::string bad = non_finite_state();
    if (bad.empty() && !(it.trial.position_lb.allFinite() && it.trial.impulse_lb.allFinite()))
      bad = "a non-finite position or impulse for the fluid";
    if (!bad.empty())
      return Ending{exit_code::unhealthy, "non-finite solid state in the implicit scheme's " + where + ": " + bad, true};
    return std::nullopt;
  }

  /// fluid_state_t(step + 1, k) answers iterate k with the fluid before the step at the
  /// iterate's markers (the mean positions over its interval, where J was spread), u~,
  /// against the u^k that drove it. Not converged (and iterations left): the next
  /// iterate, u^{k+1} = u^k + omega (u~ - u^k) (Aitken), published, `again` = true. Else the
  /// iterate is accepted.
  std::optional<Ending> answer_iterate(const cosimlcm::fluid_state_t& m, bool& again) {
    Iterate& it = *iterate_;
    const protocol::ImplicitSettings& cfg = c_.scheme.implicit;
    const FluidSample answer = start_sample_of(m);
    const double r = (answer.velocity_lb - it.drive.velocity_lb).norm(), un = answer.velocity_lb.norm();
    // The round-off floor: 1e-14 of the flow's speed at the markers.
    const bool converged = r <= cfg.tolerance * un + 1e-14 * (un + 1e-300);
    it.residual = un > 0.0 ? r / un : r;
    if (!converged && it.iteration + 1 < cfg.max_iterations) {
      it.drive.velocity_lb = aitken_->next(it.drive.velocity_lb, answer.velocity_lb);
      it.drive.rho_lb = answer.rho_lb;
      model_->restore(it.start);
      ++it.iteration;
      ++iterations_redone_;
      if (const auto e = run_iterate(it)) return e;
      publish_state(it.step, it.trial.substeps, it.trial.position_lb, it.trial.impulse_lb, it.iteration,
                    it.trial.substeps);
      again = true;
      return std::nullopt;
    }
    // Accepted: the model holds the end of the interval whose impulses the fluid spread;
    // the row, the energy sentinel and the snapshot of the step, as interval() does.
    if (!converged) {
      ++unconverged_;
      unconverged_residual_max_ = std::max(unconverged_residual_max_, it.residual);
    }
    iterations_max_ = std::max(iterations_max_, it.iteration + 1);
    if (const auto trip = energy_watch_->check(it.step, sheet_energy_J(), joule_from_hartree(it.trial.fluid_work_au)))
      return Ending{exit_code::unhealthy, trip->diagnosis + "; " + fastest_cgp(), true};
    total_substeps_ += it.trial.substeps;
    record(it.step, &it.trial, it.start_bulk_velocity);
    const std::int64_t step = it.step;
    iterate_.reset();
    if (const auto e = snapshot(step)) return e;
    return std::nullopt;
  }

  /// One LB interval for fluid_state_t(m) (section 5, steps 1-4; Eqs. 18-20 and 24):
  /// solid_state_t(step), with step = m.step (the serial scheme), or m.step + 1 (the
  /// parallel scheme's dynamic steps, section 14: the interval step - 1 -> step driven by the
  /// fluid sample at its start).
  std::optional<Ending> interval(const cosimlcm::fluid_state_t& m) { return interval(m, m.step); }
  std::optional<Ending> interval(const cosimlcm::fluid_state_t& m, std::int64_t step) {
    if (const auto e = check_fluid_state(m)) return e;
    const FluidSample sample = sample_of(m);
    const bool rigid = step < rigid_steps_;
    IntervalResult r;
    try {
      r = coupler_->advance(sample, rigid);
      if (r.overspeed) return overspeed(step, *r.overspeed);
    } catch (const std::exception& e) {
      if (const std::string bad = non_finite_state(); !bad.empty())
        return Ending{exit_code::unhealthy, "non-finite solid state in the interval of step " +
                                                std::to_string(step) + ": " + bad, true};
      return Ending{exit_code::system, "the interval of step " + std::to_string(step) + ": " +
                                           one_line(e.what()), true};
    }
    std::string bad = non_finite_state();
    if (bad.empty() && !(r.position_lb.allFinite() && r.impulse_lb.allFinite()))
      bad = "a non-finite position or impulse for the fluid";
    if (!bad.empty())
      return Ending{exit_code::unhealthy, "non-finite solid state after the interval of step " +
                                              std::to_string(step) + ": " + bad, true};
    // The energy sentinel, before anything of this interval is published or recorded.
    if (const auto trip = energy_watch_->check(step, sheet_energy_J(), joule_from_hartree(r.fluid_work_au)))
      return Ending{exit_code::unhealthy, trip->diagnosis + "; " + fastest_cgp(), true};
    total_substeps_ += r.substeps;
    publish_state(step, r.substeps, r.position_lb, r.impulse_lb);
    record(step, &r, m.bulk_velocity_lb);
    if (const auto e = snapshot(step)) return e;
    if (c_.checkpoint_every > 0 && step % c_.checkpoint_every == 0) {
      try {
        checkpoint("");
      } catch (const std::exception& e) {
        return Ending{exit_code::system, "checkpoint of step " + std::to_string(step) + ": " +
                                             one_line(e.what()), true};
      }
    }
    return std::nullopt;
  }

  /// Kinetic + elastic (+ contact) energy of the sheets, J.
  double sheet_energy_J() const {
    const SolidObservables o = model_->observables();
    return joule_from_hartree(o.kinetic_energy_au + o.elastic_energy_au);
  }

  /// The watchdog's cgp_speed sentinel tripped within the interval of `step` (DESIGN 6).
  Ending overspeed(std::int64_t step, const IntervalResult::Overspeed& o) const {
    const int a_t = c_.time_ratio;
    return Ending{exit_code::unhealthy,
                  "watchdog cgp_speed at step " + std::to_string(step) + " (substep " + std::to_string(o.substep) +
                      " of " + std::to_string(a_t) + "): " + describe_cgp(s_.config, o.cgp) + " moves at " +
                      fmt("%.4g", o.speed_lb) + " c (" + fmt("%.4g", o.speed_lb / a_t) +
                      " dx per substep), above watchdog.max_cgp_speed = " + fmt("%.4g", s_.watchdog.max_cgp_speed) +
                      " c; dt_CG / T = " + fmt("%.3g", o.dt_over_relaxation) +
                      " for the fluid's reaction on it (T = m / (2 rho dA c), Eqs. 18-20; explicit substeps "
                      "diverge above 2" +
                      (o.dt_over_relaxation > 2.0 ? ": the cause" : ": not the cause; an elastic or contact force the "
                                                                    "substeps do not resolve") +
                      "); a smaller dt_CG may cure it",
                  true};
  }

  // ---- coupled checkpoints (DESIGN 2.4; protocol/README.md section 10) ----

  /// The double columns of solid.h5's series, by name: one table for writing a checkpoint
  /// and for reading it back.
  std::vector<std::pair<const char*, std::vector<double>*>> series_columns() {
    CoupledSeries& s = series_;
    return {{"time_s", &s.time_s},
            {"solid_time_s", &s.solid_time_s},
            {"displacement_um", &s.displacement_um},
            {"normal_um", &s.normal_um},
            {"fluid_force_N", &s.fluid_force_N},
            {"kinetic_J", &s.kinetic_J},
            {"elastic_J", &s.elastic_J},
            {"total_J", &s.total_J},
            {"bulk_velocity_m_s", &s.bulk_velocity_m_s},
            {"force_coefficients", &s.force_coefficients},
            {"edge_strain", &s.edge_strain}};
  }

  /// Writes OUTPUT/checkpoints/solid_NNNNNNNN.h5 for the state after the interval of
  /// last_step_ (solid_state_t(last_step_) sent) and keeps the newest three. Throws (one
  /// line) on an output error.
  std::string checkpoint(const std::string& reason) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(s_.output_dir) / "checkpoints";
    fs::create_directories(dir);
    const fs::path file = dir / protocol::checkpoint_name("solid", last_step_);
    protocol::CheckpointWriter w(file);
    w.attr("step", last_step_);
    // The implicit scheme keeps the step's start and its first iterate: a restart iterates
    // the step again from there, as the run did.
    w.attr("solid_seq", iterate_ ? iterate_->first.seq + 1 : solid_seq_);
    if (implicit_) {
      w.attr("fluid_seq_awaited", iterate_ ? iterate_->fluid_seq_awaited
                                           : inbox_.awaited() + (inbox_.awaited_received() ? 1 : 0));
      w.attr("aitken_start", aitken_ ? aitken_->step_start() : 0.0);
      w.attr("start_bulk_velocity_lb", iterate_ ? iterate_->start_bulk_velocity : 0.0);
      w.attr("iterating", static_cast<std::int64_t>(iterate_ ? 1 : 0));
      if (iterate_) {
        const FluidSample& d = iterate_->first_drive;
        w.put("iterate_rho_lb", d.rho_lb.data(), std::size_t(d.rho_lb.size()));
        w.put("iterate_velocity_lb", d.velocity_lb.data(), std::size_t(d.velocity_lb.size()));
        const SolidCoupler::ReactionMemory& mem = iterate_->start_memory;
        w.put("reaction_memory_velocity_au", mem.velocity.data(), std::size_t(mem.velocity.size()));
        w.put("reaction_memory_force_au", mem.force.data(), std::size_t(mem.force.size()));
      }
    }
    w.attr("total_substeps", total_substeps_);
    w.attr("num_cgps", static_cast<std::int64_t>(n_));
    w.attr("time_ratio", static_cast<std::int64_t>(c_.time_ratio));
    const protocol::EnergyWatch::State ew = energy_watch_->state();
    w.attr("watchdog_energy_started", static_cast<std::int64_t>(ew.started ? 1 : 0));
    w.attr("watchdog_energy0_J", ew.energy0);
    w.attr("watchdog_work_J", ew.work);
    w.attr("watchdog_work_abs_J", ew.work_abs);
    w.attr("watchdog_energy_max_J", ew.energy_max);
    w.text("scene_hash", protocol::scene_hash_of_file(s_.path));
    w.text("reason", reason.empty() ? "every coupling.checkpoint_every steps" : reason);
    const SolidState st = iterate_ ? iterate_->start : model_->state();
    w.text("model", st.model);
    w.put("positions_bohr", st.positions_bohr.data(), std::size_t(st.positions_bohr.size()));
    w.put("velocities_au", st.velocities_au.data(), std::size_t(st.velocities_au.size()));
    w.put("external_forces_au", st.external_forces_au.data(), std::size_t(st.external_forces_au.size()));
    // The solid_state_t(last_step_) in flight: the fluid has not applied it yet.
    const cosimlcm::solid_state_t& sent = iterate_ ? iterate_->first : sent_.back();
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(sent.getEncodedSize()));
    sent.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    w.put("in_flight_solid_state", bytes);
    w.put("series_step", series_.step);
    for (const auto& [name, column] : series_columns()) w.put(std::string("series_") + name, *column);
    w.commit();
    protocol::prune_checkpoints(dir, "solid_", 3);
    return file.string();
  }

  /// Loads --restart (see run()). Throws (one line) for a file that is not a checkpoint of
  /// this scene and model.
  void restore() {
    const protocol::CheckpointReader r(o_.restart);
    if (r.text("scene_hash") != protocol::scene_hash_of_file(s_.path))
      throw std::runtime_error("a checkpoint of another scene file (scene_hash differs from " + s_.path + ")");
    const std::int64_t step = r.int64_attr("step");
    if (step < 1 || step >= total_steps_)
      throw std::runtime_error("step = " + std::to_string(step) + ", allowed: 1 to " +
                               std::to_string(total_steps_ - 1));
    const auto size = static_cast<std::size_t>(3 * n_);
    SolidState st;
    st.model = r.text("model");
    st.positions_bohr = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("positions_bohr", size).data(), 3, n_);
    st.velocities_au = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("velocities_au", size).data(), 3, n_);
    st.external_forces_au =
        Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("external_forces_au", size).data(), 3, n_);
    model_->restore(st);  // std::invalid_argument: another model or CGP count
    cosimlcm::solid_state_t sent{};
    const std::vector<std::uint8_t> bytes = r.bytes("in_flight_solid_state");
    if (sent.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0 || sent.step != step ||
        sent.num_cgps != n_)
      throw std::runtime_error("in_flight_solid_state is not the solid_state_t of step " + std::to_string(step));
    series_.sheets = static_cast<int>(s_.config.sheets.size());
    series_.step = r.int64s("series_step");
    for (const auto& [name, column] : series_columns()) *column = r.doubles(std::string("series_") + name);
    solid_seq_ = r.int64_attr("solid_seq");
    total_substeps_ = r.int64_attr("total_substeps");
    // A restart with another A_T (the launcher's watchdog retry): the state does not depend
    // on it, the substep count does (solid_time_s = substeps x dt_CG is physical time); the
    // in-flight solid_state_t keeps the substeps it was computed with, and the coordinator
    // accepts them for its step (its checkpoint holds the old A_T too). The implicit scheme
    // replaces it instead (below).
    bool ratio_changed = false;
    if (r.has("time_ratio")) {
      const std::int64_t old_ratio = r.int64_attr("time_ratio");
      if (old_ratio < 1 || total_substeps_ % old_ratio != 0)
        throw std::runtime_error("time_ratio = " + std::to_string(old_ratio) + " does not divide total_substeps = " +
                                 std::to_string(total_substeps_));
      if (old_ratio != c_.time_ratio) {
        out_ << "solid: the checkpoint ran A_T = " << old_ratio << ", this run A_T = " << c_.time_ratio
             << ": " << total_substeps_ / old_ratio << " dynamic LB steps so far\n";
        total_substeps_ = total_substeps_ / old_ratio * c_.time_ratio;
        ratio_changed = true;
      }
    }
    if (r.has("watchdog_energy_started")) {
      protocol::EnergyWatch::State ew;
      ew.started = r.int64_attr("watchdog_energy_started") != 0;
      ew.energy0 = r.double_attr("watchdog_energy0_J");
      ew.work = r.double_attr("watchdog_work_J");
      ew.work_abs = r.double_attr("watchdog_work_abs_J");
      ew.energy_max = r.double_attr("watchdog_energy_max_J");
      energy_watch_->restore(ew);
    } else {
      energy_watch_->check(step, sheet_energy_J(), 0.0);  // an older checkpoint: E here is E(0)
    }
    // The parallel scheme awaits fluid_state_t(step) from step D - 1 on (it drives the interval
    // step -> step + 1; protocol/README.md 14), which the fluid publishes again.
    const bool parallel_awaits_step = parallel_ && step >= std::max<std::int64_t>(rigid_steps_, 1) - 1;
    inbox_.await_from(implicit_ ? r.int64_attr("fluid_seq_awaited") : parallel_awaits_step ? step : step + 1);
    if (implicit_ && r.int64_attr("iterating") != 0) {
      // The step's first iterate again, from its start, with the sample it began with.
      Iterate it;
      it.step = step;
      it.start = model_->state();
      // An empty memory (the first free step) was written as empty arrays.
      if (r.doubles("reaction_memory_velocity_au").size() == size) {
        it.start_memory.velocity =
            Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("reaction_memory_velocity_au", size).data(), 3, n_);
        it.start_memory.force =
            Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("reaction_memory_force_au", size).data(), 3, n_);
      }
      it.drive.rho_lb = Eigen::Map<const Eigen::VectorXd>(r.doubles("iterate_rho_lb", std::size_t(n_)).data(), n_);
      it.drive.velocity_lb = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("iterate_velocity_lb", size).data(), 3, n_);
      it.first_drive = it.drive;
      it.start_bulk_velocity = r.double_attr("start_bulk_velocity_lb");
      it.fluid_seq_awaited = r.int64_attr("fluid_seq_awaited");
      aitken_.emplace(first_relaxation());
      aitken_->restore_start(r.double_attr("aitken_start"));
      if (const auto e = run_iterate(it)) throw std::runtime_error("its first iterate again: " + e->reason);
      // At another A_T that iterate differs from the checkpoint's solid_state_t(step, 0): the
      // solid would continue from the one while the fluid spread the other's impulses (and,
      // converged, committed them). The recomputed iterate is published in its place (same
      // seq), as a run at this A_T from the step's start sends it (protocol/README.md 13).
      if (ratio_changed) {
        sent.substeps = it.trial.substeps;
        sent.solid_time_s = static_cast<double>(total_substeps_ + it.trial.substeps) * units_.dt_cg_s();
        set_positions_impulses(sent, it.trial.position_lb, it.trial.impulse_lb);
        out_ << "solid: step " << step << "'s first iterate computed again at A_T = " << c_.time_ratio
             << " and sent in place of the checkpoint's (A_T = " << r.int64_attr("time_ratio") << ")\n";
      }
      iterate_ = std::move(it);
      ++implicit_steps_;
    }
    if (snapshots_)
      for (std::int64_t k = 0; k <= step; ++k)
        if (sheet_snapshot_due(k, total_steps_ - 1, s_.sheets_every))
          snapshots_->adopt(k, static_cast<double>(k) * units_.dt_lb_s());
    // The token is this run's; the rest of the message is the one sent before, bit for bit
    // (but for the implicit scheme's first iterate at another A_T, above).
    sent.token = o_.token;
    publish(ch_.solid_state, sent);
    last_step_ = step;
    if (iterate_) iterate_->first = sent;
    sent_.push_back(std::move(sent));
  }

  /// The first CGP with a non-finite position or velocity, as a diagnosis; "" if none.
  std::string non_finite_state() const {
    const Eigen::Matrix3Xd& x = model_->positions();
    const Eigen::Matrix3Xd& v = model_->velocities();
    if (x.allFinite() && v.allFinite()) return "";
    for (Eigen::Index l = 0; l < x.cols(); ++l) {
      const bool bad_x = !x.col(l).allFinite(), bad_v = !v.col(l).allFinite();
      if (bad_x || bad_v)
        return describe_cgp(s_.config, l) + ": " + (bad_x ? "position" : "velocity") + " not finite";
    }
    return "";
  }

  // ---- publishing ----

  template <class Message>
  void publish(const std::string& channel, const Message& m) {
    link_->publish(channel, m);  // an LCM error ends the run (failure())
  }

  /// num_cgps, position_lb and impulse_lb of `m`: the columns of x and j.
  static void set_positions_impulses(cosimlcm::solid_state_t& m, const Eigen::Matrix3Xd& x,
                                     const Eigen::Matrix3Xd& j) {
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

  /// `pending_substeps`: substeps of an implicit iterate, not yet in total_substeps_.
  void publish_state(std::int64_t step, int substeps, const Eigen::Matrix3Xd& x,
                     const Eigen::Matrix3Xd& j, int iteration = 0, int pending_substeps = 0) {
    cosimlcm::solid_state_t m{};
    m.token = o_.token;
    m.seq = solid_seq_++;
    m.step = step;
    m.iteration = iteration;
    m.substeps = substeps;
    m.solid_time_s = static_cast<double>(total_substeps_ + pending_substeps) * units_.dt_cg_s();
    set_positions_impulses(m, x, j);
    publish(ch_.solid_state, m);
    last_step_ = step;
    sent_.push_back(std::move(m));
    while (sent_.size() > kKeptMessages) sent_.pop_front();
  }

  void request_resend() {
    cosimlcm::resend_t r{};
    r.token = o_.token;
    // fluid_state_t(n + 1) answers solid_state_t(n); in the parallel scheme the awaited step.
    r.step = parallel_ ? inbox_.awaited() : last_step_ + 1;
    r.what = "fluid_state";
    publish(ch_.resend, r);
    ++resends_.asked;
  }

  // ---- receiving ----

  /// Dispatches what arrives within `wait` (at most kPoll at a time, never forever).
  void pump(Clock::duration wait) {
    link_->pump(std::clamp(std::chrono::duration_cast<std::chrono::milliseconds>(wait), std::chrono::milliseconds(0), kPoll));
  }

  /// What a message of the run must satisfy now: the token, this solid's CGP count, the
  /// steps from 1 to the awaited one + kStepWindow (within the run), A_T.
  protocol::Expectation expectation() const {
    protocol::Expectation e;
    e.token = o_.token;
    e.num_cgps = static_cast<std::int32_t>(n_);
    e.lowest_step = parallel_ ? 0 : 1;
    // The implicit scheme's last answer is fluid_state_t(N) (N = total_steps).
    e.highest_step = std::min<std::int64_t>(last_step_ + 1 + protocol::kStepWindow,
                                            total_steps_ - (implicit_ ? 0 : 1));
    e.time_ratio = c_.time_ratio;
    e.max_iterations = c_.scheme.iterations_allowed();
    return e;
  }

  /// The coordinator answers every hello_t with its welcome_t: only refused copies
  /// (kRejectedCopiesLimit in a row) end the run, naming the field.
  void refused_welcome(const protocol::Rejection& r) {
    if (!welcome_ && ++welcomes_refused_ >= protocol::kRejectedCopiesLimit && !fatal_)
      fatal_ = Ending{exit_code::bad_input,
                      r.what + " (" + std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)", true};
  }

  /// A copy of fluid_state_t that was refused (the value checks, or bytes of this run that
  /// do not decode; `m` is null then): counted, never applied. A refused copy of the awaited
  /// step is asked for again at once; after kRejectedCopiesLimit refused copies in a row the
  /// run ends, naming the field, with check_fluid_state's code where it applies (2, or 3 for
  /// a non-finite number or rho <= 0), else 2.
  void refused_copy(std::int64_t key, const protocol::Rejection& r, const cosimlcm::fluid_state_t* m) {
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
      if (auto e = check_fluid_state(*m)) {
        fatal_ = *e;
        return;
      }
    fatal_ = Ending{exit_code::bad_input,
                    "fluid_state_t of step " + std::to_string(m != nullptr ? m->step : key) + ": " + r.detail() +
                        " (" + std::to_string(protocol::kRejectedCopiesLimit) + " copies refused)",
                    true};
  }

  /// What the sequencer orders fluid_state_t by: the step (serial), the fluid's seq
  /// (implicit: several messages per step, consecutive seq in lock-step).
  std::int64_t key_of(const cosimlcm::fluid_state_t& m) const { return implicit_ ? m.seq : m.step; }

  void on_resend(const cosimlcm::resend_t& m) {
    if (m.what != "solid_state") return;  // our own request for fluid_state, heard back
    ++resends_.requests;
    // Every kept message of that step (the implicit scheme's iterates of one step share it;
    // the fluid drops the copies it has had by their seq).
    for (const cosimlcm::solid_state_t& sent : sent_)
      if (sent.step == m.step) {
        publish(ch_.solid_state, sent);  // unchanged: same seq, bit for bit
        ++resends_.answered;
      }
    // A step not reached yet (it comes when ready) or no longer kept: ignored.
  }

  /// The coordinator's stop_t, if it fits the run (protocol/session/stop_rules.hpp): exit
  /// code 0 only at the run's last step, once this solid has sent its part of it.
  void on_stop(cosimlcm::stop_t&& m) {
    // The last solid_state_t the fluid needs: of step N - 1, or N (the implicit scheme's closing one).
    const bool at_end = total_steps_ > 0 && last_step_ >= total_steps_ - (implicit_ ? 0 : 1);
    const protocol::StopFit fit = protocol::fit_stop(m, {"solid", total_steps_, at_end});
    if (fit.verdict == protocol::StopVerdict::Refuse) {
      link_->refuse(ch_.stop, *fit.rejection);
      return;
    }
    if (!stop_) stop_ = std::move(m);
  }

  Ending peer_stop() const {
    const cosimlcm::stop_t& m = *stop_;
    if (m.exit_code == exit_code::ok) return Ending{exit_code::ok, "", false};
    return Ending{exit_code::peer_lost,
                  "the fluid stopped the run at step " + std::to_string(m.step) +
                      " with exit code " + std::to_string(m.exit_code) + ": " +
                      (m.reason.empty() ? std::string("(no reason given)") : one_line(m.reason)),
                  false};
  }

  // ---- output ----

  /// A row of solid.h5 for step `step`; `r` is the interval that produced it (null: step 0).
  void record(std::int64_t step, const IntervalResult* r, double bulk_velocity_lb = 0.0) {
    const SolidObservables o = model_->observables();
    if (series_.sheets == 0) series_.sheets = static_cast<int>(s_.config.sheets.size());
    const double ek = joule_from_hartree(o.kinetic_energy_au);
    const double ee = joule_from_hartree(o.elastic_energy_au);
    series_.step.push_back(step);
    series_.time_s.push_back(static_cast<double>(step) * units_.dt_lb_s());
    series_.solid_time_s.push_back(static_cast<double>(total_substeps_) * units_.dt_cg_s());
    for (std::size_t k = 0; k < s_.config.sheets.size(); ++k) {
      const SheetSpec& sh = s_.config.sheets[k];
      const Eigen::Vector3d d = o.marked_displacement_bohr[k];
      for (int c = 0; c < 3; ++c) series_.displacement_um.push_back(um_from_bohr(d[c]));
      series_.normal_um.push_back(um_from_bohr(d.dot(sheet_normal(sh))));
      // The fluid's mean force on the sheet over the interval: -sum_l J_l / dt_LB, every
      // CGP of the sheet (clamped ones included), lattice force F_LB -> N.
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      if (r != nullptr)
        f = -r->impulse_lb.middleCols(first_cgp(s_.config, k), sh.num_cgps()).rowwise().sum() *
            units_.force_lb_N();
      for (int c = 0; c < 3; ++c) series_.fluid_force_N.push_back(f[c]);
      // Eq. 33 with rho_f = rho_air and A = W H, the area the sheet's CGPs carry.
      const double area_m2 = static_cast<double>(sh.num_cgps()) * sh.cell_area_bohr2() *
                             PhysicalConstants::bohr_m * PhysicalConstants::bohr_m;
      const double u_b = units_.velocity_m_s(bulk_velocity_lb);
      const double q = 0.5 * units_.air_density_kg_m3() * u_b * u_b * area_m2;
      for (int c = 0; c < 3; ++c) series_.force_coefficients.push_back(q > 0.0 ? f[c] / q : 0.0);
      // The leading edge: the side column further upstream (smaller x); CGPs on the first
      // free row, the middle row and the top row.
      const Eigen::Matrix3Xd ref = flat_sheet_positions(sh);
      const int i_lead = ref(0, sh.index(0, 0)) <= ref(0, sh.index(sh.nx_cg - 1, 0)) ? 0 : sh.nx_cg - 1;
      const Eigen::Index first = first_cgp(s_.config, k);
      for (const int j : {std::min(sh.clamped_rows, sh.ny_cg - 1), sh.ny_cg / 2, sh.ny_cg - 1})
        series_.edge_strain.push_back(
            o.area_strain.size() > 0 ? o.area_strain[first + sh.index(i_lead, j)] : 0.0);
    }
    series_.bulk_velocity_m_s.push_back(units_.velocity_m_s(bulk_velocity_lb));
    series_.kinetic_J.push_back(ek);
    series_.elastic_J.push_back(ee);
    series_.total_J.push_back(ek + ee);
  }

  /// OUTPUT/sheets_NNNNNN.h5 and sheets.xmf (solid/sheet_snapshots.hpp) at step 0, every
  /// [output] sheets_every LB steps and the last step; an output error ends the run (1).
  std::optional<Ending> snapshot(std::int64_t step) {
    if (!snapshots_ || !sheet_snapshot_due(step, total_steps_ - 1, s_.sheets_every))
      return std::nullopt;
    try {
      snapshots_->write(step, static_cast<double>(step) * units_.dt_lb_s(), *model_);
    } catch (const std::exception& e) {
      return Ending{exit_code::system,
                    "sheet snapshot of step " + std::to_string(step) + ": " + one_line(e.what()),
                    true};
    }
    return std::nullopt;
  }

  std::string output_path() const {
    return (std::filesystem::path(s_.output_dir) / "solid.h5").string();
  }

  void write_series() const {
    const std::string path = output_path();
    const protocol::H5Quiet quiet;
    protocol::H5Id file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                        "cannot create " + path);
    const hid_t f = file.get();
    const CoupledSeries& s = series_;
    const hsize_t n = s.rows(), ns = static_cast<hsize_t>(s.sheets);
    write_dataset(f, "step", H5T_STD_I64LE, H5T_NATIVE_INT64, {n}, s.step.data());
    write_dataset(f, "time_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.time_s.data());
    write_dataset(f, "solid_time_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.solid_time_s.data());
    write_dataset(f, "marked_displacement_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns, 3},
                  s.displacement_um.data());
    write_dataset(f, "marked_normal_displacement_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns},
                  s.normal_um.data());
    write_dataset(f, "fluid_force_N", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns, 3},
                  s.fluid_force_N.data());
    write_dataset(f, "bulk_velocity_m_s", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n},
                  s.bulk_velocity_m_s.data());
    write_dataset(f, "force_coefficients", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns, 3},
                  s.force_coefficients.data());
    write_dataset(f, "leading_edge_strain", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, ns, 3},
                  s.edge_strain.data());
    write_dataset(f, "kinetic_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.kinetic_J.data());
    write_dataset(f, "elastic_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.elastic_J.data());
    write_dataset(f, "total_energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, s.total_J.data());
    write_attribute(f, "scene", s_.name);
    write_attribute(f, "model", s_.model);
    write_attribute(f, "mode", "coupled");
    write_attribute(f, "token", o_.token);
    write_attribute(f, "dt_s", units_.dt_cg_s());
    write_attribute(f, "dt_lb_s", units_.dt_lb_s());
    write_attribute(f, "time_ratio", static_cast<double>(c_.time_ratio));
    write_attribute(f, "total_steps", static_cast<double>(total_steps_));
    write_attribute(f, "rigid_steps", static_cast<double>(rigid_steps_));
    file.close("cannot close " + path);
  }

  void progress() {
    if (o_.quiet) return;
    const Clock::time_point now = Clock::now();
    if (now - last_progress_ < kProgressEvery) return;
    last_progress_ = now;
    const double wall = std::chrono::duration<double>(now - start_).count();
    const double rate = wall > 0.0 ? static_cast<double>(last_step_) / wall : 0.0;
    const double left = static_cast<double>(std::max<std::int64_t>(0, total_steps_ - 1 - last_step_));
    char line[256];
    std::snprintf(line, sizeof line,
                  "solid: step %lld/%lld  t = %.4g us  %.3g LB steps/s  ETA %.0f s%s\n",
                  static_cast<long long>(last_step_), static_cast<long long>(total_steps_),
                  static_cast<double>(last_step_) * units_.dt_lb_s() * 1e6, rate,
                  rate > 0.0 ? left / rate : 0.0, last_step_ < rigid_steps_ ? "  (rigid)" : "");
    err_ << line;
    err_.flush();
  }

  std::string counters() const {
    if (!link_) return "no transport opened";
    return protocol::session_counters(*link_, inbox_, resends_);
  }

  /// Ends the run: stop_t for our own errors, solid.h5, the counters, the one-line reason.
  int finish(Ending e) {
    // A clean abort (the fluid lost, or stopped with an error) keeps the state after the
    // last interval for a restart (DESIGN 2.4).
    if (e.code == exit_code::peer_lost && model_ && !sent_.empty() && last_step_ > first_step_) {
      try {
        e.reason += "; checkpoint " + checkpoint(e.reason);
      } catch (const std::exception& x) {
        e.reason += "; no checkpoint: " + one_line(x.what());
      }
    }
    if (e.publish_stop && link_) link_->publish_stop(last_step_, e.code, one_line(e.reason));
    if (series_.rows() > 0) {
      try {
        write_series();
      } catch (const std::exception& x) {
        if (e.code == exit_code::ok) e = Ending{exit_code::system, one_line(x.what()), false};
        else err_ << "solid: " << one_line(x.what()) << "\n";
      }
    }
    if (series_.rows() == 0) {
      out_ << "solid: coupled run stopped before the handshake completed (" << hellos_
           << " hello_t sent); " << counters() << "\n";
    } else {
      const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
      out_ << "solid: coupled run " << (e.code == exit_code::ok ? "done" : "stopped")
           << " at step " << last_step_ << " of " << total_steps_ << ", " << total_substeps_
           << " substeps (" << fmt("%.5g", static_cast<double>(total_substeps_) * units_.dt_cg_s() * 1e6)
           << " us) in " << fmt("%.1f", wall) << " s; " << counters() << "; " << series_.rows()
           << " rows in " << output_path()
           << (snapshots_ ? ", " + std::to_string(snapshots_->count()) + " sheet snapshots in " +
                                snapshots_->xdmf_path().string()
                          : std::string())
           << "\n";
      if (energy_watch_ && coupler_)
        out_ << "solid: watchdog margins: CGP speed max " << fmt("%.3g", coupler_->max_speed_lb())
             << " c after a substep (limit " << fmt("%g", s_.watchdog.max_cgp_speed)
             << "), unexplained energy max " << fmt("%.3g", energy_watch_->max_ratio())
             << " of the energy scale (limit " << fmt("%g", s_.watchdog.energy_growth) << ")\n";
      out_ << "solid: peak memory " << fmt("%.1f", protocol::peak_rss_mib()) << " MiB (largest resident set)\n";
      if (implicit_ && implicit_steps_ > 0)
        out_ << "solid: implicit scheme: " << implicit_steps_ << " steps iterated, "
             << fmt("%.3g", double(implicit_steps_ + iterations_redone_) / double(implicit_steps_))
             << " iterations a step on average, at most " << iterations_max_ << " (coupling.max_iterations = "
             << c_.scheme.implicit.max_iterations << ", tolerance " << fmt("%g", c_.scheme.implicit.tolerance)
             << "); " << unconverged_ << " steps not converged"
             << (unconverged_ > 0 ? " (relative residual up to " + fmt("%.3g", unconverged_residual_max_) + ")" : std::string())
             << "; Aitken factor: first " << fmt("%.4g", first_relaxation()) << ", last "
             << fmt("%.4g", aitken_ ? aitken_->omega() : 0.0) << "\n";
      if (timed_steps_ > 0)
        out_ << "solid: per LB step: compute " << fmt("%.4g", 1e3 * compute_s_ / double(timed_steps_))
             << " ms (substeps, publishing, recording), waiting " << fmt("%.4g", 1e3 * wait_s_ / double(timed_steps_))
             << " ms (for fluid_state_t), over " << timed_steps_ << " steps\n";
    }
    return report(e);
  }

  int report(const Ending& e) {
    out_.flush();
    if (e.code != exit_code::ok) {
      err_ << "solid: " << one_line(e.reason) << "\n";
      err_.flush();
    }
    return e.code;
  }

  const SolidScene& s_;
  const CouplingSettings c_;
  const CoupledSolidOptions& o_;
  std::ostream& out_;
  std::ostream& err_;
  const protocol::Channels ch_;
  const UnitConverter units_;

  std::unique_ptr<SolidModel> model_;
  std::unique_ptr<SolidCoupler> coupler_;
  std::optional<protocol::EnergyWatch> energy_watch_;  ///< the watchdog's energy sentinel
  Eigen::Index n_ = 0;

  /// The transport: every message in and out goes through it (opened after the model is
  /// built: a --check run needs no token and no bus).
  std::optional<protocol::PeerLink> link_;
  /// fluid_state_t by step (by the fluid's seq in the implicit scheme), the resend timer.
  FluidInbox inbox_;
  int welcomes_refused_ = 0;  ///< welcome_t refused by the checks before one was taken

  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<cosimlcm::stop_t> stop_;
  std::optional<Ending> fatal_;  // an LCM failure seen inside a handler
  std::deque<cosimlcm::solid_state_t> sent_;

  std::int64_t total_steps_ = 0, rigid_steps_ = 0;
  std::int64_t solid_seq_ = 0, last_step_ = 0, total_substeps_ = 0;
  // The implicit scheme (protocol/README.md 13).
  const bool implicit_ = c_.scheme.implicit_scheme();
  const bool parallel_ = c_.scheme.parallel_scheme();  ///< protocol/README.md 14
  std::optional<Iterate> iterate_;       ///< the step being iterated
  std::optional<AitkenRelaxation> aitken_;
  std::int64_t implicit_steps_ = 0, iterations_redone_ = 0, unconverged_ = 0;
  int iterations_max_ = 0;
  double unconverged_residual_max_ = 0.0;
  std::int64_t first_step_ = 0;  ///< 0, or the step of --restart
  std::int64_t hellos_ = 0;
  protocol::ResendCounts resends_;

  CoupledSeries series_;
  std::unique_ptr<SheetSnapshotWriter> snapshots_;  ///< [output] sheets_every > 0
  Clock::time_point start_ = Clock::now(), last_progress_ = start_;
  double compute_s_ = 0.0, wait_s_ = 0.0;  ///< per-step timing (DESIGN 7)
  std::int64_t timed_steps_ = 0;
};

}  // namespace

int run_coupled_solid(const SolidScene& scene, const CoupledSolidOptions& options,
                      std::ostream& out, std::ostream& err) {
  if (!scene.coupled()) {
    err << "solid: " << scene.path << ": not a coupled scene (no [coupling] section)\n";
    return exit_code::bad_input;
  }
  if (!options.check_only && options.token.empty()) {
    err << "solid: a coupled scene needs the run's token: --token TOKEN or the environment "
           "variable COSIM_RUN_TOKEN (the launcher draws one per run)\n";
    return exit_code::bad_input;
  }
  try {
    CoupledSolid run(scene, options, out, err);
    return run.run();
  } catch (const std::exception& e) {
    out.flush();
    err << "solid: " << one_line(e.what()) << "\n";
    return exit_code::system;
  }
}

}  // namespace cosim::solid
