// The fluid of a coupled run (DESIGN 2.1, 2.4, 6): the solver and its immersed boundary,
// the watchdog's per-step sentinels on markers and flow, the monitor rows, snapshots and
// checkpoints, the restart, and the run's closing summary. The schemes (fluid/schemes/)
// drive it step by step; the coordinator (coordinator.hpp) carries its messages.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/observables/flow_monitor.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/ib/held_body.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/io/held_body_log.hpp"
#include "fluid/io/monitor_log.hpp"
#include "fluid/config/scene_config.hpp"
#include "fluid/io/snapshots.hpp"
#include "fluid/watchdog/marker_watch.hpp"
#include "fluid/watchdog/solid_audit.hpp"
#include "common/run/progress.hpp"
#include "common/run/exit_codes.hpp"
#include "common/watchdog/watchdog.hpp"

namespace cosim::protocol {
struct CheckpointIdentity;
}

namespace cosim::fluid {

class Coordinator;
class FluidScheme;

/// Where the time of an LB step goes (DESIGN 7), summed over the run, seconds.
struct StepTiming {
  double compute = 0.0;  ///< spread, step, health, sample
  double wait = 0.0;     ///< for solid_state_t
  double publish = 0.0;  ///< fluid_state_t
  double watch = 0.0;    ///< the watchdog's share of compute
};

class FluidRun {
 public:
  using Clock = std::chrono::steady_clock;

  /// After an accepted handshake: the initial flow of `domain` (the grid in this process or
  /// over MPI ranks, led from here), monitor.h5 and the snapshots.
  FluidRun(const FluidScene& scene, const CoupledFluidOptions& options, Coordinator& coordinator,
           const FluidScheme& scheme, FluidDomain& domain);
  /// The coordinator no longer prints this run's margins (an ending after it is gone).
  ~FluidRun();
  FluidRun(const FluidRun&) = delete;
  FluidRun& operator=(const FluidRun&) = delete;

  /// Step 0's monitor row and snapshot, or the --restart checkpoint (then its in-flight
  /// fluid_state_t, if the scheme keeps one, is published again; the folder's files are
  /// written once the solid's first solid_state_t shows it accepted its own). The first LB step; or,
  /// in `failed`, the exit code of a checkpoint that cannot be read (stop_t published).
  std::int64_t start(std::optional<int>& failed);

  /// The grid: the schemes step it, sample and spread at the markers through it.
  FluidDomain& domain() { return domain_; }
  StepTiming& timing() { return timing_; }
  /// The bulk velocity U_b of the latest monitor row (fluid_state_t carries it).
  double bulk_velocity() const { return bulk_u_; }
  /// Whether step_outputs(now) writes a monitor row (and so sets bulk_velocity()).
  bool monitor_due(std::int64_t now) const { return now % s_.monitor_every == 0 || now == s_.steps; }
  std::int64_t total_steps() const { return s_.steps; }
  std::int64_t rigid_steps() const { return s_.coupling->rigid_steps; }
  std::int64_t checkpoint_every() const { return s_.coupling->checkpoint_every; }

  /// [held_body] of a coupled scene (fluid/ib/held_body.hpp; Turek and Hron's cylinder, the
  /// sheets its elastic bar): the body's impulses of this step from the fluid at the state
  /// the step reads, spread before the sheets' `sheet_impulses` J_l are; the forces on both
  /// (- sum J each) kept for the step's row of held_body.csv, which step_outputs() adds
  /// (an implicit scheme's last iteration counts). Nothing without [held_body].
  void hold_body(const std::vector<Vec3>& sheet_impulses);

  // ---- the watchdog (DESIGN 6; common/watchdog/watchdog.hpp) ----
  /// How far each marker moved, how far apart they are (before the fluid at `step` is
  /// touched: it is kept, if healthy, as the checkpoint of a trip); the markers X_l and
  /// impulses J_l go to the audit of the solid that a trip's diagnosis consults
  /// (fluid/watchdog/solid_audit.hpp). The exit code of a trip. The first one of a restart
  /// first writes what the restart waited for (the solid has accepted its checkpoint).
  std::optional<int> check_positions(std::int64_t step, const std::vector<Vec3>& x, const std::vector<Vec3>& j);
  protocol::MarkerWatch& markers() { return markers_; }
  /// The flow_health sentinel every watchdog.health_every steps on the state `step` that
  /// the kernel just read, from its extrema; the exit code of a trip.
  std::optional<int> check_step_read(std::int64_t step);
  /// Eq. 17 at X_l and the watchdog on the samples, before anything of `now` is written or
  /// published; the exit code of a trip.
  std::optional<int> sample_markers(std::int64_t now, const std::vector<Vec3>& x, std::vector<MarkerSample>& samples);
  /// The whole-grid health check before every write (monitor row, snapshot, checkpoint),
  /// then the monitor row and the snapshot of step `now`, the held body's row, and the
  /// inlet's ramp for the next step (ramp_inlet); the exit code of a trip.
  std::optional<int> step_outputs(std::int64_t now, bool last, bool periodic);

