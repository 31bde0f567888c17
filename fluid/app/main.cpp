// `fluid`: runs a fluid-only scene (no solid process) and reports its health.
//
//   fluid SCENE.toml [--steps N] [--output DIR] [--monitor-every N] [--fields-every N]
//                    [--threads N] [--quiet] [--check] [--print KEY,...]
//
// Exit status: 0 the run finished; 1 an output or system error; 2 the scene file or the
// command line is invalid (one line on stderr); 3 the flow became unhealthy (NaN, rho <= 0,
// rho outside [watchdog] rho_min and rho_max, or Mach above run.mach_limit; checked every
// run.monitor_every and, from the kernel's extrema, every watchdog.health_every steps): one
// line on stderr naming the step, cell and quantity, and nothing is written for that step.
//
// Initial state: rho = 1 everywhere with u = 0 (run.initial = "rest"), or with the inlet
// profile of the first inlet face extended through the whole domain (run.initial =
// "inlet", the default when a face is an inlet): the flow that would enter anyway, so the
// start is not an impulsive one from rest against the inlet.
#include <omp.h>
#include <pthread.h>
#include <unistd.h>

#include <csignal>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>
#include <string>

#include <cstdlib>
#include <iostream>

#include "common/text/cli_parse.hpp"
#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/domain/decomposition.hpp"
#include "fluid/io/field_writer.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/io/held_body_log.hpp"
#include "fluid/ib/held_body.hpp"
#include "fluid/observables/flow_monitor.hpp"
#include "fluid/domain/fluid_domain.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "fluid/collision/kernel_dispatch.hpp"
#include "fluid/io/monitor_log.hpp"
#include "fluid/config/scene_config.hpp"
#include "fluid/config/scene_values.hpp"
#include "fluid/io/snapshots.hpp"
#include "protocol/channels.hpp"
#include "common/run/progress.hpp"
#include "common/run/provenance.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/interrupt.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"
#if COSIM_HAVE_MPI
#include "fluid/mpi/distributed_fluid.hpp"
#include "fluid/mpi/led_domain.hpp"
#include "fluid/mpi/mpi_world.hpp"
#endif

