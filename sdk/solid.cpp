// The solid library's run (sdk/include/cosim/solid.hpp): the solid server's scene reader,
// session (solid/coupled/solid_peer.hpp over protocol/session/) and coupling schemes (the
// registry of solid/schemes/: serial, parallel, implicit) around a user's Solid, which the
// schemes drive as they drive the server's model (solid/schemes/scheme_solid.hpp). Protocol
// state lives there; this file only wires it to the user's interface: the command line, the
// hello_t, the lock-step loop, the user's steps and checkpoints, the ending.
#include "cosim/solid.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/run/checkpoint_file.hpp"
#include "protocol/checkpoint_identity.hpp"
#include "common/text/cli_parse.hpp"
#include "protocol/fault_injection.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/session/announcement.hpp"
#include "common/run/exit_codes.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"
#include "common/run/provenance.hpp"
#include "sdk/energy_balance.hpp"
#include "solid/io/solid_log.hpp"
#include "sdk/energy_balance_checkpoint.hpp"
#include "sdk/solid_series.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/coupling/fluid_state_check.hpp"
#include "solid/schemes/scheme_context.hpp"
#include "solid/schemes/scheme_solid.hpp"
#include "solid/schemes/solid_scheme.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "solid/coupled/solid_peer.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::sdk {

namespace {

namespace exit_code = protocol::exit_code;
using solid::solid_log;
using protocol::Ending;
using protocol::fmt;
using protocol::one_line;
using Clock = std::chrono::steady_clock;

/// The launcher's options that take a value, and its flags (section 6a; cli_parse.hpp's).
const std::set<std::string> kValueOptions{"--output", "--token", "--channel-prefix", "--lcm-url",
                                          "--time-ratio", "--faults", "--restart"};
const std::set<std::string> kFlags{"--quiet", "--help", "-h", "--version"};

/// Splits `args` (after the program's name) into the launcher's arguments, kept for the
/// command-line parser, and the solid's own "--NAME VALUE" (or --NAME=VALUE) parameters.
std::vector<std::string> split_params(const std::vector<std::string>& args, std::map<std::string, std::string>& params) {
  std::vector<std::string> kept;
  for (std::size_t k = 0; k < args.size(); ++k) {
    const std::string& a = args[k];
    const std::string key = a.substr(0, a.find('='));
    if (a.rfind("--", 0) != 0 || a.size() < 3 || kFlags.count(key) || kValueOptions.count(key)) {
      kept.push_back(a);
      if (kValueOptions.count(a) && k + 1 < args.size()) kept.push_back(args[++k]);
      continue;
    }
    std::string name = a.substr(2), value;
    if (const auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    } else if (k + 1 < args.size()) {
      value = args[++k];
    } else {
      throw std::invalid_argument("command line: --" + name + " needs a value (the solid's own --NAME VALUE)");
    }
    params[name] = value;
  }
  return kept;
}

/// The user's markers: sizes, finite values, positive areas; a one-line reason, or "".
std::string markers_problem(const Markers& m) {
  const Eigen::Index n = m.position_lb.cols();
  if (n < 1) return "start() gave no markers; a coupled run exchanges 1 to 2^31 - 1";
  if (n > std::numeric_limits<std::int32_t>::max()) return "start() gave more than 2^31 - 1 markers";
  if (m.area_lb.size() != n)
    return "start() gave " + std::to_string(n) + " positions but " + std::to_string(m.area_lb.size()) + " areas";
  if (!m.position_lb.allFinite()) return "start() gave a non-finite marker position";
  for (Eigen::Index l = 0; l < n; ++l)
    if (!(m.area_lb[l] > 0.0) || !std::isfinite(m.area_lb[l]))
      return "start(): area_lb[" + std::to_string(l) + "] = " + fmt("%g", m.area_lb[l]) + "; allowed: > 0, finite";
  return "";
}

/// The user's answer for `step`: sizes and finite values; nothing if it is fine.
std::optional<Ending> answer_problem(const Answer& a, Eigen::Index n, std::int64_t step) {
  const std::string where = "the solid's answer for LB step " + std::to_string(step) + ": ";
  if (a.position_lb.cols() != n || a.impulse_lb.cols() != n)
    return Ending{exit_code::unhealthy,
                  where + std::to_string(a.position_lb.cols()) + " positions and " +
                      std::to_string(a.impulse_lb.cols()) + " impulses for " + std::to_string(n) + " markers",
                  true};
  for (Eigen::Index l = 0; l < n; ++l) {
    if (!a.position_lb.col(l).allFinite())
      return Ending{exit_code::unhealthy, where + "marker " + std::to_string(l) + ": position not finite", true};
    if (!a.impulse_lb.col(l).allFinite())
      return Ending{exit_code::unhealthy, where + "marker " + std::to_string(l) + ": impulse not finite", true};
  }
  return std::nullopt;
}

Sheet sheet_of(const solid::SheetSpec& spec, const protocol::UnitConverter& units) {
  Sheet s;
  s.nx = spec.nx_cg;
  s.ny = spec.ny_cg;
  s.clamped_rows = spec.clamped_rows;
  s.spacing_w_lb = units.length_lb_from_bohr(spec.width_spacing_bohr);
  s.spacing_h_lb = units.length_lb_from_bohr(spec.height_spacing_bohr);
  s.position_lb = solid::marker_positions_lb({spec}, units);
  const std::vector<double> a = solid::marker_areas_lb({spec}, units);
  s.area_lb = Eigen::Map<const Eigen::VectorXd>(a.data(), Eigen::Index(a.size()));
  return s;
}

/// One run of a user's Solid: the pieces of the solid server's session around it, and the
/// user's Solid as the coupling schemes drive a solid.
class SdkRun final : public solid::SchemeSolid {
 public:
  SdkRun(Solid& solid, const solid::SolidScene& scene, const solid::CoupledSolidOptions& options, Scene info)
      : solid_(solid), s_(scene), o_(options), info_(std::move(info)), units_(scene.unit_inputs()),
        scheme_(solid::make_solid_scheme(scene.coupling->scheme)),
        peer_(*scene.coupling, options, *scheme_,
              [this](const cosimlcm::fluid_state_t& m) {
                return solid::check_fluid_state(m, n_, scheme_->final_step(peer_.total_steps()),
                                                peer_.total_steps(), s_.config);
              },
              std::cout),
        ctx_{*this, peer_, std::cout} {}

