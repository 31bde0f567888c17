// The one scene-config layer (protocol/config/): one LCM URL rule for both servers, for the
// scene and for --lcm-url; the models' options refused when the chosen model does not read
// them; one table of which process owns which section, and the did-you-mean of both parsers.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <tuple>
#include <vector>

#include "tests/support/run_command.hpp"
#include "fluid/config/scene_config.hpp"
#include "protocol/config/scene_sections.hpp"
#include "protocol/lcm_url.hpp"
#include "protocol/units.hpp"
#include "solid/config/solid_scene.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::lines;
using cosim::test::RunResult;
using cosim::test::slurp;
const auto& quote = cosim::test::quoted;

/// Runs `EXE ARGS` with stdout and stderr captured in files of `scratch`.
RunResult run(const std::string& exe, const std::string& args, const fs::path& scratch) {
  return cosim::test::run_command(quote(exe) + " " + args, scratch);
}

class Scratch {
 public:
  explicit Scratch(const char* name)
      : dir_(fs::temp_directory_path() /
             ("cosim_test_config_" + std::to_string(getpid()) + "_" + name)) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~Scratch() { fs::remove_all(dir_); }
  const fs::path& dir() const { return dir_; }
  /// Writes `text` to NAME in the folder.
  fs::path file(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }

 private:
  fs::path dir_;
};

/// A small coupled scene that both servers load: the fluid's sections, a rigid sheet, and
/// [coupling] with `coupling_extra` (e.g. an lcm_url line).
std::string coupled_scene(const std::string& solid = "model = \"rigid\"\n",
                          const std::string& coupling_extra = "", const std::string& extra = "") {
  return "[scene]\nname = \"config_test\"\n\n[grid]\nnx = 16\nny = 16\nnz = 16\ndx_um = 0.2561\n\n"
         "[fluid]\ntau = 0.8\n\n[boundaries]\nx_min = \"periodic\"\nx_max = \"periodic\"\n"
         "y_min = \"wall\"\ny_max = \"free_slip\"\nz_min = \"periodic\"\nz_max = \"periodic\"\n\n"
         "[run]\nsteps = 4\n\n[solid]\n" + solid +
         "\n[[sheet]]\nnx_cg = 2\nny_cg = 3\nbase_um = [1.0, 0, 2.0]\n\n"
         "[coupling]\n" + coupling_extra + "\n" + extra;
}