namespace cosim::fluid {
namespace {

namespace exit_code = protocol::exit_code;  // protocol/README.md section 9, defined once

using Clock = std::chrono::steady_clock;
using protocol::fmt;
using protocol::one_line;

double max_boundary_speed(const FluidParams& p) {
  double u = 0.0;
  for (const FaceSpec& f : p.faces) {
    if (f.kind == FaceKind::Inlet) u = std::max(u, f.inlet_speed);
    if (f.kind == FaceKind::Wall)
      u = std::max(u, std::hypot(f.wall_velocity[0], f.wall_velocity[1], f.wall_velocity[2]));
  }
  return u;
}

std::string describe_face(const FluidScene& s, int f) {
  const FaceSpec& spec = s.params.faces[f];
  std::string out = std::string(face_name(f)) + " " + kind_name(spec.kind);
  if (spec.kind == FaceKind::Inlet) {
    out += " (u = " + fmt("%.4g", spec.inlet_speed);
    if (spec.profile == InletProfile::Parabolic) out += " peak, parabolic";
    if (spec.profile == InletProfile::Blasius)
      out += ", Blasius layer " + fmt("%.3g", spec.boundary_layer * s.dx_um) + " um = " +
             fmt("%.3g", spec.boundary_layer) + " cells";
    out += ")";
  }
  if (spec.kind == FaceKind::Wall &&
      (spec.wall_velocity[0] != 0 || spec.wall_velocity[1] != 0 || spec.wall_velocity[2] != 0))
    out += " (moving: " + fmt("%.4g", spec.wall_velocity[0]) + ", " +
           fmt("%.4g", spec.wall_velocity[1]) + ", " + fmt("%.4g", spec.wall_velocity[2]) + ")";
  return out;
}

void print_header(const FluidScene& s, const protocol::UnitConverter& units) {
  const GridShape& g = s.params.shape;
  const double dt_ns = units.dt_lb_s() * 1e9;
  const double nu = (s.params.tau - 0.5) / 3.0;
  const double u = max_boundary_speed(s.params);
  fluid_log().info() << "scene " << s.name << (s.description.empty() ? "" : ": ") << s.description << " (" << s.path
                     << ")";
  std::printf("  grid     %d x %d x %d = %lld cells; domain %.4g x %.4g x %.4g um\n", g.nx, g.ny,
              g.nz, static_cast<long long>(g.cells()), g.nx * s.dx_um, g.ny * s.dx_um,
              g.nz * s.dx_um);
  std::printf("  units    dx = %.4g um, dt = dx / c = %.5g ns (c = sqrt(3) c_s = %.5g m/s)\n",
              s.dx_um, dt_ns, units.lattice_speed_m_s());
  std::printf("  fluid    tau = %.5g, nu = %.5g (lattice) = %.4g m^2/s", s.params.tau, nu,
              units.viscosity_m2_s(s.params.tau));
  if (s.reynolds)
    std::printf("; Re = U L / nu = %.4g (U = %.4g = %.4g m/s, L = %.4g um = %.4g cells)",
                *s.reynolds, s.reference_speed, units.velocity_m_s(s.reference_speed),
                s.reference_length_um, s.reference_length_um / s.dx_um);
  std::printf("\n");
  const KernelTable& k = active_kernel();
  std::printf("  kernel   %s (%s) on %s, chosen by %s\n", k.level, k.vectors, cpu_model().c_str(),
              kernel_level_source());
  std::printf("  speed    fastest boundary %.4g (U/c) = Mach %.3f; health limit Mach %.3g\n", u,
              u * std::sqrt(3.0), s.mach_limit);
  std::printf("  faces   ");
  for (int f = 0; f < kFaces; ++f) std::printf(" %s%s", describe_face(s, f).c_str(), f + 1 < kFaces ? "," : "\n");
  const auto& F = s.params.body_force;
  if (F[0] != 0 || F[1] != 0 || F[2] != 0)
    std::printf("  force    body force density (%.4g, %.4g, %.4g) lattice units\n", F[0], F[1], F[2]);
  std::printf("  memory   %.1f MiB of populations (%s x 19 %s per cell, with ghosts; %s propagation)\n",
              double(population_bytes(g, s.params.precision, s.params.propagation)) / (1024.0 * 1024.0),
              s.params.propagation == Propagation::InPlace ? "1" : "2",
              s.params.precision == Precision::Double ? "doubles"
              : s.params.precision == Precision::Mixed  ? "floats (mixed: float store, double arithmetic)"
              : s.params.precision == Precision::Single ? "floats (single: float store, float arithmetic)"
                                                        : "16-bit codes of f - w (half: FP16S store, float arithmetic)",
              propagation_name(s.params.propagation));
  std::printf("  run      %lld steps = %.4g us; initial %s; monitor every %lld; ",
              static_cast<long long>(s.steps), units.time_s(double(s.steps)) * 1e6,
              s.initial == InitialFlow::Inlet ? "inlet profile" : "at rest",
              static_cast<long long>(s.monitor_every));
  if (s.fields_every > 0)
    std::printf("fields every %lld", static_cast<long long>(s.fields_every));
  else
    std::printf("no field output");
  if (s.planes_every > 0) {
    std::printf("; y planes at");
    for (const double f : s.planes_y) std::printf(" %.4g", f);
    std::printf(" of the height every %lld", static_cast<long long>(s.planes_every));
  }
  std::printf("; output %s; %d OpenMP threads\n", s.output_dir.c_str(), omp_get_max_threads());
  for (const std::string& c : s.unit_conversions) std::printf("  physical %s\n", c.c_str());
  if (s.inlet_ramp_steps > 0.0)
    std::printf("  inlet    ramped by (1 - cos(pi t / T)) / 2 over T = %.6g steps\n", s.inlet_ramp_steps);
  if (s.held_body) {
    const HeldBodyShape& b = s.held_body->shape;
    std::printf("  body     held at rest: cylinder at (%.4g, %.4g) cells, radius %.4g", b.x_c, b.y_c, b.radius);
    if (b.bar_thickness > 0.0) std::printf(", bar to x = %.4g, thickness %.4g", b.bar_tip_x, b.bar_thickness);
    std::printf(" cells; markers retracted %.3g, %d forcing passes per step; held_body.csv every %lld steps\n",
                b.retraction, b.iterations, static_cast<long long>(s.held_body->record_every));
  }
  std::fflush(stdout);
  // Liveness while writing (coupled scenes): the solid hears nothing while the fluid writes
  // its largest file (fluid/io/snapshots.hpp).
  if (const std::string w = silent_write_warning(s); !w.empty()) fluid_log().warning(std::cerr) << w;
}

/// The fluid-only run's progress line on stderr (common/run/progress.hpp): step, simulated
/// time, MLUPS and ETA; none where `logger` does not show progress (--quiet).
class Progress {
 public:
  Progress(const log::Logger& logger, std::int64_t total, double dt_us, std::int64_t cells)
      : line_(logger), clock_(total), dt_us_(dt_us), cells_(cells) {}