  int run() {
    Markers start;
    try {
      start = solid_.start(info_);
    } catch (const std::invalid_argument& e) {
      return report(Ending{exit_code::bad_input, solid_.model() + ": " + one_line(e.what())});
    }
    if (const std::string why = markers_problem(start); !why.empty())
      return report(Ending{exit_code::bad_input, solid_.model() + ": " + why});
    for (const auto& [name, value] : info_.params)
      if (!info_.asked.count(name))
        return report(Ending{exit_code::bad_input, "command line: unknown option --" + name + " (" + solid_.model() +
                                                       " reads none of that name)"});
    // The implicit scheme iterates each step from its start: the solid's save() and restore().
    if (scheme_->order().several_per_step && solid_.save().empty())
      return report(Ending{exit_code::bad_input, s_.path + ": [coupling] scheme = \"" + std::string(scheme_->name()) +
                                                     "\" iterates each step from its start: " + solid_.model() +
                                                     " needs save() and restore() (it keeps no state)"});
    n_ = start.position_lb.cols();
    x_ = start.position_lb;
    area_ = start.area_lb;
    warn_unread_sections(start);
    const double stable = solid_.stable_dt_cg_s();
    if (!(stable > 0.0))
      return report(Ending{exit_code::bad_input, solid_.model() + ": stable_dt_cg_s() = " + fmt("%g", stable) +
                                                     "; allowed: > 0 (+infinity: no limit)"});
    solid_log().info() << solid_.model() << " on the solid library, scene " << s_.name << " (" << s_.path << "), "
                       << n_ << " markers, A_T = " << s_.coupling->time_ratio << ", channels "
                       << peer_.channel_prefix() << "*";
    if (const auto e = peer_.open(n_)) return report(*e);
    cosimlcm::hello_t hello{};
    try {
      hello = protocol::to_lcm(protocol::announcement("solid", o_.token, solid_.model(), s_.path,
                                                      s_.coupling->scheme.scheme, units_, s_.coupling->time_ratio));
    } catch (const std::runtime_error& e) {
      return finish(Ending{exit_code::system, e.what()});
    }
    hello.stable_dt_cg_s = std::isfinite(stable) ? stable : std::numeric_limits<double>::max();
    hello.num_cgps = static_cast<std::int32_t>(n_);
    if (const auto e = peer_.handshake(hello)) return finish(*e);
    solid_log().info() << "handshake accepted: " << peer_.total_steps() << " LB steps (" << peer_.rigid_steps()
                       << " rigid)" << scheme_->announcement();
    peer_.await_from(scheme_->first_key(peer_.rigid_steps()));
    series_.emplace(units_, solid_.model(), n_);
    if (!o_.restart.empty()) {
      // Continue from a checkpoint of step N: the solid's state after it and the
      // solid_state_t(N) it sent, published again (the in-flight impulses).
      try {
        restore(o_.restart);
      } catch (const std::exception& e) {
        return finish(Ending{exit_code::bad_input, "--restart " + o_.restart + ": " + one_line(e.what()), true});
      }
      solid_log().info() << "restarted from " << o_.restart << " at step " << peer_.last_step()
                         << " (solid.h5 with its " << series_->rows()
                         << " rows is written once the fluid has accepted its checkpoint too)";
      // A restart that either side refuses writes nothing (write_series).
      restart_pending_ = true;
    } else {
      // Step 0: the initial positions, zero impulses (section 5).
      peer_.publish_state(0, 0, 0.0, x_, Eigen::Matrix3Xd::Zero(3, n_), 0);
    }
    first_step_ = peer_.last_step();
    // The energy balance, when the solid reports its energy: from step 0, a restart's
    // continued from its checkpoint (an older checkpoint without it: from the restored state).
    if (const double e0 = o_.restart.empty() ? solid_.energy_lb() : restored_energy_; std::isfinite(e0)) {
      balance_.emplace(e0, x_);
      if (saved_balance_) balance_->restore(*saved_balance_);  // a restart's: continued
    }
    if (o_.restart.empty()) series_->add(0, x_, Eigen::Matrix3Xd::Zero(3, n_), energy(), balance_ ? 0.0 : kNone);
    start_ = Clock::now();
    peer_.heard();
    for (;;) {
      if (const auto e = peer_.wait([] {})) return finish(*e);
      const cosimlcm::fluid_state_t m = peer_.awaited();
      restart_pending_ = false;  // the fluid publishes nothing before it accepted its checkpoint
      if (const auto e = scheme_->on_fluid_state(m, ctx_)) return finish(*e);
      peer_.advance();
      if (const auto e = peer_.failure()) return finish(*e);
    }
  }