  // ---- checkpoints (DESIGN 2.4; protocol/README.md section 10) ----
  /// OUTPUT/checkpoints/fluid_NNNNNNNN.h5 of the state at `step` (fluid_state_t(step)
  /// published, solid_state_t(step) not yet applied); the newest three are kept. Returns
  /// what to add to an abort's reason (where it went, or why not); a periodic checkpoint
  /// (empty reason) that cannot be written throws.
  /// `kept`: of the state kept apart (FluidDomain::keep_state: the implicit scheme's
  /// committed state while a step is iterated).
  std::string checkpoint(std::int64_t step, const std::string& reason, bool kept = false);

  /// The peer lost or stopped with an error while the fluid waited at `step`: `note` (a
  /// checkpoint's line, or why there is none) added, the retry advice when a smaller dt_CG
  /// may cure the solid's trip; the exit code.
  int peer_ending(protocol::Ending e, std::int64_t step, const std::string& note);

  /// Every protocol::progress_every_s(1) seconds, unless quiet: "fluid: progress step N/M
  /// phase spin-up|free t = .. us .. MLUPS compute .. % wait .. % ETA .." on stderr (for
  /// launch/progress.py); once, after the last rigid step: "fluid: sheet released at step N".
  void progress(std::int64_t now, int iteration = -1);
  /// The end of a run that completed: stop_t(0) and the summary lines; exit code 0.
  int finish();

 private:
  int unhealthy(const std::string& problem, std::int64_t step);
  int trip(const protocol::Trip& t, bool checkpoint_state, std::int64_t step);
  protocol::Trip blame(const protocol::Trip& t) const;
  std::int64_t restore(std::optional<cosimlcm::fluid_state_t>& in_flight);
  std::optional<int> open_run_files(std::int64_t step);
  std::optional<int> accept_restart(std::int64_t step);
  protocol::CheckpointIdentity identity() const;

  const FluidScene& s_;
  const std::string restart_;
  const std::string run_id_;   ///< the launcher's run id (checkpoints; a restart's check)
  const bool new_time_ratio_;  ///< a restart may change A_T
  /// The fluid's lines; --quiet: no progress line.
  const log::Logger logger_;
  Coordinator& coord_;
  const FluidScheme& scheme_;
  FluidDomain& domain_;
  HealthLimits limits_;
  double dt_us_;
  std::string monitor_path_;        ///< OUTPUT/monitor.h5
  std::optional<MonitorLog> log_;  ///< created at step 0, or once both sides accepted a restart
  bool restart_pending_ = false;   ///< a restart's checkpoint read, the solid's not yet known accepted
  Snapshots snapshots_;
  protocol::MarkerWatch markers_;  ///< the watchdog's per-step sentinels (DESIGN 6)
  protocol::SolidAudit audit_;     ///< whether a trip is the solid's fault
  /// The samples of the last fluid_state_t published (its step, rho_l, u_l), for the audit.
  std::int64_t sample_step_ = -1;
  std::vector<double> sample_rho_;
  std::vector<Vec3> sample_u_;
  StepTiming timing_;
  double bulk_u_ = 0.0;            ///< U_b of the latest health check (Eq. 34), lattice units
  double mass0_ = 0.0;             ///< the fluid's mass at step 0 (for the drift)
  std::vector<FlowSummary> rows_;  ///< monitor.h5's rows so far (for checkpoints)
  std::optional<HeldBody> body_;   ///< [held_body]
  std::optional<HeldBodyLog> body_log_;  ///< held_body.csv (from start(); anew once a restart is accepted)
  Vec3 body_force_{0.0, 0.0, 0.0}, sheet_force_{0.0, 0.0, 0.0};  ///< of the step being taken
  Clock::time_point start_ = Clock::now();
  protocol::ProgressClock clock_{s_.steps};          ///< rate and ETA (common/run/progress.hpp)
  double progress_every_s_ = protocol::progress_every_s(1.0);
  bool released_ = false;                            ///< the release line was printed
};

}  // namespace cosim::fluid
