// The solid server's coupled run against the fake fluid (solid_coupled_fake_fluid.hpp; the
// bus arrangement is described in test_solid_coupled.cpp) when things go wrong: no welcome,
// a silent or failing fluid, bad, lost, duplicated, foreign and malformed messages.

#include <gtest/gtest.h>

#include "tests/solid/solid_coupled_fake_fluid.hpp"

namespace {

using namespace cosim::test::solid_coupled;
using cosim::test::messages::encode;

// No fluid at all: hello_t every 200 ms, then exit 4 after handshake_timeout_s, with stop_t(4)
// published three times.
TEST(SolidCoupled, NoWelcomeReturnsFour) {
  const fs::path dir = scratch_dir("nowelcome");
  const SolidScene scene =
      cosim::solid::load_solid_scene(write_scene(dir, 0, 3.0, 0.5).string());
  lcm::LCM bus("memq://");
  std::vector<cosimlcm::hello_t> hellos;
  std::vector<cosimlcm::stop_t> stops;
  const Channels ch("TEST_");
  bus.subscribeFunction(ch.hello, +[](const lcm::ReceiveBuffer*, const std::string&,
                                      const cosimlcm::hello_t* m, std::vector<cosimlcm::hello_t>* v) {
    v->push_back(*m);
  }, &hellos);
  bus.subscribeFunction(ch.stop, +[](const lcm::ReceiveBuffer*, const std::string&,
                                     const cosimlcm::stop_t* m, std::vector<cosimlcm::stop_t>* v) {
    v->push_back(*m);
  }, &stops);
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("no welcome_t on TEST_WELCOME within handshake_timeout_s = 0.5 s"),
            std::string::npos)
      << r.err;
  EXPECT_GE(hellos.size(), 2u);
  EXPECT_LE(hellos.size(), 4u);
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops[0].exit_code, 4);
  EXPECT_EQ(stops[0].token, kToken);
  fs::remove_all(dir);
}

// A fluid that goes silent after the welcome: resend_t for the awaited step every
// resend_after_s, then stop_t(4) three times and 4 after peer_timeout_s, naming the step.
TEST(SolidCoupled, SilentFluidIsLostAfterPeerTimeout) {
  const fs::path dir = scratch_dir("silent");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0, 0.6).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 4);
  fluid.silent_after_welcome = true;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("silent for 0.6 s (peer_timeout_s) while the solid waited for "
                       "fluid_state_t of step 1"),
            std::string::npos)
      << r.err;
  int asked = 0;
  for (const auto& m : fluid.resends)
    if (m.what == "fluid_state") {
      EXPECT_EQ(m.step, 1);
      ++asked;
    }
  EXPECT_GE(asked, 3);  // every 0.1 s for 0.6 s
  ASSERT_EQ(fluid.stops.size(), 3u);
  EXPECT_EQ(fluid.stops[0].exit_code, 4);
  EXPECT_EQ(fluid.stops[0].step, 0);
  EXPECT_EQ(dataset_rows(dir / "out" / "solid.h5", "step"), 1);  // the output is written
  fs::remove_all(dir);
}

// The fluid stops the run with an error: the solid returns 4, naming the peer's code and
// reason, and does not answer with a stop_t of its own.
TEST(SolidCoupled, FluidStopWithErrorReturnsFour) {
  const fs::path dir = scratch_dir("fluidstop");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 10);
  fluid.stop_with_error_at = 2;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("the fluid stopped the run at step 2 with exit code 3: unhealthy flow"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(fluid.states.size(), 2u);
  EXPECT_EQ(fluid.solid_stops(), 0u) << "the solid answered the fluid's stop_t with its own";
  fs::remove_all(dir);
}

// The solid's checks of a fluid_state_t (section 5): a wrong size is malformed (2); a
// non-finite number or rho <= 0 is unhealthy (3). Each ends the run with stop_t(code).
TEST(SolidCoupled, BadFluidStateEndsTheRun) {
  struct Case {
    const char* name;
    std::function<void(cosimlcm::fluid_state_t&)> corrupt;
    int code;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"size",
       [](cosimlcm::fluid_state_t& f) {
         f.num_cgps = 11;
         f.rho_lb.pop_back();
         f.velocity_lb.pop_back();
       },
       2, "fluid_state_t of step 1: num_cgps = 11, expected 12"},
      {"rho", [](cosimlcm::fluid_state_t& f) { f.rho_lb[5] = 0.0; }, 3,
       "fluid_state_t of step 1: CGP 5 (sheet 0, i = 2, j = 1): rho_lb = 0; the density must be > 0"},
      {"nan", [](cosimlcm::fluid_state_t& f) { f.velocity_lb[7][2] = std::nan(""); }, 3,
       "fluid_state_t of step 1: CGP 7 (sheet 0, i = 1, j = 2): velocity_lb[2] = nan is not "
       "finite"},
  };
  for (const Case& c : cases) {
    const fs::path dir = scratch_dir(std::string("bad_") + c.name);
    const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
    lcm::LCM bus("memq://");
    FakeFluid fluid(bus, scene, 4);
    fluid.corrupt = c.corrupt;
    const Outcome r = run_solid(scene, bus);
    EXPECT_EQ(r.code, c.code) << c.name << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    ASSERT_EQ(fluid.stops.size(), 3u) << c.name;
    EXPECT_EQ(fluid.stops[0].exit_code, c.code);
    EXPECT_EQ(fluid.states.size(), 1u) << c.name << ": the bad sample was applied";
    fs::remove_all(dir);
  }
}

