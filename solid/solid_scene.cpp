#include "solid/solid_scene.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>
#include <system_error>
#include <vector>

#include <toml++/toml.h>

#include "protocol/units.hpp"
#include "solid/model_registry.hpp"
#include "solid/sheet_spec.hpp"

// Why the limits are what they are:
//  - stages 1..16 and truncation_range 2 or 3: what the RCGP construction accepts
//    (rcgp_construction.hpp). 16 stages are Lambda = 2^15 x 1 nm = 33 um per CGP, beyond
//    any sheet of the paper; range 1 cannot carry bending (no room for a zero second and a
//    non-zero fourth flexural moment).
//  - bending_poisson in [0, 0.5): the Poisson ratio of an isotropic plate lies in (-1, 0.5);
//    graphene's bending Poisson ratio is small and positive, and a negative one has no use
//    in these scenes. 0.5 is the incompressible limit.
//  - nx_cg, ny_cg >= 2: a sheet of one CGP across has no width or no height to bend;
//    at most 65536 per axis so that the index arithmetic of SheetSpec stays in int.
//  - clamped_rows in [1, ny_cg): at least one row holds the sheet to the plate (a free-
//    floating sheet has rigid-body modes and no vibration to validate); at least one row
//    must be free.
//  - dt_s > 0: the upper limit is the model's stable step 2 / omega_max, checked by the
//    `solid` executable once the model is built (it is not known before).

namespace cosim::solid {

namespace {

namespace fs = std::filesystem;
using protocol::PhysicalConstants;

constexpr double kMicrometre = 1e-6;

/// Keys allowed in each section; everything else is an error.
struct Section {
  const char* name;
  bool array;  ///< an array of tables ([[name]]) instead of one table ([name])
  std::vector<const char*> keys;
};

const std::vector<Section>& schema() {
  static const std::vector<Section> s = {
      {"scene", false, {"name", "description"}},
      {"solid",
       false,
       {"model", "stages", "flexural_scaling", "truncation_range", "moment_matching",
        "bending_poisson", "cache_dir"}},
      {"contact", false, {"epsilon_eV", "cutoff_um"}},
      {"sheet",
       true,
       {"nx_cg", "ny_cg", "spacing_um", "base_um", "theta_deg", "clamped_rows",
        "atoms_per_cgp"}},
      {"run", false, {"mode", "substeps", "dt_s", "record_every"}},
      {"perturbation", false, {"tip_displacement_um"}},
      {"load", false, {"pressure_Pa", "damping_ratio"}},
      {"output", false, {"directory"}},
  };
  return s;
}

std::string join(const std::vector<const char*>& items, const char* prefix,
                 const char* suffix) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += ", ";
    out += prefix;
    out += items[i];
    out += suffix;
  }
  return out;
}

std::string section_list() {
  std::string out;
  for (const Section& s : schema()) {
    if (!out.empty()) out += ", ";
    out += s.array ? std::string("[[") + s.name + "]]" : std::string("[") + s.name + "]";
  }
  return out;
}

/// Levenshtein distance, for "did you mean" on a misspelt key.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string suggestion(std::string_view got, const std::vector<const char*>& allowed) {
  std::size_t best = got.size() >= 8 ? 4 : 3;  // up to 2 edits, 3 for long names
  const char* pick = nullptr;
  for (const char* a : allowed) {
    const std::size_t d = edit_distance(got, a);
    if (d < best) best = d, pick = a;
  }
  return pick ? std::string(" (did you mean \"") + pick + "\"?)" : std::string();
}

/// Control characters become spaces, so that a message stays on one line.
std::string one_line(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return s;
}

std::string shorten(std::string s, std::size_t max = 60) {
  if (s.size() > max) s = s.substr(0, max - 3) + "...";
  return s;
}