  void update(std::int64_t step) {
    if (!line_.due(step == clock_.total())) return;
    char text[192];
    std::snprintf(text, sizeof text, "step %lld/%lld  t = %.4g us  %.1f MLUPS  ETA %s",
                  static_cast<long long>(step), static_cast<long long>(clock_.total()), double(step) * dt_us_,
                  double(cells_) * clock_.rate(step) * 1e-6, protocol::format_duration(clock_.eta_s(step)).c_str());
    line_.show(text);
  }
  /// Clears a carriage-return line before something else is printed.
  void clear() { line_.clear(); }
  double elapsed_s() const { return clock_.elapsed_s(); }

 private:
  protocol::ProgressLine line_;
  protocol::ProgressClock clock_;
  double dt_us_;
  std::int64_t cells_;
};

/// The run loop of a fluid-only scene over `domain` (one process, or blocks over MPI ranks:
/// every rank runs this loop; the leading one prints and writes).
int run(const FluidScene& s, bool quiet, FluidDomain& domain) {
  const protocol::UnitConverter units(unit_inputs(s));
  const double dt_us = units.dt_lb_s() * 1e6;
  const bool leads = domain.leads();
  if (s.threads > 0) omp_set_num_threads(s.threads);
  if (leads) {
    print_header(s, units);
    if (const std::string d = domain.describe(); !d.empty()) std::printf("  blocks   %s\n", d.c_str());
    std::fflush(stdout);
  }

  domain.initialize(s);
  // The inlet's start-up ramp (inlet.ramp_us) and the held body ([held_body]).
  ramp_inlet(domain, s, 0);
  std::optional<HeldBody> body;
  if (s.held_body) body.emplace(s.held_body->shape, ImmersedBoundary(s.params));

  const HealthLimits limits{s.mach_limit, 0.0, s.watchdog.rho_min, s.watchdog.rho_max};
  Progress progress(fluid_log(!quiet && leads ? log::Level::progress : log::Level::info), s.steps, dt_us,
                    s.params.shape.cells());
  const auto stop = [&](const std::string& problem) {
    if (!leads) return;
    progress.clear();
    std::fflush(stdout);
    fluid_log().error() << "unhealthy flow, run stopped: " << one_line(problem);
  };
  // Health before every write: an unhealthy state is diagnosed and nothing is written. The
  // summary is on the leading process; its verdict goes to every process.
  const auto healthy_summary = [&]() -> std::optional<FlowSummary> {
    FlowSummary sum;
    std::string problem;
    if (const std::optional<FlowSummary> got = domain.summary()) {
      sum = *got;
      problem = health_problem(sum, limits);
    }
    problem = domain.from_leader(problem);
    if (problem.empty()) return sum;
    stop(problem);
    return std::nullopt;
  };

  const std::optional<FlowSummary> first = healthy_summary();
  if (!first) return exit_code::unhealthy;
  const double mass0 = first->mass;

  std::optional<MonitorLog> log;
  std::optional<HeldBodyLog> body_log;
  std::optional<Snapshots> snapshots;
  if (leads) {
    std::filesystem::create_directories(s.output_dir);
    protocol::write_provenance_files(s.output_dir);  // OUTPUT/scene.toml, provenance_fluid.toml
    log.emplace((std::filesystem::path(s.output_dir) / "monitor.h5").string(), dt_us);
    log->append(*first);
    if (body)
      body_log.emplace((std::filesystem::path(s.output_dir) / "held_body.csv").string(), units.dt_lb_s(),
                       held_body_newtons_per_m(units, s.params.shape.nz));
    std::printf("%s\n", format_summary(*first, dt_us, mass0).c_str());
    std::fflush(stdout);
  }
  // Every process writes its own part of the snapshots (collective; its own Snapshots).
  snapshots.emplace(s, dt_us);
  const auto write_snapshots = [&](bool last) { domain.write_snapshots(*snapshots, last); };
  if (Snapshots::due(s, 0, false)) write_snapshots(false);

  for (std::int64_t step = 1; step <= s.steps; ++step) {
    if (body) {
      body->hold(domain);  // the impulses that hold the markers at rest during this step
      if (leads) body_log->add(body->force());
    }
    domain.step();
    ramp_inlet(domain, s, step);
    if (body && leads && (step % s.held_body->record_every == 0 || step == s.steps)) body_log->record(step);
    // The watchdog's cadence: the state the step read (step - 1), from the kernel's extrema.
    if ((step - 1) % s.watchdog.health_every == 0)
      if (const std::string problem = domain.kernel_problem(limits); !problem.empty()) {
        stop(problem);
        return exit_code::unhealthy;
      }
    const bool last = step == s.steps;
    const bool monitor = step % s.monitor_every == 0 || last;
    const bool snapshot = Snapshots::due(s, step, last);
    if (monitor || snapshot) {
      const std::optional<FlowSummary> sum = healthy_summary();
      if (!sum) return exit_code::unhealthy;
      if (leads && monitor) {
        log->append(*sum);
        progress.clear();
        std::printf("%s\n", format_summary(*sum, dt_us, mass0).c_str());
        std::fflush(stdout);
      }
      if (snapshot) write_snapshots(last);
    }
    progress.update(step);
  }
  progress.clear();
  const double wall = progress.elapsed_s();
  const std::vector<double> peaks = domain.peak_memory_mib();
  if (leads) fluid_log().info() << peak_memory_line(peaks);
  if (leads)
    fluid_log().info() << log::printf_text("done, %lld steps (%.4g us) in %.1f s, %.1f MLUPS; output in %s",
                                           static_cast<long long>(s.steps), double(s.steps) * dt_us, wall,
                                           wall > 0 ? double(s.params.shape.cells()) * double(s.steps) / wall * 1e-6
                                                    : 0.0,
                                           s.output_dir.c_str());
  return exit_code::ok;
}

#if COSIM_HAVE_MPI
mpi::World* g_world = nullptr;  // set by main() when mpirun started the process
#endif
// The signal mask before main() blocked SIGINT and SIGTERM for MPI's threads.
sigset_t g_mask_before_mpi;
bool g_interrupts_blocked = false;
// The standard error of a rank other than 0 while the command line and the scene are read
// (every rank finds the same problems; rank 0 says them once): -1 when not held back.
int g_held_stderr = -1;
void release_stderr() {
  if (g_held_stderr < 0) return;
  std::fflush(stderr);
  dup2(g_held_stderr, 2);
  close(g_held_stderr);
  g_held_stderr = -1;
}

#if COSIM_HAVE_MPI
int mpi_ranks() { return g_world != nullptr ? g_world->size() : 1; }

#endif

/// A fluid-only scene in this process, or over the MPI ranks of an mpirun.
int run_fluid_only(const FluidScene& scene, bool quiet) {
#if COSIM_HAVE_MPI
  if (mpi_ranks() > 1) {
    std::unique_ptr<FluidDomain> domain;
    try {
      domain = std::make_unique<mpi::DistributedFluid>(scene, g_world->comm());
    } catch (const std::invalid_argument& e) {
      if (g_world->rank() == 0) std::fprintf(stderr, "%s: %s\n", scene.path.c_str(), one_line(e.what()).c_str());
      return exit_code::bad_input;
    }
    return run(scene, quiet, *domain);
  }
#endif
  SerialDomain domain(scene.params);
  return run(scene, quiet, domain);
}

/// A coupled scene: the coordinator, the session and the scheme in this process, the grid
/// here or, under mpirun on several ranks, in slabs over the ranks, led from rank 0 (the
/// other ranks follow its calls; fluid/mpi/led_domain.hpp).
int run_coupled_scene(const FluidScene& scene, const CoupledFluidOptions& co) {
#if COSIM_HAVE_MPI
  if (mpi_ranks() > 1) {
    std::unique_ptr<mpi::DistributedFluid> grid;
    try {
      grid = std::make_unique<mpi::DistributedFluid>(scene, g_world->comm());
    } catch (const std::invalid_argument& e) {
      if (g_world->rank() == 0) std::fprintf(stderr, "%s: %s\n", scene.path.c_str(), one_line(e.what()).c_str());
      return exit_code::bad_input;
    }
    // The leading process's loop (mpi::LedDomain) neither ramps an inlet nor holds a body.
    if (scene.inlet_ramp_steps > 0.0 || scene.held_body) {
      if (g_world->rank() == 0)
        std::fprintf(stderr, "%s: %s in a coupled run over %d MPI ranks: not supported; run it on one process\n",
                     scene.path.c_str(), scene.held_body ? "[held_body]" : "inlet.ramp_us", mpi_ranks());
      return exit_code::bad_input;
    }
    MPI_Comm orders = MPI_COMM_NULL;
    mpi::check(MPI_Comm_dup(g_world->comm(), &orders), "MPI_Comm_dup");
    if (g_world->rank() != 0)
      return mpi::follow(*grid, scene, protocol::UnitConverter(unit_inputs(scene)).dt_lb_s() * 1e6, orders);
    std::printf("  blocks   %s\n", grid->describe().c_str());
    std::fflush(stdout);
    mpi::LedDomain led(*grid, orders);
    const int code = run_coupled_fluid(scene, co, std::cout, std::cerr, led);
    led.end(code);
    return code;
  }
#endif
  return run_coupled_fluid(scene, co, std::cout, std::cerr);
}

int main_impl(int argc, char** argv) {
  CLI::App app{
      "Runs a fluid-only scene (D3Q19 lattice Boltzmann) and writes its monitor log and "
      "fields.\nExit status: 0 done, 1 output/system error, 2 invalid scene or command line, "
      "3 unhealthy flow (NaN, rho <= 0, Mach above run.mach_limit).",
      "fluid"};
  std::string scene_path;
  std::int64_t steps = 0, monitor_every = 0, fields_every = 0, time_ratio = 0;
  int threads = 0;
  std::string output;
  bool quiet = false, check = false;
  app.add_option("scene", scene_path, "scene file (TOML), e.g. scenes/channel_reduced.toml")
      ->required();
  CLI::Option* o_steps = app.add_option("--steps", steps, "number of LB steps (run.steps)");
  CLI::Option* o_output =
      app.add_option("--output", output, "output directory (output.directory)");
  CLI::Option* o_monitor = app.add_option(
      "--monitor-every", monitor_every, "health check + monitor row every N steps (run.monitor_every)");
  CLI::Option* o_fields = app.add_option(
      "--fields-every", fields_every, "field snapshot every N steps, 0 = none (output.fields_every)");
  CLI::Option* o_threads =
      app.add_option("--threads", threads, "OpenMP threads, 0 = OpenMP's default (run.threads)");
  app.add_flag("--quiet", quiet, "no progress line on stderr");
  app.add_flag("--check", check, "validate the scene, print the header, and exit");
  std::string print_keys;
  app.add_option("--print", print_keys,
                 "print KEY=VALUE for each of the comma-separated keys as the fluid reads them "
                 "(coupling.lcm_url, coupling.handshake_timeout_s, coupling.peer_timeout_s, "
                 "coupling.time_ratio, coupling.channel_prefix, output.directory, run.steps, run.precision, "
                 "run.propagation) and exit");
  std::string token, channel_prefix, lcm_url;
  app.add_option("--token", token,
                 "coupled scenes: the run's token (default: the environment's COSIM_RUN_TOKEN)");
  app.add_option("--channel-prefix", channel_prefix,
                 "coupled scenes: LCM channel prefix (overrides coupling.channel_prefix)");
  CLI::Option* o_url = app.add_option(
      "--lcm-url", lcm_url,
      "coupled scenes: LCM URL (overrides coupling.lcm_url; udpm://ADDR:PORT?ttl=0 or memq://)");
  CLI::Option* o_time_ratio = app.add_option(
      "--time-ratio", time_ratio,
      "coupled scenes: A_T, substeps per LB step (overrides coupling.time_ratio; the "
      "launcher's watchdog retry)");
  std::string restart;
  app.add_option("--restart", restart,
                 "coupled scenes: continue from this checkpoint (OUTPUT/checkpoints/fluid_N.h5); "
                 "the solid restarts from its checkpoint of the same step (launch/run-coupled.sh "
                 "--restart DIR picks both)");
  std::string faults;
  CLI::Option* o_faults = app.add_option(
      "--faults", faults,
      "coupled scenes, tests: inject transport faults into what the fluid publishes, e.g. "
      "drop=0.01,duplicate=0.01,reorder=0.01,delay=0.01,delay_ms=20,seed=1 (default: the "
      "environment's COSIM_FAULTS; protocol/fault_injection.hpp)");
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, "fluid")) return *code;