 private:
  // ---- the solid as the coupling schemes drive it (solid/schemes/scheme_solid.hpp) ----

  std::int64_t total_steps() const override { return peer_.total_steps(); }
  std::int64_t rigid_steps() const override { return peer_.rigid_steps(); }
  Eigen::Index num_cgps() const override { return n_; }
  int time_ratio() const override { return s_.coupling->time_ratio; }
  Eigen::Matrix3Xd positions_lb() const override { return x_; }
  std::int64_t total_substeps() const override { return total_substeps_; }
  double solid_time_s(std::int64_t substeps) const override { return static_cast<double>(substeps) * units_.dt_cg_s(); }

  std::optional<Ending> check(const cosimlcm::fluid_state_t& m) const override {
    return solid::check_fluid_state(m, n_, scheme_->final_step(peer_.total_steps()), peer_.total_steps(), s_.config);
  }

  /// The interval of `step` (section 5): during the spin-up the markers held, U_B = 0,
  /// J_l = g dA = -2 rho u dA; then the user's step() with the fluid sample.
  std::optional<Ending> interval(const solid::FluidSample& sample, std::int64_t step,
                                 solid::IntervalResult& r) override {
    if (step >= peer_.rigid_steps()) return user_step(sample, step, r);
    r.position_lb = x_;
    r.impulse_lb.resize(3, n_);
    for (Eigen::Index l = 0; l < n_; ++l)
      r.impulse_lb.col(l) =
          momentum_exchange(sample.rho_lb[l], Eigen::Vector3d::Zero(), sample.velocity_lb.col(l), area_[l]);
    r.substeps = 0;
    return std::nullopt;
  }

