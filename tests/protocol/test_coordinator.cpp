// DESIGN 2.2: the coordinator's transport-free logic. The handshake refuses every mismatch
// with a line that names it; lock-step sequencing survives lost, duplicated and reordered
// messages; a silent peer is re-asked, then given up; other runs' messages are counted,
// never applied.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/handshake.hpp"
#include "protocol/step_sequencer.hpp"
#include "protocol/units.hpp"

namespace {

using namespace cosim::protocol;

const std::string kToken = "0123456789abcdef";
const std::string kSceneHash = "fedcba9876543210";

/// A hello as a server would fill it, every number from the unit converter.
Hello hello_from(const UnitConverter& u, const std::string& role) {
  Hello h;
  h.token = kToken;
  h.role = role;
  h.model = role == "fluid" ? "d3q19-bgk" : "rcgp";
  h.version = kProtocolVersion;
  h.scene_hash = kSceneHash;
  h.dx_m = u.dx_m();
  h.dt_lb_s = u.dt_lb_s();
  h.sound_speed_m_s = u.inputs().sound_speed_m_s;
  h.air_density_kg_m3 = u.air_density_kg_m3();
  if (role == "solid") {
    h.time_ratio = u.inputs().time_ratio;
    h.dt_cg_s = u.dt_cg_s();
    h.stable_dt_cg_s = 1.25 * u.dt_cg_s();
    h.num_cgps = 5 * 40;  // the paper's 5 x 40 sheet
  }
  return h;
}

/// Refused, with one line containing every one of `needles`.
void expect_refused(const HandshakeResult& r, const std::vector<std::string>& needles) {
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.time_ratio, 0);
  EXPECT_EQ(r.reason.find('\n'), std::string::npos) << r.reason;
  for (const auto& n : needles)
    EXPECT_NE(r.reason.find(n), std::string::npos) << "'" << n << "' not in: " << r.reason;
}

