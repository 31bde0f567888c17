#include "solid/coupled/solid_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <system_error>
#include <tuple>

#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/session/announcement.hpp"
#include "common/run/peak_memory.hpp"
#include "common/text/text.hpp"
#include "solid/coupling/fluid_state_check.hpp"
#include "solid/coupled/initial_deflection.hpp"
#include "solid/io/solid_log.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/io/output_units.hpp"
#include "solid/model/sheet_spec.hpp"

namespace cosim::solid {

namespace {

using protocol::fmt;
using protocol::indent;
using protocol::one_line;
using protocol::PhysicalConstants;
using protocol::UnitConverter;

}  // namespace

SolidRun::SolidRun(const SolidScene& scene)
    : s_(scene), c_(*scene.coupling), units_(scene.unit_inputs()) {}

// ---- set-up ----

std::optional<Ending> SolidRun::build() {
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
  // [perturbation]: the sheets start deflected and at rest (step 0's positions), held so
  // through the rigid steps, then released. A model without dynamics stays as built.
  if (s_.tip_displacement_bohr != 0.0 && std::isfinite(model_->stable_time_step()))
    apply_initial_deflection(s_.config, s_.tip_displacement_bohr, s_.deflection_shape, *model_);
  coupler_ = std::make_unique<SolidCoupler>(*model_, units_, marker_areas_lb(s_.config.sheets, units_),
                                            solid_origin_lb());
  // The watchdog (DESIGN 6; common/watchdog/watchdog.hpp): a CGP's speed after every substep, the
  // energy after every interval. The energy floor: the sheets at 1e-6 c.
  coupler_->set_speed_limit(s_.watchdog.max_cgp_speed);
  coupler_->set_held(held_cgps());
  coupler_->set_reaction_law(s_.reaction_law);
  const double mass_kg = model_->masses().sum() * PhysicalConstants::electron_mass_kg;
  const double c = units_.dx_m() / units_.dt_lb_s();
  energy_watch_.emplace(s_.watchdog.energy_growth, 0.5 * mass_kg * c * c * 1e-12);
  return std::nullopt;
}

std::vector<bool> SolidRun::held_cgps() const {
  std::vector<bool> held(static_cast<std::size_t>(n_), !std::isfinite(model_->stable_time_step()));
  Eigen::Index first = 0;
  for (const SheetSpec& sheet : s_.config.sheets) {
    for (Eigen::Index k = 0; k < sheet.num_cgps() && first + k < n_; ++k)
      if (sheet.is_clamped(k)) held[static_cast<std::size_t>(first + k)] = true;
    first += sheet.num_cgps();
  }
  return held;
}

/// 0, 0 for a model without dynamics (nothing the fluid could accelerate).
std::pair<double, double> SolidRun::light_cgp() const {
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

std::string SolidRun::fastest_cgp() const {
  Eigen::Index l = 0;
  const double v2 = model_->velocities().colwise().squaredNorm().maxCoeff(&l);
  return "fastest " + describe_cgp(s_.config, l) + " at " + fmt("%.4g", units_.velocity_ratio() * std::sqrt(v2)) + " c";
}

/// A model without dynamics (rigid: +infinity) announces the largest double, since hello_t
/// carries positive finite numbers only.
double SolidRun::stable_dt_cg_s() const {
  const double s = model_->stable_time_step() * PhysicalConstants::time_au_s;
  return std::isfinite(s) ? s : std::numeric_limits<double>::max();
}

void SolidRun::print_header(std::ostream& out, const std::string& channel_prefix) const {
  solid_log().info(out) << "coupled scene " << s_.name << (s_.description.empty() ? "" : ": ") << s_.description
                        << " (" << s_.path << ")";
  out << indent(model_->startup_report());
  out << "  sheets   " << s_.config.sheets.size() << " sheet(s), " << n_ << " CGPs (markers)\n";
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
    out << line;
  }
  const double stable = model_->stable_time_step() * PhysicalConstants::time_au_s;
  out << "  units    dx = " << fmt("%.6g", units_.dx_m() / kMicrometre)
      << " um, dt_LB = " << fmt("%.6g", units_.dt_lb_s()) << " s, A_T = " << c_.time_ratio
      << ", dt_CG = " << fmt("%.6g", units_.dt_cg_s()) << " s; stable step of the model "
      << (std::isfinite(stable) ? fmt("%.6g s", stable) + " (dt_CG is " +
                                      fmt("%.3g", units_.dt_cg_s() / stable) + " of it" +
                                      (units_.dt_cg_s() > stable ? ": the coordinator will refuse it)" : ")")
                                : std::string("none (no dynamics)"))
      << "\n";
  if (s_.reaction_law != protocol::config::ReactionLaw::MomentumExchange)
    out << "  reaction law " << protocol::config::reaction_law_name(s_.reaction_law)
        << " ([reaction]; solid/coupling/reaction_law.hpp), not the momentum-exchange default\n";
  if (s_.tip_displacement_bohr != 0.0)
    out << "  initial  " << (s_.deflection_shape == DeflectionShape::Translation ? "displacement " : "tip deflection ")
        << fmt("%.6g", um_from_bohr(s_.tip_displacement_bohr)) << " um along each sheet's normal, at rest ([perturbation]; "
        << (s_.deflection_shape == DeflectionShape::Translation ? "every CGP translated" : "a uniformly loaded cantilever's shape")
        << ")"
        << (std::isfinite(stable) ? std::string() : std::string(": not applied, the model has no dynamics"))
        << "\n";
  out << "  coupling channels " << channel_prefix << "*, LCM " << c_.lcm_url
      << ", rigid_steps " << c_.rigid_steps << " (the welcome_t's count), timeouts: handshake "
      << fmt("%g", c_.handshake_timeout_s) << " s, peer " << fmt("%g", c_.peer_timeout_s)
      << " s, resend after " << fmt("%g", c_.resend_after_s) << " s; output " << s_.output_dir
      << (s_.sheets_every > 0 ? ", sheet snapshots every " + std::to_string(s_.sheets_every) +
                                    " LB steps (sheets.xmf)"
                              : std::string())
      << "\n";
  out.flush();
}

std::optional<Ending> SolidRun::open_output() {
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

cosimlcm::hello_t SolidRun::hello(const std::string& token) const {
  cosimlcm::hello_t h = protocol::to_lcm(
      protocol::announcement("solid", token, s_.model, s_.path, c_.scheme.scheme, units_, c_.time_ratio));
  h.stable_dt_cg_s = stable_dt_cg_s();
  h.num_cgps = static_cast<std::int32_t>(n_);
  std::tie(h.light_cgp_mass_kg, h.light_cgp_area_m2) = light_cgp();
  return h;
}

void SolidRun::set_length(std::int64_t total_steps, std::int64_t rigid_steps, std::int64_t final_step) {
  total_steps_ = total_steps;
  rigid_steps_ = rigid_steps;
  final_step_ = final_step;
}

// ---- one LB interval ----

std::optional<Ending> SolidRun::check(const cosimlcm::fluid_state_t& m) const {
  return check_fluid_state(m, n_, final_step_, total_steps_, s_.config);
}

// Section 5, steps 1-4; Eqs. 18-20 and 24 (SolidCoupler::advance).
std::optional<Ending> SolidRun::interval(const FluidSample& sample, std::int64_t step, IntervalResult& r) {
  const bool rigid = step < rigid_steps_;
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
  if (const std::string bad = non_finite(r); !bad.empty())
    return Ending{exit_code::unhealthy, "non-finite solid state after the interval of step " +
                                            std::to_string(step) + ": " + bad, true};
  return std::nullopt;
}

std::optional<Ending> SolidRun::commit(std::int64_t step, const IntervalResult& r, double bulk_velocity_lb) {
  if (const auto trip = energy_watch_->check(step, sheet_energy_J(), joule_from_hartree(r.fluid_work_au)))
    return Ending{exit_code::unhealthy, trip->diagnosis + "; " + fastest_cgp(), true};
  total_substeps_ += r.substeps;
  record(step, &r, bulk_velocity_lb);
  return std::nullopt;
}

void SolidRun::start() {
  record(0, nullptr, 0.0);
  reference_energy(0);
}

void SolidRun::reference_energy(std::int64_t step) { energy_watch_->check(step, sheet_energy_J(), 0.0); }

std::optional<Ending> SolidRun::snapshot(std::int64_t step) {
  if (!snapshots_ || !sheet_snapshot_due(step, total_steps_ - 1, s_.sheets_every)) return std::nullopt;
  try {
    snapshots_->write(step, static_cast<double>(step) * units_.dt_lb_s(), *model_);
  } catch (const std::exception& e) {
    return Ending{exit_code::system,
                  "sheet snapshot of step " + std::to_string(step) + ": " + one_line(e.what()), true};
  }
  return std::nullopt;
}

void SolidRun::record(std::int64_t step, const IntervalResult* r, double bulk_velocity_lb) {
  const SolidObservables o = model_->observables();
  CoupledSeries& series = series_;
  if (series.sheets == 0) series.sheets = static_cast<int>(s_.config.sheets.size());
  const double ek = joule_from_hartree(o.kinetic_energy_au);
  const double ee = joule_from_hartree(o.elastic_energy_au);
  series.step.push_back(step);
  series.time_s.push_back(static_cast<double>(step) * units_.dt_lb_s());
  series.solid_time_s.push_back(solid_time_s(total_substeps_));
  for (std::size_t k = 0; k < s_.config.sheets.size(); ++k) {
    const SheetSpec& sh = s_.config.sheets[k];
    const Eigen::Vector3d d = o.marked_displacement_bohr[k];
    for (int c = 0; c < 3; ++c) series.displacement_um.push_back(um_from_bohr(d[c]));
    series.normal_um.push_back(um_from_bohr(d.dot(sheet_normal(sh))));
    // The fluid's mean force on the sheet over the interval: -sum_l J_l / dt_LB, every
    // CGP of the sheet (clamped ones included), lattice force F_LB -> N.
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    if (r != nullptr)
      f = -r->impulse_lb.middleCols(first_cgp(s_.config, k), sh.num_cgps()).rowwise().sum() *
          units_.force_lb_N();
    for (int c = 0; c < 3; ++c) series.fluid_force_N.push_back(f[c]);
    // Eq. 33 with rho_f = rho_air and A = W H, the area the sheet's CGPs carry.
    const double area_m2 = static_cast<double>(sh.num_cgps()) * sh.cell_area_bohr2() *
                           PhysicalConstants::bohr_m * PhysicalConstants::bohr_m;
    const double u_b = units_.velocity_m_s(bulk_velocity_lb);
    const double q = 0.5 * units_.air_density_kg_m3() * u_b * u_b * area_m2;
    for (int c = 0; c < 3; ++c) series.force_coefficients.push_back(q > 0.0 ? f[c] / q : 0.0);
    // The leading edge: the side column further upstream (smaller x); CGPs on the first
    // free row, the middle row and the top row.
    const Eigen::Matrix3Xd ref = flat_sheet_positions(sh);
    const int i_lead = ref(0, sh.index(0, 0)) <= ref(0, sh.index(sh.nx_cg - 1, 0)) ? 0 : sh.nx_cg - 1;
    const Eigen::Index first = first_cgp(s_.config, k);
    for (const int j : {std::min(sh.clamped_rows, sh.ny_cg - 1), sh.ny_cg / 2, sh.ny_cg - 1})
      series.edge_strain.push_back(o.area_strain.size() > 0 ? o.area_strain[first + sh.index(i_lead, j)] : 0.0);
  }
  series.bulk_velocity_m_s.push_back(units_.velocity_m_s(bulk_velocity_lb));
  series.kinetic_J.push_back(ek);
  series.elastic_J.push_back(ee);
  series.total_J.push_back(ek + ee);
}

double SolidRun::sheet_energy_J() const {
  const SolidObservables o = model_->observables();
  return joule_from_hartree(o.kinetic_energy_au + o.elastic_energy_au);
}

// ---- diagnoses ----

Ending SolidRun::overspeed(std::int64_t step, const IntervalResult::Overspeed& o) const {
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

std::string SolidRun::non_finite(const IntervalResult& r) const {
  std::string bad = non_finite_state();
  if (bad.empty() && !(r.position_lb.allFinite() && r.impulse_lb.allFinite()))
    bad = "a non-finite position or impulse for the fluid";
  return bad;
}

std::string SolidRun::non_finite_state() const {
  const Eigen::Matrix3Xd& x = model_->positions();
  const Eigen::Matrix3Xd& v = model_->velocities();
  if (x.allFinite() && v.allFinite()) return "";
  for (Eigen::Index l = 0; l < x.cols(); ++l) {
    const bool bad_x = !x.col(l).allFinite(), bad_v = !v.col(l).allFinite();
    if (bad_x || bad_v) return describe_cgp(s_.config, l) + ": " + (bad_x ? "position" : "velocity") + " not finite";
  }
  return "";
}

void SolidRun::print_margins(std::ostream& out) const {
  if (energy_watch_ && coupler_)
    solid_log().info(out) << "watchdog margins: CGP speed max " << fmt("%.3g", coupler_->max_speed_lb())
        << " c after a substep (limit " << fmt("%g", s_.watchdog.max_cgp_speed)
        << "), unexplained energy max " << fmt("%.3g", energy_watch_->max_ratio())
        << " of the energy scale (limit " << fmt("%g", s_.watchdog.energy_growth) << ")";
  solid_log().info(out) << "peak memory " << fmt("%.1f", protocol::peak_rss_mib()) << " MiB (largest resident set)";
}

}  // namespace cosim::solid