  FluidScene scene;
  try {
    scene = load_scene(scene_path);
    SceneOverrides ov;
    if (o_steps->count()) ov.steps = steps;
    if (o_monitor->count()) ov.monitor_every = monitor_every;
    if (o_fields->count()) ov.fields_every = fields_every;
    if (o_threads->count()) ov.threads = threads;
    if (o_output->count()) ov.output_dir = output;
    if (o_time_ratio->count()) ov.time_ratio = time_ratio;
    if (o_url->count()) ov.lcm_url = lcm_url;
    apply_overrides(scene, ov);
    if (!print_keys.empty()) {
      std::fputs(scene_values(scene, print_keys).c_str(), stdout);
      return exit_code::ok;
    }
  } catch (const SceneError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return exit_code::bad_input;
  }
  release_stderr();  // from here on a rank's problems are its own
  protocol::record_scene(scene.path);
  try {
    active_kernel();  // COSIM_KERNEL_LEVEL, if set, names a level this binary and CPU have
  } catch (const std::invalid_argument& e) {
    fluid_log().error() << e.what();
    return exit_code::bad_input;
  }
  if (check) {
    if (scene.threads > 0) omp_set_num_threads(scene.threads);
    print_header(scene, protocol::UnitConverter(unit_inputs(scene)));
    return exit_code::ok;
  }
  if (scene.coupling) {
    protocol::catch_interrupts();  // before any thread starts (OpenMP, LCM)
    if (token.empty())
      if (const char* env = std::getenv("COSIM_RUN_TOKEN")) token = env;
    if (!channel_prefix.empty()) {
      try {
        protocol::validate_channel_prefix(channel_prefix);
      } catch (const std::invalid_argument& e) {
        fluid_log().error() << "--channel-prefix " << channel_prefix << ": " << e.what();
        return exit_code::bad_input;
      }
    }
    if (scene.threads > 0) omp_set_num_threads(scene.threads);
    print_header(scene, protocol::UnitConverter(unit_inputs(scene)));
    CoupledFluidOptions co;
    co.token = token;
    co.channel_prefix = channel_prefix;
    co.lcm_url = lcm_url;
    co.quiet = quiet;
    co.restart = restart;
    try {
      co.read_environment();  // the run id, --new-time-ratio, the run's key
      co.faults = protocol::fault_settings_from(o_faults->count() ? &faults : nullptr);
    } catch (const std::invalid_argument& e) {
      fluid_log().error() << e.what();
      return exit_code::bad_input;
    }
    return run_coupled_scene(scene, co);
  }
  if (g_interrupts_blocked) pthread_sigmask(SIG_SETMASK, &g_mask_before_mpi, nullptr);
  return run_fluid_only(scene, quiet);
}

}  // namespace
}  // namespace cosim::fluid