TEST(Coordinator, HandshakeRejectsMismatch) {
  const UnitConverter u;  // the paper's units: dx = 0.2561 um, dt_LB = dx / c, A_T = 150
  const Hello fluid = hello_from(u, "fluid");
  const Hello solid = hello_from(u, "solid");

  // A matching pair starts, at the paper's A_T (Eq. 30).
  const HandshakeResult ok = check_handshake(fluid, solid, kToken);
  EXPECT_TRUE(ok.accepted) << ok.reason;
  EXPECT_TRUE(ok.reason.empty());
  EXPECT_EQ(ok.time_ratio, 150);
  EXPECT_EQ(ok.time_ratio, u.inputs().time_ratio);

  // Roles.
  expect_refused(check_handshake(solid, fluid, kToken), {"role", "'solid'", "'fluid'"});

  // Token, on either side, and an empty run token.
  {
    Hello f = fluid;
    f.token = "aaaaaaaaaaaaaaaa";
    expect_refused(check_handshake(f, solid, kToken), {"token", "fluid", f.token, kToken});
    Hello s = solid;
    s.token = "bbbbbbbbbbbbbbbb";
    expect_refused(check_handshake(fluid, s, kToken), {"token", "solid", s.token, kToken});
    expect_refused(check_handshake(fluid, solid, ""), {"token", "empty"});
  }

  // Protocol version.
  {
    Hello s = solid;
    s.version = "1";  // a peer of the previous version
    expect_refused(check_handshake(fluid, s, kToken), {"version", std::string("'") + kProtocolVersion + "'", "'1'"});
    // Checks run in order: with the scene also wrong, the version is named.
    s.scene_hash = "0000000000000000";
    expect_refused(check_handshake(fluid, s, kToken), {"version"});
  }

  // Scene hash.
  {
    Hello s = solid;
    s.scene_hash = "0000000000000000";
    expect_refused(check_handshake(fluid, s, kToken), {"scene_hash", kSceneHash, s.scene_hash});
  }

  // Units: each field is named; a round-off difference (1e-14) is not a mismatch.
  {
    Hello s = solid;
    s.dx_m = u.dx_m() * (1.0 + 1e-9);
    expect_refused(check_handshake(fluid, s, kToken), {"units differ", "dx_m", "fluid", "solid"});
    s = solid;
    s.air_density_kg_m3 = 1.01 * u.air_density_kg_m3();
    expect_refused(check_handshake(fluid, s, kToken), {"units differ", "air_density_kg_m3"});
    s = solid;
    s.sound_speed_m_s = (1.0 + 1e-6) * u.inputs().sound_speed_m_s;
    expect_refused(check_handshake(fluid, s, kToken), {"sound_speed_m_s"});
    s = solid;
    s.dt_lb_s = u.dt_lb_s() * (1.0 + 1e-14);
    EXPECT_TRUE(check_handshake(fluid, s, kToken).accepted);
  }

  // Non-finite or non-positive numbers name the field.
  {
    Hello s = solid;
    s.stable_dt_cg_s = std::numeric_limits<double>::quiet_NaN();
    expect_refused(check_handshake(fluid, s, kToken), {"stable_dt_cg_s", "positive finite"});
    Hello f = fluid;
    f.dt_lb_s = -u.dt_lb_s();
    expect_refused(check_handshake(f, solid, kToken), {"fluid", "dt_lb_s", "positive finite"});
    s = solid;
    s.dt_cg_s = std::numeric_limits<double>::infinity();
    expect_refused(check_handshake(fluid, s, kToken), {"dt_cg_s", "positive finite"});
  }

  // A_T not a whole number: dt_CG must divide dt_LB.
  {
    Hello s = solid;
    s.dt_cg_s = u.dt_lb_s() / 149.5;
    expect_refused(check_handshake(fluid, s, kToken),
                   {"A_T", "149.5", "not a whole number", "dt_CG must divide dt_LB"});
    s.dt_cg_s = 2.0 * u.dt_lb_s();  // A_T = 0.5
    s.stable_dt_cg_s = 4.0 * u.dt_lb_s();
    expect_refused(check_handshake(fluid, s, kToken), {"A_T", "dt_CG must divide dt_LB"});
  }

  // The solid's own time_ratio must be that A_T.
  {
    const UnitConverter u100(UnitInputs{.time_ratio = 100});
    Hello s = solid;
    s.time_ratio = u100.inputs().time_ratio;
    expect_refused(check_handshake(fluid, s, kToken), {"time_ratio = 100", "A_T", "150"});
  }

  // dt_CG above the stable step: refused with the largest stable A_T-compatible dt_CG,
  // which is then accepted.
  {
    Hello s = solid;
    s.stable_dt_cg_s = 0.9 * u.dt_cg_s();
    const int stable_ratio = static_cast<int>(std::ceil(u.dt_lb_s() / s.stable_dt_cg_s));
    EXPECT_EQ(stable_ratio, 167);  // ceil(150 / 0.9)
    expect_refused(check_handshake(fluid, s, kToken),
                   {"stable", "dt_LB / ceil(dt_LB / stable)",
                    "(A_T = " + std::to_string(stable_ratio) + ")"});
    // The watchdog's retry takes the smallest stable A_T from the verdict.
    EXPECT_EQ(check_handshake(fluid, s, kToken).stable_time_ratio, stable_ratio);
    const UnitConverter suggested(UnitInputs{.time_ratio = stable_ratio});
    s.dt_cg_s = suggested.dt_cg_s();
    s.time_ratio = suggested.inputs().time_ratio;
    const HandshakeResult r = check_handshake(fluid, s, kToken);
    EXPECT_TRUE(r.accepted) << r.reason;
    EXPECT_EQ(r.time_ratio, stable_ratio);
    EXPECT_LE(s.dt_cg_s, s.stable_dt_cg_s);
  }

  // Nothing to couple.
  {
    Hello s = solid;
    s.num_cgps = 0;
    expect_refused(check_handshake(fluid, s, kToken), {"num_cgps = 0"});
  }

  // The added-mass fields (section 12): both 0 (not reported) or both positive and finite.
  {
    Hello s = solid;
    s.light_cgp_mass_kg = 3.989e-20;
    s.light_cgp_area_m2 = 5.28e-14;
    EXPECT_TRUE(check_handshake(fluid, s, kToken).accepted);
    s.light_cgp_area_m2 = 0.0;
    expect_refused(check_handshake(fluid, s, kToken),
                   {"light_cgp_mass_kg = 3.989e-20 and light_cgp_area_m2 = 0", "both 0 (not reported)"});
    s.light_cgp_mass_kg = 0.0;
    EXPECT_TRUE(check_handshake(fluid, s, kToken).accepted);
    s.light_cgp_mass_kg = -1.0;
    s.light_cgp_area_m2 = 1.0;
    expect_refused(check_handshake(fluid, s, kToken), {"light_cgp_mass_kg = -1"});
  }
}

