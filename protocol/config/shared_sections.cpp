#include "protocol/config/shared_sections.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <utility>

#include "protocol/channels.hpp"

// Why the limits are what they are:
//  - time_ratio 1..1e6: an int32 on the wire; a million substeps per LB step is beyond any
//    sheet of the paper, whose A_T is 150.
//  - timeouts in (0, 86400] s: a day; longer is a typo, and the milliseconds of PeerWatch
//    stay far from overflow. resend_after_s below peer_timeout_s: re-requests come before
//    the peer is given up.
//  - lcm_url: protocol/lcm_url.hpp (packets never leave the machine).

namespace cosim::protocol::config {

std::optional<std::string> time_ratio_problem(std::int64_t v) {
  if (v >= 1 && v <= CouplingSettings::time_ratio_max) return std::nullopt;
  return "must be an integer from 1 to " + std::to_string(CouplingSettings::time_ratio_max) +
         " (A_T = dt_LB / dt_CG: CGP substeps per LB step)";
}

namespace {

bool valid_name(const std::string& s) {
  return !s.empty() && s.size() <= 64 &&
         std::all_of(s.begin(), s.end(),
                     [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) || c == '_' ||
                              c == '-' || c == '.';
                     }) &&
         s != "." && s != "..";
}

}  // namespace

void read_scene_header(const SceneReader& scene, std::string& name, std::string& description) {
  name = std::filesystem::path(scene.path()).stem().string();
  description.clear();
  const Table sec = scene.section("scene");
  if (const auto n = sec.string("name")) {
    if (!valid_name(*n))
      sec.bad("name", "must be 1 to 64 characters from A-Z a-z 0-9 _ - . (it names the output "
                      "directory)");
    name = *n;
  }
  if (const auto d = sec.string("description")) description = one_line(*d);
}

std::optional<Medium> read_medium(const SceneReader& scene) {
  const Table fl = scene.section("fluid");
  const bool rho = fl.has("density_kg_m3"), cs = fl.has("sound_speed_m_s");
  if (!rho && !cs) return std::nullopt;
  if (rho != cs)
    fl.bad(rho ? "density_kg_m3" : "sound_speed_m_s",
           "needs fluid." + std::string(rho ? "sound_speed_m_s" : "density_kg_m3") +
               " too: a medium other than the paper's air gives its density and the lattice's sound speed");
  Medium m;
  m.density_kg_m3 = *fl.positive("density_kg_m3", "the fluid's density, kg/m^3");
  m.sound_speed_m_s = *fl.positive("sound_speed_m_s", "the lattice's sound speed c_s, m/s: dt = dx / (sqrt(3) c_s)");
  return m;
}

std::string read_output_directory(const SceneReader& scene, const std::string& scene_name) {
  const Table sec = scene.section("output");
  const auto d = sec.string("directory");
  if (!d) return "out/" + scene_name;
  if (d->empty()) sec.bad("directory", "must not be empty");
  return *d;
}

const std::vector<std::string_view>& coupling_keys() {
  static const std::vector<std::string_view> keys = {
      "time_ratio",     "rigid_steps", "handshake_timeout_s", "peer_timeout_s",
      "resend_after_s", "checkpoint_every", "scheme", "max_iterations",
      "tolerance",      "relaxation",  "lcm_url",             "channel_prefix"};
  return keys;
}

std::vector<std::string_view> watchdog_key_names() {
  std::vector<std::string_view> names;
  for (const auto& [name, type] : protocol::watchdog_keys()) names.push_back(name);
  return names;
}

namespace {

/// The schemes of the name table that sub-iterate, e.g. "implicit".
std::string iterating_schemes() {
  std::string names;
  for (const protocol::MessageOrder& o : protocol::kMessageOrders)
    if (o.several_per_step) names += (names.empty() ? "" : "\" or \"") + std::string(o.name);
  return names;
}

/// scheme, max_iterations, tolerance, relaxation (protocol/coupling_scheme.hpp).
void read_scheme(const Table& sec, protocol::SchemeSettings& out) {
  using protocol::ImplicitSettings;
  std::vector<const char*> names;  // the name table's, in the order of the enum
  for (const protocol::MessageOrder& o : protocol::kMessageOrders) names.push_back(o.name);
  if (const auto i = sec.choice("scheme", names)) out.scheme = protocol::kMessageOrders[*i].scheme;
  ImplicitSettings& m = out.implicit;
  if (const auto v = sec.integer_in("max_iterations", 1, ImplicitSettings::max_iterations_max,
                                    " (sub-iterations per LB step of the implicit scheme)"))
    m.max_iterations = *v;
  if (const auto v = sec.number("tolerance")) {
    if (!(*v >= ImplicitSettings::tolerance_min && *v < 1.0))
      sec.bad("tolerance", "must be a number in [1e-14, 1) (the implicit scheme's relative change "
                           "of the fluid sample at convergence)");
    m.tolerance = *v;
  }
  if (const auto v = sec.number("relaxation")) {
    if (!(*v > 0.0 && *v <= 1.0))
      sec.bad("relaxation", "must be a number in (0, 1] (the implicit scheme's first Aitken "
                            "relaxation factor; default 0.5)");
    m.relaxation = *v;
  }
  // The sub-iteration keys belong to a scheme that iterates (the name table's).
  if (!protocol::message_order(out.scheme).several_per_step)
    for (const char* key : {"max_iterations", "tolerance", "relaxation"})
      if (sec.has(key))
        sec.bad(key, std::string("belongs to coupling.scheme = \"") + iterating_schemes() +
                         "\"; this scene's scheme is \"" + protocol::scheme_name(out.scheme) + "\"");
}

}  // namespace