std::string format_double(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string format_short(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.5g", v);
  return buf;
}

/// A value as the user wrote it (close enough): strings quoted, arrays inline.
std::string show(const toml::node& n) {
  if (const auto* s = n.as_string()) {
    std::string out(1, '"');  // not "\"" + ...: GCC 12 warns falsely (-Wrestrict)
    out += one_line(s->get());
    out += '"';
    return shorten(out);
  }
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  if (const auto* d = n.as_floating_point()) return format_double(d->get());
  if (const auto* b = n.as_boolean()) return b->get() ? "true" : "false";
  if (const auto* a = n.as_array()) {
    std::string out = "[";
    for (std::size_t i = 0; i < a->size(); ++i) out += (i ? ", " : "") + show(*a->get(i));
    return shorten(out + "]");
  }
  if (n.is_table()) return "{...}";
  std::ostringstream os;
  n.visit([&](const auto& v) { os << v; });
  return shorten(one_line(os.str()));
}

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date or time";
  }
}

bool valid_name(const std::string& s) {
  return !s.empty() && s.size() <= 64 &&
         std::all_of(s.begin(), s.end(),
                     [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) || c == '_' ||
                              c == '-' || c == '.';
                     }) &&
         s != "." && s != "..";
}

/// One table of the document and the name it has in messages: "solid" for [solid],
/// "sheet[1]" for the second [[sheet]].
struct Scope {
  const toml::table* table = nullptr;  ///< null: the section is absent
  std::string name;
  std::uint32_t line = 0;  ///< of the section header; 0 if absent

  std::string key(const char* k) const { return name + "." + k; }
  const toml::node* node(const char* k) const { return table ? table->get(k) : nullptr; }
};

/// Reads typed values out of the document and reports problems with file and line.
class Reader {
 public:
  Reader(std::string path, const toml::table& root) : path_(std::move(path)), root_(root) {}

  [[noreturn]] void fail(std::uint32_t line, const std::string& what) const {
    std::string where = path_;
    if (line > 0) where += ":" + std::to_string(line);
    throw SolidSceneError(one_line(where + ": " + what));
  }
  /// "KEY = VALUE: msg" at the value's line.
  [[noreturn]] void bad(const toml::node& v, const std::string& key,
                        const std::string& msg) const {
    fail(v.source().begin.line, key + " = " + show(v) + ": " + msg);
  }
  /// A required key is absent: reported at its section's line when the section exists.
  [[noreturn]] void missing(const Scope& s, const char* key, const std::string& what) const {
    fail(s.line, s.key(key) + ": missing; " + what);
  }

  /// Every section and key must be in the schema; [[sheet]] must be an array of tables,
  /// the others single tables.
  void check_known_keys() const {
    std::vector<const char*> sections;
    for (const Section& s : schema()) sections.push_back(s.name);
    for (auto&& [k, v] : root_) {
      const std::string name(k.str());
      const Section* sec = find_section(name);
      if (!sec) {
        if (v.is_table() || v.is_array_of_tables())
          fail(k.source().begin.line, "[" + name + "]: unknown section; allowed: " +
                                          section_list() + suggestion(name, sections));
        bad(v, name, "unknown key at the top level; keys belong in one of the sections " +
                         section_list() + suggestion(name, sections));
      }
      if (sec->array) {
        if (!v.is_array_of_tables())
          fail(v.source().begin.line,
               std::string(v.is_table() ? "[" : "") + sec->name + (v.is_table() ? "]" : "") +
                   ": must be an array of tables: write each sheet as [[" + sec->name +
                   "]] with keys " + join(sec->keys, "", ""));
        std::size_t i = 0;
        for (const toml::node& e : *v.as_array())
          check_keys(*sec, *e.as_table(), std::string(sec->name) + "[" + std::to_string(i++) + "]");
      } else {
        if (!v.is_table())
          bad(v, sec->name,
              std::string("must be a table: a section [") + sec->name + "] with keys " +
                  join(sec->keys, "", ""));
        check_keys(*sec, *v.as_table(), sec->name);
      }
    }
  }