TEST(Coordinator, SequencerDetectsLossDuplicationAndReordering) {
  using V = StepSequencer::Verdict;
  struct Msg {
    std::int64_t step, seq;
  };

  // Scripted: each fault once.
  {
    StepSequencer s(10);
    EarlyBuffer<Msg> buffer(4);
    EXPECT_EQ(s.expected_step(), 10);
    EXPECT_THROW(s.advance(), std::logic_error);  // nothing accepted yet: no skipping

    EXPECT_EQ(s.offer(10, 0), V::Accept);
    EXPECT_EQ(s.offer(10, 0), V::Duplicate);  // UDP delivered it twice
    EXPECT_TRUE(s.expected_received());
    s.advance();
    EXPECT_EQ(s.offer(10, 0), V::Stale);  // a copy arriving after the step was consumed

    // Step 11 is lost: step 12 arrives first; the consumer keeps it and asks for 11.
    EXPECT_EQ(s.offer(12, 2), V::Early);
    EXPECT_TRUE(s.missing_expected());
    EXPECT_TRUE(buffer.store(12, Msg{12, 2}));
    EXPECT_FALSE(buffer.store(12, Msg{12, 2}));  // one copy per step
    EXPECT_EQ(s.offer(11, 3), V::Accept);         // the resent step 11
    EXPECT_FALSE(s.missing_expected());
    s.advance();
    const auto held = buffer.take(s.expected_step());
    ASSERT_TRUE(held.has_value());
    EXPECT_EQ(s.offer(held->step, held->seq), V::Accept);  // seq 2 after seq 3: reordered
    EXPECT_EQ(buffer.size(), 0U);
    s.advance();

    // Reordered without loss: 14 overtakes 13.
    EXPECT_EQ(s.offer(14, 5), V::Early);
    EXPECT_EQ(s.offer(13, 4), V::Accept);
    s.advance();
    EXPECT_EQ(s.offer(14, 5), V::Accept);
    EXPECT_EQ(s.offer(11, 3), V::Stale);  // a late duplicate of the resend

    EXPECT_EQ(s.accepted(), 5);
    EXPECT_EQ(s.duplicates(), 1);
    EXPECT_EQ(s.stale(), 2);
    EXPECT_EQ(s.early(), 2);
    EXPECT_EQ(s.reordered(), 3);  // seq 2 after 3, 4 after 5, 3 after 5
  }

  // The buffer keeps the steps nearest to being consumed.
  {
    EarlyBuffer<Msg> buffer(2);
    EXPECT_TRUE(buffer.store(7, Msg{7, 0}));
    EXPECT_TRUE(buffer.store(5, Msg{5, 0}));
    EXPECT_FALSE(buffer.store(9, Msg{9, 0}));  // full, and farther than everything held
    EXPECT_TRUE(buffer.store(6, Msg{6, 0}));   // evicts 7
    EXPECT_FALSE(buffer.take(7).has_value());
    buffer.drop_before(6);
    EXPECT_FALSE(buffer.take(5).has_value());
    EXPECT_TRUE(buffer.take(6).has_value());
  }

  // A lossy, duplicating, reordering channel: every step is applied exactly once, in order.
  {
    constexpr std::int64_t n_steps = 300;
    std::mt19937 rng(12345);
    std::bernoulli_distribution lose(0.2), duplicate(0.1), swap(0.2);
    std::deque<Msg> wire;
    std::int64_t next_seq = 0;
    std::int64_t lost = 0;
    auto publish = [&](std::int64_t step) {
      const Msg m{step, next_seq++};
      if (lose(rng)) {
        ++lost;
        return;
      }
      wire.push_back(m);
      if (duplicate(rng)) wire.push_back(m);
      if (wire.size() >= 2 && swap(rng)) std::swap(wire[wire.size() - 1], wire[wire.size() - 2]);
    };
    for (std::int64_t k = 0; k < n_steps; ++k) publish(k);

    StepSequencer s(0);
    EarlyBuffer<Msg> buffer(8);
    std::vector<std::int64_t> applied;
    auto apply_and_drain = [&](std::int64_t step) {
      applied.push_back(step);
      s.advance();
      while (auto m = buffer.take(s.expected_step())) {
        ASSERT_EQ(s.offer(m->step, m->seq), V::Accept);
        applied.push_back(m->step);
        s.advance();
      }
    };
    for (int guard = 0; s.expected_step() < n_steps && guard < 100000; ++guard) {
      if (wire.empty()) {  // silence: the peer watch's Resend for the awaited step
        publish(s.expected_step());
        continue;
      }
      const Msg m = wire.front();
      wire.pop_front();
      switch (s.offer(m.step, m.seq)) {
        case V::Accept:
          apply_and_drain(m.step);
          break;
        case V::Early:
          buffer.store(m.step, m);
          if (s.missing_expected()) publish(s.expected_step());  // resend request
          break;
        case V::Duplicate:
        case V::Stale:
          break;
      }
    }
    std::vector<std::int64_t> in_order(n_steps);
    for (std::int64_t k = 0; k < n_steps; ++k) in_order[static_cast<std::size_t>(k)] = k;
    EXPECT_EQ(applied, in_order);
    EXPECT_EQ(s.accepted(), n_steps);
    EXPECT_GT(lost, 0);
    EXPECT_GT(s.early(), 0);
    EXPECT_GT(s.stale() + s.duplicates(), 0);
    EXPECT_GT(s.reordered(), 0);
  }
}

