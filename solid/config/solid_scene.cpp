#include "solid/config/solid_scene.hpp"

#include <algorithm>
#include <cctype>
#include <array>
#include <cmath>
#include <cstdio>
#include <string_view>
#include <stdexcept>
#include <utility>
#include <vector>

#include "protocol/channels.hpp"
#include "protocol/config/scene_reader.hpp"
#include "protocol/config/reaction_section.hpp"
#include "protocol/config/shared_sections.hpp"
#include "protocol/lcm_url.hpp"
#include "common/run/memory_budget.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_options.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/model/sheet_spec.hpp"

// Why the limits are what they are:
//  - the models' options: beside the models (solid/models/elastic_sheet/elastic_sheet_options.cpp).
//  - nx_cg, ny_cg >= 2: a sheet of one CGP across has no width or no height to bend;
//    at most 65536 per axis so that the index arithmetic of SheetSpec stays in int.
//  - clamped_rows in [1, ny_cg): at least one row holds the sheet to the plate (a free-
//    floating sheet has rigid-body modes and no vibration to validate); at least one row
//    must be free.
//  - lengths in micrometres within [1e-9, 1e6] in magnitude (a femtometre to a metre): far
//    beyond any sheet or grid of the paper either way, and every conversion (to bohr, to
//    lattice cells, dt_LB = dx / c) stays a positive finite number; 1e308 um would be
//    infinite in bohr, 1e-320 um zero.
//  - dt_s > 0: the upper limit is the model's stable step 2 / omega_max, checked by the
//    `solid` executable once the model is built (it is not known before).
//  - [coupling] and [watchdog]: the one parser both servers use
//    (protocol/config/shared_sections.cpp).