int main(int argc, char** argv) {
#if COSIM_HAVE_MPI
  // MPI only under mpirun: alone, the fluid runs as a build without MPI does.
  std::optional<cosim::fluid::mpi::World> world;
  if (cosim::fluid::mpi::launched_by_mpirun()) {
    // SIGINT and SIGTERM blocked before MPI starts threads of its own, which would otherwise
    // take them and end the process: a coupled run takes them in the thread of
    // protocol::catch_interrupts (rank 0 then stops the run at its next step); a fluid-only
    // run unblocks them again.
    sigset_t interrupts;
    sigemptyset(&interrupts);
    sigaddset(&interrupts, SIGINT);
    sigaddset(&interrupts, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &interrupts, &cosim::fluid::g_mask_before_mpi);
    cosim::fluid::g_interrupts_blocked = true;
    world.emplace(argc, argv);
    cosim::fluid::g_world = &*world;
    // One process prints: the others' standard output would repeat the leader's lines.
    if (world->rank() != 0) {
      if (std::freopen("/dev/null", "w", stdout) == nullptr) return 1;
      std::fflush(stderr);
      cosim::fluid::g_held_stderr = dup(2);
      if (cosim::fluid::g_held_stderr >= 0 && std::freopen("/dev/null", "w", stderr) == nullptr) return 1;
    }
  }
#else
  // Started by mpirun on several ranks, a build without MPI would run the whole scene in
  // each of them into the same folder.
  if (const int ranks = cosim::fluid::mpirun_world_size(); ranks > 1) {
    cosim::fluid::fluid_log().error() << "started on " << ranks
                                      << " MPI ranks, but this build has no MPI (install libopenmpi-dev "
                                         "and rebuild: cmake -DCOSIM_MPI=ON)";
    return cosim::protocol::exit_code::bad_input;
  }
#endif
  try {
    return cosim::fluid::main_impl(argc, argv);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    cosim::fluid::release_stderr();
    cosim::fluid::fluid_log().error() << cosim::fluid::one_line(e.what());
#if COSIM_HAVE_MPI
    // The other ranks may wait in a collective for this one: end them all.
    if (world && world->size() > 1) cosim::fluid::mpi::World::abort(cosim::protocol::exit_code::system);
#endif
    return cosim::protocol::exit_code::system;
  }
}
