#include "fluid/coupled/fluid_run.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <type_traits>

#include "common/text/text.hpp"
#include "fluid/coupled/coordinator.hpp"
#include "fluid/lattice/d3q19.hpp"
#include "fluid/io/fluid_log.hpp"
#include "fluid/schemes/fluid_scheme.hpp"
#include "common/run/checkpoint_file.hpp"
#include "protocol/checkpoint_identity.hpp"
#include "protocol/handshake.hpp"
#include "common/run/progress.hpp"
#include "common/run/provenance.hpp"
#include "protocol/session/interrupt.hpp"
#include "common/text/text.hpp"

namespace cosim::fluid {

namespace {

namespace exit_code = protocol::exit_code;
using protocol::Ending;

const std::string& created(const std::string& dir) {
  std::filesystem::create_directories(dir);
  return dir;
}

/// The monitor rows as flat arrays (what monitor.h5 holds), and back.
void put_rows(protocol::CheckpointWriter& w, const std::vector<FlowSummary>& rows) {
  std::vector<std::int64_t> steps, cells;
  std::vector<double> values;
  for (const FlowSummary& r : rows) {
    steps.push_back(r.step);
    for (const double v : {r.mass, r.momentum[0], r.momentum[1], r.momentum[2], r.max_mach, r.rho_min, r.rho_max})
      values.push_back(v);
    for (const CellIndex& c : {r.max_mach_cell, r.rho_min_cell, r.rho_max_cell, r.nan_cell})
      for (const int v : {c.x, c.y, c.z}) cells.push_back(v);
    cells.push_back(r.has_nan ? 1 : 0);
  }
  w.put("monitor_step", steps);
  w.put("monitor_values", values);
  w.put("monitor_cells", cells);
}

std::vector<FlowSummary> get_rows(const protocol::CheckpointReader& r) {
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

}  // namespace

FluidRun::FluidRun(const FluidScene& scene, const CoupledFluidOptions& options, Coordinator& coordinator,
                   const FluidScheme& scheme, FluidDomain& domain)
    : s_(scene), restart_(options.restart), run_id_(options.run_id), new_time_ratio_(options.new_time_ratio),
      logger_(fluid_log(options.quiet ? log::Level::info : log::Level::progress)), coord_(coordinator), scheme_(scheme),
      domain_(domain),
      limits_{scene.mach_limit, 0.0, scene.watchdog.rho_min, scene.watchdog.rho_max},
      dt_us_(coordinator.units().dt_lb_s() * 1e6),
      monitor_path_((std::filesystem::path(created(scene.output_dir)) / "monitor.h5").string()),
      snapshots_(scene, dt_us_), markers_(scene.watchdog, scene.mach_limit, scene.coupling->time_ratio),
      audit_(scene.coupling->rigid_steps, scene.reaction_law == protocol::config::ReactionLaw::MomentumExchange ||
                                              scene.reaction_law == protocol::config::ReactionLaw::PerSubstepOverTimeRatio) {
  domain_.initialize(s_);
  if (s_.held_body) body_.emplace(s_.held_body->shape, ImmersedBoundary(s_.params));
  coord_.on_end([this](std::ostream& out) {
    if (markers_.has_reference()) logger_.info(out) << "watchdog margins: " << markers_.margins();
  });
}

FluidRun::~FluidRun() { coord_.on_end({}); }

protocol::CheckpointIdentity FluidRun::identity() const {
  return {s_.path, run_id_, s_.coupling->time_ratio, new_time_ratio_};
}

std::int64_t FluidRun::start(std::optional<int>& failed) {
  std::int64_t first_step = 0;
  if (!restart_.empty()) {
    std::optional<cosimlcm::fluid_state_t> in_flight;
    try {
      first_step = restore(in_flight);
    } catch (const std::exception& x) {
      failed = coord_.stop_and_end({exit_code::bad_input, "--restart " + restart_ + ": " + x.what(), false}, 0);
      return 0;
    }
    logger_.info(coord_.out()) << "restarted from " << restart_ << " at step " << first_step
                               << " (the folder's files are rewritten once the solid has accepted its checkpoint too)";
    if (in_flight) coord_.republish(std::move(*in_flight));
    // monitor.h5, held_body.csv, the scene copy and provenance wait for the solid's
    // solid_state_t of the restart (accept_restart()): a restart that either side refuses
    // writes nothing into the folder.
    restart_pending_ = true;
  } else {
    const FlowSummary first = *domain_.summary();
    mass0_ = first.mass;
    bulk_u_ = first.momentum[0] / first.mass;
    log_.emplace(monitor_path_, dt_us_);
    log_->append(first);
    rows_.push_back(first);
    if (snapshots_.due(0, false)) domain_.write_snapshots(snapshots_, false);
    if (const auto code = open_run_files(first_step)) {
      failed = code;
      return first_step;
    }
  }
  ramp_inlet(domain_, s_, first_step);
  coord_.set_first_step(first_step);
  start_ = Clock::now();
  clock_.restart(first_step);
  released_ = first_step >= rigid_steps();
  return first_step;
}

/// OUTPUT/scene.toml, provenance_fluid.toml and held_body.csv: once the run is accepted (a
/// refused start or restart adds nothing to the folder). The exit code of a failed write.
std::optional<int> FluidRun::open_run_files(std::int64_t step) {
  try {
    protocol::write_provenance_files(s_.output_dir);
    if (body_)
      body_log_.emplace((std::filesystem::path(s_.output_dir) / "held_body.csv").string(), coord_.units().dt_lb_s(),
                        held_body_newtons_per_m(coord_.units(), s_.params.shape.nz), true);
  } catch (const std::exception& x) {
    return coord_.stop_and_end({exit_code::system, protocol::one_line(x.what()), true}, step);
  }
  return std::nullopt;
}

/// The first solid_state_t of a restart: the solid has read and accepted its checkpoint
/// (it publishes nothing before), and so has the fluid; only now monitor.h5 is rewritten
/// from the checkpoint's rows, and the scene copy, provenance and held_body.csv written.
/// The line "fluid: restart accepted" tells the launcher (launch/run-coupled.sh) that the
/// folder now holds the continued run.
std::optional<int> FluidRun::accept_restart(std::int64_t step) {
  restart_pending_ = false;
  try {
    log_.emplace(monitor_path_, dt_us_);
    for (const FlowSummary& row : rows_) log_->append(row);
  } catch (const std::exception& x) {
    return coord_.stop_and_end({exit_code::system, protocol::one_line(x.what()), true}, step);
  }
  if (const auto code = open_run_files(step)) return code;
  logger_.info(coord_.out()) << "restart accepted at step " << step
                             << ": both checkpoints read; monitor.h5 continues from its " << rows_.size() << " rows";
  return std::nullopt;
}

void FluidRun::hold_body(const std::vector<Vec3>& sheet_impulses) {
  if (!body_) return;
  body_force_ = body_->hold(domain_);
  sheet_force_ = {0.0, 0.0, 0.0};
  for (const Vec3& j : sheet_impulses)
    for (int c = 0; c < 3; ++c) sheet_force_[c] -= j[c];
}

// ---- the stability watchdog (DESIGN 6; common/watchdog/watchdog.hpp) ----

std::optional<int> FluidRun::check_positions(std::int64_t step, const std::vector<Vec3>& x,
                                             const std::vector<Vec3>& j) {
  if (restart_pending_)
    if (const auto code = accept_restart(step)) return code;
  const Clock::time_point w0 = Clock::now();
  static const std::vector<double> no_rho;
  static const std::vector<Vec3> no_u;
  const bool sampled = sample_step_ == step;
  audit_.observe(step, x, j, sampled ? sample_rho_ : no_rho, sampled ? sample_u_ : no_u);
  if (const auto t = markers_.check_positions(step, x)) return trip(*t, true, step);
  timing_.watch += std::chrono::duration<double>(Clock::now() - w0).count();
  return std::nullopt;
}

std::optional<int> FluidRun::sample_markers(std::int64_t now, const std::vector<Vec3>& x,
                                            std::vector<MarkerSample>& samples) {
  const std::size_t n = x.size();
  domain_.sample(x, samples);
  // What fluid_state_t(now) carries, for the audit of the solid's answer to it.
  sample_step_ = now;
  sample_rho_.resize(n);
  sample_u_.resize(n);
  for (std::size_t l = 0; l < n; ++l) sample_rho_[l] = samples[l].rho, sample_u_[l] = samples[l].u;
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
  if (const auto t = markers_.check_samples(now, sample_rho, sample_u)) return trip(*t, false, now);
  timing_.watch += std::chrono::duration<double>(Clock::now() - w1).count();
  return std::nullopt;
}

std::optional<int> FluidRun::check_step_read(std::int64_t step) {
  if (step % s_.watchdog.health_every != 0) return std::nullopt;
  const Clock::time_point w = Clock::now();
  const std::string problem = domain_.kernel_problem(limits_);
  timing_.watch += std::chrono::duration<double>(Clock::now() - w).count();
  if (problem.empty()) return std::nullopt;
  return unhealthy(problem, step);
}

/// The trip of flow_health at `step` for health_problem()'s line.
int FluidRun::unhealthy(const std::string& problem, std::int64_t step) {
  protocol::Trip t;
  t.sentinel = "flow_health";
  t.step = step;
  // health_problem names the step first ("step N: cell (...): ..."): said once here.
  const std::string prefix = "step " + std::to_string(step) + ": ";
  t.diagnosis = "watchdog flow_health at step " + std::to_string(step) + ": unhealthy flow at " +
                (problem.rfind(prefix, 0) == 0 ? problem.substr(prefix.size()) : problem);
  return trip(t, false, step);
}

/// A tripped sentinel: the diagnosis, a checkpoint of the fluid at `step` when
/// `checkpoint_state` and that state is healthy (else the latest periodic one stands), the
/// retry advice for the launcher, and stop_t(3) to the solid. Nothing of the tripped state
/// is written.
int FluidRun::trip(const protocol::Trip& tripped, bool checkpoint_state, std::int64_t step) {
  const protocol::Trip t = blame(tripped);
  std::string reason = t.diagnosis;
  if (checkpoint_state && step >= 1 && step > coord_.first_step()) {
    const std::string problem = health_problem(*domain_.summary(), limits_);
    if (problem.empty()) reason += checkpoint(step, t.diagnosis);
    else reason += "; no checkpoint of step " + std::to_string(step) + ": " + problem;
  }
  if (t.dt_cure) coord_.announce_retry(step, s_.coupling->time_ratio, 0);
  return coord_.stop_and_end({exit_code::unhealthy, reason, false}, step);
}

/// A sentinel on the markers whose cause the exchanged data show to be the solid's
/// (fluid/watchdog/solid_audit.hpp): its measurement and the solid named, no advice about
/// dt_CG, the inlet or the grid, unless the handshake's added-mass check measured that the
/// substeps do not resolve the fluid's reaction (then a smaller dt_CG may cure it).
protocol::Trip FluidRun::blame(const protocol::Trip& t) const {
  if (t.measurement.empty()) return t;
  const auto am = coord_.added_mass();
  const auto why = audit_.blame(coord_.light_cgp_area_lb());
  if (!why) return t;
  protocol::Trip b = t;
  b.diagnosis = t.measurement + "; " + *why;
  b.dt_cure = am && am->relaxation_substeps < s_.watchdog.relaxation_substeps_min;
  if (b.dt_cure)
    b.diagnosis += "; but the substeps do not resolve the fluid's reaction on the lightest CGP (T = " +
                   protocol::fmt("%.3g", am->relaxation_substeps) + " substeps): a smaller dt_CG may cure it";
  return b;
}

std::optional<int> FluidRun::step_outputs(std::int64_t now, bool last, bool periodic) {
  const bool monitor = monitor_due(now) || last;
  const bool snapshot = snapshots_.due(now, last);
  if (monitor || snapshot || periodic) {
    const FlowSummary sum = *domain_.summary();
    const std::string problem = health_problem(sum, limits_);
    if (!problem.empty()) return unhealthy(problem, now);
    if (monitor) {
      log_->append(sum);
      rows_.push_back(sum);
      bulk_u_ = sum.momentum[0] / sum.mass;
      coord_.out() << format_summary(sum, dt_us_, mass0_) << "\n";
      coord_.out().flush();
    }
  }
  if (snapshot) domain_.write_snapshots(snapshots_, last);
  if (body_log_) {
    body_log_->add(body_force_, sheet_force_);
    if (now % s_.held_body->record_every == 0 || last) body_log_->record(now);
  }
  ramp_inlet(domain_, s_, now);
  return std::nullopt;
}

int FluidRun::peer_ending(Ending e, std::int64_t step, const std::string& note) {
  e.reason += note;
  // The solid's watchdog tripped on a sentinel that a smaller dt_CG may cure.
  if (coord_.peer_code() == exit_code::unhealthy && protocol::dt_curable(e.reason))
    coord_.announce_retry(step, s_.coupling->time_ratio, 0);
  return coord_.end(e);
}

// ---- coupled checkpoints (DESIGN 2.4; protocol/README.md section 10) ----

/// The populations of any store (doubles, floats for the modes "mixed" and "single", or the
/// 16-bit codes of f_q - w_q for "half", stored as unsigned 16-bit integers) of
/// the whole grid, as one process holds them (each rank of a run over MPI ranks writes its own
/// range: parallel HDF5), with the precision mode's name and its arithmetic; a restart reads
/// them back into a run of the same mode, on any number of ranks (precision_problem).
std::string FluidRun::checkpoint(std::int64_t step, const std::string& reason, bool kept) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(s_.output_dir) / "checkpoints";
  const fs::path file = dir / protocol::checkpoint_name("fluid", step);
  const std::size_t size = std::size_t(D3Q19::Q) * layout_of(s_.params.shape, s_.params.precision).stride();
  try {
    fs::create_directories(dir);
    protocol::CheckpointWriter w(file);
    w.attr("step", step);
    // The counters the scheme continues with (and its messages in flight).
    scheme_.write_checkpoint(w, step, coord_);
    w.attr("num_cgps", static_cast<std::int64_t>(coord_.num_cgps()));
    w.attr("bulk_velocity_lb", bulk_u_);
    w.attr("mass0", mass0_);
    if (markers_.has_reference()) {
      const protocol::MarkerWatch::Reference ref = markers_.reference();
      w.put("watchdog_neighbour", ref.neighbour);
      w.put("watchdog_distance", ref.distance);
      w.put("watchdog_last_positions", ref.last_positions);
    }
    protocol::write_identity(w, identity());
    w.text("reason", reason.empty() ? "every coupling.checkpoint_every steps" : reason);
    const Precision p = s_.params.precision;
    w.reserve("populations", stores_halves(p) ? H5T_STD_U16LE : stores_floats(p) ? H5T_IEEE_F32LE : H5T_IEEE_F64LE,
              size);
    w.text("precision", precision_name(s_.params.precision));
    // Marks the names of issue 35 ("mixed" = float store, double arithmetic, called "single"
    // before): a checkpoint without it is an older build's (precision_problem).
    w.text("arithmetic", float_arithmetic(s_.params.precision) ? "float" : "double");
    put_rows(w, rows_);
    // The file closed, every process writes its share of the store into it.
    w.pause();
    if (const std::string error = domain_.write_store(kept, w.part(), "populations"); !error.empty())
      throw std::runtime_error(error);
    w.commit();
    protocol::prune_checkpoints(dir, "fluid_", 3, run_id_);
  } catch (const std::exception& x) {
    if (reason.empty()) throw;
    return "; no checkpoint: " + std::string(x.what());
  }
  return "; checkpoint " + file.string();
}

/// Loads --restart: the populations, the step, the counters and the monitor rows; lists
/// the earlier snapshots; `in_flight`: the scheme's message to publish again. Returns the
/// step the run continues from. Throws (one line) for a file that is not a checkpoint of
/// this scene.
std::int64_t FluidRun::restore(std::optional<cosimlcm::fluid_state_t>& in_flight) {
  const protocol::CheckpointReader r(restart_);
  protocol::check_identity(r, identity());
  const std::int64_t step = r.int64_attr("step");
  if (step >= s_.steps && step >= 1)
    throw std::runtime_error("step = " + std::to_string(step) + ": the run already ends there (run.steps = " +
                             std::to_string(s_.steps) + "); to continue it, raise [run] steps above " +
                             std::to_string(step));
  if (step < 1)
    throw std::runtime_error("step = " + std::to_string(step) + ", allowed: 1 to " + std::to_string(s_.steps - 1) +
                             " (run.steps = " + std::to_string(s_.steps) + ")");
  if (r.int64_attr("num_cgps") != coord_.num_cgps())
    throw std::runtime_error("num_cgps = " + std::to_string(r.int64_attr("num_cgps")) + ", but the solid announced " +
                             std::to_string(coord_.num_cgps()));
  // The populations in the store's precision (its "precision" text): the scene hash above
  // ties the checkpoint to this scene file, run.precision included; the mode's name is
  // checked too, since an older build's "single" is today's "mixed".
  if (const std::string why = precision_problem(r.text("precision"), r.has("arithmetic"), s_.params.precision);
      !why.empty())
    throw std::runtime_error(why);
  // The checkpoint holds the whole store, ghost planes included, as the step left them: no
  // ghost fill here, the restarted step reads the very ghosts the run's next step would have
  // read (SinglePrecisionCoupledRestartIsBitIdentical). A fill from the stored values gives
  // the same bits (the kernel's x-outflow ghosts are computed from the values as stored,
  // FusedStepMatchesGhostFillStepSingleStore), but a restart does not depend on that. Each
  // process reads its own share (its block's store).
  const std::size_t size = std::size_t(D3Q19::Q) * layout_of(s_.params.shape, s_.params.precision).stride();
  r.check_array("populations", size);
  if (const std::string error = domain_.read_store(restart_, "populations", step); !error.empty())
    throw std::runtime_error(error);
  coord_.set_fluid_seq(r.int64_attr("fluid_seq"));
  bulk_u_ = r.double_attr("bulk_velocity_lb");
  mass0_ = r.double_attr("mass0");
  if (r.has("watchdog_neighbour")) {
    protocol::MarkerWatch::Reference ref;
    ref.neighbour = r.int64s("watchdog_neighbour");
    ref.distance = r.doubles("watchdog_distance");
    ref.last_positions = r.doubles("watchdog_last_positions");
    if (std::ssize(ref.neighbour) != coord_.num_cgps())
      throw std::runtime_error("watchdog_neighbour has " + std::to_string(ref.neighbour.size()) +
                               " markers, the solid announced " + std::to_string(coord_.num_cgps()));
    markers_.restore(ref);
  }
  in_flight = scheme_.read_checkpoint(r, step);
  rows_ = get_rows(r);
  // monitor.h5 only once the solid has accepted its checkpoint too (accept_restart()).
  snapshots_.adopt_up_to(step);
  // The in-flight solid_state_t(step) was computed with the checkpoint's A_T (a retry may
  // run another: the fluid's state does not depend on it). The solid republishes it once
  // the handshake is done; it may have arrived while this checkpoint was read: the inbox
  // offers what it holds again.
  coord_.expect_restart(step, scheme_.restart_key(r),
                        r.has("time_ratio") ? static_cast<int>(r.int64_attr("time_ratio")) : s_.coupling->time_ratio);
  return step;
}

void FluidRun::progress(std::int64_t now, int iteration) {
  // The release: the rigid spin-up is over after step rigid_steps (DESIGN 2.4).
  if (!released_ && now >= rigid_steps() && iteration < 0) {
    released_ = true;
    logger_.info(std::cerr) << "sheet released at step " << now << " (t = "
                            << protocol::fmt("%.4g", double(now) * dt_us_)
                            << " us): the rigid spin-up is over, the sheets move freely";
  }
  if (!logger_.shows(log::Level::progress) || !(clock_.due(progress_every_s_) || now == s_.steps)) return;
  // One machine-readable line per interval for launch/progress.py (the launcher's one line).
  const double wall = clock_.elapsed_s();
  const auto share = [wall](double part) { return wall > 0.0 ? 100.0 * part / wall : 0.0; };
  std::string it = iteration < 0 ? "" : "  iteration " + std::to_string(iteration);
  logger_.progress(std::cerr) << log::printf_text("step %lld/%lld  phase %s  t = %.4g us  %.1f MLUPS  compute %.0f %%  "
                                               "wait %.0f %%  ETA %s%s",
                                               static_cast<long long>(now), static_cast<long long>(s_.steps),
                                               now <= rigid_steps() ? "spin-up" : "free", double(now) * dt_us_,
                                               double(s_.params.shape.cells()) * clock_.rate(now) * 1e-6,
                                               share(timing_.compute), share(timing_.wait),
                                               protocol::format_duration(clock_.eta_s(now)).c_str(), it.c_str());
}

int FluidRun::finish() {
  coord_.publish_stop(s_.steps, exit_code::ok, "");
  std::ostream& out = coord_.out();
  const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
  logger_.info(out) << "coupled run done, " << s_.steps << " LB steps in " << wall << " s; " << coord_.counters()
                    << "; output in " << s_.output_dir;
  const double per = 1e3 / double(s_.steps);
  const StepTiming& t = timing_;
  const double mlups = t.compute > 0 ? double(s_.params.shape.cells()) * double(s_.steps) / t.compute * 1e-6 : 0.0;
  logger_.info(out) << log::printf_text("per LB step: compute %.4g ms (spread, step, health, sample), waiting "
                                        "%.4g ms (for solid_state_t), publishing %.4g ms; %.1f MLUPS while computing",
                                        t.compute * per, t.wait * per, t.publish * per, mlups);
  logger_.info(out) << log::printf_text("watchdog: %.4g ms per LB step, %.2g %% of the compute (the markers, the "
                                        "samples and the kernel's extrema every %lld steps)",
                                        t.watch * per, t.compute > 0 ? 100.0 * t.watch / t.compute : 0.0,
                                        static_cast<long long>(s_.watchdog.health_every));
  logger_.info(out) << "watchdog margins: " << markers_.margins();
  logger_.info(out) << peak_memory_line(domain_.peak_memory_mib());
  scheme_.summary(out, s_.steps);
  out.flush();
  // The solid may have lost every copy of the stop_t: it asks, and is answered, until quiet.
  if (const int again = coord_.linger(); again > 0)
    logger_.info(out) << "closing: the stop_t sent again " << again << " times for the solid's resend_t";
  coord_.done();
  return exit_code::ok;
}

}  // namespace cosim::fluid