// UDP's troubles (section 7): a lost fluid_state_t is asked for again and the run goes on;
// a duplicate and a stale copy are counted, never applied; a message with another run's
// token is counted, never applied; a resend_t for a published solid_state_t is answered
// with the same message, bit for bit (same seq).
TEST(SolidCoupled, LostDuplicateAndForeignMessages) {
  const fs::path dir = scratch_dir("udp");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 5);
  fluid.lose_first_copy = {2};
  fluid.duplicate_step = 3;
  fluid.foreign_step = 1;
  fluid.ask_resend_of = 1;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  // The duplicate of step 3 comes after the solid has moved on to step 4, so it counts as
  // stale, like the copy of step 2: either way, never applied. The solid's request for step
  // 2 is a round of kResendCopies copies, each answered: all but the first answer are
  // copies too.
  EXPECT_EQ(counter(r.out, "foreign"), 1) << r.out;
  EXPECT_EQ(counter(r.out, "duplicates") + counter(r.out, "stale"), 2 + cosim::protocol::kResendCopies - 1) << r.out;
  EXPECT_EQ(counter(r.out, "early"), 0) << r.out;
  EXPECT_NE(r.out.find("resend requests 1 answered 1"), std::string::npos) << r.out;
  bool asked_for_2 = false;
  for (const auto& m : fluid.resends) asked_for_2 |= m.what == "fluid_state" && m.step == 2;
  EXPECT_TRUE(asked_for_2);

  // Steps 0..4 once each, and step 1 a second time: the resend, identical to the first.
  std::map<std::int64_t, std::vector<const cosimlcm::solid_state_t*>> by_step;
  for (const auto& m : fluid.states) by_step[m.step].push_back(&m);
  ASSERT_EQ(by_step.size(), 5u);
  ASSERT_EQ(by_step[1].size(), 2u);
  const cosimlcm::solid_state_t& a = *by_step[1][0];
  const cosimlcm::solid_state_t& b = *by_step[1][1];
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_EQ(a.seq, 1);
  std::vector<std::uint8_t> ea(static_cast<std::size_t>(a.getEncodedSize())),
      eb(static_cast<std::size_t>(b.getEncodedSize()));
  a.encode(ea.data(), 0, static_cast<int>(ea.size()));
  b.encode(eb.data(), 0, static_cast<int>(eb.size()));
  EXPECT_EQ(ea, eb);
  for (std::int64_t s : {0, 2, 3, 4}) EXPECT_EQ(by_step[s].size(), 1u) << "step " << s;
  fs::remove_all(dir);
}

/// Every dataset of solid.h5 that MalformedMessagesAreRejected compares, read as doubles;
/// empty if the file cannot be read.
std::map<std::string, std::vector<double>> solid_h5(const fs::path& file) {
  std::map<std::string, std::vector<double>> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  for (const char* name :
       {"step", "time_s", "solid_time_s", "marked_displacement_um", "marked_normal_displacement_um",
        "fluid_force_N", "bulk_velocity_m_s", "force_coefficients", "leading_edge_strain",
        "kinetic_energy_J", "elastic_energy_J", "total_energy_J"}) {
    const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    if (d < 0) continue;
    const hid_t space = H5Dget_space(d);
    std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
    if (!v.empty()) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(space);
    H5Dclose(d);
    out.emplace(name, std::move(v));
  }
  H5Fclose(f);
  return out;
}