  /// The interval the fluid gets: the energy balance of a moving step, the row of solid.h5,
  /// the substeps on the clock.
  std::optional<Ending> commit(std::int64_t step, const solid::IntervalResult& r, double) override {
    if (step >= peer_.rigid_steps()) {
      x_ = r.position_lb;
      if (balance_)
        if (const auto t = balance_->add(step, r.position_lb, r.impulse_lb, solid_.energy_lb()))
          return Ending{exit_code::unhealthy, solid_.model() + ": " + t->diagnosis, true};
    }
    series_->add(step, r.position_lb, r.impulse_lb, energy(), balance_ ? balance_->work() : kNone);
    total_substeps_ += r.substeps;
    return std::nullopt;
  }
  std::optional<Ending> snapshot(std::int64_t) override { return std::nullopt; }
  std::optional<Ending> checkpoint_if_due(std::int64_t step) override {
    const std::int64_t every = s_.coupling->checkpoint_every;
    if (every > 0 && step % every == 0) try {
        checkpoint("every coupling.checkpoint_every steps");
      } catch (const std::exception& e) {
        return Ending{exit_code::system, "checkpoint of step " + std::to_string(step) + ": " + one_line(e.what()), true};
      }
    return std::nullopt;
  }

  /// The implicit scheme's iterates: each from the solid's save() at the step's start.
  void keep_start() override { start_state_ = solid_.save(); }
  std::optional<Ending> iterate(const solid::FluidSample& drive, std::int64_t step, int iteration,
                                solid::IntervalResult& trial) override {
    if (iteration > 0) try {
        solid_.restore(start_state_);
      } catch (const std::exception& e) {
        return Ending{exit_code::system, solid_.model() + ": restore() for iteration " + std::to_string(iteration) +
                                             " of LB step " + std::to_string(step) + ": " + one_line(e.what()),
                      true};
      }
    return user_step(drive, step, trial);
  }
  /// The kept start is the checkpoint's sdk_state (checkpoint()); nothing more.
  void save_start(protocol::CheckpointWriter&) const override {}
  void restore_start(const protocol::CheckpointReader&) override {}

 private:
  /// The user's step() of `step` driven by `sample`: A_T substeps, the answer checked.
  std::optional<Ending> user_step(const solid::FluidSample& sample, std::int64_t step, solid::IntervalResult& r) {
    Interval in;
    in.step = step;
    in.substeps = s_.coupling->time_ratio;
    in.rho_lb = sample.rho_lb;
    in.velocity_lb = sample.velocity_lb;
    Answer a;
    const Clock::time_point t0 = Clock::now();
    try {
      a = solid_.step(in);
    } catch (const std::length_error& e) {  // a mis-sized answer (the Python binding's)
      return Ending{exit_code::unhealthy,
                    "the solid's answer for LB step " + std::to_string(step) + ": " + one_line(e.what()), true};
    } catch (const std::exception& e) {
      return Ending{exit_code::system,
                    solid_.model() + ": step() of LB step " + std::to_string(step) + ": " + one_line(e.what()), true};
    }
    compute_s_ += std::chrono::duration<double>(Clock::now() - t0).count();
    ++computed_;
    if (auto e = answer_problem(a, n_, step)) return e;
    r.position_lb = a.position_lb;
    r.impulse_lb = a.impulse_lb;
    r.substeps = in.substeps;
    return std::nullopt;
  }

  // ---- checkpoints (DESIGN 2.4; protocol/README.md section 10) ----

