#include "fluid/config/scene_config.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fluid/lattice/d3q19.hpp"
#include "fluid/domain/decomposition.hpp"
#include "fluid/lattice/grid_layout.hpp"
#include "protocol/config/reaction_section.hpp"
#include "protocol/config/scene_reader.hpp"
#include "protocol/config/shared_sections.hpp"
#include "protocol/lcm_url.hpp"
#include "common/run/memory_budget.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"

// Why the limits of SceneLimits are what they are:
//  - tau > 1/2: nu = (tau - 1/2)/3 (Eq. 13) must be positive; at or below 1/2 BGK has zero
//    or negative viscosity and blows up.
//  - tau <= 2 (nu <= 1/2): a bound on accuracy, not stability. The slip of half-way
//    bounce-back walls grows quadratically with tau (He et al. 1997, he1997) and the
//    relaxation is no longer fast compared with streaming (Knudsen number ~ tau / L), so
//    the Navier-Stokes limit degrades (Krueger et al. 2017, kruger2017, advise tau of order
//    1). A scene that asks for more viscosity wants a finer grid or a slower flow.
//  - mach_limit in (0, 0.5], default 0.3: the equilibrium (Eq. 11) is the Maxwellian
//    expanded to second order in Ma = |u| / c_s = |u| sqrt(3); the density varies by
//    ~Ma^2 and the truncated terms are O(Ma^3). Ma 0.3 is the customary limit of
//    weakly-compressible LBM (~9 % density variation); above 0.5 the model is neither
//    incompressible nor a valid compressible one and BGK at the paper's tau is close to
//    its stability edge, so no scene may ask for it.
//  - 8 <= n <= 65536 cells per axis: below 8 the boundary treatments of opposite faces
//    (bounce-back, the Blasius layer, the outflow copy) meet in the same cells; above
//    65536 the padded index arithmetic leaves int. The population memory is checked
//    against 75 % of this machine's memory as well (the rest is the solid server's and the
//    system's), so a typo fails here and not in malloc.
//  - threads <= 1024: more than any machine this runs on; a larger number is a typo.
//  - dx_um and reference_length_um in [1e-9, 1e6] micrometres (a femtometre to a metre):
//    far beyond any scene either way, and the conversions (cells, dt = dx / c, Re) stay
//    positive finite numbers (1e308 um gives an infinite domain, 1e-320 um a zero dt).
//  - a tau derived from reynolds must be > 1/2 like a given one: a huge Re (or a tiny
//    L / dx) rounds nu = U L / Re to 0 and tau to exactly 1/2.