  Scope section(const char* name) const {
    const toml::node* n = root_.get(name);
    if (!n) return {nullptr, name, 0};
    return {n->as_table(), name, n->source().begin.line};
  }
  /// The tables of an array section ([[sheet]]); empty if absent.
  std::vector<Scope> array_section(const char* name) const {
    std::vector<Scope> out;
    const toml::node* n = root_.get(name);
    if (!n) return out;
    std::size_t i = 0;
    for (const toml::node& e : *n->as_array())  // shape checked by check_known_keys
      out.push_back({e.as_table(), std::string(name) + "[" + std::to_string(i++) + "]",
                     e.source().begin.line});
    return out;
  }

  std::optional<double> number(const Scope& s, const char* key) const {
    const toml::node* n = s.node(key);
    if (!n) return std::nullopt;
    double v = 0.0;
    if (const auto* i = n->as_integer())
      v = double(i->get());
    else if (const auto* d = n->as_floating_point())
      v = d->get();
    else
      bad(*n, s.key(key), std::string("must be a number, not ") + type_name(*n));
    if (!std::isfinite(v)) bad(*n, s.key(key), "must be a finite number");
    return v;
  }

  std::optional<std::int64_t> integer(const Scope& s, const char* key) const {
    const toml::node* n = s.node(key);
    if (!n) return std::nullopt;
    const auto* i = n->as_integer();
    if (!i) bad(*n, s.key(key), std::string("must be an integer, not ") + type_name(*n));
    return i->get();
  }

