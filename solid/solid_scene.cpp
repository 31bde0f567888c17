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
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "protocol/channels.hpp"
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
//  - lengths in micrometres within [1e-9, 1e6] in magnitude (a femtometre to a metre): far
//    beyond any sheet or grid of the paper either way, and every conversion (to bohr, to
//    lattice cells, dt_LB = dx / c) stays a positive finite number; 1e308 um would be
//    infinite in bohr, 1e-320 um zero.
//  - dt_s > 0: the upper limit is the model's stable step 2 / omega_max, checked by the
//    `solid` executable once the model is built (it is not known before).
//  - [coupling] (the same limits as fluid/scene_config.cpp, which reads the same keys):
//    time_ratio 1..1e6 (an int32 on the wire; a million substeps per LB step is beyond any
//    sheet of the paper, whose A_T is 150); timeouts in (0, 86400] s (a day: longer is a
//    typo, and the milliseconds of PeerWatch stay far from overflow); resend_after_s below
//    peer_timeout_s (PeerWatch: re-requests come before the peer is given up); lcm_url
//    udpm:// with ttl=0 or memq:// only (protocol/README.md section 1: packets never leave
//    the machine).

namespace cosim::solid {

namespace {

namespace fs = std::filesystem;
using protocol::PhysicalConstants;

constexpr double kMicrometre = 1e-6;

/// Which kind of scene a section belongs to.
enum class Use { Both, Standalone, Coupled };

/// Keys allowed in each section; everything else is an error.
struct Section {
  const char* name;
  bool array;  ///< an array of tables ([[name]]) instead of one table ([name])
  std::vector<const char*> keys;
  Use use = Use::Both;
  /// Keys of the same section that the fluid reads in a coupled scene: allowed there and
  /// left unread ([grid] nx, ny, nz; [output] fields_every, planes_every, planes_y).
  std::vector<const char*> fluid_keys = {};
};

std::vector<const char*> watchdog_key_names() {
  std::vector<const char*> names;
  for (const auto& [name, type] : protocol::watchdog_keys()) names.push_back(name);
  return names;
}

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
      {"run", false, {"mode", "substeps", "dt_s", "record_every"}, Use::Standalone},
      {"perturbation", false, {"tip_displacement_um"}, Use::Standalone},
      {"load", false, {"pressure_Pa", "damping_ratio"}, Use::Standalone},
      {"output",
       false,
       {"directory", "sheets_every"},
       Use::Both,
       {"fields_every", "planes_every", "planes_y"}},
      {"grid", false, {"dx_um"}, Use::Coupled, {"nx", "ny", "nz"}},
      {"coupling",
       false,
       {"time_ratio", "rigid_steps", "handshake_timeout_s", "peer_timeout_s", "resend_after_s",
        "checkpoint_every", "scheme", "max_iterations", "tolerance", "relaxation",
        "lcm_url", "channel_prefix"},
       Use::Coupled},
      // The stability watchdog (protocol/watchdog.hpp): the same table in both servers,
      // each validating every key.
      {"watchdog", false, watchdog_key_names(), Use::Coupled},
  };
  return s;
}

/// The fluid's own sections of a coupled scene (fluid/scene_config.cpp reads them); the
/// solid leaves them unread. [run] is the solid's in a standalone scene only.
const std::vector<const char*>& fluid_sections() {
  static const std::vector<const char*> s = {"fluid",         "inlet",      "boundaries",
                                             "wall_velocity", "body_force", "run"};
  return s;
}

bool is_fluid_section(std::string_view name) {
  const auto& f = fluid_sections();
  return std::any_of(f.begin(), f.end(), [&](const char* n) { return name == n; });
}