  /// OUTPUT/checkpoints/solid_NNNNNNNN.h5 of the last step sent, if the solid keeps any: its
  /// path, or "".
  std::string checkpoint(const std::string& reason) {
    // A step being iterated restarts from its start (the scheme's restart point).
    const std::optional<solid::SolidScheme::RestartPoint> point = scheme_->restart_point();
    const std::vector<double> state = point ? start_state_ : solid_.save();
    if (state.empty()) return "";
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(s_.output_dir) / "checkpoints";
    fs::create_directories(dir);
    const fs::path file = dir / protocol::checkpoint_name("solid", peer_.last_step());
    protocol::CheckpointWriter w(file);
    w.attr("step", peer_.last_step());
    w.attr("solid_seq", point ? point->in_flight->seq + 1 : peer_.next_seq());
    scheme_->save(w, ctx_);
    w.attr("total_substeps", total_substeps_);
    w.attr("num_cgps", static_cast<std::int64_t>(n_));
    protocol::write_identity(w, identity());
    w.text("reason", reason);
    w.text("model", solid_.model());
    w.put("positions_lb", x_.data(), std::size_t(x_.size()));
    w.put("sdk_state", state);
    if (series_) series_->save(w);
    if (balance_) save_balance(w, balance_->saved());
    const cosimlcm::solid_state_t& sent = point ? *point->in_flight : peer_.last_sent();
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(sent.getEncodedSize()));
    sent.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    w.put("in_flight_solid_state", bytes);
    w.commit();
    protocol::prune_checkpoints(dir, "solid_", 3, o_.run_id);
    return file.string();
  }

  /// Whose checkpoints this run writes and accepts: its scene, run and A_T (a library solid
  /// restarts at its checkpoint's A_T only, see restore).
  protocol::CheckpointIdentity identity() const {
    return {s_.path, o_.run_id, s_.coupling->time_ratio, o_.new_time_ratio};
  }