  /// An integer in [lo, hi]; `why` is appended to the message.
  std::optional<int> integer_in(const Scope& s, const char* key, std::int64_t lo,
                                std::int64_t hi, const std::string& why = "") const {
    const auto v = integer(s, key);
    if (!v) return std::nullopt;
    if (*v < lo || *v > hi)
      bad(*s.node(key), s.key(key),
          "must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + why);
    return int(*v);
  }

  std::optional<bool> boolean(const Scope& s, const char* key) const {
    const toml::node* n = s.node(key);
    if (!n) return std::nullopt;
    const auto* b = n->as_boolean();
    if (!b) bad(*n, s.key(key), std::string("must be true or false, not ") + type_name(*n));
    return b->get();
  }

  std::optional<std::string> string(const Scope& s, const char* key) const {
    const toml::node* n = s.node(key);
    if (!n) return std::nullopt;
    const auto* str = n->as_string();
    if (!str) bad(*n, s.key(key), std::string("must be a string, not ") + type_name(*n));
    return str->get();
  }

  /// A string from a closed list; returns its index.
  std::optional<std::size_t> choice(const Scope& s, const char* key,
                                    const std::vector<const char*>& allowed) const {
    const std::optional<std::string> v = string(s, key);
    if (!v) return std::nullopt;
    for (std::size_t i = 0; i < allowed.size(); ++i)
      if (*v == allowed[i]) return i;
    bad(*s.node(key), s.key(key),
        "must be one of " + join(allowed, "\"", "\"") + suggestion(*v, allowed));
  }

  /// A number > 0.
  std::optional<double> positive(const Scope& s, const char* key, const std::string& what) const {
    const auto v = number(s, key);
    if (v && !(*v > 0.0)) bad(*s.node(key), s.key(key), "must be > 0 (" + what + ")");
    return v;
  }

 private:
  void check_keys(const Section& sec, const toml::table& t, const std::string& name) const {
    for (auto&& [kk, vv] : t) {
      const std::string key(kk.str());
      const bool known = std::any_of(sec.keys.begin(), sec.keys.end(),
                                     [&](const char* a) { return key == a; });
      if (!known)
        bad(vv, name + "." + key,
            std::string("unknown key in ") + (sec.array ? "[[" : "[") + sec.name +
                (sec.array ? "]]" : "]") + "; allowed: " + join(sec.keys, "", "") +
                suggestion(key, sec.keys));
    }
  }

  static const Section* find_section(std::string_view name) {
    for (const Section& s : schema())
      if (name == s.name) return &s;
    return nullptr;
  }

  std::string path_;
  const toml::table& root_;
};

toml::table parse(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw SolidSceneError(one_line(path + ": cannot read the scene file: no such file"));
  if (!fs::is_regular_file(path, ec))
    throw SolidSceneError(one_line(path + ": cannot read the scene file: not a regular file"));
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw SolidSceneError(one_line(path + ": cannot read the scene file: permission denied?"));
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return toml::parse(text.str(), path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw SolidSceneError(one_line(path + ":" + std::to_string(b.line) + ":" +
                                   std::to_string(b.column) + ": TOML syntax error: " +
                                   std::string(e.description())));
  }
}

bool model_registered(std::string_view name) {
  const auto models = solid_models();
  return std::any_of(models.begin(), models.end(),
                     [&](const SolidModelEntry& e) { return e.name == name; });
}

void load_solid(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("solid");
  if (const auto m = r.string(sec, "model")) {
    if (!model_registered(*m))
      r.bad(*sec.node("model"), sec.key("model"),
            "unknown solid model; available: " + available_solid_models());
    s.model = *m;
  } else if (!model_registered(s.model)) {
    r.fail(sec.line, sec.key("model") + " = \"" + s.model +
                         "\" (the default): not built into this server; available: " +
                         available_solid_models());
  }
  RcgpOptions& o = s.config.rcgp;
  if (const auto v = r.integer_in(sec, "stages", SolidSceneLimits::stages_min,
                                  SolidSceneLimits::stages_max,
                                  " (stage 1 is about 1 nm per CGP, each stage doubles it; 9 "
                                  "reach the paper's 0.25 um)"))
    o.stages = *v;
  if (const auto v = r.choice(sec, "flexural_scaling", {"paper", "physical"}))
    o.flexural_scaling = *v == 0 ? FlexuralScaling::Paper : FlexuralScaling::Physical;
  if (const auto v = r.integer(sec, "truncation_range")) {
    if (*v != 2 && *v != 3)
      r.bad(*sec.node("truncation_range"), sec.key("truncation_range"),
            "must be 2 or 3 (CG spacings; range 1 cannot carry bending)");
    o.truncation_range = int(*v);
  }
  if (const auto v = r.boolean(sec, "moment_matching")) o.moment_matching = *v;
  if (const auto v = r.number(sec, "bending_poisson")) {
    if (!(*v >= 0.0 && *v < SolidSceneLimits::bending_poisson_max))
      r.bad(*sec.node("bending_poisson"), sec.key("bending_poisson"),
            "must be in [0, 0.5) (the Poisson ratio of the bending energy)");
    o.bending_poisson = *v;
  }
  if (const auto v = r.string(sec, "cache_dir")) o.cache_dir = *v;
}

void load_contact(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("contact");
  if (const auto v = r.positive(sec, "epsilon_eV", "the Lennard-Jones energy, eV"))
    s.config.contact.epsilon_eV = *v;
  if (const auto v = r.positive(sec, "cutoff_um", "the cut-off sigma, micrometres"))
    s.config.contact.cutoff_bohr = *v * kMicrometre / PhysicalConstants::bohr_m;
}

void load_sheets(const Reader& r, SolidScene& s) {
  const std::vector<Scope> sheets = r.array_section("sheet");
  if (sheets.empty())
    r.fail(0, "[[sheet]]: missing; at least one [[sheet]] is required (with no keys it is "
              "the paper's 5 x 40 sheet)");
  const std::int64_t axis_max = SolidSceneLimits::cgps_per_axis_max;
  for (const Scope& sec : sheets) {
    SheetSpec spec;
    if (const auto v = r.integer_in(sec, "nx_cg", 2, axis_max, " (CGPs across the width)"))
      spec.nx_cg = *v;
    if (const auto v = r.integer_in(sec, "ny_cg", 2, axis_max, " (CGPs up the height)"))
      spec.ny_cg = *v;
    if (const toml::node* n = sec.node("spacing_um"); n && n->is_array()) {
      // [width, height]: a rectangular CGP lattice, as the RCGP construction's.
      const char* shape =
          "must be a positive number or [width, height], two positive numbers in micrometres";
      const toml::array* a = n->as_array();
      if (a->size() != 2) r.bad(*n, sec.key("spacing_um"), shape);
      std::array<double, 2> h{};
      for (std::size_t c = 0; c < 2; ++c) {
        const toml::node& e = *a->get(c);
        if (const auto* i = e.as_integer())
          h[c] = double(i->get());
        else if (const auto* d = e.as_floating_point())
          h[c] = d->get();
        else
          r.bad(*n, sec.key("spacing_um"), shape);
        if (!(h[c] > 0.0) || !std::isfinite(h[c])) r.bad(*n, sec.key("spacing_um"), shape);
      }
      spec.width_spacing_bohr = h[0] * kMicrometre / PhysicalConstants::bohr_m;
      spec.height_spacing_bohr = h[1] * kMicrometre / PhysicalConstants::bohr_m;
    } else if (const auto v = r.positive(sec, "spacing_um", "the CGP spacing, micrometres")) {
      spec.width_spacing_bohr = spec.height_spacing_bohr = *v * kMicrometre / PhysicalConstants::bohr_m;
    }
    if (const toml::node* n = sec.node("base_um")) {
      const char* shape = "must be an array of three finite numbers [x, y, z] in micrometres";
      const toml::array* a = n->as_array();
      if (!a || a->size() != 3) r.bad(*n, sec.key("base_um"), shape);
      for (int c = 0; c < 3; ++c) {
        const toml::node& e = *a->get(std::size_t(c));
        double v = 0.0;
        if (const auto* i = e.as_integer())
          v = double(i->get());
        else if (const auto* d = e.as_floating_point())
          v = d->get();
        else
          r.bad(*n, sec.key("base_um"), shape);
        if (!std::isfinite(v)) r.bad(*n, sec.key("base_um"), shape);
        spec.base_bohr[c] = v * kMicrometre / PhysicalConstants::bohr_m;
      }
    }
    if (const auto v = r.number(sec, "theta_deg")) spec.theta_deg = *v;
    if (const auto v = r.integer(sec, "clamped_rows")) {
      if (*v < 1 || *v >= spec.ny_cg)
        r.bad(*sec.node("clamped_rows"), sec.key("clamped_rows"),
              "must be an integer from 1 to ny_cg - 1 = " + std::to_string(spec.ny_cg - 1) +
                  " (at least one row on the plate, at least one free)");
      spec.clamped_rows = int(*v);
    }
    if (const auto v = r.positive(sec, "atoms_per_cgp", "carbon atoms lumped into one CGP"))
      spec.cgp_mass_me =
          *v * PhysicalConstants::carbon_mass_kg / PhysicalConstants::electron_mass_kg;
    try {
      check_sheet_spec(spec);  // what the models check; the rules above should cover it
    } catch (const std::invalid_argument& e) {
      r.fail(sec.line, sec.name + ": " + e.what());
    }
    s.config.sheets.push_back(spec);
  }
}

void load_run(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("run");
  if (!sec.table)
    r.fail(0, "[run]: missing; the section with mode (\"free\" or \"static\") and substeps is "
              "required");
  const auto mode = r.choice(sec, "mode", {"free", "static"});
  if (!mode)
    r.missing(sec, "mode",
              "\"free\" (vibration from [perturbation]) or \"static\" (relaxation under "
              "[load])");
  s.mode = *mode == 0 ? SolidRunMode::Free : SolidRunMode::Static;
  const auto n = r.integer(sec, "substeps");
  if (!n) r.missing(sec, "substeps", "the number of substeps, an integer >= 1");
  if (*n < 1) r.bad(*sec.node("substeps"), sec.key("substeps"), "must be an integer >= 1");
  s.substeps = *n;
  s.dt_s = protocol::UnitConverter{}.dt_cg_s();
  if (const auto dt = r.positive(sec, "dt_s", "the substep in seconds; default dt_CG = " +
                                                  format_short(s.dt_s) + " s")) {
    s.dt_s = *dt;
    s.dt_is_default = false;
  }
  if (const auto e = r.integer(sec, "record_every")) {
    if (*e < 1) r.bad(*sec.node("record_every"), sec.key("record_every"), "must be an integer >= 1");
    s.record_every = *e;
  }
}

void load_mode_sections(const Reader& r, SolidScene& s) {
  const Scope pert = r.section("perturbation");
  const Scope load = r.section("load");
  const bool free = s.mode == SolidRunMode::Free;
  if (free && load.table)
    r.fail(load.line, "[load]: given, but run.mode = \"free\"; a load belongs to run.mode = "
                      "\"static\" (remove the section or change the mode)");
  if (!free && pert.table)
    r.fail(pert.line, "[perturbation]: given, but run.mode = \"static\"; a perturbation belongs "
                      "to run.mode = \"free\" (remove the section or change the mode)");
  if (free) {
    if (!pert.table)
      r.fail(0, "[perturbation]: missing; run.mode = \"free\" needs [perturbation] with "
                "tip_displacement_um");
    const auto a = r.number(pert, "tip_displacement_um");
    if (!a)
      r.missing(pert, "tip_displacement_um",
                "the initial normal displacement of the top row, micrometres, non-zero");
    if (*a == 0.0)
      r.bad(*pert.node("tip_displacement_um"), pert.key("tip_displacement_um"),
            "must be non-zero (micrometres along the sheet normal; 0 would not vibrate)");
    s.tip_displacement_bohr = *a * kMicrometre / PhysicalConstants::bohr_m;
  } else {
    if (!load.table)
      r.fail(0, "[load]: missing; run.mode = \"static\" needs [load] with pressure_Pa");
    const auto p = r.number(load, "pressure_Pa");
    if (!p) r.missing(load, "pressure_Pa", "the uniform normal pressure, Pa (finite)");
    s.pressure_Pa = *p;
    if (const auto z = r.positive(load, "damping_ratio",
                                  "zeta of the damping force -2 zeta omega_1 m v; 1 is critical "
                                  "for the first mode"))
      s.damping_ratio = *z;
  }
}

}  // namespace