CouplingSettings read_coupling(const SceneReader& scene) {
  const Table sec = scene.section("coupling");
  CouplingSettings c;
  if (const auto v = sec.integer("time_ratio")) {
    if (const auto why = time_ratio_problem(*v)) sec.bad("time_ratio", *why);
    c.time_ratio = int(*v);
  }
  if (const auto v = sec.integer("rigid_steps")) {
    if (*v < 0)
      sec.bad("rigid_steps",
              "must be an integer >= 0 (LB steps of spin-up with the sheets held rigid)");
    c.rigid_steps = *v;
  }
  if (const auto v = sec.integer("checkpoint_every")) {
    if (*v < 0)
      sec.bad("checkpoint_every",
              "must be an integer >= 0 (LB steps between coupled checkpoints; 0: none)");
    c.checkpoint_every = *v;
  }
  read_scheme(sec, c.scheme);
  for (const auto& [key, target] : {std::pair{"handshake_timeout_s", &c.handshake_timeout_s},
                                    std::pair{"peer_timeout_s", &c.peer_timeout_s},
                                    std::pair{"resend_after_s", &c.resend_after_s}}) {
    if (const auto v = sec.number(key)) {
      if (!(*v > 0.0) || *v > CouplingSettings::timeout_max_s)
        sec.bad(key, "must be a number of seconds in (0, 86400]");
      *target = *v;
    }
  }
  if (!(c.resend_after_s < c.peer_timeout_s)) {
    // Reported at resend_after_s if the file sets it, else at peer_timeout_s.
    const std::string why = "resend requests must come before the peer is given up";
    if (sec.has("resend_after_s"))
      sec.bad("resend_after_s", "must be below coupling.peer_timeout_s = " +
                                    format_double(c.peer_timeout_s) +
                                    (sec.has("peer_timeout_s") ? "" : " (the default)") + "; " + why);
    sec.bad("peer_timeout_s", "must be above coupling.resend_after_s = " +
                                  format_double(c.resend_after_s) + " (the default); " + why);
  }
  if (const auto v = sec.string("lcm_url")) {
    if (const auto why = protocol::lcm_url_problem(*v)) {
      // One rule, two wordings that tests pin: the fluid's message starts with the rule, the
      // solid's with what is wrong (tests/fluid/test_scene.cpp coupling_ttl,
      // tests/solid/test_solid_scene.cpp coupling_ttl_one).
      if (scene.process() == Process::Fluid)
        sec.bad("lcm_url", "must be a udpm:// URL with ttl=0 or memq://; " + *why);
      sec.bad("lcm_url", *why);
    }
    c.lcm_url = *v;
  }
  if (const auto v = sec.string("channel_prefix")) {
    try {
      protocol::validate_channel_prefix(*v);
    } catch (const std::invalid_argument& e) {
      sec.bad("channel_prefix", e.what());
    }
    c.channel_prefix = *v;
  }
  return c;
}

WatchdogSettings read_watchdog(const SceneReader& scene) {
  WatchdogSettings w;
  const Table sec = scene.section("watchdog");
  if (!sec.present()) return w;
  for (const auto& [key, type] : protocol::watchdog_keys()) {
    if (!sec.has(key)) continue;
    double v = 0.0;
    if (type == protocol::WatchdogKeyType::Boolean)
      v = *sec.boolean(key) ? 1.0 : 0.0;
    else if (type == protocol::WatchdogKeyType::Integer)
      v = double(*sec.integer(key));
    else
      v = *sec.number(key);
    if (const std::string why = protocol::set_watchdog_value(w, key, v); !why.empty()) sec.bad(key, why);
  }
  if (const std::string why = protocol::watchdog_consistency_problem(w); !why.empty()) sec.fail(why);
  return w;
}

}  // namespace cosim::protocol::config
