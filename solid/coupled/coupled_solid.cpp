#include "solid/coupled/coupled_solid.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "common/hdf5/hdf5_handle.hpp"
#include "common/run/progress.hpp"
#include "common/run/provenance.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/interrupt.hpp"
#include "common/text/text.hpp"
#include "solid/io/solid_log.hpp"
#include "solid/schemes/solid_scheme.hpp"
#include "solid/coupled/server_solid.hpp"
#include "solid/coupled/solid_checkpoints.hpp"
#include "solid/coupled/solid_peer.hpp"
#include "solid/coupled/solid_run.hpp"

namespace cosim::solid {

namespace {

using Clock = std::chrono::steady_clock;
using protocol::fmt;
using protocol::one_line;

/// The coupled run: the solid's physics (SolidRun), its session (SolidPeer), its checkpoints
/// and the coupling scheme (solid/schemes/) wired together, and the lock-step loop over them:
/// wait for the awaited fluid_state_t, hand it to the scheme, move on.
class CoupledSolid {
 public:
  CoupledSolid(const SolidScene& scene, const CoupledSolidOptions& options, std::ostream& out, std::ostream& err)
      : s_(scene), o_(options), log_(solid_log(options.quiet ? log::Level::info : log::Level::progress)), out_(out),
        err_(err), scheme_(make_solid_scheme(scene.coupling->scheme)),
        run_(scene),
        peer_(*scene.coupling, options, *scheme_, [this](const cosimlcm::fluid_state_t& m) { return run_.check(m); },
              out),
        solid_(run_, checkpoints_), checkpoints_(scene, options, run_, peer_, *scheme_, solid_, out),
        ctx_{solid_, peer_, out} {}

  CoupledSolid(const CoupledSolid&) = delete;
  CoupledSolid& operator=(const CoupledSolid&) = delete;

  int run() {
    if (const auto e = run_.build()) return report(*e);
    run_.print_header(out_, peer_.channel_prefix());
    if (o_.check_only) return exit_code::ok;
    if (const auto e = run_.open_output()) return report(*e);
    if (const auto e = peer_.open(run_.num_cgps())) return report(*e);
    if (const auto e = handshake()) return finish(*e);
    log_.info(out_) << "handshake accepted: " << run_.total_steps() << " LB steps (" << run_.rigid_steps()
                    << " rigid), A_T = " << run_.coupling().time_ratio << scheme_->announcement();
    peer_.await_from(scheme_->first_key(run_.rigid_steps()));
    out_.flush();
    start_ = Clock::now();

    if (!o_.restart.empty()) {
      // Continue from a checkpoint at step N: the state after the interval of step N and
      // the solid_state_t(N) it sent, which is published again (the in-flight impulses).
      try {
        checkpoints_.restore(o_.restart);
      } catch (const std::exception& e) {
        return finish(Ending{exit_code::bad_input, "--restart " + o_.restart + ": " + one_line(e.what()), true});
      }
      log_.info(out_) << "restarted from " << o_.restart << " at step " << peer_.last_step()
                      << " (the folder's files are rewritten once the fluid has accepted its checkpoint too)";
      // solid.h5, the scene copy and provenance wait for the fluid's first fluid_state_t
      // (accept_restart()): a restart that either side refuses writes nothing.
      restart_pending_ = true;
    } else {
      // Step 0: the initial positions, zero impulses (section 5).
      ctx_.publish(0, 0, run_.coupler().positions_lb(), Eigen::Matrix3Xd::Zero(3, run_.num_cgps()));
      run_.start();
      if (const auto e = open_run_files()) return finish(*e);
      if (const auto e = run_.snapshot(0)) return finish(*e);
    }
    first_step_ = peer_.last_step();
    clock_ = protocol::ProgressClock(run_.total_steps() - 1, first_step_);
    peer_.heard();
    for (;;) {
      const Clock::time_point t0 = Clock::now();
      if (const auto e = peer_.wait([this] { progress(); })) return finish(*e);
      const Clock::time_point t1 = Clock::now();
      const cosimlcm::fluid_state_t m = peer_.awaited();
      if (restart_pending_)
        if (const auto e = accept_restart()) return finish(*e);
      if (const auto e = scheme_->on_fluid_state(m, ctx_)) return finish(*e);
      if (const auto e = append_series()) return finish(*e);
      wait_s_ += std::chrono::duration<double>(t1 - t0).count();
      compute_s_ += std::chrono::duration<double>(Clock::now() - t1).count();
      ++timed_steps_;
      peer_.advance();
      progress();
      if (const auto e = peer_.failure()) return finish(*e);
    }
  }