TEST(Coordinator, PeerWatchResendsThenGivesUp) {
  using A = PeerWatch::Action;
  using std::chrono::milliseconds;
  const PeerWatch::time_point t0{};  // any epoch: no clock is read
  PeerWatch w(milliseconds(1000), milliseconds(300));

  w.heard(t0);
  EXPECT_EQ(w.poll(t0 + milliseconds(299)), A::Wait);
  EXPECT_EQ(w.poll(t0 + milliseconds(300)), A::Resend);
  EXPECT_EQ(w.poll(t0 + milliseconds(301)), A::Wait);  // one resend per interval
  EXPECT_EQ(w.poll(t0 + milliseconds(600)), A::Resend);
  EXPECT_EQ(w.resends_since_heard(), 2);

  // News resets both clocks.
  w.heard(t0 + milliseconds(700));
  EXPECT_EQ(w.resends_since_heard(), 0);
  EXPECT_EQ(w.poll(t0 + milliseconds(999)), A::Wait);
  EXPECT_EQ(w.poll(t0 + milliseconds(1000)), A::Resend);
  EXPECT_EQ(w.poll(t0 + milliseconds(1300)), A::Resend);
  EXPECT_EQ(w.poll(t0 + milliseconds(1600)), A::Resend);
  EXPECT_EQ(w.poll(t0 + milliseconds(1699)), A::Wait);
  EXPECT_EQ(w.poll(t0 + milliseconds(1700)), A::GiveUp);  // timeout after the last news
  EXPECT_EQ(w.poll(t0 + milliseconds(5000)), A::GiveUp);  // and it stays given up
  EXPECT_EQ(w.resends_since_heard(), 3);

  // A poll before any news starts the clock.
  PeerWatch fresh(milliseconds(100), milliseconds(40));
  EXPECT_EQ(fresh.poll(t0 + milliseconds(5000)), A::Wait);
  EXPECT_EQ(fresh.poll(t0 + milliseconds(5040)), A::Resend);
  EXPECT_EQ(fresh.poll(t0 + milliseconds(5100)), A::GiveUp);

  // Settings that could never resend are refused.
  EXPECT_THROW(PeerWatch(milliseconds(100), milliseconds(100)), std::invalid_argument);
  EXPECT_THROW(PeerWatch(milliseconds(100), milliseconds(0)), std::invalid_argument);
}