namespace cosim::fluid {

namespace {

using protocol::config::SceneReader;
using protocol::config::SectionSchema;
using protocol::config::Table;
using protocol::config::format_double;

constexpr const char* kKindList = "\"periodic\", \"wall\", \"free_slip\", \"inlet\", \"outflow\"";

/// The fluid's sections and keys; [scene], [grid], [output] are shared with the solid (their
/// keys and who reads them: protocol/config/scene_sections.cpp), and the solid's sections of
/// a coupled scene are left to it.
const std::vector<SectionSchema>& schema() {
  static const std::vector<SectionSchema> s = {
      {"scene"},
      {"grid"},
      {"fluid"},  // shared: its medium keys are the solid's too (protocol/config/scene_sections.cpp)
      {"inlet", {"u_max", "u_max_m_s", "profile", "boundary_layer_um", "density", "ramp_us"}},
      {"held_body",
       {"center_um", "radius_um", "bar_tip_x_um", "bar_thickness_um", "retraction", "spacing", "iterations",
        "record_every"}},
      {"boundaries", {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"}},
      {"wall_velocity", {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"}},
      {"body_force", {"x", "y", "z"}},
      {"run", {"steps", "duration_us", "monitor_every", "mach_limit", "threads", "initial", "precision", "blocks", "propagation"}},
      {"output"},
      {"coupling", protocol::config::coupling_keys()},
      // The stability watchdog (common/watchdog/watchdog.hpp): the same table in both servers.
      {"watchdog", protocol::config::watchdog_key_names()},
  };
  return s;
}

std::string format_fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

double mach(double u) { return std::abs(u) * std::sqrt(3.0); }

std::string mach_text(double u, double limit) {
  return "Mach " + format_fixed(mach(u), 3) + " (= |u| sqrt(3)) exceeds run.mach_limit = " +
         format_double(limit) + "; the largest allowed speed is " +
         format_fixed(limit / std::sqrt(3.0), 4) + " (lattice units, U/c)";
}

/// "[name]: missing; what", with no line.
[[noreturn]] void missing_section(const SceneReader& r, const char* name, const std::string& what) {
  r.fail(0, std::string("[") + name + "]: missing; " + what);
}

void load_grid(const SceneReader& r, FluidScene& s) {
  const std::string range = "an integer number of cells from " +
                            std::to_string(SceneLimits::grid_min) + " to " +
                            std::to_string(SceneLimits::grid_max);
  const Table grid = r.section("grid");
  if (!grid.present()) missing_section(r, "grid", "the section with nx, ny, nz is required");
  int* dims[3] = {&s.params.shape.nx, &s.params.shape.ny, &s.params.shape.nz};
  const char* keys[3] = {"nx", "ny", "nz"};
  for (int a = 0; a < 3; ++a) {
    const auto n = grid.integer(keys[a]);
    if (!n) grid.missing(keys[a], range);
    // nz below 8: a span-periodic slab (checked against the z faces in load_boundaries).
    const bool thin_span = a == 2 && *n >= 1 && *n < SceneLimits::grid_min;
    if (!thin_span && (*n < SceneLimits::grid_min || *n > SceneLimits::grid_max))
      grid.bad(keys[a], "must be " + range +
                            (*n < SceneLimits::grid_min ? " (below 8 the boundary layers of "
                                                          "opposite faces overlap)"
                                                        : ""));
    *dims[a] = int(*n);
  }
  if (const auto dx = grid.number("dx_um")) {
    if (!(*dx > 0.0)) grid.bad("dx_um", "must be > 0 (micrometres per cell)");
    if (!(*dx >= Table::length_min_um && *dx <= Table::length_max_um))
      grid.bad("dx_um", "must be in [1e-9, 1e6] micrometres per cell");
    s.dx_um = *dx;
  }
}

/// The population grids of the grid and run.precision, with the copy of one that a restart
/// reads, must fit in the fluid's share of this machine's memory (common/run/memory_budget.hpp),
/// checked before anything is allocated.
void check_memory(const SceneReader& r, const FluidScene& s) {
  const std::size_t grids = population_bytes(s.params.shape, s.params.precision, s.params.propagation);
  const double need = 1.5 * double(grids);
  const std::string beyond =
      protocol::beyond_share(need, protocol::kFluidMemoryShare, "the rest is left to the solid server and the system");
  if (!beyond.empty())
    r.fail(r.section_line("grid"),
           "grid = " + std::to_string(s.params.shape.nx) + " x " +
               std::to_string(s.params.shape.ny) + " x " + std::to_string(s.params.shape.nz) +
               (s.params.propagation == Propagation::InPlace ? ": the population grid (in-place propagation) needs "
                                                             : ": the two population grids (two-grid propagation) need ") +
               protocol::human_bytes(double(grids)) + " (" +
               protocol::human_bytes(need) + " with the copy of one that a restart reads), " + beyond +
               "; reduce nx, ny, nz");
}

/// The scene's lattice units (dx from [grid], dt = dx / c): for the keys given in physical units.
protocol::UnitConverter lattice_units(const FluidScene& s) { return protocol::UnitConverter(unit_inputs(s)); }

/// [fluid] density_kg_m3 and sound_speed_m_s (protocol::config::read_medium, shared with the
/// solid): before [run] and [inlet], whose physical keys convert with them.
void load_medium(const SceneReader& r, FluidScene& s) {
  s.medium = protocol::config::read_medium(r);
  if (!s.medium) return;
  const FluidMedium& m = *s.medium;
  const protocol::UnitConverter u = lattice_units(s);
  s.unit_conversions.push_back("fluid.sound_speed_m_s = " + protocol::fmt("%.6g", m.sound_speed_m_s) +
                               " m/s -> dt = dx / (sqrt(3) c_s) = " + protocol::fmt("%.6g", u.dt_lb_s()) +
                               " s; fluid.density_kg_m3 = " + protocol::fmt("%.6g", m.density_kg_m3));
}

void load_run(const SceneReader& r, FluidScene& s) {
  const Table run = r.section("run");
  if (!run.present()) missing_section(r, "run", "the section with steps is required");
  if (const auto m = run.number("mach_limit")) {
    if (!(*m > 0.0 && *m <= SceneLimits::mach_limit_max))
      run.bad("mach_limit",
              "must be in (0, 0.5]; 0.3 is the usual weakly-compressible limit, above 0.5 the "
              "second-order equilibrium is no model of the flow");
    s.mach_limit = *m;
  }
  if (run.has("duration_us")) {  // the run's length in physical time, converted to LB steps
    if (run.has("steps"))
      r.fail(run.line_of("duration_us"), "run.steps = " + run.show("steps") + " and run.duration_us = " +
                                             run.show("duration_us") +
                                             ": give one of them: steps (LB steps) or duration_us (microseconds)");
    const double us = *run.positive("duration_us", "the simulated time in microseconds");
    const double dt_us = lattice_units(s).dt_lb_s() * 1e6;
    const double n = std::round(us / dt_us);
    if (!(n >= 1.0 && n <= SceneLimits::steps_max))
      run.bad("duration_us", "is " + protocol::fmt("%.4g", us / dt_us) + " LB steps of dt = dx / c = " +
                                 protocol::fmt("%.5g", dt_us) + " us; allowed: 1 to 1e12 LB steps");
    s.steps = static_cast<std::int64_t>(n);
    s.unit_conversions.push_back("run.duration_us = " + protocol::fmt("%.6g", us) + " us -> run.steps = " +
                                 std::to_string(s.steps) + " LB steps of dt = " + protocol::fmt("%.5g", dt_us) +
                                 " us (" + protocol::fmt("%.6g", double(s.steps) * dt_us) + " us simulated)");
  } else {
    const auto steps = run.integer("steps");
    if (!steps) run.missing("steps", "the number of LB steps, an integer >= 1 (or run.duration_us, in microseconds)");
    if (*steps < 1) run.bad("steps", "must be an integer >= 1");
    s.steps = *steps;
  }
  if (const auto m = run.integer("monitor_every")) {
    if (*m < 1) run.bad("monitor_every", "must be >= 1");
    s.monitor_every = *m;
  }
  if (const auto t = run.integer("threads")) {
    if (*t < 0 || *t > SceneLimits::threads_max)
      run.bad("threads", "must be in [0, 1024]; 0 leaves the choice to OpenMP (OMP_NUM_THREADS)");
    s.threads = int(*t);
  }
  // The blocks of an MPI run (fluid/domain/decomposition.hpp): blocks along y and z, [1, py, pz].
  if (const auto b = run.numbers("blocks", 3, 3, "three block counts along x, y and z, e.g. [1, 2, 2]")) {
    for (const double n : *b)
      if (!(n >= 1.0 && n <= 4096.0 && n == std::floor(n)))
        run.bad("blocks", "each count must be an integer in [1, 4096]");
    const std::array<int, 3> blocks = {int((*b)[0]), int((*b)[1]), int((*b)[2])};
    if (const std::string why = blocks_problem(s.params.shape, blocks); !why.empty()) run.bad("blocks", why);
    s.blocks = blocks;
  }
  // How the populations are stored and computed (Precision; in the order of its names).
  if (const auto p = run.choice("precision", {"double", "mixed", "single", "half"}))
    s.params.precision = kPrecisionModes[*p];
  // How a step moves the populations (FluidParams::propagation): the same bits either way
  // (in a coupled scene too: the schemes run the whole step after the solid's message,
  // FluidDomain::bulk_before_impulses), in one process or over MPI ranks.
  if (const auto p = run.choice("propagation", {"two-grid", "in-place"}))
    s.params.propagation = *p == 0 ? Propagation::TwoGrid : Propagation::InPlace;
}

void load_boundaries(const SceneReader& r, FluidScene& s) {
  static const std::vector<const char*> kinds = {"periodic", "wall", "free_slip", "inlet",
                                                 "outflow"};
  static const FaceKind kind_of[] = {FaceKind::Periodic, FaceKind::Wall, FaceKind::FreeSlip,
                                     FaceKind::Inlet, FaceKind::Outflow};
  const Table b = r.section("boundaries");
  if (!b.present())
    missing_section(r, "boundaries",
                    std::string("the section with x_min, x_max, y_min, y_max, z_min, z_max, "
                                "each one of ") + kKindList);
  for (int f = 0; f < kFaces; ++f) {
    const auto k = b.choice(face_name(f), kinds);
    if (!k) b.missing(face_name(f), std::string("all six faces are required, each one of ") + kKindList);
    s.params.faces[f].kind = kind_of[*k];
  }
  if (s.params.shape.nz < SceneLimits::grid_min &&
      (s.params.faces[ZMin].kind != FaceKind::Periodic || s.params.faces[ZMax].kind != FaceKind::Periodic))
    r.fail(r.section("grid").line_of("nz"),
           "grid.nz = " + std::to_string(s.params.shape.nz) +
               ": below 8 cells only between periodic z faces (a span-periodic slab: no boundary layers to "
               "overlap); boundaries.z_min = \"" + kind_name(s.params.faces[ZMin].kind) + "\"");
  for (int a = 0; a < 3; ++a) {
    const FaceSpec& lo = s.params.faces[2 * a];
    const FaceSpec& hi = s.params.faces[2 * a + 1];
    if ((lo.kind == FaceKind::Periodic) != (hi.kind == FaceKind::Periodic))
      r.fail(b.line_of(face_name(2 * a)),
             std::string("boundaries.") + face_name(2 * a) + " = \"" + kind_name(lo.kind) +
                 "\", boundaries." + face_name(2 * a + 1) + " = \"" + kind_name(hi.kind) +
                 "\": a periodic face needs a periodic partner; make both periodic or neither");
  }
}

void load_wall_velocity(const SceneReader& r, FluidScene& s) {
  const Table w = r.section("wall_velocity");
  for (int f = 0; f < kFaces; ++f) {
    const char* face = face_name(f);
    if (!w.has(face)) continue;
    if (s.params.faces[f].kind != FaceKind::Wall)
      w.bad(face, std::string("only a wall can move, and boundaries.") + face + " is \"" +
                      kind_name(s.params.faces[f].kind) + "\"");
    const std::vector<double> v = *w.numbers(
        face, 3, 3, "must be an array of three numbers [ux, uy, uz] in lattice units (U/c)");
    const std::array<double, 3> u = {v[0], v[1], v[2]};
    if (u[face_axis(f)] != 0.0)
      w.bad(face, std::string("must be tangential: the component along the normal of ") + face +
                      " must be 0");
    const double speed = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (mach(speed) > s.mach_limit) w.bad(face, mach_text(speed, s.mach_limit));
    s.params.faces[f].wall_velocity = u;
  }
}

void load_inlet(const SceneReader& r, FluidScene& s) {
  const bool has_inlet = std::any_of(s.params.faces.begin(), s.params.faces.end(),
                                     [](const FaceSpec& f) { return f.kind == FaceKind::Inlet; });
  const Table in = r.section("inlet");
  if (!has_inlet) {
    if (in.present())
      in.fail("[inlet]: given, but no face of [boundaries] is \"inlet\"; remove the section or "
              "make a face an inlet");
    return;
  }
  if (!in.present())
    missing_section(r, "inlet", "a face is \"inlet\", so [inlet] with u_max is required");
  std::optional<double> u;
  if (in.has("u_max_m_s")) {  // the inlet speed in m/s, converted to lattice units U/c
    if (in.has("u_max"))
      r.fail(in.line_of("u_max_m_s"), "inlet.u_max = " + in.show("u_max") + " and inlet.u_max_m_s = " +
                                          in.show("u_max_m_s") +
                                          ": give one of them: u_max (lattice units U/c) or u_max_m_s (m/s)");
    const double m_s = *in.number("u_max_m_s");
    if (m_s < 0.0) in.bad("u_max_m_s", "must be >= 0 (the speed into the domain, m/s)");
    const double c = lattice_units(s).lattice_speed_m_s();
    u = m_s / c;
    if (mach(*u) > s.mach_limit) in.bad("u_max_m_s", mach_text(*u, s.mach_limit));
    s.unit_conversions.push_back("inlet.u_max_m_s = " + protocol::fmt("%.6g", m_s) + " m/s -> inlet.u_max = " +
                                 protocol::fmt("%.6g", *u) + " (U/c, c = dx / dt = " + protocol::fmt("%.6g", c) +
                                 " m/s)");
  } else {
    u = in.number("u_max");
    if (!u) in.missing("u_max", "the inlet speed in lattice units (U_max/c), >= 0 (or inlet.u_max_m_s, in m/s)");
    if (*u < 0.0) in.bad("u_max", "must be >= 0 (the speed into the domain, lattice units U/c)");
    if (mach(*u) > s.mach_limit) in.bad("u_max", mach_text(*u, s.mach_limit));
  }

  const auto profile = in.choice("profile", {"uniform", "blasius", "parabolic"});
  const bool blasius = profile && *profile == 1;
  const bool parabolic = profile && *profile == 2;
  if (parabolic) {
    for (int f = XMin; f <= XMax; ++f)
      if (s.params.faces[f].kind != FaceKind::Inlet && s.params.faces[f].kind != FaceKind::Outflow)
        in.bad("profile", std::string("\"parabolic\" spans the channel between the y walls from an x face; boundaries.") +
                              face_name(f) + " is \"" + kind_name(s.params.faces[f].kind) +
                              "\" (allowed on x: \"inlet\", \"outflow\")");
    for (int f = YMin; f <= YMax; ++f)
      if (s.params.faces[f].kind != FaceKind::Wall)
        in.bad("profile", std::string("\"parabolic\" needs walls on y_min and y_max (the profile vanishes on both); "
                                      "boundaries.") +
                              face_name(f) + " is \"" + kind_name(s.params.faces[f].kind) + "\"");
  }
  double layer_cells = 0.0;
  if (blasius) {
    if (s.params.faces[YMin].kind != FaceKind::Wall)
      in.bad("profile", std::string("needs boundaries.y_min = \"wall\" (the Blasius layer grows "
                                    "from the y_min plate), not \"") +
                            kind_name(s.params.faces[YMin].kind) + "\"");
    for (int f = YMin; f <= YMax; ++f)
      if (s.params.faces[f].kind == FaceKind::Inlet)
        in.bad("profile", std::string("is not possible with boundaries.") + face_name(f) +
                              " = \"inlet\": the Blasius layer grows along the y_min plate, so "
                              "the inlet must be an x or z face");
    const auto layer = in.number("boundary_layer_um");
    const double height_um = s.params.shape.ny * s.dx_um;
    const std::string range = "the layer thickness in micrometres, in (0, ny dx_um = " +
                              format_double(height_um) + "]";
    if (!layer) in.missing("boundary_layer_um", "profile = \"blasius\" needs " + range);
    if (!(*layer > 0.0 && *layer <= height_um)) in.bad("boundary_layer_um", "must be " + range);
    layer_cells = *layer / s.dx_um;
  } else if (in.has("boundary_layer_um")) {
    in.bad("boundary_layer_um",
           "only allowed with inlet.profile = \"blasius\" (the uniform profile has no layer)");
  }
  double density = 1.0;
  if (const auto rho = in.number("density")) {
    if (!(*rho > 0.0)) in.bad("density", "must be > 0 (lattice units, rho_0 = 1)");
    density = *rho;
  }
  if (in.has("ramp_us")) {  // Turek and Hron's start-up, (1 - cos(pi t / T)) / 2 for t < T
    const double us = *in.number("ramp_us");
    if (!(us >= 0.0)) in.bad("ramp_us", "must be >= 0 (the inlet's start-up time in microseconds; 0: none)");
    const double dt_us = lattice_units(s).dt_lb_s() * 1e6;
    s.inlet_ramp_steps = us / dt_us;
    s.unit_conversions.push_back("inlet.ramp_us = " + protocol::fmt("%.6g", us) + " us -> " +
                                 protocol::fmt("%.6g", s.inlet_ramp_steps) + " LB steps");
  }
  for (FaceSpec& f : s.params.faces) {
    if (f.kind != FaceKind::Inlet) continue;
    f.inlet_speed = *u;
    f.profile = blasius ? InletProfile::Blasius : parabolic ? InletProfile::Parabolic : InletProfile::Uniform;
    f.boundary_layer = layer_cells;
    f.channel_height = parabolic ? double(s.params.shape.ny) : 0.0;
    f.inlet_density = density;
  }
}

void load_body_force(const SceneReader& r, FluidScene& s) {
  const Table b = r.section("body_force");
  const char* keys[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    if (const auto f = b.number(keys[a])) s.params.body_force[a] = *f;
}

void load_fluid(const SceneReader& r, FluidScene& s) {
  const Table fl = r.section("fluid");
  if (!fl.present())
    missing_section(r, "fluid", "the section with tau, or reynolds and reference_length_um, is required");
  const auto tau = fl.number("tau");
  const auto re = fl.number("reynolds");
  const auto length = fl.number("reference_length_um");
  const double speed = reference_speed(s.params);
  s.reference_speed = speed;
  if (length) {
    if (!(*length > 0.0)) fl.bad("reference_length_um", "must be > 0 (micrometres)");
    if (!(*length >= Table::length_min_um && *length <= Table::length_max_um))
      fl.bad("reference_length_um", "must be in [1e-9, 1e6] micrometres");
    s.reference_length_um = *length;
  }
  if (fl.has("viscosity_m2_s")) {  // the physical kinematic viscosity: tau from nu dt / dx^2 (Eq. 13)
    if (tau || re) fl.bad("viscosity_m2_s", "give one of fluid.tau, fluid.reynolds and fluid.viscosity_m2_s");
    const double nu = *fl.positive("viscosity_m2_s", "the kinematic viscosity, m^2/s");
    const protocol::UnitConverter units = lattice_units(s);
    const double nu_lb = nu * units.dt_lb_s() / (units.dx_m() * units.dx_m());
    const double derived = 0.5 + 3.0 * nu_lb;  // Eq. 13
    if (!(derived > SceneLimits::tau_min) || derived > SceneLimits::tau_max)
      fl.bad("viscosity_m2_s", "gives tau = " + format_double(derived) + " (nu dt / dx^2 = " + format_double(nu_lb) +
                                   "); tau must be in (0.5, 2]: change grid.dx_um or fluid.sound_speed_m_s");
    s.params.tau = derived;
    s.unit_conversions.push_back("fluid.viscosity_m2_s = " + protocol::fmt("%.6g", nu) + " m^2/s -> tau = " +
                                 protocol::fmt("%.6g", derived) + " (nu dt / dx^2 = " + protocol::fmt("%.6g", nu_lb) +
                                 ")");
  } else {
    const std::string tau_range =
        "must be in (0.5, 2]: at or below 1/2 BGK is unstable (nu = (tau - 1/2)/3 <= 0), above 2 "
        "the bounce-back wall slip and the Knudsen number spoil the Navier-Stokes limit";
    if (tau && re)
      r.fail(fl.line_of("reynolds"), "fluid.tau = " + fl.show("tau") + ", fluid.reynolds = " +
                                         fl.show("reynolds") +
                                         ": give exactly one of the two (reynolds derives tau "
                                         "from nu = U L / Re)");
    if (!tau && !re)
      fl.missing("tau", "give tau (> 0.5), or reynolds with reference_length_um (tau from nu = U L / Re)");
    if (tau) {
      if (!(*tau > SceneLimits::tau_min))
        fl.bad("tau", "must be > 0.5 (BGK is unstable at or below 1/2: nu = (tau - 1/2)/3 <= 0)");
      if (*tau > SceneLimits::tau_max) fl.bad("tau", tau_range);
      s.params.tau = *tau;
    } else {
      if (!(*re > 0.0)) fl.bad("reynolds", "must be > 0");
      if (!length)
        fl.bad("reynolds",
               "needs fluid.reference_length_um, the length L of Re = U L / nu (micrometres)");
      if (!(speed > 0.0))
        fl.bad("reynolds",
               "needs a reference speed U: an inlet with u_max > 0 or a moving wall; give tau "
               "instead");
      const double length_cells = *length / s.dx_um;
      const double nu = speed * length_cells / *re;
      const double derived = 0.5 + 3.0 * nu;  // Eq. 13
      if (!(derived > SceneLimits::tau_min))
        fl.bad("reynolds",
               "gives tau = " + format_double(derived) + " (nu = U L / Re = " + format_double(nu) +
                   " in lattice units): BGK is unstable at or below 1/2; lower Re, or use a finer "
                   "grid or a longer reference length");
      if (derived > SceneLimits::tau_max)
        fl.bad("reynolds",
               "gives tau = " + format_fixed(derived, 4) + " (nu = U L / Re = " +
                   format_fixed(nu, 4) + " in lattice units), above the limit 2 (bounce-back slip, "
                   "Knudsen number); raise Re or U, or use a coarser grid");
      s.params.tau = derived;
    }
  }
  if (length && speed > 0.0) {
    const double nu = (s.params.tau - 0.5) / 3.0;
    s.reynolds = speed * (s.reference_length_um / s.dx_um) / nu;
  }
}

/// [held_body]: the body in micrometres from the domain's corner (the inlet plane x = 0 and
/// the y_min wall y = 0 are the half-way planes of the lattice, so the cell centre i lies at
/// (i + 1/2) dx), converted to cells.
void load_held_body(const SceneReader& r, FluidScene& s) {
  const Table h = r.section("held_body");
  if (!h.present()) return;
  if (s.params.faces[ZMin].kind != FaceKind::Periodic)
    h.fail("[held_body]: needs boundaries.z_min and z_max = \"periodic\": the body spans the periodic z axis");
  const double dx = s.dx_um;
  const auto to_cells = [&](double um) { return um / dx - 0.5; };
  HeldBodySettings b;
  const auto c = h.numbers("center_um", 2, 2, "must be [x, y], the cylinder's axis in micrometres");
  if (!c) h.missing("center_um", "the cylinder's axis [x, y] in micrometres");
  const double Lx = s.params.shape.nx * dx, Ly = s.params.shape.ny * dx;
  if (!((*c)[0] > 0.0 && (*c)[0] < Lx && (*c)[1] > 0.0 && (*c)[1] < Ly))
    h.bad("center_um", "must lie inside the domain, (0, " + format_double(Lx) + ") x (0, " + format_double(Ly) + ") um");
  b.shape.x_c = to_cells((*c)[0]);
  b.shape.y_c = to_cells((*c)[1]);
  const auto radius = h.length_um("radius_um", "the cylinder's radius");
  if (!radius) h.missing("radius_um", "the cylinder's radius in micrometres");
  b.shape.radius = *radius / dx;
  if (b.shape.radius < 2.0)
    h.bad("radius_um", "is " + format_double(b.shape.radius) + " cells; at least 2 (the kernel of Eq. 23 is 4 cells wide)");
  if (h.has("bar_tip_x_um") != h.has("bar_thickness_um"))
    h.bad(h.has("bar_tip_x_um") ? "bar_tip_x_um" : "bar_thickness_um",
          "needs held_body." + std::string(h.has("bar_tip_x_um") ? "bar_thickness_um" : "bar_tip_x_um") +
              " too (the bar: from the cylinder's axis to x = bar_tip_x_um, centred on its y)");
  if (h.has("bar_tip_x_um")) {
    const double tip = *h.number("bar_tip_x_um");
    if (!(tip > (*c)[0] + *radius && tip < Lx))
      h.bad("bar_tip_x_um", "must lie beyond the cylinder and inside the domain, (" + format_double((*c)[0] + *radius) +
                                ", " + format_double(Lx) + ") um");
    const double t = *h.length_um("bar_thickness_um", "the bar's thickness");
    if (!(t < 2.0 * *radius)) h.bad("bar_thickness_um", "must be below the cylinder's diameter");
    b.shape.bar_tip_x = to_cells(tip);
    b.shape.bar_thickness = t / dx;
  }
  if (const auto v = h.number("retraction")) {
    if (!(*v >= 0.0 && *v <= 1.0))
      h.bad("retraction", "must be in [0, 1] cells (the markers sit that far inside the surface; Breugem 2012: 0.3)");
    b.shape.retraction = *v;
  }
  if (b.shape.bar_thickness > 0.0 && b.shape.bar_thickness <= 2.0 * b.shape.retraction)
    h.bad("bar_thickness_um", "is " + format_double(b.shape.bar_thickness) +
                                  " cells, not more than twice held_body.retraction: no bar would be left");
  if (const auto v = h.number("spacing")) {
    if (!(*v >= 0.25 && *v <= 2.0)) h.bad("spacing", "must be in [0.25, 2] cells (the markers' spacing)");
    b.shape.spacing = *v;
  }
  if (const auto v = h.integer_in("iterations", 1, 50, " (multi-direct forcing passes per step)")) b.shape.iterations = *v;
  if (const auto v = h.integer("record_every")) {
    if (*v < 1) h.bad("record_every", "must be an integer >= 1 (steps per row of held_body.csv)");
    b.record_every = *v;
  }
  s.held_body = b;
}

void load_output_and_initial(const SceneReader& r, FluidScene& s) {
  s.output_dir = protocol::config::read_output_directory(r, s.name);
  const Table out = r.section("output");
  if (const auto f = out.integer("fields_every")) {
    if (*f < 0) out.bad("fields_every", "must be >= 0 (0: no field output)");
    s.fields_every = *f;
  }
  if (const auto f = out.integer("planes_every")) {
    if (*f < 0) out.bad("planes_every", "must be >= 0 (0: no plane snapshots)");
    s.planes_every = *f;
  }
  const char* heights = "must be an array of numbers in (0, 1): heights of the y planes as "
                        "fractions of the channel height (the paper's y = L/2: 0.5)";
  if (const auto ys = out.numbers("planes_y", 1, 16, heights)) {
    for (const double v : *ys)
      if (!(v > 0.0 && v < 1.0)) out.bad("planes_y", heights);
    s.planes_y = *ys;
  }
  if (s.planes_every > 0 && s.planes_y.empty())
    out.missing("planes_y", "planes_every > 0 needs the planes, e.g. planes_y = [0.5, 0.3333]");
  const bool has_inlet = std::any_of(s.params.faces.begin(), s.params.faces.end(),
                                     [](const FaceSpec& f) { return f.kind == FaceKind::Inlet; });
  s.initial = has_inlet ? InitialFlow::Inlet : InitialFlow::Rest;
  const Table run = r.section("run");
  if (const auto i = run.choice("initial", {"rest", "inlet"})) {
    if (*i == 1 && !has_inlet)
      run.bad("initial", "needs a face of [boundaries] that is \"inlet\"; use \"rest\"");
    s.initial = *i == 1 ? InitialFlow::Inlet : InitialFlow::Rest;
  }
}

FluidScene read_scene(const std::string& path) {
  const SceneReader r(path, protocol::config::Process::Fluid);
  r.check_sections(schema());

  FluidScene s;
  s.path = path;
  protocol::config::read_scene_header(r, s.name, s.description);

  load_grid(r, s);
  load_medium(r, s);
  load_run(r, s);
  check_memory(r, s);
  load_boundaries(r, s);
  load_wall_velocity(r, s);
  load_inlet(r, s);
  load_body_force(r, s);
  load_fluid(r, s);
  load_held_body(r, s);
  load_output_and_initial(r, s);
  if (r.coupled()) {
    s.coupling = protocol::config::read_coupling(r);
    s.reaction_law = protocol::config::read_reaction_law(r, *s.coupling);
  }
  s.watchdog = protocol::config::read_watchdog(r);

  // What the solver itself would refuse; the checks above should have caught all of it.
  const std::string err = BoundaryConditions::check(s.params.faces);
  if (!err.empty()) r.fail(r.section_line("boundaries"), "boundaries: " + err);
  return s;
}

}  // namespace

protocol::UnitInputs unit_inputs(const FluidScene& s) {
  return protocol::scene_unit_inputs(s.dx_um * 1e-6, s.medium,
                                     s.coupling ? s.coupling->time_ratio : protocol::UnitInputs{}.time_ratio);
}

std::size_t population_bytes(const GridShape& shape, Precision precision, Propagation propagation) {
  const std::size_t grids = propagation == Propagation::InPlace ? 1 : 2;
  return grids * std::size_t(D3Q19::Q) * layout_of(shape, precision).stride() *
         bytes_per_value(precision);
}

double reference_speed(const FluidParams& params) {
  double wall = 0.0;
  for (const FaceSpec& f : params.faces) {
    if (f.kind == FaceKind::Inlet) return f.inlet_speed;
    if (f.kind == FaceKind::Wall) {
      const auto& u = f.wall_velocity;
      wall = std::max(wall, std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]));
    }
  }
  return wall;
}

FluidScene load_scene(const std::string& path) {
  return protocol::config::rethrow_as<SceneError>([&] { return read_scene(path); });
}

void apply_overrides(FluidScene& s, const SceneOverrides& o) {
  const auto fail = [](const std::string& opt, const std::string& value, const std::string& msg) {
    throw SceneError(protocol::config::command_line_problem(opt, value, msg));
  };
  if (o.steps) {
    if (*o.steps < 1) fail("--steps", std::to_string(*o.steps), "must be an integer >= 1");
    s.steps = *o.steps;
  }
  if (o.monitor_every) {
    if (*o.monitor_every < 1)
      fail("--monitor-every", std::to_string(*o.monitor_every), "must be an integer >= 1");
    s.monitor_every = *o.monitor_every;
  }
  if (o.fields_every) {
    if (*o.fields_every < 0)
      fail("--fields-every", std::to_string(*o.fields_every),
           "must be an integer >= 0 (0: no field output)");
    s.fields_every = *o.fields_every;
  }
  if (o.threads) {
    if (*o.threads < 0 || *o.threads > SceneLimits::threads_max)
      fail("--threads", std::to_string(*o.threads),
           "must be in [0, 1024]; 0 leaves the choice to OpenMP");
    s.threads = *o.threads;
  }
  if (o.output_dir) {
    if (o.output_dir->empty()) fail("--output", "\"\"", "must not be empty");
    s.output_dir = *o.output_dir;
  }
  if (o.time_ratio) {
    if (!s.coupling)
      fail("--time-ratio", std::to_string(*o.time_ratio),
           "only for a coupled scene (one with a [coupling] section)");
    if (const auto why = protocol::config::time_ratio_problem(*o.time_ratio))
      fail("--time-ratio", std::to_string(*o.time_ratio), *why);
    s.coupling->time_ratio = int(*o.time_ratio);
  }
  if (o.lcm_url) {
    // The rule of [coupling] lcm_url; with a fluid-only scene the URL is unused.
    if (const auto why = protocol::lcm_url_problem(*o.lcm_url))
      fail("--lcm-url", protocol::config::quoted(*o.lcm_url), *why);
    if (s.coupling) s.coupling->lcm_url = *o.lcm_url;
  }
}

void initialize_flow(FluidSolver& solver, const FluidScene& s) {
  if (s.initial == InitialFlow::Rest) {
    solver.initialize_uniform(1.0, {0.0, 0.0, 0.0});
    return;
  }
  int inlet = 0;
  while (s.params.faces[inlet].kind != FaceKind::Inlet) ++inlet;  // load_scene ensures one
  const FaceSpec& spec = s.params.faces[inlet];
  const int axis = face_axis(inlet);
  const double inward = face_side(inlet) == 0 ? 1.0 : -1.0;
  const int y0 = solver.y_origin();  // a block's first row (fluid/mpi)
  solver.initialize([&](int, int y, int) {
    double u[3] = {0.0, 0.0, 0.0};
    u[axis] = inward * inlet_profile(spec, y + y0);
    return CellState{1.0, u[0], u[1], u[2]};
  });
}


}  // namespace cosim::fluid