 private:
  /// Section 6, and the run's length from the welcome_t.
  std::optional<Ending> handshake() {
    cosimlcm::hello_t hello{};
    try {
      hello = run_.hello(o_.token);
    } catch (const std::runtime_error& e) {  // the scene file cannot be hashed
      return Ending{exit_code::system, e.what()};
    }
    if (auto e = peer_.handshake(hello)) return e;
    run_.set_length(peer_.total_steps(), peer_.rigid_steps(), scheme_->final_step(peer_.total_steps()));
    return std::nullopt;
  }

  /// Every protocol::progress_every_s(1) seconds and at the last step, unless quiet: "solid: progress step N/M
  /// phase spin-up|free t = .. us .. LB steps/s compute .. % wait .. % ETA .." on stderr,
  /// for launch/progress.py (the launcher's one line).
  void progress() {
    if (!log_.shows(log::Level::progress)) return;
    const std::int64_t step = peer_.last_step(), total = run_.total_steps();
    // The last step's line always goes out, so that a run shorter than the interval has one.
    if (!clock_.due(progress_every_s_) && step != total - 1) return;
    const double wall = clock_.elapsed_s(), rate = clock_.rate(step);
    const auto share = [wall](double part) { return wall > 0.0 ? 100.0 * part / wall : 0.0; };
    log_.progress(err_) << log::printf_text(
        "step %lld/%lld  phase %s  t = %.4g us  %.3g LB steps/s  compute %.0f %%  wait %.0f %%  ETA %s",
        static_cast<long long>(step), static_cast<long long>(total), step < run_.rigid_steps() ? "spin-up" : "free",
        static_cast<double>(step) * run_.units().dt_lb_s() * 1e6, rate, share(compute_s_), share(wait_s_),
        protocol::format_duration(clock_.eta_s(step)).c_str());
  }

  /// solid.h5 from the rows so far, OUTPUT/scene.toml and provenance_solid.toml: once the
  /// run is accepted (a refused start or restart adds nothing to the folder).
  std::optional<Ending> open_run_files() {
    if (auto e = open_series()) return e;
    try {
      protocol::write_provenance_files(s_.output_dir);
    } catch (const std::exception& x) {
      return Ending{exit_code::system, one_line(x.what()), true};
    }
    return std::nullopt;
  }

  /// The first fluid_state_t of a restart: the fluid has read and accepted its checkpoint
  /// (it publishes nothing before) and the solid its own: only now is solid.h5 rewritten
  /// from the checkpoint's rows.
  std::optional<Ending> accept_restart() {
    restart_pending_ = false;
    if (auto e = open_run_files()) return e;
    log_.info(out_) << "restart accepted at step " << peer_.last_step()
                    << ": both checkpoints read; solid.h5 continues from its " << run_.series().rows() << " rows";
    return std::nullopt;
  }

  std::string output_path() const { return (std::filesystem::path(s_.output_dir) / "solid.h5").string(); }

  /// solid.h5 from the rows so far (after step 0 or a restart), then appended as the run
  /// goes (CoupledSeriesFile): a refused restart never touches an earlier run's file.
  std::optional<Ending> open_series() {
    CoupledSeries::Attributes a;
    a.scene = s_.name;
    a.model = s_.model;
    a.token = o_.token;
    a.dt_cg_s = run_.units().dt_cg_s();
    a.dt_lb_s = run_.units().dt_lb_s();
    a.time_ratio = run_.coupling().time_ratio;
    a.total_steps = run_.total_steps();
    a.rigid_steps = run_.rigid_steps();
    try {
      series_file_ = std::make_unique<CoupledSeriesFile>(output_path(), a, run_.series());
    } catch (const std::exception& x) {
      return Ending{exit_code::system, one_line(x.what()), true};
    }
    return std::nullopt;
  }
  std::optional<Ending> append_series() {
    try {
      if (series_file_ && !series_failed_) series_file_->append(run_.series());
    } catch (const std::exception& x) {
      series_failed_ = true;  // what the file holds stays; nothing more is tried
      return Ending{exit_code::system, one_line(x.what()), true};
    }
    return std::nullopt;
  }

