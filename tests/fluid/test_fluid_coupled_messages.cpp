// The fluid's coupled loop against a fake solid (memq://, one process; protocol/README.md
// section 8a): malformed solid_state_t copies refused, counted and never applied, the run bit
// for bit the clean one; undecodable copies, an impulse at step 0, another A_T or scheme at
// the handshake.
#include <gtest/gtest.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/config/scene_config.hpp"
#include "protocol/channels.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/message_checks.hpp"
#include "protocol/units.hpp"
#include "solid/config/solid_scene.hpp"
#include "tests/support/scene_invariants.hpp"
#include "tests/support/fake_peer.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/valid_messages.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cosim::test::messages;


const fs::path kSource = COSIM_SOURCE_DIR;

fs::path scratch_dir(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_fluid_coupled_" + name); }

// ---- the fluid's coupled loop against a fake solid (memq://, one process) ----

/// A small coupled scene for the fluid: 16 x 12 x 12 cells, 6 LB steps (2 rigid), memq://
/// and short timeouts, so that a broken loop ends the test within seconds.
fs::path write_fluid_scene(const fs::path& dir) {
  const fs::path scene = dir / "coupled.toml";
  std::ofstream(scene) << "[scene]\nname = \"security\"\n\n"
                          "[grid]\nnx = 16\nny = 12\nnz = 12\ndx_um = 0.2561\n\n"
                          "[fluid]\ntau = 0.8\n\n[inlet]\nu_max = 0.02\n\n"
                          "[boundaries]\nx_min = \"inlet\"\nx_max = \"outflow\"\ny_min = \"wall\"\n"
                          "y_max = \"free_slip\"\nz_min = \"periodic\"\nz_max = \"periodic\"\n\n"
                          "[run]\nsteps = 6\nmonitor_every = 2\n\n"
                          "[output]\ndirectory = \""
                       << (dir / "out").string()
                       << "\"\nfields_every = 0\n\n"
                          "[coupling]\ntime_ratio = 150\nrigid_steps = 2\nhandshake_timeout_s = 3\n"
                          "peer_timeout_s = 3\nresend_after_s = 0.1\nlcm_url = \"memq://\"\n"
                          "channel_prefix = \"SEC_\"\n";
  return scene;
}

/// A minimal solid for the fluid: 4 markers at fixed positions in the channel, J_l = -u_l / 2
/// from each sample (so an applied message of another content would change the flow), the
/// substeps and solid time of protocol/README.md section 5. The knobs send malformed copies.
struct FakeSolid {
  FakeSolid(lcm::LCM& bus_, const fs::path& scene_path, std::int64_t rigid_steps_)
      : bus(bus_), ch("SEC_"), link("solid", kToken, "SEC_", bus_), rigid_steps(rigid_steps_) {
    const cosim::protocol::UnitConverter u;
    dt_lb_s = u.dt_lb_s();
    hello = valid_hello();
    hello.scene_hash = cosim::protocol::scene_hash_of_file(scene_path.string());
    hello.num_cgps = kCgps;
    link.on<cosimlcm::hello_t>(ch.hello, [this](const cosimlcm::hello_t& m) { on_hello(nullptr, ch.hello, &m); });
    link.on<cosimlcm::welcome_t>(ch.welcome, [this](const cosimlcm::welcome_t& m) { on_welcome(nullptr, ch.welcome, &m); });
    link.on<cosimlcm::fluid_state_t>(ch.fluid_state,
                                     [this](const cosimlcm::fluid_state_t& m) { on_fluid_state(nullptr, ch.fluid_state, &m); });
    link.on<cosimlcm::resend_t>(ch.resend, [this](const cosimlcm::resend_t& m) { on_resend(nullptr, ch.resend, &m); });
    link.on<cosimlcm::stop_t>(ch.stop, [this](const cosimlcm::stop_t& m) { on_stop(nullptr, ch.stop, &m); });
  }

  static constexpr std::int32_t kCgps = 4;

  // ---- knobs ----
  /// Raw messages published on SOLID_STATE before the first copy of each step's state.
  std::function<std::vector<std::vector<std::uint8_t>>(const cosimlcm::solid_state_t&)> before;
  /// Applied to every copy of this step's state (first copy and resends).
  std::int64_t spoil_step = -1;
  std::function<void(cosimlcm::solid_state_t&)> spoil;
  /// Applied to the bytes of every copy of this step's state, after `spoil`.
  std::function<std::vector<std::uint8_t>(std::vector<std::uint8_t>)> raw_spoil;
  /// Applied to every hello_t this solid sends.
  std::function<void(cosimlcm::hello_t&)> spoil_hello;
  /// Applied to the bytes of every hello_t this solid sends, after `spoil_hello`.
  std::function<std::vector<std::uint8_t>(std::vector<std::uint8_t>)> raw_hello;

  // ---- what it saw ----
  std::map<std::int64_t, cosimlcm::fluid_state_t> samples;  ///< first copy per step
  std::vector<cosimlcm::welcome_t> welcomes;
  std::vector<cosimlcm::stop_t> stops;
  int resends_for_state = 0;

  lcm::LCM& bus;
  cosim::protocol::Channels ch;
  cosim::test::FakePeerLink link;  ///< receives through the session layer's gate
  std::int64_t rigid_steps;
  double dt_lb_s = 0.0;
  cosimlcm::hello_t hello;
  std::int64_t seq = 0;
  bool started = false;
  std::map<std::int64_t, cosimlcm::solid_state_t> sent;

  cosimlcm::solid_state_t state(std::int64_t n, const cosimlcm::fluid_state_t* f) {
    cosimlcm::solid_state_t m{};
    m.token = kToken;
    m.seq = seq++;
    m.step = n;
    const std::int64_t dynamic_from = std::max<std::int64_t>(rigid_steps, 1);
    m.substeps = n < dynamic_from ? 0 : kTimeRatio;
    m.solid_time_s = static_cast<double>(std::max<std::int64_t>(0, n - dynamic_from + 1)) * dt_lb_s;
    m.num_cgps = kCgps;
    for (std::int32_t l = 0; l < kCgps; ++l) {
      m.position_lb.push_back({5.0 + (l % 2), 2.0 + 2.0 * (l / 2), 6.0});
      std::vector<double> j{0.0, 0.0, 0.0};
      if (f != nullptr)
        for (std::size_t c = 0; c < 3; ++c) j[c] = -0.5 * f->velocity_lb[static_cast<std::size_t>(l)][c];
      m.impulse_lb.push_back(j);
    }
    return m;
  }

  void send(const cosimlcm::solid_state_t& good, bool first) {
    if (first && before)
      for (const auto& raw : before(good))
        bus.publish(ch.solid_state, raw.data(), static_cast<unsigned int>(raw.size()));
    cosimlcm::solid_state_t m = good;
    if (m.step == spoil_step && spoil) spoil(m);
    if (m.step == spoil_step && raw_spoil) {
      const std::vector<std::uint8_t> raw = raw_spoil(encode(m));
      bus.publish(ch.solid_state, raw.data(), static_cast<unsigned int>(raw.size()));
      return;
    }
    bus.publish(ch.solid_state, &m);
  }

  void on_hello(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::hello_t* m) {
    if (m->role != "fluid" || started) return;
    cosimlcm::hello_t h = hello;
    if (spoil_hello) spoil_hello(h);
    for (int k = 0; k < 3; ++k) {  // a solid repeats its hello
      if (raw_hello) {
        const std::vector<std::uint8_t> raw = raw_hello(encode(h));
        bus.publish(ch.hello, raw.data(), static_cast<unsigned int>(raw.size()));
      } else {
        bus.publish(ch.hello, &h);
      }
    }
  }
  void on_welcome(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::welcome_t* m) {
    welcomes.push_back(*m);
    if (!m->accepted || started) return;
    started = true;
    sent[0] = state(0, nullptr);
    send(sent[0], true);
  }
  void on_fluid_state(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::fluid_state_t* m) {
    if (sent.count(m->step) != 0) return;  // a copy: answered already
    samples[m->step] = *m;
    sent[m->step] = state(m->step, m);
    send(sent[m->step], true);
  }
  void on_resend(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::resend_t* m) {
    if (m->what != "solid_state") return;
    ++resends_for_state;
    const auto it = sent.find(m->step);
    if (it != sent.end()) send(it->second, false);
  }
  void on_stop(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::stop_t* m) {
    stops.push_back(*m);
  }
};

struct FluidOutcome {
  int code = -1;
  std::string out, err;
};

FluidOutcome run_fluid(const fs::path& scene_path, lcm::LCM& bus) {
  const cosim::fluid::FluidScene scene = cosim::fluid::load_scene(scene_path.string());
  cosim::fluid::CoupledFluidOptions opt;
  opt.token = kToken;
  opt.quiet = true;
  opt.bus = &bus;
  FluidOutcome o;
  std::ostringstream out, err;
  std::thread fluid([&] { o.code = cosim::fluid::run_coupled_fluid(scene, opt, out, err); });
  fluid.join();
  while (bus.handleTimeout(0) > 0) {
  }
  o.out = out.str();
  o.err = err.str();
  return o;
}

/// The number after ", NAME " in a counters line; -1 if absent.
long long counter(const std::string& out, const std::string& name) {
  const std::size_t at = out.find(", " + name + " ");
  return at == std::string::npos ? -1 : std::stoll(out.substr(at + name.size() + 3));
}

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

/// The samples of two runs, bit for bit; "" when identical.
std::string compare_samples(const std::map<std::int64_t, cosimlcm::fluid_state_t>& a,
                            const std::map<std::int64_t, cosimlcm::fluid_state_t>& b) {
  if (a.size() != b.size()) return std::to_string(a.size()) + " vs " + std::to_string(b.size()) + " samples";
  for (const auto& [step, fa] : a) {
    const auto it = b.find(step);
    if (it == b.end()) return "step " + std::to_string(step) + " missing";
    const cosimlcm::fluid_state_t& fb = it->second;
    if (bits(fa.bulk_velocity_lb) != bits(fb.bulk_velocity_lb)) return "bulk velocity of step " + std::to_string(step);
    for (std::size_t l = 0; l < fa.rho_lb.size(); ++l) {
      if (bits(fa.rho_lb[l]) != bits(fb.rho_lb[l])) return "rho of step " + std::to_string(step);
      for (std::size_t c = 0; c < 3; ++c)
        if (bits(fa.velocity_lb[l][c]) != bits(fb.velocity_lb[l][c]))
          return "velocity of step " + std::to_string(step);
    }
  }
  return "";
}

/// Malformed copies of a state, raw bytes: values the checks refuse and bytes the decoder
/// refuses (a hostile count, a zero string length, a truncation).
std::vector<std::vector<std::uint8_t>> malformed_copies(const cosimlcm::solid_state_t& good) {
  std::vector<std::vector<std::uint8_t>> out;
  const std::vector<std::function<void(cosimlcm::solid_state_t&)>> spoilers = {
      [](auto& m) { m.impulse_lb[1][0] = kNaN; },
      [](auto& m) {
        m.num_cgps = 3;
        m.position_lb.pop_back();
        m.impulse_lb.pop_back();
      },
      [](auto& m) { m.substeps = 7; },
      [](auto& m) { m.seq = -1; },
      [](auto& m) { m.position_lb[0][2] = kInf; },
  };
  const std::size_t k = static_cast<std::size_t>(good.step) % spoilers.size();
  for (const std::size_t i : {k, (k + 1) % spoilers.size()}) {
    cosimlcm::solid_state_t m = good;
    spoilers[i](m);
    out.push_back(encode(m));
  }
  std::vector<std::uint8_t> hostile = encode(good);
  put_i32(hostile, 61, 0x7fffffffU);  // num_cgps = 2^31 - 1 (after 8 + 21 + 8 + 8 + 4 + 4 + 8 bytes)
  out.push_back(hostile);
  std::vector<std::uint8_t> no_token = encode(good);
  put_i32(no_token, 8, 0);  // token length 0
  out.push_back(no_token);
  std::vector<std::uint8_t> cut = encode(good);
  cut.resize(cut.size() / 2);
  out.push_back(cut);
  return out;
}

// The fluid refuses malformed solid_state_t copies (counted, logged once, never applied) and
// the run is bit for bit the clean one; only refused copies of a step end the run after
// kRejectedCopiesLimit of them, with the code of the fluid's per-step checks (3 for a
// non-finite number) or 2, naming the field; refused hello_t lead to a refused handshake.
TEST(FluidCoupled, MalformedMessagesAreRejected) {
  const fs::path dir = scratch_dir("fluid");
  const fs::path scene = write_fluid_scene(dir);

  lcm::LCM clean_bus("memq://");
  ASSERT_TRUE(clean_bus.good());
  FakeSolid clean(clean_bus, scene, 2);
  const FluidOutcome c = run_fluid(scene, clean_bus);
  ASSERT_EQ(c.code, 0) << c.out << c.err;
  EXPECT_EQ(counter(c.out, "rejected"), 0) << c.out;
  EXPECT_EQ(counter(c.out, "undecodable"), 0) << c.out;
  ASSERT_EQ(clean.samples.size(), 5u);  // fluid_state_t 1..5

  lcm::LCM noisy_bus("memq://");
  FakeSolid noisy(noisy_bus, scene, 2);
  noisy.before = malformed_copies;
  const FluidOutcome n = run_fluid(scene, noisy_bus);
  ASSERT_EQ(n.code, 0) << n.out << n.err;
  EXPECT_EQ(n.err, "");
  EXPECT_EQ(compare_samples(clean.samples, noisy.samples), "") << "a refused copy was applied";
  EXPECT_EQ(counter(n.out, "rejected"), 2 * 6) << n.out;     // two per state, steps 0..5
  EXPECT_EQ(counter(n.out, "undecodable"), 3 * 6) << n.out;  // three per state
  EXPECT_NE(n.out.find("fluid: refusing messages on channel 'SEC_SOLID_STATE' (non-finite): "
                       "solid_state_t: impulse_lb[1][0] = nan; every number must be finite"),
            std::string::npos)
      << n.out;
  EXPECT_NE(n.out.find("does not decode as solid_state_t (solid_state_t: num_cgps = 2147483647 needs"),
            std::string::npos)
      << n.out;
  // Logged once per (channel, category): non-finite, count, range; decoding once per channel.
  EXPECT_EQ(std::count(n.out.begin(), n.out.end(), '\n'),
            std::count(c.out.begin(), c.out.end(), '\n') + 3 + 1)
      << n.out;

  struct Persistent {
    const char* name;
    std::function<void(cosimlcm::solid_state_t&)> spoil;
    int code;
    const char* message;
  };
  const std::vector<Persistent> cases = {
      {"nan", [](auto& m) { m.impulse_lb[2][1] = kNaN; }, 3,
       "fluid: coupled run stopped: solid_state_t of step 3: a non-finite position or impulse at CGP 2\n"},
      {"seq", [](auto& m) { m.seq = -5; }, 2,
       "fluid: coupled run stopped: solid_state_t of step 3: seq = -5; allowed: 0 or more (the "
       "sender's counter) (3 copies refused)\n"},
      {"count",
       [](auto& m) {  // consistent for LCM's encode, which reads num_cgps rows
         m.num_cgps = 3;
         m.position_lb.pop_back();
         m.impulse_lb.pop_back();
       },
       2, "fluid: coupled run stopped: solid_state_t of step 3: num_cgps = 3, expected 4\n"},
  };
  for (const Persistent& p : cases) {
    lcm::LCM bus("memq://");
    FakeSolid solid(bus, scene, 2);
    solid.spoil_step = 3;
    solid.spoil = p.spoil;
    const FluidOutcome r = run_fluid(scene, bus);
    EXPECT_EQ(r.code, p.code) << p.name << ": " << r.out << r.err;
    EXPECT_EQ(r.err, p.message) << p.name;
    EXPECT_EQ(solid.samples.size(), 3u) << p.name << ": steps 1..3 only";
    // Asked again after each refused copy (and maybe on the resend timer, on a busy machine).
    EXPECT_GE(solid.resends_for_state, 2) << p.name;
    ASSERT_FALSE(solid.stops.empty()) << p.name;
    EXPECT_EQ(solid.stops.back().exit_code, p.code) << p.name;
    EXPECT_EQ(counter(r.out, "rejected"), 3) << p.name << ": " << r.out;
  }

  // A solid that sends only refused hello_t: the handshake is refused, naming the field.
  lcm::LCM bus("memq://");
  FakeSolid gas(bus, scene, 2);
  gas.spoil_hello = [](cosimlcm::hello_t& h) { h.role = "gas"; };
  const FluidOutcome g = run_fluid(scene, bus);
  EXPECT_EQ(g.code, 2) << g.out << g.err;
  EXPECT_EQ(g.err, "fluid: coupled run stopped: handshake refused: hello_t: role = 'gas'; "
                   "allowed: 'fluid', 'solid'\n");
  ASSERT_FALSE(gas.welcomes.empty());
  EXPECT_EQ(gas.welcomes[0].accepted, 0);
  EXPECT_EQ(gas.welcomes[0].reason, "handshake refused: hello_t: role = 'gas'; allowed: 'fluid', 'solid'");

  // A solid of another protocol version (another fingerprint, the run's token): its hello_t
  // does not decode; the handshake is refused at once, naming the type and the byte.
  lcm::LCM old_bus("memq://");
  FakeSolid old(old_bus, scene, 2);
  old.raw_hello = [](std::vector<std::uint8_t> b) {
    b[7] ^= 0x01;
    return b;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const FluidOutcome o = run_fluid(scene, old_bus);
  EXPECT_EQ(o.code, 2) << o.out << o.err;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
  EXPECT_NE(o.err.find("handshake refused: the solid's hello_t does not decode: hello_t: fingerprint = 0x"),
            std::string::npos)
      << o.err;
  EXPECT_NE(o.err.find("(decoding failed at byte 0 of "), std::string::npos) << o.err;
  fs::remove_all(dir);
}

/// The fluid scene of these tests with lines added to its [coupling] section (the last one).
fs::path fluid_scene_with(const fs::path& dir, const std::string& coupling_lines) {
  const fs::path base = write_fluid_scene(dir);
  std::ifstream in(base);
  std::stringstream text;
  text << in.rdbuf() << coupling_lines;
  const fs::path p = dir / "scene_with.toml";
  std::ofstream(p) << text.str();
  return p;
}

// Undecodable bytes whose header names this run count toward the three-copies rule of the
// awaited step: a solid that answers every resend of step 3 with bytes that do not decode
// ends the run with 2, naming the reason, long before the peer timeout (3 s here), instead
// of "silent" after it.
TEST(FluidCoupled, UndecodableCopiesCountTowardTheLimit) {
  const fs::path dir = scratch_dir("undecodable");
  const fs::path scene = write_fluid_scene(dir);
  lcm::LCM bus("memq://");
  FakeSolid solid(bus, scene, 2);
  solid.spoil_step = 3;
  solid.raw_spoil = [](std::vector<std::uint8_t> b) {
    b.resize(b.size() - 5);  // truncated: the header (token, seq, step) still reads
    return b;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const FluidOutcome r = run_fluid(scene, bus);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("fluid: coupled run stopped: solid_state_t of step 3: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(3 copies refused)"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("silent"), std::string::npos) << r.err;
  EXPECT_LT(seconds, 3.0) << "ended by the peer timeout, not by the three-copies rule";
  EXPECT_EQ(solid.samples.size(), 3u) << "steps 1..3 only";
  EXPECT_GE(solid.resends_for_state, 2) << "each undecodable copy is asked for again";
  ASSERT_FALSE(solid.stops.empty());
  EXPECT_EQ(solid.stops.back().exit_code, 2);
  EXPECT_EQ(solid.stops.back().sender, "fluid");
  EXPECT_EQ(solid.stops.back().step, 3);
  fs::remove_all(dir);
}

// solid_state_t(0) opens the run: no interval precedes it, so step 0 -> 1 must not spread
// an impulse (protocol/README.md 5). A non-zero impulse there is refused with 2, naming the
// field and its value (it was neither refused nor applied before).
TEST(FluidCoupled, ImpulseAtStepZeroIsRefusedOrApplied) {
  const fs::path dir = scratch_dir("impulse0");
  const fs::path scene = write_fluid_scene(dir);
  lcm::LCM bus("memq://");
  FakeSolid solid(bus, scene, 2);
  solid.spoil_step = 0;
  solid.spoil = [](cosimlcm::solid_state_t& m) { m.impulse_lb[2][1] = 1.25e-3; };
  const FluidOutcome r = run_fluid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_EQ(r.err,
            "fluid: coupled run stopped: solid_state_t of step 0: impulse_lb[2][1] = 0.00125; allowed: 0 at "
            "step 0 (no interval precedes it; protocol/README.md 5)\n");
  EXPECT_TRUE(solid.samples.empty()) << "no fluid_state_t after a refused step 0";
  ASSERT_FALSE(solid.stops.empty());
  EXPECT_EQ(solid.stops.back().exit_code, 2);
  fs::remove_all(dir);
}

// A solid that announces a self-consistent A_T of its own (time_ratio = 300 with dt_CG =
// dt_LB / 300) on a scene of A_T = 150 is refused at the handshake, naming both values
// (it was welcomed and died at the first free step).
TEST(FluidCoupled, HandshakeRefusesAnotherTimeRatio) {
  // The pure check: the fluid announces its own A_T.
  const cosim::protocol::UnitConverter u150, u300(cosim::protocol::UnitInputs{.time_ratio = 300});
  cosim::protocol::Hello fluid = cosim::protocol::from_lcm(valid_hello());
  fluid.role = "fluid";
  fluid.time_ratio = 150;
  cosim::protocol::Hello solid = cosim::protocol::from_lcm(valid_hello());
  solid.time_ratio = 300;
  solid.dt_cg_s = u300.dt_cg_s();
  const cosim::protocol::HandshakeResult v = cosim::protocol::check_handshake(fluid, solid, kToken);
  EXPECT_FALSE(v.accepted);
  EXPECT_NE(v.reason.find("time_ratio mismatch: the solid runs A_T = 300"), std::string::npos) << v.reason;
  EXPECT_NE(v.reason.find("the fluid's scene A_T = 150"), std::string::npos) << v.reason;
  solid.time_ratio = 150;
  solid.dt_cg_s = u150.dt_cg_s();
  EXPECT_TRUE(cosim::protocol::check_handshake(fluid, solid, kToken).accepted);

  // The coordinator on the wire.
  const fs::path dir = scratch_dir("time_ratio");
  const fs::path scene = write_fluid_scene(dir);
  lcm::LCM bus("memq://");
  FakeSolid fake(bus, scene, 2);
  fake.spoil_hello = [&](cosimlcm::hello_t& h) {
    h.time_ratio = 300;
    h.dt_cg_s = u300.dt_cg_s();
    h.stable_dt_cg_s = 1e-11;
  };
  const FluidOutcome r = run_fluid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("handshake refused: time_ratio mismatch: the solid runs A_T = 300"), std::string::npos)
      << r.err;
  ASSERT_FALSE(fake.welcomes.empty());
  EXPECT_EQ(fake.welcomes[0].accepted, 0);
  EXPECT_TRUE(fake.samples.empty());
  fs::remove_all(dir);
}

// hello_t and welcome_t carry the coupling scheme: a serial solid (or one that names none)
// on a parallel scene is refused at the handshake, naming both schemes (it ran 98 of 100
// steps and then reported a silent peer).
TEST(FluidCoupled, HandshakeRefusesAnotherScheme) {
  cosim::protocol::Hello fluid = cosim::protocol::from_lcm(valid_hello());
  fluid.role = "fluid";
  fluid.scheme = "parallel";
  cosim::protocol::Hello solid = cosim::protocol::from_lcm(valid_hello());
  for (const char* announced : {"serial", ""}) {
    solid.scheme = announced;
    const cosim::protocol::HandshakeResult v = cosim::protocol::check_handshake(fluid, solid, kToken);
    EXPECT_FALSE(v.accepted) << announced;
    EXPECT_NE(v.reason.find("coupling scheme mismatch: the fluid runs the 'parallel' scheme"), std::string::npos)
        << v.reason;
    EXPECT_NE(v.reason.find("the solid announced 'serial'"), std::string::npos) << v.reason;
  }
  solid.scheme = "parallel";
  EXPECT_TRUE(cosim::protocol::check_handshake(fluid, solid, kToken).accepted);
  fluid.scheme = "";  // empty is read as serial on both sides
  solid.scheme = "serial";
  EXPECT_TRUE(cosim::protocol::check_handshake(fluid, solid, kToken).accepted);

  const fs::path dir = scratch_dir("scheme");
  const fs::path scene = fluid_scene_with(dir, "scheme = \"parallel\"\n");
  for (const char* announced : {"serial", "implicit"}) {
    lcm::LCM bus("memq://");
    FakeSolid fake(bus, scene, 2);
    fake.spoil_hello = [&](cosimlcm::hello_t& h) { h.scheme = announced; };
    const FluidOutcome r = run_fluid(scene, bus);
    EXPECT_EQ(r.code, 2) << r.out << r.err;
    EXPECT_NE(r.err.find("handshake refused: coupling scheme mismatch: the fluid runs the 'parallel' scheme"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find(std::string("the solid announced '") + announced + "'"), std::string::npos) << r.err;
    ASSERT_FALSE(fake.welcomes.empty());
    EXPECT_EQ(fake.welcomes[0].accepted, 0);
    EXPECT_EQ(fake.welcomes[0].scheme, "parallel");
    EXPECT_TRUE(fake.samples.empty());
  }
  fs::remove_all(dir);
}

}  // namespace