bool used_in(const Section& s, bool coupled) {
  return s.use == Use::Both || (s.use == Use::Coupled) == coupled;
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

std::string section_name(const Section& s) {
  return s.array ? std::string("[[") + s.name + "]]" : std::string("[") + s.name + "]";
}

/// The sections a scene of this kind may have, for messages.
std::string section_list(bool coupled) {
  std::string out;
  for (const Section& s : schema()) {
    if (!used_in(s, coupled)) continue;
    if (!out.empty()) out += ", ";
    out += section_name(s);
  }
  if (coupled) {
    out += "; the fluid's ";
    for (std::size_t i = 0; i < fluid_sections().size(); ++i)
      out += std::string(i ? ", [" : "[") + fluid_sections()[i] + "]";
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

/// |v| within [length_min_um, length_max_um].
bool length_in_range(double v) {
  const double a = std::abs(v);
  return a >= SolidSceneLimits::length_min_um && a <= SolidSceneLimits::length_max_um;
}

std::string length_range_text() { return "must be in [1e-9, 1e6] micrometres"; }

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

  /// Every section and key must be in the schema of the scene's kind (coupled: with a
  /// [coupling] section); [[sheet]] must be an array of tables, the others single tables.
  /// In a coupled scene the fluid's sections and keys are left to the fluid.
  void check_known_keys(bool coupled) const {
    std::vector<const char*> sections;
    for (const Section& s : schema())
      if (used_in(s, coupled)) sections.push_back(s.name);
    if (coupled)
      for (const char* f : fluid_sections()) sections.push_back(f);
    for (auto&& [k, v] : root_) {
      const std::string name(k.str());
      if (coupled && is_fluid_section(name)) continue;  // the fluid's (fluid/scene_config.cpp)
      const Section* sec = find_section(name);
      if (sec && !used_in(*sec, coupled)) {
        if (coupled)
          fail(k.source().begin.line,
               section_name(*sec) + ": not used in a coupled scene (one with [coupling]): the "
                                    "fluid drives the sheets; remove the section, or remove "
                                    "[coupling] for a standalone run");
        sec = nullptr;  // [grid] or [coupling] in a standalone scene: unknown, as before
      }
      if (!sec) {
        if (v.is_table() || v.is_array_of_tables())
          fail(k.source().begin.line, "[" + name + "]: unknown section; allowed: " +
                                          section_list(coupled) + suggestion(name, sections));
        bad(v, name, "unknown key at the top level; keys belong in one of the sections " +
                         section_list(coupled) + suggestion(name, sections));
      }
      if (sec->array) {
        if (!v.is_array_of_tables())
          fail(v.source().begin.line,
               std::string(v.is_table() ? "[" : "") + sec->name + (v.is_table() ? "]" : "") +
                   ": must be an array of tables: write each sheet as [[" + sec->name +
                   "]] with keys " + join(sec->keys, "", ""));
        std::size_t i = 0;
        for (const toml::node& e : *v.as_array())
          check_keys(*sec, *e.as_table(), std::string(sec->name) + "[" + std::to_string(i++) + "]",
                     coupled);
      } else {
        if (!v.is_table())
          bad(v, sec->name,
              std::string("must be a table: a section [") + sec->name + "] with keys " +
                  join(allowed_keys(*sec, coupled), "", ""));
        check_keys(*sec, *v.as_table(), sec->name, coupled);
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

  /// A length in micrometres: > 0 and within SolidSceneLimits' range.
  std::optional<double> length_um(const Scope& s, const char* key, const std::string& what) const {
    const auto v = positive(s, key, what);
    if (v && !length_in_range(*v))
      bad(*s.node(key), s.key(key), length_range_text() + " (" + what + ")");
    return v;
  }

 private:
  static std::vector<const char*> allowed_keys(const Section& sec, bool coupled) {
    std::vector<const char*> keys = sec.keys;
    if (coupled) keys.insert(keys.end(), sec.fluid_keys.begin(), sec.fluid_keys.end());
    return keys;
  }

  void check_keys(const Section& sec, const toml::table& t, const std::string& name,
                  bool coupled) const {
    const std::vector<const char*> keys = allowed_keys(sec, coupled);
    for (auto&& [kk, vv] : t) {
      const std::string key(kk.str());
      const bool known =
          std::any_of(keys.begin(), keys.end(), [&](const char* a) { return key == a; });
      if (!known)
        bad(vv, name + "." + key,
            std::string("unknown key in ") + (sec.array ? "[[" : "[") + sec.name +
                (sec.array ? "]]" : "]") + "; allowed: " + join(keys, "", "") +
                suggestion(key, keys));
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
  if (const auto v = r.length_um(sec, "cutoff_um", "the cut-off sigma, micrometres"))
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
        if (!length_in_range(h[c]))
          r.bad(*n, sec.key("spacing_um"), length_range_text() + " (the CGP spacings)");
      }
      spec.width_spacing_bohr = h[0] * kMicrometre / PhysicalConstants::bohr_m;
      spec.height_spacing_bohr = h[1] * kMicrometre / PhysicalConstants::bohr_m;
    } else if (const auto v = r.length_um(sec, "spacing_um", "the CGP spacing, micrometres")) {
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
        if (std::abs(v) > SolidSceneLimits::length_max_um)
          r.bad(*n, sec.key("base_um"), "must lie within 1e6 micrometres of the origin on each axis");
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

void load_grid(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("grid");
  if (const auto v = r.length_um(sec, "dx_um", "micrometres per lattice cell, dx_LB = dx_CG"))
    s.dx_m = *v * kMicrometre;
}

/// [coupling] scheme, max_iterations, tolerance, relaxation (protocol/coupling_scheme.hpp);
/// the fluid's parser checks the same limits.
void load_scheme(const Reader& r, const Scope& sec, protocol::SchemeSettings& out) {
  using protocol::ImplicitSettings;
  if (const auto i = r.choice(sec, "scheme", {"serial", "implicit", "parallel"}))
    out.scheme = static_cast<protocol::CouplingScheme>(*i);
  ImplicitSettings& m = out.implicit;
  if (const auto v = r.integer_in(sec, "max_iterations", 1, ImplicitSettings::max_iterations_max,
                                  " (sub-iterations per LB step of the implicit scheme)"))
    m.max_iterations = *v;
  if (const auto v = r.number(sec, "tolerance")) {
    if (!(*v >= ImplicitSettings::tolerance_min && *v < 1.0))
      r.bad(*sec.node("tolerance"), sec.key("tolerance"),
            "must be a number in [1e-14, 1) (the implicit scheme's relative change of the fluid sample at convergence)");
    m.tolerance = *v;
  }
  if (const auto v = r.number(sec, "relaxation")) {
    if (!(*v > 0.0 && *v <= 1.0))
      r.bad(*sec.node("relaxation"), sec.key("relaxation"),
            "must be a number in (0, 1] (the implicit scheme's first Aitken relaxation factor; "
            "default 0.5)");
    m.relaxation = *v;
  }
  if (out.scheme != protocol::CouplingScheme::Implicit)
    for (const char* key : {"max_iterations", "tolerance", "relaxation"})
      if (const toml::node* n = sec.node(key))
        r.bad(*n, sec.key(key), std::string("belongs to coupling.scheme = \"implicit\"; this scene's scheme is \"") +
                                    protocol::scheme_name(out.scheme) + "\"");
}

void load_coupling(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("coupling");
  CouplingSettings c;
  if (const auto v = r.integer_in(sec, "time_ratio", 1, CouplingSettings::time_ratio_max,
                                  " (A_T = dt_LB / dt_CG: CGP substeps per LB step)"))
    c.time_ratio = *v;
  if (const auto v = r.integer(sec, "rigid_steps")) {
    if (*v < 0)
      r.bad(*sec.node("rigid_steps"), sec.key("rigid_steps"),
            "must be an integer >= 0 (LB steps of spin-up with the sheets held rigid)");
    c.rigid_steps = *v;
  }
  if (const auto v = r.integer(sec, "checkpoint_every")) {
    if (*v < 0)
      r.bad(*sec.node("checkpoint_every"), sec.key("checkpoint_every"),
            "must be an integer >= 0 (LB steps between coupled checkpoints; 0: none)");
    c.checkpoint_every = *v;
  }
  load_scheme(r, sec, c.scheme);
  for (const auto& [key, target] : {std::pair{"handshake_timeout_s", &c.handshake_timeout_s},
                                    std::pair{"peer_timeout_s", &c.peer_timeout_s},
                                    std::pair{"resend_after_s", &c.resend_after_s}}) {
    if (const auto v = r.number(sec, key)) {
      if (!(*v > 0.0) || *v > CouplingSettings::timeout_max_s)
        r.bad(*sec.node(key), sec.key(key), "must be a number of seconds in (0, 86400]");
      *target = *v;
    }
  }
  if (!(c.resend_after_s < c.peer_timeout_s)) {
    // Reported at resend_after_s if the file sets it, else at peer_timeout_s.
    const std::string why = "resend requests must come before the peer is given up";
    if (sec.node("resend_after_s"))
      r.bad(*sec.node("resend_after_s"), sec.key("resend_after_s"),
            "must be below coupling.peer_timeout_s = " + format_double(c.peer_timeout_s) +
                (sec.node("peer_timeout_s") ? "" : " (the default)") + "; " + why);
    r.bad(*sec.node("peer_timeout_s"), sec.key("peer_timeout_s"),
          "must be above coupling.resend_after_s = " + format_double(c.resend_after_s) +
              " (the default); " + why);
  }
  if (const auto v = r.string(sec, "lcm_url")) {
    if (const std::string why = lcm_url_problem(*v); !why.empty())
      r.bad(*sec.node("lcm_url"), sec.key("lcm_url"), why);
    c.lcm_url = *v;
  }
  if (const auto v = r.string(sec, "channel_prefix")) {
    try {
      protocol::validate_channel_prefix(*v);
    } catch (const std::invalid_argument& e) {
      r.bad(*sec.node("channel_prefix"), sec.key("channel_prefix"), e.what());
    }
    c.channel_prefix = *v;
  }
  s.coupling = c;
}

/// [watchdog] (protocol/watchdog.hpp): every key through the table both servers share.
void load_watchdog(const Reader& r, SolidScene& s) {
  const Scope sec = r.section("watchdog");
  if (!sec.table) return;
  for (const auto& [key, type] : protocol::watchdog_keys()) {
    const toml::node* n = sec.node(key);
    if (!n) continue;
    double v = 0.0;
    if (type == protocol::WatchdogKeyType::Boolean)
      v = *r.boolean(sec, key) ? 1.0 : 0.0;
    else if (type == protocol::WatchdogKeyType::Integer)
      v = double(*r.integer(sec, key));
    else
      v = *r.number(sec, key);
    const std::string why = protocol::set_watchdog_value(s.watchdog, key, v);
    if (!why.empty()) r.bad(*n, sec.key(key), why);
  }
  const std::string why = protocol::watchdog_consistency_problem(s.watchdog);
  if (!why.empty()) r.fail(sec.line, why);
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
    if (!length_in_range(*a))
      r.bad(*pert.node("tip_displacement_um"), pert.key("tip_displacement_um"),
            "|value| " + length_range_text() + " (along the sheet normal)");
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

std::string lcm_url_problem(std::string_view url) {
  const std::string allowed = std::string("a coupled run talks over udpm:// with ttl=0, so that "
                                          "packets never leave this machine (default ") +
                              std::string(CouplingSettings::default_lcm_url) +
                              "), or over memq:// (one process)";
  if (url.starts_with("memq://")) return "";
  if (!url.starts_with("udpm://")) return "not allowed: " + allowed;
  const std::size_t q = url.find('?');
  bool ttl0 = false;
  if (q != std::string_view::npos) {
    std::string_view rest = url.substr(q + 1);
    while (!rest.empty()) {
      const std::size_t amp = rest.find('&');
      const std::string_view item = rest.substr(0, amp);
      rest = amp == std::string_view::npos ? std::string_view() : rest.substr(amp + 1);
      if (!item.starts_with("ttl=")) continue;
      if (item != "ttl=0")
        return std::string(item) + " is not allowed: the ttl must be 0; " + allowed;
      ttl0 = true;
    }
  }
  if (!ttl0) return "has no ttl=0: " + allowed;
  return "";
}

protocol::UnitInputs SolidScene::unit_inputs() const {
  protocol::UnitInputs in;  // Table 1's air
  in.dx_m = dx_m;
  if (coupling) in.time_ratio = coupling->time_ratio;
  return in;
}

double cantilever_load_shape(double s) { return (6.0 * s * s - 4.0 * s * s * s + s * s * s * s) / 3.0; }

SolidScene load_solid_scene(const std::string& path) {
  const toml::table root = parse(path);
  const Reader r(path, root);
  const bool coupled = root.contains("coupling");
  r.check_known_keys(coupled);

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
  if (coupled) {
    load_grid(r, s);
    load_coupling(r, s);
    load_watchdog(r, s);
    s.dt_s = protocol::UnitConverter(s.unit_inputs()).dt_cg_s();  // dt_CG = dt_LB / A_T
    s.dt_is_default = true;
    s.substeps = 0;
    s.record_every = 1;
  } else {
    load_run(r, s);
    load_mode_sections(r, s);
  }

  s.output_dir = "out/" + s.name;
  const Scope out = r.section("output");
  if (const auto d = r.string(out, "directory")) {
    if (d->empty()) r.bad(*out.node("directory"), out.key("directory"), "must not be empty");
    s.output_dir = *d;
  }
  if (const auto e = r.integer(out, "sheets_every")) {
    if (*e < 0)
      r.bad(*out.node("sheets_every"), out.key("sheets_every"),
            std::string("must be an integer >= 0 (0: no sheet snapshots; N: sheets_NNNNNN.h5 "
                        "and sheets.xmf every N ") +
                (coupled ? "LB steps" : "substeps") + ", at the first and the last)");
    s.sheets_every = *e;
  }
  return s;
}

void apply_overrides(SolidScene& s, const SolidSceneOverrides& o) {
  const auto fail = [](const std::string& opt, const std::string& value, const std::string& msg) {
    throw SolidSceneError(one_line("command line: " + opt + " = " + value + ": " + msg));
  };
  const auto quoted = [](const std::string& v) {
    std::string q(1, '"');  // not "\"" + ...: GCC 12 warns falsely (-Wrestrict)
    q += one_line(v);
    q += '"';
    return shorten(q);
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
    if (const std::string why = lcm_url_problem(*o.lcm_url); !why.empty())
      fail("--lcm-url", quoted(*o.lcm_url), why);
    s.coupling->lcm_url = *o.lcm_url;
  }
  if (o.time_ratio) {
    if (!s.coupled()) fail("--time-ratio", std::to_string(*o.time_ratio), only_coupled);
    if (*o.time_ratio < 1 || *o.time_ratio > CouplingSettings::time_ratio_max)
      fail("--time-ratio", std::to_string(*o.time_ratio),
           "must be an integer from 1 to 1000000 (A_T = dt_LB / dt_CG: CGP substeps per LB step)");
    s.coupling->time_ratio = static_cast<int>(*o.time_ratio);
    s.dt_s = protocol::UnitConverter(s.unit_inputs()).dt_cg_s();  // dt_CG = dt_LB / A_T
  }
}

}  // namespace cosim::solid
