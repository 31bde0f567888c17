#include "fluid/scene_config.hpp"

#include "protocol/channels.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>

#include <toml++/toml.h>

#include "fluid/d3q19.hpp"
#include "fluid/grid_layout.hpp"
#include "protocol/watchdog.hpp"

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
//    against this machine's memory as well, so a typo fails here and not in malloc.
//  - threads <= 1024: more than any machine this runs on; a larger number is a typo.
//  - dx_um and reference_length_um in [1e-9, 1e6] micrometres (a femtometre to a metre):
//    far beyond any scene either way, and the conversions (cells, dt = dx / c, Re) stay
//    positive finite numbers (1e308 um gives an infinite domain, 1e-320 um a zero dt).
//  - a tau derived from reynolds must be > 1/2 like a given one: a huge Re (or a tiny
//    L / dx) rounds nu = U L / Re to 0 and tau to exactly 1/2.

namespace cosim::fluid {

namespace {

namespace fs = std::filesystem;

constexpr const char* kKindList = "\"periodic\", \"wall\", \"free_slip\", \"inlet\", \"outflow\"";

/// Keys allowed in each section; everything else is an error.
struct Section {
  const char* name;
  std::vector<const char*> keys;
};

std::vector<const char*> watchdog_key_names() {
  std::vector<const char*> names;
  for (const auto& [name, type] : protocol::watchdog_keys()) names.push_back(name);
  return names;
}

const std::vector<Section>& schema() {
  static const std::vector<Section> s = {
      {"scene", {"name", "description"}},
      {"grid", {"nx", "ny", "nz", "dx_um"}},
      {"fluid", {"tau", "reynolds", "reference_length_um"}},
      {"inlet", {"u_max", "profile", "boundary_layer_um", "density"}},
      {"boundaries", {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"}},
      {"wall_velocity", {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"}},
      {"body_force", {"x", "y", "z"}},
      {"run", {"steps", "monitor_every", "mach_limit", "threads", "initial", "precision"}},
      // sheets_every belongs to the solid (snapshots of its CGPs) in coupled scenes.
      {"output", {"directory", "fields_every", "planes_every", "planes_y", "sheets_every"}},
      {"coupling",
       {"time_ratio", "rigid_steps", "handshake_timeout_s", "peer_timeout_s", "resend_after_s",
        "checkpoint_every", "scheme", "max_iterations", "tolerance", "relaxation",
        "lcm_url", "channel_prefix"}},
      // The stability watchdog (protocol/watchdog.hpp): the same table in both servers.
      {"watchdog", watchdog_key_names()},
  };
  return s;
}

/// Sections of a coupled scene that belong to the solid process (solid/solid_scene.cpp
/// checks them); the fluid only requires [coupling] beside them.
bool is_solid_section(std::string_view name) {
  return name == "solid" || name == "sheet" || name == "contact";
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
  // Up to 2 edits, or 3 for long names ("boundary" for "boundaries").
  std::size_t best = got.size() >= 8 ? 4 : 3;
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

std::string format_fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

/// A value as the user wrote it (close enough): strings quoted, arrays inline.
std::string show(const toml::node& n) {
  if (const auto* s = n.as_string()) {
    std::string out(1, '"');
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

std::string human_bytes(double b) {
  const char* unit[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (b >= 1024.0 && u < 6) b /= 1024.0, ++u;
  return format_fixed(b, u == 0 ? 0 : 1) + " " + unit[u];
}

/// Reads typed values out of the document and reports problems with file and line.
class Reader {
 public:
  Reader(std::string path, const toml::table& root) : path_(std::move(path)), root_(root) {}

  [[noreturn]] void fail(std::uint32_t line, const std::string& what) const {
    std::string where = path_;
    if (line > 0) where += ":" + std::to_string(line);
    throw SceneError(one_line(where + ": " + what));
  }
  /// "KEY = VALUE: msg" at the value's line.
  [[noreturn]] void bad(const toml::node& v, const std::string& key,
                        const std::string& msg) const {
    fail(v.source().begin.line, key + " = " + show(v) + ": " + msg);
  }
  /// A required key is absent: reported at its section's line when the section exists.
  [[noreturn]] void missing(const std::string& key, const std::string& what) const {
    const std::size_t dot = key.find('.');
    const std::uint32_t line =
        dot == std::string::npos ? 0 : section_line(key.substr(0, dot).c_str());
    fail(line, key + ": missing; " + what);
  }

  /// Every section and key must be in the schema.
  void check_known_keys() const {
    std::vector<const char*> sections;
    for (const Section& s : schema()) sections.push_back(s.name);
    for (auto&& [k, v] : root_) {
      if (is_solid_section(k.str())) {
        if (!root_.get("coupling"))
          fail(k.source().begin.line,
               "[" + std::string(k.str()) + "]: a solid section needs a [coupling] section (a "
               "coupled scene); a fluid-only scene has no sheets");
        continue;
      }
      const Section* sec = find_section(k.str());
      if (!sec) {
        const std::string name(k.str());
        if (v.is_table())
          fail(k.source().begin.line, "[" + name + "]: unknown section; allowed: " +
                                          join(sections, "[", "]") + suggestion(name, sections));
        bad(v, name, "unknown key at the top level; keys belong in one of the sections " +
                         join(sections, "[", "]") + suggestion(name, sections));
      }
      if (!v.is_table())
        bad(v, sec->name,
            std::string("must be a table: a section [") + sec->name + "] with keys " +
                join(sec->keys, "", ""));
      for (auto&& [kk, vv] : *v.as_table()) {
        const std::string key(kk.str());
        const bool known = std::any_of(sec->keys.begin(), sec->keys.end(),
                                       [&](const char* a) { return key == a; });
        if (!known)
          bad(vv, std::string(sec->name) + "." + key,
              std::string("unknown key in [") + sec->name + "]; allowed: " +
                  join(sec->keys, "", "") + suggestion(key, sec->keys));
      }
    }
  }

  const toml::table* section(const char* name) const {
    const toml::node* n = root_.get(name);
    return n ? n->as_table() : nullptr;  // a non-table was rejected by check_known_keys
  }
  std::uint32_t section_line(const char* name) const {
    const toml::node* n = root_.get(name);
    return n ? n->source().begin.line : 0;
  }

  const toml::node* node(const char* sec, const char* key) const {
    const toml::table* t = section(sec);
    return t ? t->get(key) : nullptr;
  }

  std::optional<double> number(const char* sec, const char* key) const {
    const toml::node* n = node(sec, key);
    if (!n) return std::nullopt;
    double v = 0.0;
    if (const auto* i = n->as_integer())
      v = double(i->get());
    else if (const auto* d = n->as_floating_point())
      v = d->get();
    else
      bad(*n, dotted(sec, key), std::string("must be a number, not ") + type_name(*n));
    if (!std::isfinite(v)) bad(*n, dotted(sec, key), "must be a finite number");
    return v;
  }

  std::optional<std::int64_t> integer(const char* sec, const char* key) const {
    const toml::node* n = node(sec, key);
    if (!n) return std::nullopt;
    const auto* i = n->as_integer();
    if (!i) bad(*n, dotted(sec, key), std::string("must be an integer, not ") + type_name(*n));
    return i->get();
  }

  std::optional<std::string> string(const char* sec, const char* key) const {
    const toml::node* n = node(sec, key);
    if (!n) return std::nullopt;
    const auto* s = n->as_string();
    if (!s) bad(*n, dotted(sec, key), std::string("must be a string, not ") + type_name(*n));
    return s->get();
  }

  /// A string from a closed list; returns its index.
  std::optional<std::size_t> choice(const char* sec, const char* key,
                                    const std::vector<const char*>& allowed) const {
    const std::optional<std::string> s = string(sec, key);
    if (!s) return std::nullopt;
    for (std::size_t i = 0; i < allowed.size(); ++i)
      if (*s == allowed[i]) return i;
    bad(*node(sec, key), dotted(sec, key),
        "must be one of " + join(allowed, "\"", "\"") + suggestion(*s, allowed));
  }

  static std::string dotted(const char* sec, const char* key) {
    return std::string(sec) + "." + key;
  }

 private:
  static const Section* find_section(std::string_view name) {
    for (const Section& s : schema())
      if (name == s.name) return &s;
    return nullptr;
  }

  std::string path_;
  const toml::table& root_;
};

double mach(double u) { return std::abs(u) * std::sqrt(3.0); }

std::string mach_text(double u, double limit) {
  return "Mach " + format_fixed(mach(u), 3) + " (= |u| sqrt(3)) exceeds run.mach_limit = " +
         format_double(limit) + "; the largest allowed speed is " +
         format_fixed(limit / std::sqrt(3.0), 4) + " (lattice units, U/c)";
}

bool valid_name(const std::string& s) {
  return !s.empty() && s.size() <= 64 &&
         std::all_of(s.begin(), s.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
         }) &&
         s != "." && s != "..";
}

std::size_t machine_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;
  return std::size_t(pages) * std::size_t(page);
}

toml::table parse(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw SceneError(one_line(path + ": cannot read the scene file: no such file"));
  if (!fs::is_regular_file(path, ec))
    throw SceneError(one_line(path + ": cannot read the scene file: not a regular file"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(one_line(path + ": cannot read the scene file: permission denied?"));
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return toml::parse(text.str(), path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw SceneError(one_line(path + ":" + std::to_string(b.line) + ":" +
                              std::to_string(b.column) + ": TOML syntax error: " +
                              std::string(e.description())));
  }
}

void load_grid(const Reader& r, FluidScene& s) {
  const std::string range = "an integer number of cells from " +
                            std::to_string(SceneLimits::grid_min) + " to " +
                            std::to_string(SceneLimits::grid_max);
  if (!r.section("grid")) r.missing("[grid]", "the section with nx, ny, nz is required");
  int* dims[3] = {&s.params.shape.nx, &s.params.shape.ny, &s.params.shape.nz};
  const char* keys[3] = {"nx", "ny", "nz"};
  for (int a = 0; a < 3; ++a) {
    const auto n = r.integer("grid", keys[a]);
    if (!n) r.missing(Reader::dotted("grid", keys[a]), range);
    if (*n < SceneLimits::grid_min || *n > SceneLimits::grid_max)
      r.bad(*r.node("grid", keys[a]), Reader::dotted("grid", keys[a]),
            "must be " + range +
                (*n < SceneLimits::grid_min ? " (below 8 the boundary layers of opposite faces "
                                              "overlap)"
                                            : ""));
    *dims[a] = int(*n);
  }
  if (const auto dx = r.number("grid", "dx_um")) {
    if (!(*dx > 0.0))
      r.bad(*r.node("grid", "dx_um"), "grid.dx_um", "must be > 0 (micrometres per cell)");
    if (!(*dx >= SceneLimits::length_min_um && *dx <= SceneLimits::length_max_um))
      r.bad(*r.node("grid", "dx_um"), "grid.dx_um", "must be in [1e-9, 1e6] micrometres per cell");
    s.dx_um = *dx;
  }
}

/// The population grids of the grid and run.precision must fit in this machine's memory.
void check_memory(const Reader& r, const FluidScene& s) {
  const std::size_t need = population_bytes(s.params.shape, s.params.precision);
  const std::size_t have = machine_memory_bytes();
  if (have > 0 && need > have)
    r.fail(r.section_line("grid"),
           "grid = " + std::to_string(s.params.shape.nx) + " x " +
               std::to_string(s.params.shape.ny) + " x " + std::to_string(s.params.shape.nz) +
               ": the two population grids need " + human_bytes(double(need)) +
               ", more than this machine's memory (" + human_bytes(double(have)) +
               "); reduce nx, ny, nz");
}

/// [coupling] scheme, max_iterations, tolerance, relaxation (protocol/coupling_scheme.hpp);
/// the solid's parser checks the same limits.
void load_scheme(const Reader& r, protocol::SchemeSettings& out) {
  using protocol::ImplicitSettings;
  if (const auto i = r.choice("coupling", "scheme", {"serial", "implicit", "parallel"}))
    out.scheme = static_cast<protocol::CouplingScheme>(*i);
  ImplicitSettings& m = out.implicit;
  if (const auto v = r.integer("coupling", "max_iterations")) {
    if (*v < 1 || *v > ImplicitSettings::max_iterations_max)
      r.bad(*r.node("coupling", "max_iterations"), "coupling.max_iterations",
            "must be an integer from 1 to " + std::to_string(ImplicitSettings::max_iterations_max) +
                " (sub-iterations per LB step of the implicit scheme)");
    m.max_iterations = int(*v);
  }
  if (const auto v = r.number("coupling", "tolerance")) {
    if (!(*v >= ImplicitSettings::tolerance_min && *v < 1.0))
      r.bad(*r.node("coupling", "tolerance"), "coupling.tolerance",
            "must be a number in [1e-14, 1) (the implicit scheme's relative change of the fluid sample at convergence)");
    m.tolerance = *v;
  }
  if (const auto v = r.number("coupling", "relaxation")) {
    if (!(*v > 0.0 && *v <= 1.0))
      r.bad(*r.node("coupling", "relaxation"), "coupling.relaxation",
            "must be a number in (0, 1] (the implicit scheme's first Aitken relaxation factor; "
            "default 0.5)");
    m.relaxation = *v;
  }
  if (out.scheme != protocol::CouplingScheme::Implicit)
    for (const char* key : {"max_iterations", "tolerance", "relaxation"})
      if (const toml::node* n = r.node("coupling", key))
        r.bad(*n, std::string("coupling.") + key, std::string("belongs to coupling.scheme = \"implicit\"; this scene's scheme is \"") +
                                                   protocol::scheme_name(out.scheme) + "\"");
}

void load_coupling(const Reader& r, FluidScene& s) {
  if (!r.section("coupling")) return;
  CouplingSettings c;
  if (const auto v = r.integer("coupling", "time_ratio")) {
    if (*v < 1 || *v > 1000000)
      r.bad(*r.node("coupling", "time_ratio"), "coupling.time_ratio",
            "must be an integer from 1 to 1000000 (A_T = dt_LB / dt_CG)");
    c.time_ratio = int(*v);
  }
  if (const auto v = r.integer("coupling", "rigid_steps")) {
    if (*v < 0)
      r.bad(*r.node("coupling", "rigid_steps"), "coupling.rigid_steps", "must be an integer >= 0");
    c.rigid_steps = *v;
  }
  if (const auto v = r.integer("coupling", "checkpoint_every")) {
    if (*v < 0)
      r.bad(*r.node("coupling", "checkpoint_every"), "coupling.checkpoint_every",
            "must be an integer >= 0 (LB steps between coupled checkpoints; 0: none)");
    c.checkpoint_every = *v;
  }
  load_scheme(r, c.scheme);
  for (auto [key, target] : {std::pair{"handshake_timeout_s", &c.handshake_timeout_s},
                             std::pair{"peer_timeout_s", &c.peer_timeout_s},
                             std::pair{"resend_after_s", &c.resend_after_s}}) {
    if (const auto v = r.number("coupling", key)) {
      if (!(*v > 0.0) || *v > 86400.0)
        r.bad(*r.node("coupling", key), std::string("coupling.") + key,
              "must be a number of seconds in (0, 86400]");
      *target = *v;
    }
  }
  if (!(c.resend_after_s < c.peer_timeout_s))
    r.fail(r.section_line("coupling"),
           "coupling.resend_after_s = " + std::to_string(c.resend_after_s) +
               ": must be below coupling.peer_timeout_s = " + std::to_string(c.peer_timeout_s));
  if (const auto v = r.string("coupling", "lcm_url")) {
    const bool udpm = v->rfind("udpm://", 0) == 0;
    if (udpm ? v->find("ttl=0") == std::string::npos : v->rfind("memq://", 0) != 0)
      r.bad(*r.node("coupling", "lcm_url"), "coupling.lcm_url",
            "must be a udpm:// URL with ttl=0 (packets never leave this machine) or memq://");
    c.lcm_url = *v;
  }
  if (const auto v = r.string("coupling", "channel_prefix")) {
    try {
      protocol::validate_channel_prefix(*v);
    } catch (const std::invalid_argument& e) {
      r.bad(*r.node("coupling", "channel_prefix"), "coupling.channel_prefix", e.what());
    }
    c.channel_prefix = *v;
  }
  s.coupling = c;
}

/// [watchdog] (protocol/watchdog.hpp): every key through the table both servers share.
void load_watchdog(const Reader& r, FluidScene& s) {
  const toml::table* sec = r.section("watchdog");
  if (!sec) return;
  for (const auto& [key, type] : protocol::watchdog_keys()) {
    const toml::node* n = r.node("watchdog", key);
    if (!n) continue;
    const std::string dotted = Reader::dotted("watchdog", key);
    double v = 0.0;
    if (type == protocol::WatchdogKeyType::Boolean) {
      const auto* b = n->as_boolean();
      if (!b) r.bad(*n, dotted, std::string("must be true or false, not ") + type_name(*n));
      v = b->get() ? 1.0 : 0.0;
    } else if (type == protocol::WatchdogKeyType::Integer) {
      v = double(*r.integer("watchdog", key));
    } else {
      v = *r.number("watchdog", key);
    }
    const std::string why = protocol::set_watchdog_value(s.watchdog, key, v);
    if (!why.empty()) r.bad(*n, dotted, why);
  }
  const std::string why = protocol::watchdog_consistency_problem(s.watchdog);
  if (!why.empty()) r.fail(r.section_line("watchdog"), why);
}

void load_run(const Reader& r, FluidScene& s) {
  if (!r.section("run")) r.missing("[run]", "the section with steps is required");
  if (const auto m = r.number("run", "mach_limit")) {
    if (!(*m > 0.0 && *m <= SceneLimits::mach_limit_max))
      r.bad(*r.node("run", "mach_limit"), "run.mach_limit",
            "must be in (0, 0.5]; 0.3 is the usual weakly-compressible limit, above 0.5 the "
            "second-order equilibrium is no model of the flow");
    s.mach_limit = *m;
  }
  const auto steps = r.integer("run", "steps");
  if (!steps) r.missing("run.steps", "the number of LB steps, an integer >= 1");
  if (*steps < 1) r.bad(*r.node("run", "steps"), "run.steps", "must be an integer >= 1");
  s.steps = *steps;
  if (const auto m = r.integer("run", "monitor_every")) {
    if (*m < 1) r.bad(*r.node("run", "monitor_every"), "run.monitor_every", "must be >= 1");
    s.monitor_every = *m;
  }
  if (const auto t = r.integer("run", "threads")) {
    if (*t < 0 || *t > SceneLimits::threads_max)
      r.bad(*r.node("run", "threads"), "run.threads",
            "must be in [0, 1024]; 0 leaves the choice to OpenMP (OMP_NUM_THREADS)");
    s.threads = int(*t);
  }
  // How the populations are stored; the arithmetic is double either way.
  if (const auto p = r.choice("run", "precision", {"double", "single"}))
    s.params.precision = *p == 0 ? Precision::Double : Precision::Single;
}

void load_boundaries(const Reader& r, FluidScene& s) {
  static const std::vector<const char*> kinds = {"periodic", "wall", "free_slip", "inlet",
                                                 "outflow"};
  static const FaceKind kind_of[] = {FaceKind::Periodic, FaceKind::Wall, FaceKind::FreeSlip,
                                     FaceKind::Inlet, FaceKind::Outflow};
  if (!r.section("boundaries"))
    r.missing("[boundaries]", std::string("the section with x_min, x_max, y_min, y_max, "
                                          "z_min, z_max, each one of ") + kKindList);
  for (int f = 0; f < kFaces; ++f) {
    const auto k = r.choice("boundaries", face_name(f), kinds);
    if (!k)
      r.missing(Reader::dotted("boundaries", face_name(f)),
                std::string("all six faces are required, each one of ") + kKindList);
    s.params.faces[f].kind = kind_of[*k];
  }
  for (int a = 0; a < 3; ++a) {
    const FaceSpec& lo = s.params.faces[2 * a];
    const FaceSpec& hi = s.params.faces[2 * a + 1];
    if ((lo.kind == FaceKind::Periodic) != (hi.kind == FaceKind::Periodic)) {
      const toml::node& n = *r.node("boundaries", face_name(2 * a));
      r.fail(n.source().begin.line,
             std::string("boundaries.") + face_name(2 * a) + " = \"" + kind_name(lo.kind) +
                 "\", boundaries." + face_name(2 * a + 1) + " = \"" + kind_name(hi.kind) +
                 "\": a periodic face needs a periodic partner; make both periodic or neither");
    }
  }
}

void load_wall_velocity(const Reader& r, FluidScene& s) {
  if (!r.section("wall_velocity")) return;
  for (int f = 0; f < kFaces; ++f) {
    const toml::node* n = r.node("wall_velocity", face_name(f));
    if (!n) continue;
    const std::string key = Reader::dotted("wall_velocity", face_name(f));
    if (s.params.faces[f].kind != FaceKind::Wall)
      r.bad(*n, key,
            std::string("only a wall can move, and boundaries.") + face_name(f) + " is \"" +
                kind_name(s.params.faces[f].kind) + "\"");
    const toml::array* a = n->as_array();
    const char* shape = "must be an array of three numbers [ux, uy, uz] in lattice units (U/c)";
    if (!a || a->size() != 3) r.bad(*n, key, shape);
    std::array<double, 3> u{};
    for (int c = 0; c < 3; ++c) {
      const toml::node& e = *a->get(std::size_t(c));
      if (const auto* i = e.as_integer())
        u[c] = double(i->get());
      else if (const auto* d = e.as_floating_point())
        u[c] = d->get();
      else
        r.bad(*n, key, shape);
      if (!std::isfinite(u[c])) r.bad(*n, key, shape);
    }
    if (u[face_axis(f)] != 0.0)
      r.bad(*n, key,
            std::string("must be tangential: the component along the normal of ") +
                face_name(f) + " must be 0");
    const double speed = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (mach(speed) > s.mach_limit) r.bad(*n, key, mach_text(speed, s.mach_limit));
    s.params.faces[f].wall_velocity = u;
  }
}

void load_inlet(const Reader& r, FluidScene& s) {
  const bool has_inlet = std::any_of(s.params.faces.begin(), s.params.faces.end(),
                                     [](const FaceSpec& f) { return f.kind == FaceKind::Inlet; });
  const toml::table* sec = r.section("inlet");
  if (!has_inlet) {
    if (sec)
      r.fail(r.section_line("inlet"),
             "[inlet]: given, but no face of [boundaries] is \"inlet\"; remove the section or "
             "make a face an inlet");
    return;
  }
  if (!sec) r.missing("[inlet]", "a face is \"inlet\", so [inlet] with u_max is required");
  const auto u = r.number("inlet", "u_max");
  if (!u) r.missing("inlet.u_max", "the inlet speed in lattice units (U_max/c), >= 0");
  if (*u < 0.0)
    r.bad(*r.node("inlet", "u_max"), "inlet.u_max",
          "must be >= 0 (the speed into the domain, lattice units U/c)");
  if (mach(*u) > s.mach_limit) r.bad(*r.node("inlet", "u_max"), "inlet.u_max", mach_text(*u, s.mach_limit));

  const auto profile = r.choice("inlet", "profile", {"uniform", "blasius"});
  const bool blasius = profile && *profile == 1;
  double layer_cells = 0.0;
  const toml::node* layer_node = r.node("inlet", "boundary_layer_um");
  if (blasius) {
    if (s.params.faces[YMin].kind != FaceKind::Wall)
      r.bad(*r.node("inlet", "profile"), "inlet.profile",
            std::string("needs boundaries.y_min = \"wall\" (the Blasius layer grows from the "
                        "y_min plate), not \"") +
                kind_name(s.params.faces[YMin].kind) + "\"");
    for (int f = YMin; f <= YMax; ++f)
      if (s.params.faces[f].kind == FaceKind::Inlet)
        r.bad(*r.node("inlet", "profile"), "inlet.profile",
              std::string("is not possible with boundaries.") + face_name(f) +
                  " = \"inlet\": the Blasius layer grows along the y_min plate, so the inlet "
                  "must be an x or z face");
    const auto layer = r.number("inlet", "boundary_layer_um");
    const double height_um = s.params.shape.ny * s.dx_um;
    const std::string range = "the layer thickness in micrometres, in (0, ny dx_um = " +
                              format_double(height_um) + "]";
    if (!layer) r.missing("inlet.boundary_layer_um", "profile = \"blasius\" needs " + range);
    if (!(*layer > 0.0 && *layer <= height_um))
      r.bad(*layer_node, "inlet.boundary_layer_um", "must be " + range);
    layer_cells = *layer / s.dx_um;
  } else if (layer_node) {
    r.bad(*layer_node, "inlet.boundary_layer_um",
          "only allowed with inlet.profile = \"blasius\" (the uniform profile has no layer)");
  }
  double density = 1.0;
  if (const auto rho = r.number("inlet", "density")) {
    if (!(*rho > 0.0))
      r.bad(*r.node("inlet", "density"), "inlet.density", "must be > 0 (lattice units, rho_0 = 1)");
    density = *rho;
  }
  for (FaceSpec& f : s.params.faces) {
    if (f.kind != FaceKind::Inlet) continue;
    f.inlet_speed = *u;
    f.profile = blasius ? InletProfile::Blasius : InletProfile::Uniform;
    f.boundary_layer = layer_cells;
    f.inlet_density = density;
  }
}

void load_body_force(const Reader& r, FluidScene& s) {
  const char* keys[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    if (const auto f = r.number("body_force", keys[a])) s.params.body_force[a] = *f;
}

void load_fluid(const Reader& r, FluidScene& s) {
  if (!r.section("fluid"))
    r.missing("[fluid]", "the section with tau, or reynolds and reference_length_um, is required");
  const auto tau = r.number("fluid", "tau");
  const auto re = r.number("fluid", "reynolds");
  const auto length = r.number("fluid", "reference_length_um");
  const double speed = reference_speed(s.params);
  s.reference_speed = speed;
  if (length) {
    if (!(*length > 0.0))
      r.bad(*r.node("fluid", "reference_length_um"), "fluid.reference_length_um",
            "must be > 0 (micrometres)");
    if (!(*length >= SceneLimits::length_min_um && *length <= SceneLimits::length_max_um))
      r.bad(*r.node("fluid", "reference_length_um"), "fluid.reference_length_um",
            "must be in [1e-9, 1e6] micrometres");
    s.reference_length_um = *length;
  }
  const std::string tau_range =
      "must be in (0.5, 2]: at or below 1/2 BGK is unstable (nu = (tau - 1/2)/3 <= 0), above 2 "
      "the bounce-back wall slip and the Knudsen number spoil the Navier-Stokes limit";
  if (tau && re)
    r.fail(r.node("fluid", "reynolds")->source().begin.line,
           "fluid.tau = " + show(*r.node("fluid", "tau")) + ", fluid.reynolds = " +
               show(*r.node("fluid", "reynolds")) +
               ": give exactly one of the two (reynolds derives tau from nu = U L / Re)");
  if (!tau && !re)
    r.missing("fluid.tau",
              "give tau (> 0.5), or reynolds with reference_length_um (tau from nu = U L / Re)");
  if (tau) {
    if (!(*tau > SceneLimits::tau_min)) {
      r.bad(*r.node("fluid", "tau"), "fluid.tau",
            "must be > 0.5 (BGK is unstable at or below 1/2: nu = (tau - 1/2)/3 <= 0)");
    }
    if (*tau > SceneLimits::tau_max) r.bad(*r.node("fluid", "tau"), "fluid.tau", tau_range);
    s.params.tau = *tau;
  } else {
    const toml::node& n = *r.node("fluid", "reynolds");
    if (!(*re > 0.0)) r.bad(n, "fluid.reynolds", "must be > 0");
    if (!length)
      r.bad(n, "fluid.reynolds",
            "needs fluid.reference_length_um, the length L of Re = U L / nu (micrometres)");
    if (!(speed > 0.0))
      r.bad(n, "fluid.reynolds",
            "needs a reference speed U: an inlet with u_max > 0 or a moving wall; give tau "
            "instead");
    const double length_cells = *length / s.dx_um;
    const double nu = speed * length_cells / *re;
    const double derived = 0.5 + 3.0 * nu;  // Eq. 13
    if (!(derived > SceneLimits::tau_min))
      r.bad(n, "fluid.reynolds",
            "gives tau = " + format_double(derived) + " (nu = U L / Re = " + format_double(nu) +
                " in lattice units): BGK is unstable at or below 1/2; lower Re, or use a finer "
                "grid or a longer reference length");
    if (derived > SceneLimits::tau_max)
      r.bad(n, "fluid.reynolds",
            "gives tau = " + format_fixed(derived, 4) + " (nu = U L / Re = " +
                format_fixed(nu, 4) + " in lattice units), above the limit 2 (bounce-back slip, "
                "Knudsen number); raise Re or U, or use a coarser grid");
    s.params.tau = derived;
  }
  if (length && speed > 0.0) {
    const double nu = (s.params.tau - 0.5) / 3.0;
    s.reynolds = speed * (s.reference_length_um / s.dx_um) / nu;
  }
}

void load_output_and_initial(const Reader& r, FluidScene& s) {
  s.output_dir = "out/" + s.name;
  if (const auto d = r.string("output", "directory")) {
    if (d->empty()) r.bad(*r.node("output", "directory"), "output.directory", "must not be empty");
    s.output_dir = *d;
  }
  if (const auto f = r.integer("output", "fields_every")) {
    if (*f < 0)
      r.bad(*r.node("output", "fields_every"), "output.fields_every",
            "must be >= 0 (0: no field output)");
    s.fields_every = *f;
  }
  if (const auto f = r.integer("output", "planes_every")) {
    if (*f < 0)
      r.bad(*r.node("output", "planes_every"), "output.planes_every",
            "must be >= 0 (0: no plane snapshots)");
    s.planes_every = *f;
  }
  if (const toml::node* n = r.node("output", "planes_y")) {
    const char* what = "must be an array of numbers in (0, 1): heights of the y planes as "
                       "fractions of the channel height (the paper's y = L/2: 0.5)";
    const toml::array* a = n->as_array();
    if (!a || a->empty() || a->size() > 16) r.bad(*n, "output.planes_y", what);
    for (const toml::node& e : *a) {
      double v = 0.0;
      if (const auto* i = e.as_integer())
        v = double(i->get());
      else if (const auto* d = e.as_floating_point())
        v = d->get();
      else
        r.bad(*n, "output.planes_y", what);
      if (!(v > 0.0 && v < 1.0)) r.bad(*n, "output.planes_y", what);
      s.planes_y.push_back(v);
    }
  }
  if (s.planes_every > 0 && s.planes_y.empty())
    r.missing("output.planes_y", "planes_every > 0 needs the planes, e.g. planes_y = [0.5, 0.3333]");
  const bool has_inlet = std::any_of(s.params.faces.begin(), s.params.faces.end(),
                                     [](const FaceSpec& f) { return f.kind == FaceKind::Inlet; });
  s.initial = has_inlet ? InitialFlow::Inlet : InitialFlow::Rest;
  if (const auto i = r.choice("run", "initial", {"rest", "inlet"})) {
    if (*i == 1 && !has_inlet)
      r.bad(*r.node("run", "initial"), "run.initial",
            "needs a face of [boundaries] that is \"inlet\"; use \"rest\"");
    s.initial = *i == 1 ? InitialFlow::Inlet : InitialFlow::Rest;
  }
}

}  // namespace

std::size_t population_bytes(const GridShape& shape, Precision precision) {
  return 2 * std::size_t(D3Q19::Q) * layout_of(shape, precision).stride() *
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
  const toml::table root = parse(path);
  const Reader r(path, root);
  r.check_known_keys();

  FluidScene s;
  s.path = path;
  s.name = fs::path(path).stem().string();
  if (const auto n = r.string("scene", "name")) {
    if (!valid_name(*n))
      r.bad(*r.node("scene", "name"), "scene.name",
            "must be 1 to 64 characters from A-Z a-z 0-9 _ - . (it names the output "
            "directory)");
    s.name = *n;
  }
  if (const auto d = r.string("scene", "description")) s.description = one_line(*d);

  load_grid(r, s);
  load_run(r, s);
  check_memory(r, s);
  load_boundaries(r, s);
  load_wall_velocity(r, s);
  load_inlet(r, s);
  load_body_force(r, s);
  load_fluid(r, s);
  load_output_and_initial(r, s);
  load_coupling(r, s);
  load_watchdog(r, s);

  // What the solver itself would refuse; the checks above should have caught all of it.
  const std::string err = BoundaryConditions::check(s.params.faces);
  if (!err.empty()) r.fail(r.section_line("boundaries"), "boundaries: " + err);
  return s;
}

void apply_overrides(FluidScene& s, const SceneOverrides& o) {
  const auto fail = [](const std::string& opt, const std::string& value, const char* msg) {
    throw SceneError(one_line("command line: " + opt + " = " + value + ": " + msg));
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
    if (*o.time_ratio < 1 || *o.time_ratio > 1000000)
      fail("--time-ratio", std::to_string(*o.time_ratio),
           "must be an integer from 1 to 1000000 (A_T = dt_LB / dt_CG)");
    s.coupling->time_ratio = int(*o.time_ratio);
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
  solver.initialize([&](int, int y, int) {
    double u[3] = {0.0, 0.0, 0.0};
    u[axis] = inward * inlet_profile(spec, y);
    return CellState{1.0, u[0], u[1], u[2]};
  });
}


}  // namespace cosim::fluid