  /// The checkpoint at `path` back: throws (one line) for one of another scene, model, CGP
  /// count or A_T.
  void restore(const std::string& path) {
    const protocol::CheckpointReader r(path);
    protocol::check_identity(r, identity());
    if (r.text("model") != solid_.model())
      throw std::runtime_error("a checkpoint of the model '" + r.text("model") + "', this is '" + solid_.model() + "'");
    const std::int64_t step = r.int64_attr("step");
    if (step < 1 || step >= peer_.total_steps())
      throw std::runtime_error("step = " + std::to_string(step) + ", allowed: 1 to " + std::to_string(peer_.total_steps() - 1));
    if (r.int64_attr("time_ratio") != s_.coupling->time_ratio)
      throw std::runtime_error("a checkpoint of A_T = " + std::to_string(r.int64_attr("time_ratio")) +
                               "; the solid library restarts with the same A_T only (" +
                               std::to_string(s_.coupling->time_ratio) + " now)");
    x_ = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("positions_lb", static_cast<std::size_t>(3 * n_)).data(), 3, n_);
    try {
      solid_.restore(r.doubles("sdk_state"));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(solid_.model() + ": " + e.what());
    }
    restored_energy_ = solid_.energy_lb();
    cosimlcm::solid_state_t sent{};
    const std::vector<std::uint8_t> bytes = r.bytes("in_flight_solid_state");
    if (sent.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0 || sent.step != step || sent.num_cgps != n_)
      throw std::runtime_error("in_flight_solid_state is not the solid_state_t of step " + std::to_string(step));
    sent.token = o_.token;
    saved_balance_ = read_balance(r, n_);
    if (!series_->restore(r))
      solid_log().info() << path << " holds no solid.h5 rows (an older library's checkpoint): solid.h5 starts at step "
                         << step;
    total_substeps_ = r.int64_attr("total_substeps");
    // The scheme's part (what it awaits; the implicit scheme's first iterate again).
    peer_.await_from(scheme_->restore(r, step, false, sent, ctx_));
    peer_.resume(std::move(sent), r.int64_attr("solid_seq"));
  }

  int finish(Ending e) {
    // A clean abort (the fluid lost, or stopped with an error) keeps the state after the last
    // step for a restart, as the solid server does.
    if (e.code == exit_code::peer_lost && peer_.sent_any() && peer_.last_step() > first_step_) {
      try {
        if (const std::string file = checkpoint(e.reason); !file.empty()) e.reason += "; checkpoint " + file;
      } catch (const std::exception& x) {
        e.reason += "; no checkpoint: " + one_line(x.what());
      }
    }
    peer_.stop(e);
    write_series();
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    solid_log().info() << "coupled run " << (e.code == exit_code::ok ? "done" : "stopped") << " at step "
                       << peer_.last_step() << " of " << peer_.total_steps() << ", " << total_substeps_
                       << " substeps in " << fmt("%.1f", wall) << " s; " << peer_.counters();
    scheme_->report(std::cout);
    if (computed_ > 0)
      solid_log().info() << "per LB step: step() " << fmt("%.4g", 1e3 * compute_s_ / double(computed_))
                         << " ms over " << computed_ << " steps";
    return report(e);
  }

  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

  /// E after the last step when the solid reports it, else NaN.
  double energy() const { return balance_ ? solid_.energy_lb() : kNone; }

  /// OUTPUT/solid.h5 (sdk/solid_series.hpp) and the energy balance's margin; a file that
  /// cannot be written is said on one line, the run's ending stands.
  void write_series() {
    if (!series_ || restart_pending_) return;
    if (balance_)
      solid_log().info() << "energy balance: the largest unexplained energy " << fmt("%.3g", balance_->max_ratio())
                         << " of the energy scale (limit " << fmt("%g", EnergyBalance::kGrowth)
                         << "); the fluid's work " << fmt("%.4g", balance_->work()) << " rho_air dx^3 c^2";
    const std::filesystem::path file = std::filesystem::path(s_.output_dir) / "solid.h5";
    try {
      std::filesystem::create_directories(s_.output_dir);
      series_->write(file.string());
    } catch (const std::exception& x) {
      solid_log().info() << file.string() << " not written: " << one_line(x.what());
    }
  }

  /// The scene's sections this solid does not read, named once: the solid server's model
  /// sections, and [[sheet]] when the solid's markers are not the scene's.
  void warn_unread_sections(const Markers& start) const {
    std::vector<std::string> unread = solid::model_sections_present(s_.path);
    const bool own = start.position_lb.cols() != info_.position_lb.cols() ||
                     !(Eigen::Matrix3Xd(start.position_lb).array() == Eigen::Matrix3Xd(info_.position_lb).array()).all();
    if (!s_.config.sheets.empty() && own) unread.push_back("[[sheet]] (" + solid_.model() + " has markers of its own)");
    if (unread.empty()) return;
    std::string list;
    for (const std::string& u : unread) list += (list.empty() ? "" : ", ") + u;
    solid_log().warning() << s_.path << ": " << list << " not read: " << solid_.model()
                          << " is a solid on the library, which reads [scene], [grid], [output], [coupling] and the "
                             "[[sheet]] markers (the solid server's model sections are for build/solid/solid)";
  }

  int report(const Ending& e) {
    std::cout.flush();
    if (e.code != exit_code::ok) solid_log().error() << one_line(e.reason);
    return e.code;
  }

  Solid& solid_;
  const solid::SolidScene& s_;
  const solid::CoupledSolidOptions& o_;
  Scene info_;
  const protocol::UnitConverter units_;
  std::unique_ptr<solid::SolidScheme> scheme_;
  Eigen::Index n_ = 0;
  solid::SolidPeer peer_;
  Eigen::Matrix3Xd x_;
  Eigen::VectorXd area_;
  std::optional<EnergyBalance> balance_;
  std::optional<EnergyBalance::Saved> saved_balance_;  ///< a restart's checkpoint's balance
  std::optional<SolidSeries> series_;
  bool restart_pending_ = false;  ///< a restart the fluid has not yet accepted: solid.h5 stays as it is
  solid::SchemeContext ctx_;
  std::vector<double> start_state_;       ///< save() at the start of the step being iterated
  double restored_energy_ = kNone;        ///< energy_lb() of a restart's restored state
  std::int64_t total_substeps_ = 0, computed_ = 0, first_step_ = 0;
  double compute_s_ = 0.0;
  Clock::time_point start_ = Clock::now();
};