namespace cosim::solid {

namespace {

using protocol::PhysicalConstants;
using protocol::config::SceneReader;
using protocol::config::SectionSchema;
using protocol::config::Table;
using protocol::config::Use;
using protocol::config::quoted;

constexpr double kMicrometre = 1e-6;

/// The solid's sections and keys, in the order messages list them; [scene], [output],
/// [grid] and [fluid]'s medium are shared with the fluid (their keys and who reads them:
/// protocol/config/scene_sections.cpp), and the fluid's sections of a coupled scene are
/// left to it. [solid] holds "model" and the options of the registered models, which may
/// bring sections of their own (solid/model/model_registry.hpp).
std::vector<SectionSchema> schema() {
  std::vector<SectionSchema> s = {
      {"scene"},
      {"solid", {"model"}},
      {"contact"},
      {"material"},
      {"sheet",
       {"nx_cg", "ny_cg", "spacing_um", "base_um", "theta_deg", "incline_deg", "clamped_rows",
        "leading_edge", "atoms_per_cgp"},
       true},
      {"run", {"mode", "substeps", "dt_s", "record_every"}, false, Use::Standalone},
      {"perturbation", {"tip_displacement_um", "shape"}},
      {"load", {"pressure_Pa", "damping_ratio"}, false, Use::Standalone},
      {"output"},
      {"grid", {}, false, Use::Coupled},
      {"fluid", {}, false, Use::Coupled},  // its medium: the units of both (read_medium)
      {"coupling", protocol::config::coupling_keys(), false, Use::Coupled},
      // The stability watchdog (common/watchdog/watchdog.hpp): the same table in both servers,
      // each validating every key.
      {"watchdog", protocol::config::watchdog_key_names(), false, Use::Coupled},
      // The reaction law (protocol/config/reaction_section.hpp, solid/coupling/reaction_law.hpp).
      {"reaction", protocol::config::reaction_keys(), false, Use::Coupled},
  };
  for (const SolidModelEntry& m : solid_models())
    for (const ModelOptions* o : m.options) {
      auto sec = std::find_if(s.begin(), s.end(), [&](const SectionSchema& e) { return e.name == o->section; });
      if (sec == s.end()) sec = s.insert(s.end(), SectionSchema{o->section});
      for (const std::string_view k : o->keys)
        if (std::find(sec->keys.begin(), sec->keys.end(), k) == sec->keys.end()) sec->keys.push_back(k);
    }
  return s;
}

/// |v| within [Table::length_min_um, Table::length_max_um].
bool length_in_range(double v) {
  const double a = std::abs(v);
  return a >= Table::length_min_um && a <= Table::length_max_um;
}

std::string length_range_text() { return "must be in [1e-9, 1e6] micrometres"; }

std::string format_short(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.5g", v);
  return buf;
}

/// [solid] model, then every registered model's options (each validated wherever it
/// appears), then a refusal of the options the chosen model does not read.
void load_solid(const SceneReader& r, SolidScene& s) {
  const Table sec = r.section("solid");
  const auto models = solid_models();
  const auto entry = [&](std::string_view name) {
    return std::find_if(models.begin(), models.end(),
                        [&](const SolidModelEntry& e) { return e.name == name; });
  };
  if (const auto m = sec.string("model")) {
    if (entry(*m) == models.end()) {
      std::vector<std::string_view> names;
      for (const SolidModelEntry& e : models) names.push_back(e.name);
      sec.bad("model", "unknown solid model; available: " + available_solid_models() +
                           protocol::config::suggestion(*m, names));
    }
    s.model = *m;
  } else if (entry(s.model) == models.end()) {
    sec.fail(sec.key("model") + " = \"" + s.model +
             "\" (the default): not built into this server; available: " +
             available_solid_models());
  }
  std::vector<const ModelOptions*> groups;
  for (const SolidModelEntry& m : models)
    for (const ModelOptions* o : m.options)
      if (std::find(groups.begin(), groups.end(), o) == groups.end()) groups.push_back(o);
  for (const ModelOptions* o : groups) o->read(r.section(o->section), s.config);
  if (s.config.material)  // the sheets' constants come from [material], not from graphene
    for (const std::string_view k : rcgp_option_keys())
      if (sec.has(k))
        sec.bad(k, "not used with [material] (the sheets' constants come from the material, not from the RCGP "
                   "construction of graphene); remove one of them");

  const auto used = entry(s.model)->options;
  for (const ModelOptions* o : groups) {
    if (std::find(used.begin(), used.end(), o) != used.end()) continue;
    const Table t = r.section(o->section);
    for (const std::string_view k : o->keys) {
      if (!t.has(k)) continue;
      std::string readers;
      for (const SolidModelEntry& m : models)
        if (std::find(m.options.begin(), m.options.end(), o) != m.options.end())
          readers += (readers.empty() ? "" : ", ") + std::string(m.name);
      t.bad(k, "not used by solid.model = \"" + s.model + "\" (only by " + readers +
                   "); remove it, or choose a model that reads it");
    }
  }
}

/// The memory a sheet needs, estimated before anything is allocated, within the solid's
/// share of this machine's (common/run/memory_budget.hpp). The elastic models' time-step check
/// finds each sheet's highest natural frequency from a dense eigenvalue problem: three dense
/// (3N)^2 matrices of doubles for a sheet of N CGPs (the stiffness, the mass-scaled free
/// block, the solver's workspace); measured, a 48 x 48 sheet peaks at 1.09 GB against 1.15 GB
/// estimated (`/usr/bin/time -f %M build/solid/solid SCENE --check`). Every model keeps about
/// 112 bytes per CGP when built (rigid, 1024 x 1024: 127 MB; 512 x 512: 41 MB).
void check_sheet_memory(const Table& sec, const std::string& model, const SheetSpec& spec) {
  const double n = double(spec.nx_cg) * double(spec.ny_cg);
  const bool modal = model == ElasticSheetModel::kRcgpName || model == ElasticSheetModel::kCorotationalName;
  const double need = 112.0 * n + (modal ? 3.0 * 8.0 * (3.0 * n) * (3.0 * n) : 0.0);
  const std::string beyond = protocol::beyond_share(need, protocol::kSolidMemoryShare,
                                                    "the rest is the fluid's and the system's");
  if (beyond.empty()) return;
  sec.fail(sec.name() + ": nx_cg x ny_cg = " + std::to_string(spec.nx_cg) + " x " + std::to_string(spec.ny_cg) +
           " = " + protocol::fmt("%.0f", n) + " CGPs: the " + model + " model needs about " + protocol::human_bytes(need) +
           (modal ? " (its time-step check solves a dense (3N)^2 eigenvalue problem)" : std::string()) + ", " +
           beyond + "; reduce nx_cg, ny_cg");
}

void load_sheets(const SceneReader& r, SolidScene& s) {
  const std::vector<Table> sheets = r.array_section("sheet");
  if (sheets.empty())
    r.fail(0, "[[sheet]]: missing; at least one [[sheet]] is required (with no keys it is "
              "the paper's 5 x 40 sheet)");
  const std::int64_t axis_max = SolidSceneLimits::cgps_per_axis_max;
  for (const Table& sec : sheets) {
    SheetSpec spec;
    if (const auto v = sec.integer_in("nx_cg", 2, axis_max, " (CGPs across the width)"))
      spec.nx_cg = *v;
    if (const auto v = sec.integer_in("ny_cg", 2, axis_max, " (CGPs up the height)"))
      spec.ny_cg = *v;
    if (const toml::node* n = sec.node("spacing_um"); n && n->is_array()) {
      // [width, height]: a rectangular CGP lattice, as the RCGP construction's.
      const char* shape =
          "must be a positive number or [width, height], two positive numbers in micrometres";
      const std::vector<double> h = *sec.numbers("spacing_um", 2, 2, shape);
      for (const double v : h) {
        if (!(v > 0.0)) sec.bad("spacing_um", shape);
        if (!length_in_range(v)) sec.bad("spacing_um", length_range_text() + " (the CGP spacings)");
      }
      spec.width_spacing_bohr = h[0] * kMicrometre / PhysicalConstants::bohr_m;
      spec.height_spacing_bohr = h[1] * kMicrometre / PhysicalConstants::bohr_m;
    } else if (const auto v = sec.length_um("spacing_um", "the CGP spacing, micrometres")) {
      spec.width_spacing_bohr = spec.height_spacing_bohr = *v * kMicrometre / PhysicalConstants::bohr_m;
    }
    if (const auto base = sec.numbers("base_um", 3, 3,
                                      "must be an array of three finite numbers [x, y, z] in micrometres"))
      for (int c = 0; c < 3; ++c) {
        const double v = (*base)[std::size_t(c)];
        if (std::abs(v) > Table::length_max_um)
          sec.bad("base_um", "must lie within 1e6 micrometres of the origin on each axis");
        spec.base_bohr[c] = v * kMicrometre / PhysicalConstants::bohr_m;
      }
    if (const auto v = sec.number("theta_deg")) spec.theta_deg = *v;
    if (const auto v = sec.number("incline_deg")) spec.incline_deg = *v;
    if (const auto v = sec.integer("clamped_rows")) {
      if (*v < 1 || *v >= spec.ny_cg)
        sec.bad("clamped_rows", "must be an integer from 1 to ny_cg - 1 = " +
                                    std::to_string(spec.ny_cg - 1) +
                                    " (at least one row on the plate, at least one free)");
      spec.clamped_rows = int(*v);
    }
    if (const auto v = sec.choice("leading_edge", {"clamped", "pinned"})) spec.pinned = *v == 1;
    if (s.config.material && sec.has("atoms_per_cgp"))
      sec.bad("atoms_per_cgp", "not used with [material]: a CGP's mass is density_kg_m3 x thickness_m x its cell "
                               "(spacing_um); remove one of them");
    if (const auto v = sec.positive("atoms_per_cgp", "carbon atoms lumped into one CGP")) {
      if (*v > SolidSceneLimits::atoms_per_cgp_max)
        sec.bad("atoms_per_cgp", "must be a number of carbon atoms lumped into one CGP from above 0 to 1e15");
      spec.cgp_mass_me =
          *v * PhysicalConstants::carbon_mass_kg / PhysicalConstants::electron_mass_kg;
    }
    if (s.config.material)  // rho h per unit area, a full cell per CGP
      spec.cgp_mass_me = s.config.material->mass_per_area_kg_m2() * spec.cell_area_bohr2() * PhysicalConstants::bohr_m *
                         PhysicalConstants::bohr_m / PhysicalConstants::electron_mass_kg;
    check_sheet_memory(sec, s.model, spec);
    try {
      check_sheet_spec(spec);  // what the models check; the rules above should cover it
    } catch (const std::invalid_argument& e) {
      sec.fail(sec.name() + ": " + e.what());
    }
    s.config.sheets.push_back(spec);
  }
}

void load_grid(const SceneReader& r, SolidScene& s) {
  if (const auto v = r.section("grid").length_um("dx_um", "micrometres per lattice cell, dx_LB = dx_CG"))
    s.dx_m = *v * kMicrometre;
}

void load_run(const SceneReader& r, SolidScene& s) {
  const Table sec = r.section("run");
  if (!sec.present())
    r.fail(0, "[run]: missing; the section with mode (\"free\" or \"static\") and substeps is "
              "required");
  const auto mode = sec.choice("mode", {"free", "static"});
  if (!mode)
    sec.missing("mode",
                "\"free\" (vibration from [perturbation]) or \"static\" (relaxation under "
                "[load])");
  s.mode = *mode == 0 ? SolidRunMode::Free : SolidRunMode::Static;
  const auto n = sec.integer("substeps");
  if (!n) sec.missing("substeps", "the number of substeps, an integer >= 1");
  if (*n < 1) sec.bad("substeps", "must be an integer >= 1");
  s.substeps = *n;
  s.dt_s = protocol::UnitConverter{}.dt_cg_s();
  if (const auto dt = sec.positive("dt_s", "the substep in seconds; default dt_CG = " +
                                               format_short(s.dt_s) + " s")) {
    s.dt_s = *dt;
    s.dt_is_default = false;
  }
  if (const auto e = sec.integer("record_every")) {
    if (*e < 1) sec.bad("record_every", "must be an integer >= 1");
    s.record_every = *e;
  }
}

/// [perturbation] tip_displacement_um (required in the section), in bohr.
double read_tip_displacement(const Table& pert) {
  const auto a = pert.number("tip_displacement_um");
  if (!a)
    pert.missing("tip_displacement_um",
                 "the initial normal displacement of the top row, micrometres, non-zero");
  if (*a == 0.0)
    pert.bad("tip_displacement_um",
             "must be non-zero (micrometres along the sheet normal; 0 would not vibrate)");
  if (!length_in_range(*a))
    pert.bad("tip_displacement_um", "|value| " + length_range_text() + " (along the sheet normal)");
  return *a * kMicrometre / PhysicalConstants::bohr_m;
}

/// [perturbation] shape (optional): "cantilever" (default) or "translation".
DeflectionShape read_deflection_shape(const Table& pert) {
  if (const auto v = pert.choice("shape", {"cantilever", "translation"}))
    return *v == 0 ? DeflectionShape::Cantilever : DeflectionShape::Translation;
  return DeflectionShape::Cantilever;
}

void load_mode_sections(const SceneReader& r, SolidScene& s) {
  const Table pert = r.section("perturbation");
  const Table load = r.section("load");
  const bool free = s.mode == SolidRunMode::Free;
  if (free && load.present())
    load.fail("[load]: given, but run.mode = \"free\"; a load belongs to run.mode = "
              "\"static\" (remove the section or change the mode)");
  if (!free && pert.present())
    pert.fail("[perturbation]: given, but run.mode = \"static\"; a perturbation belongs "
              "to run.mode = \"free\" (remove the section or change the mode)");
  if (free) {
    // Under gravity the sheet may start flat and at rest (released: Turek & Hron's CSM3).
    if (!pert.present() && !s.config.body.gravity_m_s2.isZero(0.0)) return;
    if (!pert.present())
      r.fail(0, "[perturbation]: missing; run.mode = \"free\" needs [perturbation] with "
                "tip_displacement_um (or [solid] gravity_m_s2, to release the flat sheet under gravity)");
    s.tip_displacement_bohr = read_tip_displacement(pert);
    s.deflection_shape = read_deflection_shape(pert);
  } else {
    if (!load.present())
      r.fail(0, "[load]: missing; run.mode = \"static\" needs [load] with pressure_Pa");
    const auto p = load.number("pressure_Pa");
    if (!p) load.missing("pressure_Pa", "the uniform normal pressure, Pa (finite)");
    s.pressure_Pa = *p;
    if (const auto z = load.positive("damping_ratio",
                                     "zeta of the damping force -2 zeta omega_1 m v; 1 is "
                                     "critical for the first mode"))
      s.damping_ratio = *z;
  }
}

SolidScene read_solid_scene(const std::string& path) {
  const SceneReader r(path, protocol::config::Process::Solid);
  r.check_sections(schema());
  const bool coupled = r.coupled();

  SolidScene s;
  s.path = path;
  protocol::config::read_scene_header(r, s.name, s.description);

  load_solid(r, s);
  load_sheets(r, s);
  if (coupled) {
    load_grid(r, s);
    s.medium = protocol::config::read_medium(r);
    s.coupling = protocol::config::read_coupling(r);
    s.watchdog = protocol::config::read_watchdog(r);
    s.reaction_law = protocol::config::read_reaction_law(r, *s.coupling);
    // A coupled release from a held deflection (in still air or in flow): optional.
    if (const Table pert = r.section("perturbation"); pert.present()) {
      s.tip_displacement_bohr = read_tip_displacement(pert);
      s.deflection_shape = read_deflection_shape(pert);
    }
    s.dt_s = protocol::UnitConverter(s.unit_inputs()).dt_cg_s();  // dt_CG = dt_LB / A_T
    s.dt_is_default = true;
    s.substeps = 0;
    s.record_every = 1;
  } else {
    load_run(r, s);
    load_mode_sections(r, s);
  }

  s.output_dir = protocol::config::read_output_directory(r, s.name);
  const Table out = r.section("output");
  if (const auto e = out.integer("sheets_every")) {
    if (*e < 0)
      out.bad("sheets_every",
              std::string("must be an integer >= 0 (0: no sheet snapshots; N: sheets_NNNNNN.h5 "
                          "and sheets.xmf every N ") +
                  (coupled ? "LB steps" : "substeps") + ", at the first and the last)");
    s.sheets_every = *e;
  }
  return s;
}

}  // namespace

protocol::UnitInputs SolidScene::unit_inputs() const {
  return protocol::scene_unit_inputs(dx_m, medium,
                                     coupling ? coupling->time_ratio : protocol::UnitInputs{}.time_ratio);
}

double cantilever_load_shape(double s) { return (6.0 * s * s - 4.0 * s * s * s + s * s * s * s) / 3.0; }

SolidScene load_solid_scene(const std::string& path) {
  return protocol::config::rethrow_as<SolidSceneError>([&] { return read_solid_scene(path); });
}

std::vector<std::string> model_sections_present(const std::string& path) {
  const SceneReader r(path, protocol::config::Process::Solid);
  std::vector<std::string> names = {"solid", "contact", "material", "perturbation"};
  for (const SolidModelEntry& m : solid_models())
    for (const ModelOptions* o : m.options)
      if (std::find(names.begin(), names.end(), o->section) == names.end()) names.emplace_back(o->section);
  std::vector<std::string> present;
  for (const std::string& n : names)
    if (r.section(n).present()) present.push_back("[" + n + "]");
  return present;
}

void apply_overrides(SolidScene& s, const SolidSceneOverrides& o) {
  const auto fail = [](const std::string& opt, const std::string& value, const std::string& msg) {
    throw SolidSceneError(protocol::config::command_line_problem(opt, value, msg));
  };
  const char* only_coupled = "only for a coupled scene (one with a [coupling] section)";
  if (o.substeps) {
    if (s.coupled())
      fail("--substeps", std::to_string(*o.substeps),
           "only for a standalone scene; in a coupled scene the fluid's [run] steps set the "
           "length of the run");
    if (*o.substeps < 1) fail("--substeps", std::to_string(*o.substeps), "must be an integer >= 1");
    s.substeps = *o.substeps;
  }
  if (o.output_dir) {
    if (o.output_dir->empty()) fail("--output", "\"\"", "must not be empty");
    s.output_dir = *o.output_dir;
  }
  if (o.channel_prefix) {
    if (!s.coupled()) fail("--channel-prefix", quoted(*o.channel_prefix), only_coupled);
    try {
      protocol::validate_channel_prefix(*o.channel_prefix);
    } catch (const std::invalid_argument& e) {
      fail("--channel-prefix", quoted(*o.channel_prefix), e.what());
    }
    s.coupling->channel_prefix = *o.channel_prefix;
  }
  if (o.lcm_url) {
    if (!s.coupled()) fail("--lcm-url", quoted(*o.lcm_url), only_coupled);
    if (const auto why = protocol::lcm_url_problem(*o.lcm_url))
      fail("--lcm-url", quoted(*o.lcm_url), *why);
    s.coupling->lcm_url = *o.lcm_url;
  }
  if (o.time_ratio) {
    if (!s.coupled()) fail("--time-ratio", std::to_string(*o.time_ratio), only_coupled);
    if (const auto why = protocol::config::time_ratio_problem(*o.time_ratio))
      fail("--time-ratio", std::to_string(*o.time_ratio), *why);
    s.coupling->time_ratio = static_cast<int>(*o.time_ratio);
    s.dt_s = protocol::UnitConverter(s.unit_inputs()).dt_cg_s();  // dt_CG = dt_LB / A_T
  }
}

}  // namespace cosim::solid