// Message security (protocol/README.md section 8a): malformed fluid_state_t copies mixed with
// the valid ones (a NaN, rho = 0, a step far ahead; bytes with a hostile num_cgps, a token
// length of 0, a truncation) are counted, logged once, never applied: the run completes with
// the solid.h5 of a clean run, bit for bit. Only refused copies of a step end the run, after
// kRejectedCopiesLimit (3) of them, naming the field.
TEST(SolidCoupled, MalformedMessagesAreRejected) {
  const fs::path clean_dir = scratch_dir("clean"), noisy_dir = scratch_dir("noisy");
  const SolidScene clean_scene = cosim::solid::load_solid_scene(write_scene(clean_dir, 1).string());
  const SolidScene noisy_scene = cosim::solid::load_solid_scene(write_scene(noisy_dir, 1).string());
  lcm::LCM clean_bus("memq://"), noisy_bus("memq://");
  FakeFluid clean(clean_bus, clean_scene, 5), noisy(noisy_bus, noisy_scene, 5);
  noisy.before = [](const cosimlcm::fluid_state_t& good) {
    std::vector<std::vector<std::uint8_t>> out;
    cosimlcm::fluid_state_t m = good;
    m.velocity_lb[4][1] = std::nan("");
    out.push_back(encode(m));
    m = good;
    m.rho_lb[0] = 0.0;
    out.push_back(encode(m));
    m = good;
    m.step += 20;
    out.push_back(encode(m));
    std::vector<std::uint8_t> hostile = encode(good);
    // num_cgps after the hash (8), the token (4 + 17), seq, step, iteration,
    // bulk_velocity_lb (28).
    const std::size_t at = 8 + 4 + 17 + 28;
    hostile[at] = 0x7f, hostile[at + 1] = hostile[at + 2] = hostile[at + 3] = 0xff;
    out.push_back(hostile);
    std::vector<std::uint8_t> no_token = encode(good);
    no_token[8] = no_token[9] = no_token[10] = no_token[11] = 0;
    out.push_back(no_token);
    std::vector<std::uint8_t> cut = encode(good);
    cut.resize(cut.size() - 9);
    out.push_back(cut);
    return out;
  };
  const Outcome c = run_solid(clean_scene, clean_bus);
  ASSERT_EQ(c.code, 0) << c.out << c.err;
  const Outcome n = run_solid(noisy_scene, noisy_bus);
  ASSERT_EQ(n.code, 0) << n.out << n.err;
  EXPECT_EQ(n.err, "");
  EXPECT_EQ(counter(c.out, "rejected"), 0) << c.out;
  EXPECT_EQ(counter(n.out, "rejected"), 3 * 4) << n.out;     // fluid_state_t 1..4
  EXPECT_EQ(counter(n.out, "undecodable"), 3 * 4) << n.out;
  EXPECT_NE(n.out.find("rejected 12 (non-finite 4, range 8)"), std::string::npos) << n.out;
  EXPECT_NE(n.out.find("solid: refusing messages on channel 'TEST_FLUID_STATE' (non-finite): "
                       "fluid_state_t: velocity_lb[4][1] = nan; every number must be finite; such "
                       "messages are counted, never applied"),
            std::string::npos)
      << n.out;
  EXPECT_NE(n.out.find("does not decode as fluid_state_t (fluid_state_t: num_cgps = 2147483647 needs"),
            std::string::npos)
      << n.out;
  // The same solid_state_t went out, and the same solid.h5 came out.
  ASSERT_EQ(clean.states.size(), 5u);
  std::map<std::int64_t, const cosimlcm::solid_state_t*> first;
  for (const auto& m : noisy.states) first.emplace(m.step, &m);
  ASSERT_EQ(first.size(), 5u);
  for (const auto& m : clean.states)
    EXPECT_EQ(encode(m), encode(*first[m.step])) << "solid_state_t of step " << m.step;
  const auto a = solid_h5(clean_dir / "out" / "solid.h5"), b = solid_h5(noisy_dir / "out" / "solid.h5");
  ASSERT_EQ(a.size(), 12u);
  for (const auto& [name, values] : a) {
    ASSERT_EQ(b.count(name), 1u) << name;
    ASSERT_EQ(values.size(), b.at(name).size()) << name;
    EXPECT_EQ(std::memcmp(values.data(), b.at(name).data(), values.size() * sizeof(double)), 0) << name;
  }

  // Only refused copies of step 2 (every copy with seq = -1): the third ends the run with 2.
  const fs::path dir = scratch_dir("refused");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 1).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 5);
  fluid.corrupt = [](cosimlcm::fluid_state_t& f) {
    if (f.step == 2) f.seq = -1;
  };
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "solid: fluid_state_t of step 2: seq = -1; allowed: 0 or more (the sender's "
                   "counter) (3 copies refused)\n");
  EXPECT_EQ(fluid.states.size(), 2u);
  ASSERT_EQ(fluid.solid_stops(), 3u);
  EXPECT_EQ(fluid.stops.back().exit_code, 2);
  int asked = 0;
  for (const auto& m : fluid.resends) asked += m.what == "fluid_state" && m.step == 2;
  EXPECT_GE(asked, 2) << "each refused copy is asked for again";

  // Only refused welcome_t (the coordinator answers each hello_t with one): exit 2 after 3.
  const fs::path wdir = scratch_dir("welcome");
  const SolidScene wscene = cosim::solid::load_solid_scene(write_scene(wdir, 1).string());
  lcm::LCM wbus("memq://");
  FakeFluid zero(wbus, wscene, 0);  // welcome_t.total_steps = 0
  const Outcome w = run_solid(wscene, wbus);
  EXPECT_EQ(w.code, 2) << w.out << w.err;
  EXPECT_EQ(w.err, "solid: welcome_t: total_steps = 0; allowed: 1 or more (3 copies refused)\n");
  EXPECT_EQ(zero.hellos.size(), 3u);
  EXPECT_TRUE(zero.states.empty());
  for (const fs::path& d : {clean_dir, noisy_dir, dir, wdir}) fs::remove_all(d);
}

}  // namespace