  /// Ends the run: stop_t for our own errors, solid.h5, the counters, the one-line reason.
  int finish(Ending e) {
    // A clean abort (the fluid lost, or stopped with an error) keeps the state after the
    // last interval for a restart (DESIGN 2.4).
    // So does an interrupt (SIGINT, SIGTERM).
    const bool clean_abort = e.code == exit_code::peer_lost || protocol::interrupted() != 0;
    if (clean_abort && run_.built() && peer_.sent_any() && peer_.last_step() > first_step_) {
      try {
        e.reason += "; checkpoint " + checkpoints_.write(e.reason);
      } catch (const std::exception& x) {
        e.reason += "; no checkpoint: " + one_line(x.what());
      }
    }
    peer_.stop(e);
    const CoupledSeries& series = run_.series();
    if (series_file_ && !series_failed_) {
      try {
        series_file_->append(run_.series());
        series_file_->close();
      } catch (const std::exception& x) {
        if (e.code == exit_code::ok) e = Ending{exit_code::system, one_line(x.what()), false};
        else log_.error(err_) << one_line(x.what());
      }
    }
    if (series.rows() == 0) {
      log_.info(out_) << "coupled run stopped before the handshake completed (" << peer_.hellos()
                      << " hello_t sent); " << peer_.counters();
      return report(e);
    }
    const std::int64_t substeps = run_.total_substeps();
    const SheetSnapshotWriter* snapshots = run_.snapshots();
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    log_.info(out_) << "coupled run " << (e.code == exit_code::ok ? "done" : "stopped") << " at step "
         << peer_.last_step() << " of " << run_.total_steps() << ", " << substeps << " substeps ("
         << fmt("%.5g", run_.solid_time_s(substeps) * 1e6) << " us) in " << fmt("%.1f", wall) << " s; "
         << peer_.counters() << "; "
         << (restart_pending_ ? "the restart was not accepted by both sides: nothing written to " + s_.output_dir
                              : std::to_string(series_file_ ? series_file_->rows() : 0) + " rows in " + output_path())
         << (snapshots ? ", " + std::to_string(snapshots->count()) + " sheet snapshots in " +
                             snapshots->xdmf_path().string()
                       : std::string());
    run_.print_margins(out_);
    scheme_->report(out_);
    if (timed_steps_ > 0)
      log_.info(out_) << "per LB step: compute " << fmt("%.4g", 1e3 * compute_s_ / double(timed_steps_))
           << " ms (substeps, publishing, recording), waiting " << fmt("%.4g", 1e3 * wait_s_ / double(timed_steps_))
           << " ms (for fluid_state_t), over " << timed_steps_ << " steps";
    return report(e);
  }

  int report(const Ending& e) {
    out_.flush();
    if (e.code != exit_code::ok) {
      log_.error(err_) << one_line(e.reason);
    }
    return e.code;
  }

  const SolidScene& s_;
  const CoupledSolidOptions& o_;
  const log::Logger log_;  ///< the solid's lines; --quiet: no progress line
  std::ostream& out_;
  std::ostream& err_;
  std::unique_ptr<SolidScheme> scheme_;
  SolidRun run_;
  SolidPeer peer_;
  ServerSolid solid_;  ///< the run as the scheme drives it
  SolidCheckpoints checkpoints_;
  std::unique_ptr<CoupledSeriesFile> series_file_;  ///< solid.h5, once step 0 or the restart is in
  bool series_failed_ = false;                      ///< an append failed (a full disk)
  bool restart_pending_ = false;  ///< a restart's checkpoint read, the fluid's not yet known accepted
  SchemeContext ctx_;

  std::int64_t first_step_ = 0;  ///< 0, or the step of --restart
  Clock::time_point start_ = Clock::now();
  protocol::ProgressClock clock_{0};  ///< rate and ETA from first_step_ to the last step (total - 1)
  double progress_every_s_ = protocol::progress_every_s(1.0);
  double compute_s_ = 0.0, wait_s_ = 0.0;  ///< per-step timing (DESIGN 7)
  std::int64_t timed_steps_ = 0;
};

}  // namespace

int run_coupled_solid(const SolidScene& scene, const CoupledSolidOptions& options,
                      std::ostream& out, std::ostream& err) {
  protocol::hdf5_no_exit_cleanup();
  if (!scene.coupled()) {
    solid_log().error(err) << scene.path << ": not a coupled scene (no [coupling] section)";
    return exit_code::bad_input;
  }
  if (!options.check_only && options.token.empty()) {
    solid_log().error(err) << "a coupled scene needs the run's token: --token TOKEN or the environment "
                              "variable COSIM_RUN_TOKEN (the launcher draws one per run)";
    return exit_code::bad_input;
  }
  try {
    CoupledSolid run(scene, options, out, err);
    return run.run();
  } catch (const std::exception& e) {
    out.flush();
    solid_log().error(err) << one_line(e.what());
    return exit_code::system;
  }
}

}  // namespace cosim::solid