template <class Load, class Error>
std::string refusal(Load load, const fs::path& p) {
  try {
    load(p.string());
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string fluid_refusal(const fs::path& p) {
  return refusal<decltype(&cosim::fluid::load_scene), cosim::fluid::SceneError>(
      &cosim::fluid::load_scene, p);
}

std::string solid_refusal(const fs::path& p) {
  return refusal<decltype(&cosim::solid::load_solid_scene), cosim::solid::SolidSceneError>(
      &cosim::solid::load_solid_scene, p);
}

// URLs the rule of protocol/lcm_url.hpp accepts and refuses (LcmUrlRuleIsOneRule,
// ExampleSolidKeepsTheUrlRule).
const std::vector<std::string> kGoodUrls = {"memq://", "udpm://239.255.76.67:7667?ttl=0", "udpm://224.0.0.1:1?ttl=0",
                                           "udpm://239.255.255.255:65535?ttl=0"};
const std::vector<std::string> kBadUrls = {
    "udpm://239.255.76.67:7667?ttl=0&ttl=1",  // the fluid used to take this one
    "udpm://239.255.76.67:7667?ttl=1&ttl=0",
    "udpm://239.255.76.67:7667?ttl=0&ttl=0",
    "udpm://239.255.76.67:7667?ttl=1",
    "udpm://239.255.76.67:7667?ttl=00",
    "udpm://239.255.76.67:7667",
    "udpm://239.255.76.67:7667?",
    "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=65536",
    "udpm://10.0.0.1:7667?ttl=0",  // not a multicast group
    "udpm://240.0.0.1:7667?ttl=0",
    "udpm://239.255.076.67:7667?ttl=0",  // a leading zero
    "udpm://239.255.76.67:07667?ttl=0",
    "udpm://239.255.76.67.1:7667?ttl=0",
    "udpm://239.255.76.67?ttl=0",
    "udpm://239.255.76.67:0?ttl=0",
    "udpm://239.255.76.67:65536?ttl=0",
    "udpm://239.255.76:7667?ttl=0",
    "udpm://?ttl=0",
    "tcpq://localhost:7700",  // made the fluid abort (SIGABRT)
    "file:///tmp/log?mode=w",
    "memq://elsewhere",
    "MEMQ://",
    "",
};

// One rule (protocol/lcm_url.hpp) for the scene's [coupling] lcm_url in both parsers and for
// --lcm-url of both executables: memq://, or udpm://ADDR:PORT (an IPv4 multicast group) with
// a query of exactly ttl=0. Anything else is one line naming the key or flag, the value and
// what is allowed, and exit status 2.
TEST(SceneConfig, LcmUrlRuleIsOneRule) {
  using cosim::protocol::lcm_url_problem;
  const std::vector<std::string>& good = kGoodUrls;
  const std::vector<std::string>& bad = kBadUrls;
  for (const std::string& u : good) EXPECT_FALSE(lcm_url_problem(u).has_value()) << u << ": " << *lcm_url_problem(u);
  for (const std::string& u : bad) {
    const auto why = lcm_url_problem(u);
    ASSERT_TRUE(why.has_value()) << u << " accepted";
    EXPECT_EQ(why->find('\n'), std::string::npos) << *why;
    EXPECT_NE(why->find("memq://"), std::string::npos) << u << ": does not say what is allowed: " << *why;
  }
  EXPECT_NE(lcm_url_problem("udpm://239.255.76.67:7667?ttl=0&ttl=1")->find("ttl=1 is not allowed"),
            std::string::npos);

  // Both scene parsers: the same URLs accepted, the same refused, naming coupling.lcm_url.
  const Scratch s("url");
  for (const std::string& u : good) {
    const fs::path p = s.file("good.toml", coupled_scene("model = \"rigid\"\n", "lcm_url = \"" + u + "\"\n"));
    EXPECT_EQ(fluid_refusal(p), "") << u;
    EXPECT_EQ(solid_refusal(p), "") << u;
    EXPECT_EQ(cosim::fluid::load_scene(p.string()).coupling->lcm_url, u);
    EXPECT_EQ(cosim::solid::load_solid_scene(p.string()).coupling->lcm_url, u);
  }
  for (const std::string& u : bad) {
    const fs::path p = s.file("bad.toml", coupled_scene("model = \"rigid\"\n", "lcm_url = \"" + u + "\"\n"));
    for (const std::string& msg : {fluid_refusal(p), solid_refusal(p)}) {
      ASSERT_FALSE(msg.empty()) << u << " accepted by a parser";
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
      EXPECT_NE(msg.find("coupling.lcm_url = \"" + u + "\": "), std::string::npos) << msg;
      EXPECT_NE(msg.find(*lcm_url_problem(u)), std::string::npos) << "not the rule's reason: " << msg;
    }
  }

  // Both executables' --lcm-url, with the same coupled scene (--check: nothing is opened).
  const fs::path scene = s.file("coupled.toml", coupled_scene("model = \"rigid\"\n", "lcm_url = \"memq://\"\n"));
  const std::string out = " --output " + quote((s.dir() / "out").string());
  for (const char* exe : {FLUID_EXE, SOLID_EXE}) {
    const RunResult ok = run(exe, quote(scene.string()) + " --check --quiet --lcm-url " +
                                      quote("udpm://239.255.76.67:7667?ttl=0") + out, s.dir());
    EXPECT_EQ(ok.status, 0) << exe << ": " << ok.out << ok.err;
    for (const std::string& u : {std::string("udpm://239.255.76.67:7667?ttl=0&ttl=1"),
                                 std::string("tcpq://localhost:7700"), std::string("")}) {
      const RunResult r = run(exe, quote(scene.string()) + " --check --quiet --lcm-url " + quote(u) + out, s.dir());
      EXPECT_EQ(r.status, 2) << exe << " --lcm-url " << u << ": " << r.out << r.err;
      EXPECT_EQ(lines(r.err), 1u) << exe << ": " << r.err;
      EXPECT_NE(r.err.find("--lcm-url = \"" + u + "\": "), std::string::npos) << exe << ": " << r.err;
      EXPECT_NE(r.err.find(*lcm_url_problem(u)), std::string::npos) << exe << ": " << r.err;
    }
  }
}

// Each model's options are read beside the model and named in the registry: a key that the
// chosen model does not read is refused with one line (today's "rigid" reads none), after
// its value has passed the key's own check.
TEST(SceneConfig, ModelRefusesKeysItDoesNotUse) {
  const Scratch s("model");
  const std::string standalone_tail =
      "\n[[sheet]]\n\n[run]\nmode = \"free\"\nsubsteps = 10\n\n[perturbation]\ntip_displacement_um = 0.5\n";
  const auto standalone = [&](const std::string& solid, const std::string& extra = "") {
    return s.file("standalone.toml", "[solid]\n" + solid + standalone_tail + extra);
  };

  std::string msg = solid_refusal(standalone("model = \"rigid\"\nstages = 3\n"));
  EXPECT_NE(msg.find(":3: solid.stages = 3: not used by solid.model = \"rigid\""), std::string::npos) << msg;
  EXPECT_NE(msg.find("rcgp, corotational"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;

  msg = solid_refusal(standalone("model = \"rigid\"\n", "\n[contact]\nepsilon_eV = 500\n"));
  EXPECT_NE(msg.find("contact.epsilon_eV = 500: not used by solid.model = \"rigid\""), std::string::npos) << msg;

  // The value's own check comes first (as for every key): out of range for anyone.
  msg = solid_refusal(standalone("model = \"rigid\"\nstages = 17\n"));
  EXPECT_NE(msg.find("solid.stages = 17: must be an integer from 1 to 16"), std::string::npos) << msg;

  // The models that read the keys take them.
  for (const char* model : {"rcgp", "corotational"}) {
    const fs::path p = standalone(std::string("model = \"") + model + "\"\nstages = 3\nbending_poisson = 0.2\n",
                                  "\n[contact]\nepsilon_eV = 500\n");
    EXPECT_EQ(solid_refusal(p), "") << model;
    const cosim::solid::SolidScene scene = cosim::solid::load_solid_scene(p.string());
    EXPECT_EQ(scene.config.rcgp.stages, 3);
    EXPECT_EQ(scene.config.rcgp.bending_poisson, 0.2);
    EXPECT_EQ(scene.config.contact.epsilon_eV, 500.0);
  }

  // The same in a coupled scene; the fluid leaves [solid] to the solid.
  const fs::path coupled = s.file("coupled.toml", coupled_scene("model = \"rigid\"\ntruncation_range = 3\n"));
  EXPECT_NE(solid_refusal(coupled).find("solid.truncation_range = 3: not used by solid.model = \"rigid\""),
            std::string::npos)
      << solid_refusal(coupled);
  EXPECT_EQ(fluid_refusal(coupled), "");
}

// Which process owns which section is one table: in a coupled scene each server leaves the
// other's sections and keys unread; without [coupling] they are refused; a section or key
// that no one reads is refused by both, with a did-you-mean that also finds a name with its
// unit suffix left off.
TEST(SceneConfig, OneTableOwnsTheSections) {
  using cosim::protocol::config::Owner;
  using cosim::protocol::config::find_section_owner;
  ASSERT_NE(find_section_owner("inlet"), nullptr);
  EXPECT_EQ(find_section_owner("inlet")->owner, Owner::Fluid);
  EXPECT_EQ(find_section_owner("sheet")->owner, Owner::Solid);
  EXPECT_TRUE(find_section_owner("sheet")->array);
  EXPECT_EQ(find_section_owner("coupling")->owner, Owner::Both);
  EXPECT_EQ(find_section_owner("no_such_section"), nullptr);

  const Scratch s("owners");
  // A coupled scene with keys of both in the shared [output]: both load it.
  const fs::path both = s.file("both.toml", coupled_scene("model = \"rigid\"\n", "",
                                                          "[output]\nfields_every = 2\nsheets_every = 3\n"));
  EXPECT_EQ(fluid_refusal(both), "");
  EXPECT_EQ(solid_refusal(both), "");
  EXPECT_EQ(cosim::fluid::load_scene(both.string()).fields_every, 2);
  EXPECT_EQ(cosim::solid::load_solid_scene(both.string()).sheets_every, 3);

  // An unknown section: both refuse it, naming the closest.
  const fs::path typo = s.file("typo.toml", coupled_scene("model = \"rigid\"\n", "", "[boundary]\nx_min = \"wall\"\n"));
  for (const std::string& msg : {fluid_refusal(typo), solid_refusal(typo)}) {
    EXPECT_NE(msg.find("[boundary]: unknown section"), std::string::npos) << msg;
    EXPECT_NE(msg.find("did you mean \"boundaries\""), std::string::npos) << msg;
  }

  // Without [coupling]: the solid's sections and keys in a fluid scene are refused.
  const fs::path fluid_only = s.file(
      "fluid_only.toml",
      "[grid]\nnx = 16\nny = 16\nnz = 16\n\n[fluid]\ntau = 0.8\n\n[boundaries]\nx_min = \"periodic\"\n"
      "x_max = \"periodic\"\ny_min = \"wall\"\ny_max = \"wall\"\nz_min = \"periodic\"\nz_max = \"periodic\"\n\n"
      "[run]\nsteps = 4\n\n[output]\nsheets_every = 3\n");
  std::string msg = fluid_refusal(fluid_only);
  EXPECT_NE(msg.find("output.sheets_every = 3: is the solid's: only in a coupled scene"), std::string::npos) << msg;
  std::ofstream(fluid_only, std::ios::app) << "\n[contact]\nepsilon_eV = 1\n";
  msg = fluid_refusal(fluid_only);
  EXPECT_NE(msg.find("[contact]: a solid section needs a [coupling] section"), std::string::npos) << msg;

  // Did-you-mean with a unit suffix left off, and for a model name.
  const fs::path theta = s.file("theta.toml", coupled_scene("model = \"corotation\"\n"));
  msg = solid_refusal(theta);
  EXPECT_NE(msg.find("did you mean \"corotational\""), std::string::npos) << msg;
  std::ofstream(theta) << coupled_scene("model = \"rigid\"\n") + "\n[[sheet]]\ntheta = 30\n";
  msg = solid_refusal(theta);
  EXPECT_NE(msg.find("sheet[1].theta = 30: unknown key in [[sheet]]"), std::string::npos) << msg;
  EXPECT_NE(msg.find("did you mean \"theta_deg\""), std::string::npos) << msg;
  std::ofstream(theta) << coupled_scene("model = \"rigid\"\n", "", "[watchdog]\nmax_cgp_speed_c = 0.3\n");
  for (const std::string& m : {fluid_refusal(theta), solid_refusal(theta)})
    EXPECT_NE(m.find("did you mean \"max_cgp_speed\""), std::string::npos) << m;
}

// The raw-protocol example solid (examples/prescribed_plate, C) applies the servers' URL rule:
// every URL the rule refuses is refused by the example with exit 2 and one line naming the
// value; every URL it accepts passes the example's URL check (the scene's 5e6 markers then
// stop it at the next check, before it opens LCM).
TEST(SceneConfig, ExampleSolidKeepsTheUrlRule) {
  const Scratch s("plate_url");
  std::string scene = cosim::test::slurp(fs::path(COSIM_SOURCE_DIR) / "scenes" / "coupled_plate.toml");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"nx_cg = 5", "nx_cg = 5000"}, {"ny_cg = 10", "ny_cg = 1000"}}) {
    const std::size_t at = scene.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    scene.replace(at, from.size(), to);
  }
  const fs::path p = s.file("plate.toml", scene);
  const auto plate = [&](const std::string& url) {
    return cosim::test::run_command(std::string(PRESCRIBED_PLATE_EXE) + " " + cosim::test::quoted(p.string()) +
                                        " --token 0123456789abcdef --lcm-url " + cosim::test::quoted(url),
                                    s.dir() / "plate");
  };
  for (const std::string& u : kGoodUrls) {
    const cosim::test::RunResult r = plate(u);
    EXPECT_EQ(r.status, 2) << u << ": " << r.err;
    EXPECT_EQ(r.err.find("LCM URL"), std::string::npos) << u << " refused: " << r.err;
    EXPECT_NE(r.err.find("at most 1000000 markers"), std::string::npos) << u << ": " << r.err;
  }
  for (const std::string& u : kBadUrls) {
    const cosim::test::RunResult r = plate(u);
    EXPECT_EQ(r.status, 2) << u << " accepted: " << r.err;
    EXPECT_NE(r.err.find("LCM URL \"" + u + "\""), std::string::npos) << u << ": " << r.err;
    EXPECT_EQ(cosim::test::lines(r.err), 1u) << u << ": a refusal is one line: " << r.err;
  }
}

// [fluid] density_kg_m3 and sound_speed_m_s are read by both processes alike
// (protocol/config/shared_sections.hpp read_medium, protocol::scene_unit_inputs): a coupled
// scene in another fluid than the paper's air gives both the same units, the ones the
// handshake compares (dx, dt_LB, c_s, density) and the ones each side converts forces,
// velocities and momenta with.
TEST(SceneConfig, MediumGivesBothProcessesTheSameUnits) {
  using cosim::protocol::UnitConverter;
  const Scratch s("medium");
  const std::string medium = "density_kg_m3 = 1000.0\nsound_speed_m_s = 23.094010767585033\n";
  std::string text = coupled_scene("model = \"rigid\"\n", "time_ratio = 40\n");
  text.replace(text.find("[fluid]\ntau = 0.8\n"), 18, "[fluid]\ntau = 0.8\n" + medium);
  const fs::path water = s.file("water.toml", text);
  const cosim::fluid::FluidScene f = cosim::fluid::load_scene(water.string());
  const cosim::solid::SolidScene so = cosim::solid::load_solid_scene(water.string());
  ASSERT_TRUE(so.medium.has_value());
  const UnitConverter uf(cosim::fluid::unit_inputs(f)), us(so.unit_inputs());
  EXPECT_DOUBLE_EQ(uf.air_density_kg_m3(), 1000.0);
  EXPECT_DOUBLE_EQ(uf.lattice_speed_m_s(), 40.0);
  const std::tuple<const char*, double, double> rows[] = {{"dx_m", uf.dx_m(), us.dx_m()},
                                   {"dt_lb_s", uf.dt_lb_s(), us.dt_lb_s()},
                                   {"dt_cg_s", uf.dt_cg_s(), us.dt_cg_s()},
                                   {"density", uf.air_density_kg_m3(), us.air_density_kg_m3()},
                                   {"force_lb_N", uf.force_lb_N(), us.force_lb_N()},
                                   {"velocity_ratio", uf.velocity_ratio(), us.velocity_ratio()},
                                   {"force_ratio", uf.force_ratio(), us.force_ratio()},
                                   {"momentum", uf.momentum_lb_from_au(1.0), us.momentum_lb_from_au(1.0)}};
  for (const auto& [name, a, b] : rows) EXPECT_EQ(a, b) << name;
  EXPECT_EQ(uf.inputs().time_ratio, 40);
  EXPECT_EQ(us.inputs().time_ratio, 40);
  EXPECT_DOUBLE_EQ(so.dt_s, us.dt_cg_s());
  // Without the medium both are the paper's air, whose forces convert otherwise.
  const fs::path air = s.file("air.toml", coupled_scene("model = \"rigid\"\n", "time_ratio = 40\n"));
  const UnitConverter af(cosim::fluid::unit_inputs(cosim::fluid::load_scene(air.string())));
  const UnitConverter as(cosim::solid::load_solid_scene(air.string()).unit_inputs());
  EXPECT_EQ(af.force_ratio(), as.force_ratio());
  EXPECT_NE(af.force_ratio(), uf.force_ratio());
  // One half of the medium: both refuse it with the same line.
  text.replace(text.find("sound_speed_m_s"), 15, "# sound_speed_m_s");
  const fs::path half = s.file("half.toml", text);
  for (const std::string& m : {fluid_refusal(half), solid_refusal(half)})
    EXPECT_NE(m.find("fluid.density_kg_m3 = 1000: needs fluid.sound_speed_m_s too"), std::string::npos) << m;
}

}  // namespace