TEST(Coordinator, SceneHashAndTokens) {
  namespace fs = std::filesystem;
  // FNV-1a 64 reference values (offset basis; published test vectors).
  EXPECT_EQ(fnv1a_64(""), 0xcbf29ce484222325ULL);
  EXPECT_EQ(fnv1a_64("a"), 0xaf63dc4c8601ec8cULL);
  EXPECT_EQ(fnv1a_64("foobar"), 0x85944171f73967e8ULL);

  const fs::path dir = fs::temp_directory_path() / ("cosim_test_coordinator_" + new_run_token());
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name, std::ios::binary) << text;
    return (dir / name).string();
  };
  EXPECT_EQ(scene_hash_of_file(write("empty.toml", "")), "cbf29ce484222325");
  EXPECT_EQ(scene_hash_of_file(write("a.toml", "a")), "af63dc4c8601ec8c");
  const std::string scene = "[grid]\nnx = 120\nny = 60\nnz = 90\n";
  const std::string h1 = scene_hash_of_file(write("s1.toml", scene));
  EXPECT_EQ(h1, scene_hash_of_file(write("s1_copy.toml", scene)));  // bytes, not the name
  EXPECT_NE(h1, scene_hash_of_file(write("s2.toml", "[grid]\nnx = 121\nny = 60\nnz = 90\n")));
  EXPECT_EQ(h1.size(), 16U);

  // Unreadable: the message names the file.
  const std::string missing = (dir / "missing.toml").string();
  try {
    scene_hash_of_file(missing);
    ADD_FAILURE() << "no exception for a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_THROW(scene_hash_of_file(dir.string()), std::runtime_error);  // a directory
  fs::remove_all(dir);

  // Tokens: 16 hex digits, fresh each time.
  std::set<std::string> tokens;
  for (int i = 0; i < 100; ++i) {
    const std::string t = new_run_token();
    EXPECT_EQ(t.size(), 16U);
    EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos) << t;
    tokens.insert(t);
  }
  EXPECT_EQ(tokens.size(), 100U);

  // Messages of another run: counted per channel, never admitted, logged once per channel.
  std::vector<std::string> log;
  ForeignCounter foreign(kToken, [&](const std::string& line) { log.push_back(line); });
  EXPECT_TRUE(foreign.admit("cosim/SOLID_STATE", kToken));
  EXPECT_FALSE(foreign.admit("cosim/SOLID_STATE", "ffffffffffffffff"));
  EXPECT_FALSE(foreign.admit("cosim/SOLID_STATE", "ffffffffffffffff"));
  EXPECT_FALSE(foreign.admit("cosim/FLUID_STATE", "eeeeeeeeeeeeeeee"));
  EXPECT_TRUE(foreign.admit("cosim/FLUID_STATE", kToken));
  EXPECT_EQ(foreign.count("cosim/SOLID_STATE"), 2);
  EXPECT_EQ(foreign.count("cosim/FLUID_STATE"), 1);
  EXPECT_EQ(foreign.count("cosim/HELLO"), 0);
  EXPECT_EQ(foreign.total(), 3);
  ASSERT_EQ(log.size(), 2U);
  EXPECT_NE(log[0].find("cosim/SOLID_STATE"), std::string::npos) << log[0];
  EXPECT_NE(log[0].find("ffffffffffffffff"), std::string::npos) << log[0];
  EXPECT_EQ(log[0].find('\n'), std::string::npos);
  EXPECT_THROW(ForeignCounter(""), std::invalid_argument);
}

}  // namespace