int run_impl(Solid& solid, std::vector<std::string> args) {
  const std::string program =
      args.empty() ? std::string("solid") : std::filesystem::path(args.front()).filename().string();
  {  // the provenance solid.h5 carries (common/run/provenance.hpp)
    std::vector<char*> raw;
    for (std::string& a : args) raw.push_back(a.data());
    protocol::record_invocation(program, static_cast<int>(raw.size()), raw.data());
  }
  CLI::App app{"A solid model on the cosim solid library, coupled to the fluid over LCM (protocol/README.md).\n"
               "Exit status: 0 done, 1 system error, 2 invalid scene or command line or refused handshake, "
               "3 non-finite answer, 4 the fluid was lost or stopped with an error.",
               program};
  std::string scene_path, output, token, prefix, url, faults;
  std::int64_t time_ratio = 0;
  bool quiet = false;
  app.add_option("scene", scene_path, "coupled scene file (TOML)")->required();
  CLI::Option* o_output = app.add_option("--output", output, "output directory ([output] directory)");
  CLI::Option* o_token = app.add_option("--token", token, "the run's token (default: $COSIM_RUN_TOKEN)");
  CLI::Option* o_prefix = app.add_option("--channel-prefix", prefix, "LCM channel prefix");
  CLI::Option* o_url = app.add_option("--lcm-url", url, "LCM URL ([coupling] lcm_url)");
  CLI::Option* o_ratio = app.add_option("--time-ratio", time_ratio, "A_T ([coupling] time_ratio)");
  CLI::Option* o_faults = app.add_option("--faults", faults, "tests: transport faults (protocol/fault_injection.hpp)");
  std::string restart;
  app.add_option("--restart", restart, "continue from this checkpoint (OUTPUT/checkpoints/solid_N.h5)");
  app.add_flag("--quiet", quiet, "no progress lines");
  Scene info;
  std::vector<std::string> launcher{program};
  try {
    const std::vector<std::string> rest = split_params(
        args.empty() ? args : std::vector<std::string>(args.begin() + 1, args.end()), info.params);
    launcher.insert(launcher.end(), rest.begin(), rest.end());
  } catch (const std::invalid_argument& e) {
    std::cerr << program << ": " << e.what() << "\n";
    return exit_code::bad_input;
  }
  std::vector<const char*> argv;
  for (const std::string& a : launcher) argv.push_back(a.c_str());
  if (const auto code =
          protocol::parse_command_line(app, static_cast<int>(argv.size()), const_cast<char**>(argv.data()), program))
    return *code;
  const auto bad = [&](const std::string& what) {
    std::cout.flush();
    std::cerr << program << ": " << one_line(what) << "\n";
    return exit_code::bad_input;
  };
  solid::SolidScene scene;
  try {
    scene = solid::load_solid_scene(scene_path);
    protocol::record_scene(scene.path);
    solid::SolidSceneOverrides ov;
    if (o_output->count()) ov.output_dir = output;
    if (o_prefix->count()) ov.channel_prefix = prefix;
    if (o_url->count()) ov.lcm_url = url;
    if (o_ratio->count()) ov.time_ratio = time_ratio;
    solid::apply_overrides(scene, ov);
  } catch (const std::exception& e) {
    return bad(e.what());
  }
  if (!scene.coupled()) return bad(scene.path + ": not a coupled scene (no [coupling] section)");
  solid::CoupledSolidOptions options;
  options.token = o_token->count() ? token : std::string();
  if (!o_token->count())
    if (const char* env = std::getenv("COSIM_RUN_TOKEN")) options.token = env;
  if (options.token.empty())
    return bad("a coupled run needs the run's token: --token TOKEN or COSIM_RUN_TOKEN (the launcher draws one per run)");
  options.quiet = quiet;
  options.restart = restart;
  try {
    options.read_environment();  // the launcher's run id, --new-time-ratio and the run's key
    options.faults = protocol::fault_settings_from(o_faults->count() ? &faults : nullptr);
  } catch (const std::invalid_argument& e) {
    return bad(e.what());
  }
  const protocol::UnitConverter units(scene.unit_inputs());
  info.path = scene.path;
  info.name = scene.name;
  info.output_dir = scene.output_dir;
  info.time_ratio = scene.coupling->time_ratio;
  info.dx_m = units.dx_m();
  info.dt_lb_s = units.dt_lb_s();
  info.dt_cg_s = units.dt_cg_s();
  info.air_density_kg_m3 = units.air_density_kg_m3();
  info.sound_speed_m_s = units.inputs().sound_speed_m_s;
  for (const solid::SheetSpec& spec : scene.config.sheets) info.sheets.push_back(sheet_of(spec, units));
  info.position_lb = solid::marker_positions_lb(scene.config.sheets, units);
  const std::vector<double> areas = solid::marker_areas_lb(scene.config.sheets, units);
  info.area_lb = Eigen::Map<const Eigen::VectorXd>(areas.data(), Eigen::Index(areas.size()));
  try {
    SdkRun r(solid, scene, options, std::move(info));
    return r.run();
  } catch (const std::exception& e) {
    std::cout.flush();
    std::cerr << program << ": " << one_line(e.what()) << "\n";
    return exit_code::system;
  }
}

}  // namespace