double cantilever_load_shape(double s) { return (6.0 * s * s - 4.0 * s * s * s + s * s * s * s) / 3.0; }

SolidScene load_solid_scene(const std::string& path) {
  const toml::table root = parse(path);
  const Reader r(path, root);
  r.check_known_keys();

  SolidScene s;
  s.path = path;
  s.name = fs::path(path).stem().string();
  const Scope scene = r.section("scene");
  if (const auto n = r.string(scene, "name")) {
    if (!valid_name(*n))
      r.bad(*scene.node("name"), scene.key("name"),
            "must be 1 to 64 characters from A-Z a-z 0-9 _ - . (it names the output "
            "directory)");
    s.name = *n;
  }
  if (const auto d = r.string(scene, "description")) s.description = one_line(*d);

  load_solid(r, s);
  load_contact(r, s);
  load_sheets(r, s);
  load_run(r, s);
  load_mode_sections(r, s);

  s.output_dir = "out/" + s.name;
  const Scope out = r.section("output");
  if (const auto d = r.string(out, "directory")) {
    if (d->empty()) r.bad(*out.node("directory"), out.key("directory"), "must not be empty");
    s.output_dir = *d;
  }
  return s;
}

void apply_overrides(SolidScene& s, const SolidSceneOverrides& o) {
  const auto fail = [](const std::string& opt, const std::string& value, const char* msg) {
    throw SolidSceneError(one_line("command line: " + opt + " = " + value + ": " + msg));
  };
  if (o.substeps) {
    if (*o.substeps < 1) fail("--substeps", std::to_string(*o.substeps), "must be an integer >= 1");
    s.substeps = *o.substeps;
  }
  if (o.output_dir) {
    if (o.output_dir->empty()) fail("--output", "\"\"", "must not be empty");
    s.output_dir = *o.output_dir;
  }
}

}  // namespace cosim::solid