double Scene::param(const std::string& option, double fallback) const {
  asked.insert(option);
  const auto it = params.find(option);
  if (it == params.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument("command line: --" + option + " = '" + it->second + "'; allowed: a finite number");
  return v;
}

Scene synthetic_scene(int nx, int ny, int time_ratio) {
  if (nx < 1 || ny < 2 || time_ratio < 1)
    throw std::invalid_argument("synthetic_scene: nx >= 1, ny >= 2 and time_ratio >= 1 allowed");
  protocol::UnitInputs in;
  in.time_ratio = time_ratio;
  const protocol::UnitConverter units(in);
  Scene s;
  s.path = "(synthetic)";
  s.name = "synthetic";
  s.time_ratio = time_ratio;
  s.dx_m = units.dx_m();
  s.dt_lb_s = units.dt_lb_s();
  s.dt_cg_s = units.dt_cg_s();
  s.air_density_kg_m3 = units.air_density_kg_m3();
  s.sound_speed_m_s = in.sound_speed_m_s;
  Sheet sh;
  sh.nx = nx;
  sh.ny = ny;
  sh.clamped_rows = 1;
  sh.spacing_w_lb = sh.spacing_h_lb = 1.0;
  sh.position_lb.resize(3, Eigen::Index(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) sh.position_lb.col(i + Eigen::Index(nx) * j) = Eigen::Vector3d(10.0, j, 10.0 + i);
  sh.area_lb = Eigen::VectorXd::Ones(sh.position_lb.cols());
  s.position_lb = sh.position_lb;
  s.area_lb = sh.area_lb;
  s.sheets.push_back(sh);
  return s;
}

double time_steps(Solid& solid, const Scene& scene, int steps) {
  const Markers m = solid.start(scene);
  Interval in;
  in.substeps = scene.time_ratio;
  in.rho_lb = Eigen::VectorXd::Ones(m.position_lb.cols());
  in.velocity_lb = Eigen::Matrix3Xd::Zero(3, m.position_lb.cols());
  in.velocity_lb.row(0).setConstant(0.05);
  const Clock::time_point t0 = Clock::now();
  for (int k = 1; k <= steps; ++k) {
    in.step = k;
    const Answer a = solid.step(in);
    if (a.impulse_lb.cols() != m.position_lb.cols()) throw std::runtime_error("time_steps: a mis-sized answer");
  }
  return std::chrono::duration<double>(Clock::now() - t0).count() / std::max(1, steps);
}

int run(Solid& solid, int argc, const char* const* argv) {
  std::vector<std::string> args(argv, argv + argc);
  return run(solid, args);
}

int run(Solid& solid, const std::vector<std::string>& args) {
  try {
    return run_impl(solid, args);
  } catch (const std::exception& e) {
    std::cout.flush();
    solid_log().error() << one_line(e.what());
    return protocol::exit_code::system;
  }
}

}  // namespace cosim::sdk
