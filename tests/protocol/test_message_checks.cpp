// The checks of every message type (protocol/message_checks.hpp, protocol/README.md section
// 8a): values and bytes, before anything is used or allocated; the rejection counters.
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
using cosim::protocol::RejectCategory;


template <class M>
struct Case {
  const char* name;
  std::function<void(M&)> breakit;
  RejectCategory category;
  const char* names;  ///< the reason must contain this (the field and its value)
};

template <class M>
void expect_rejected(const M& valid, const Expectation& e, const std::vector<Case<M>>& cases) {
  ASSERT_FALSE(cosim::protocol::check(valid, e).has_value())
      << M::getTypeName() << ": " << cosim::protocol::check(valid, e)->what;
  for (const Case<M>& c : cases) {
    M m = valid;
    c.breakit(m);
    const auto r = cosim::protocol::check(m, e);
    ASSERT_TRUE(r.has_value()) << M::getTypeName() << " " << c.name << ": accepted";
    EXPECT_EQ(r->category, c.category) << c.name << ": " << r->what;
    EXPECT_NE(r->what.find(c.names), std::string::npos) << c.name << ": " << r->what;
    EXPECT_EQ(r->what.rfind(std::string(M::getTypeName()) + ": ", 0), 0u) << r->what;
    EXPECT_EQ(r->what.find('\n'), std::string::npos) << r->what;
  }
}


// ---- the checks, message by message ----

TEST(MessageChecks, MalformedMessagesAreRejected) {
  using RC = RejectCategory;
  using SS = cosimlcm::solid_state_t;
  using FS = cosimlcm::fluid_state_t;
  expect_rejected<SS>(
      valid_solid_state(), expect_state(),
      {
          {"token", [](SS& m) { m.token = "fedcba9876543210"; }, RC::Token, "token = 'fedcba9876543210'"},
          {"num_cgps", [](SS& m) { m.num_cgps = 5; }, RC::Count, "num_cgps = 5; expected 4"},
          {"outer size", [](SS& m) { m.position_lb.pop_back(); }, RC::Count, "position_lb has 3 rows"},
          {"outer size 2", [](SS& m) { m.impulse_lb.push_back({0, 0, 0}); }, RC::Count, "impulse_lb has 5 rows"},
          {"inner size", [](SS& m) { m.impulse_lb[2].pop_back(); }, RC::Count, "impulse_lb[2] has 2 entries"},
          {"inner size 4", [](SS& m) { m.position_lb[1].push_back(0.0); }, RC::Count, "position_lb[1] has 4 entries"},
          {"nan", [](SS& m) { m.position_lb[3][1] = kNaN; }, RC::NonFinite, "position_lb[3][1] = nan"},
          {"inf", [](SS& m) { m.impulse_lb[0][2] = -kInf; }, RC::NonFinite, "impulse_lb[0][2] = -inf"},
          {"time nan", [](SS& m) { m.solid_time_s = kNaN; }, RC::NonFinite, "solid_time_s = nan"},
          {"time negative", [](SS& m) { m.solid_time_s = -1e-9; }, RC::Range, "solid_time_s = -1e-09"},
          {"step ahead", [](SS& m) { m.step = 13; }, RC::Range, "step = 13; allowed: 0 to 12"},
          {"step negative", [](SS& m) { m.step = -1; }, RC::Range, "step = -1"},
          {"step huge", [](SS& m) { m.step = std::numeric_limits<std::int64_t>::max(); }, RC::Range, "step = 9223372036854775807"},
          {"seq", [](SS& m) { m.seq = -1; }, RC::Range, "seq = -1"},
          {"substeps", [](SS& m) { m.substeps = 149; }, RC::Range, "substeps = 149; allowed: 0 or A_T = 150"},
          {"substeps negative", [](SS& m) { m.substeps = -150; }, RC::Range, "substeps = -150"},
      });
  {  // substeps 0 is allowed (step 0, the spin-up)
    SS m = valid_solid_state();
    m.substeps = 0;
    EXPECT_FALSE(cosim::protocol::check(m, expect_state()).has_value());
  }
  {  // a restart with another A_T (the watchdog's retry) also takes the checkpoint's A_T, no other
    SS m = valid_solid_state();
    m.substeps = 75;
    cosim::protocol::Expectation e = expect_state();
    e.restart_time_ratio = 75;
    EXPECT_FALSE(cosim::protocol::check(m, e).has_value());
    m.substeps = 74;
    const auto r = cosim::protocol::check(m, e);
    ASSERT_TRUE(r.has_value());
    EXPECT_NE(r->what.find("substeps = 74; allowed: 0 or A_T = 150 (or the restart's 75)"), std::string::npos) << r->what;
  }
  {  // the implicit scheme's iteration lies in [0, max_iterations)
    SS m = valid_solid_state();
    m.iteration = 3;
    cosim::protocol::Expectation e = expect_state();
    EXPECT_TRUE(cosim::protocol::check(m, e).has_value());  // serial: 0 only
    e.max_iterations = 4;
    EXPECT_FALSE(cosim::protocol::check(m, e).has_value());
    m.iteration = 4;
    const auto r = cosim::protocol::check(m, e);
    ASSERT_TRUE(r.has_value());
    EXPECT_NE(r->what.find("iteration = 4; allowed: 0 to 3"), std::string::npos) << r->what;
  }
  expect_rejected<FS>(
      valid_fluid_state(), expect_state(),
      {
          {"token", [](FS& m) { m.token = ""; }, RC::Token, "token = ''"},
          {"num_cgps", [](FS& m) { m.num_cgps = -4; }, RC::Count, "num_cgps = -4; expected 4"},
          {"rho size", [](FS& m) { m.rho_lb.pop_back(); }, RC::Count, "rho_lb has 3 entries"},
          {"velocity size", [](FS& m) { m.velocity_lb.clear(); }, RC::Count, "velocity_lb has 0 rows"},
          {"velocity inner", [](FS& m) { m.velocity_lb[1] = {0.0}; }, RC::Count, "velocity_lb[1] has 1 entries"},
          {"rho zero", [](FS& m) { m.rho_lb[2] = 0.0; }, RC::Range, "rho_lb[2] = 0; allowed: a density > 0"},
          {"rho negative", [](FS& m) { m.rho_lb[0] = -0.5; }, RC::Range, "rho_lb[0] = -0.5"},
          {"rho nan", [](FS& m) { m.rho_lb[3] = kNaN; }, RC::NonFinite, "rho_lb[3] = nan"},
          {"velocity inf", [](FS& m) { m.velocity_lb[2][0] = kInf; }, RC::NonFinite, "velocity_lb[2][0] = inf"},
          {"bulk nan", [](FS& m) { m.bulk_velocity_lb = kNaN; }, RC::NonFinite, "bulk_velocity_lb = nan"},
          {"step", [](FS& m) { m.step = 100; }, RC::Range, "step = 100"},
          {"seq", [](FS& m) { m.seq = std::numeric_limits<std::int64_t>::min(); }, RC::Range, "seq = -9223372036854775808"},
      });
  using HE = cosimlcm::hello_t;
  expect_rejected<HE>(
      valid_hello(), expect_state(),
      {
          {"token", [](HE& m) { m.token = "x"; }, RC::Token, "token = 'x'"},
          {"role", [](HE& m) { m.role = "gas"; }, RC::Text, "role = 'gas'; allowed: 'fluid', 'solid'"},
          {"model long", [](HE& m) { m.model = std::string(65, 'm'); }, RC::Text, "has 65 bytes; at most 64"},
          {"hash NUL", [](HE& m) { m.scene_hash = std::string("ab\0cd", 5); }, RC::Text, "scene_hash = 'ab\\x00cd' contains a NUL"},
          {"dx nan", [](HE& m) { m.dx_m = kNaN; }, RC::NonFinite, "dx_m = nan"},
          {"dt zero", [](HE& m) { m.dt_lb_s = 0.0; }, RC::Range, "dt_lb_s = 0; allowed: a number > 0"},
          {"stable inf", [](HE& m) { m.stable_dt_cg_s = kInf; }, RC::NonFinite, "stable_dt_cg_s = inf"},
          {"time_ratio", [](HE& m) { m.time_ratio = 0; }, RC::Range, "time_ratio = 0"},
          {"num_cgps", [](HE& m) { m.num_cgps = -1; }, RC::Count, "num_cgps = -1"},
      });
  using WE = cosimlcm::welcome_t;
  expect_rejected<WE>(
      valid_welcome(), expect_state(),
      {
          {"accepted", [](WE& m) { m.accepted = 7; }, RC::Range, "accepted = 7"},
          {"total_steps", [](WE& m) { m.total_steps = 0; }, RC::Range, "total_steps = 0"},
          {"rigid_steps", [](WE& m) { m.rigid_steps = -2; }, RC::Range, "rigid_steps = -2"},
          {"time_ratio", [](WE& m) { m.time_ratio = -150; }, RC::Range, "time_ratio = -150"},
          {"reason long", [](WE& m) { m.reason = std::string(5000, 'r'); }, RC::Text, "reason = 'rrrr"},
      });
  using RE = cosimlcm::resend_t;
  expect_rejected<RE>(valid_resend(), expect_state(),
                      {
                          {"what", [](RE& m) { m.what = "everything"; }, RC::Text, "what = 'everything'"},
                          {"step", [](RE& m) { m.step = -3; }, RC::Range, "step = -3"},
                      });
  using ST = cosimlcm::stop_t;
  expect_rejected<ST>(valid_stop(), expect_state(),
                      {
                          {"exit_code", [](ST& m) { m.exit_code = 256; }, RC::Range, "exit_code = 256; allowed: 0 to 255"},
                          {"exit_code negative", [](ST& m) { m.exit_code = -1; }, RC::Range, "exit_code = -1"},
                          {"step", [](ST& m) { m.step = -2; }, RC::Range, "step = -2"},
                          {"sender", [](ST& m) { m.sender = "coordinator"; }, RC::Text, "sender = 'coordinator'"},
                          {"reason", [](ST& m) { m.reason = std::string(4097, 'x'); }, RC::Text, "has 4097 bytes; at most 4096"},
                      });
}

// The bytes: decode_checked refuses what the generated decode would trust (a claimed count or
// a string length the bytes cannot hold, a string length of 0 or below, extra bytes, another
// type) before it allocates anything, with one line naming the field.
TEST(MessageChecks, EncodedMessagesAreCheckedBeforeDecoding) {
  const std::vector<std::uint8_t> good = encode(valid_solid_state());
  cosimlcm::solid_state_t m{};
  EXPECT_FALSE(cosim::protocol::decode_checked(good.data(), good.size(), m).has_value());
  EXPECT_EQ(m.num_cgps, 4);
  EXPECT_EQ(m.position_lb.size(), 4u);

  // Layout: hash (8), token length (4) + 17 bytes, seq (8), step (8), iteration (4),
  // substeps (4), solid_time_s (8), num_cgps (4) at byte 61.
  // num_cgps after the hash, the token (4 + 17), seq, step, iteration, substeps, solid_time_s.
  const std::size_t token_at = 8, num_at = 8 + 4 + 17 + 8 + 8 + 4 + 4 + 8;
  struct Bad {
    const char* name;
    std::function<void(std::vector<std::uint8_t>&)> breakit;
    const char* names;
  };
  const std::vector<Bad> cases = {
      {"huge count", [&](auto& b) { put_i32(b, num_at, 0x7fffffffU); }, "num_cgps = 2147483647 needs 103079215056 bytes"},
      {"negative count", [&](auto& b) { put_i32(b, num_at, 0xffffffffU); }, "num_cgps = -1; allowed: 0 or more"},
      {"count one more", [&](auto& b) { put_i32(b, num_at, 5); }, "num_cgps = 5 needs 240 bytes of arrays, but 192 are left"},
      {"count one less", [&](auto& b) { put_i32(b, num_at, 3); }, "48 bytes follow the last field"},
      {"token length 0", [&](auto& b) { put_i32(b, token_at, 0); }, "token: string length = 0"},
      {"token length negative", [&](auto& b) { put_i32(b, token_at, 0x80000000U); }, "token: string length = -2147483648"},
      {"token length huge", [&](auto& b) { put_i32(b, token_at, 1000000); }, "token: string length = 1000000, but"},
      {"token without NUL", [&](auto& b) { b[token_at + 4 + 16] = 'x'; }, "does not end with a NUL"},
      {"fingerprint", [&](auto& b) { b[0] ^= 0x01; }, "fingerprint = 0x"},
      {"truncated", [&](auto& b) { b.resize(30); }, "the message ends after 30 bytes"},
      {"empty", [&](auto& b) { b.clear(); }, "the type fingerprint: the message ends after 0 bytes"},
      {"trailing byte", [&](auto& b) { b.push_back(0); }, "1 bytes follow the last field"},
  };
  for (const Bad& c : cases) {
    std::vector<std::uint8_t> b = good;
    c.breakit(b);
    cosimlcm::solid_state_t out{};
    const auto why = cosim::protocol::decode_checked(b.data(), b.size(), out);
    ASSERT_TRUE(why.has_value()) << c.name;
    EXPECT_NE(why->find(c.names), std::string::npos) << c.name << ": " << *why;
    EXPECT_EQ(why->rfind("solid_state_t: ", 0), 0u) << *why;
    EXPECT_LE(out.position_lb.size(), 4u) << c.name << ": decoded anyway";
  }
  // Another type's bytes.
  const std::vector<std::uint8_t> stop = encode(valid_stop());
  cosimlcm::solid_state_t out{};
  EXPECT_TRUE(cosim::protocol::decode_checked(stop.data(), stop.size(), out).has_value());
  // Every type round-trips through decode_checked.
  cosimlcm::fluid_state_t f{};
  const auto fb = encode(valid_fluid_state(7));
  EXPECT_FALSE(cosim::protocol::decode_checked(fb.data(), fb.size(), f).has_value());
  EXPECT_EQ(f.rho_lb.size(), 7u);
  cosimlcm::hello_t h{};
  const auto hb = encode(valid_hello());
  EXPECT_FALSE(cosim::protocol::decode_checked(hb.data(), hb.size(), h).has_value());
  EXPECT_EQ(h.scene_hash, "0123456789abcdef");
  cosimlcm::welcome_t w{};
  const auto wb = encode(valid_welcome());
  EXPECT_FALSE(cosim::protocol::decode_checked(wb.data(), wb.size(), w).has_value());
  cosimlcm::resend_t r{};
  const auto rb = encode(valid_resend());
  EXPECT_FALSE(cosim::protocol::decode_checked(rb.data(), rb.size(), r).has_value());
  cosimlcm::stop_t s{};
  EXPECT_FALSE(cosim::protocol::decode_checked(stop.data(), stop.size(), s).has_value());
}

// The counters: per channel and category, the first of each pair logged once.
TEST(MessageChecks, RejectionsAreCountedAndLoggedOnce) {
  std::vector<std::string> lines;
  cosim::protocol::MessageRejections rej([&](const std::string& l) { lines.push_back(l); });
  EXPECT_EQ(rej.summary(), "rejected 0");
  const cosim::protocol::Rejection nan{RejectCategory::NonFinite, "fluid_state_t: rho_lb[0] = nan; every number must be finite"};
  const cosim::protocol::Rejection count{RejectCategory::Count, "fluid_state_t: num_cgps = 3; expected 4"};
  for (int k = 0; k < 3; ++k) rej.add("A_FLUID_STATE", nan);
  rej.add("A_FLUID_STATE", count);
  rej.add("A_STOP", nan);
  EXPECT_EQ(rej.total(), 5);
  EXPECT_EQ(rej.count("A_FLUID_STATE"), 4);
  EXPECT_EQ(rej.count("A_STOP"), 1);
  EXPECT_EQ(rej.count(RejectCategory::NonFinite), 4);
  EXPECT_EQ(rej.summary(), "rejected 5 (count 1, non-finite 4)");
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "refusing messages on channel 'A_FLUID_STATE' (non-finite): fluid_state_t: rho_lb[0] = "
                      "nan; every number must be finite; such messages are counted, never applied");

  // Reasons are cut for the wire: one line, at most kMaxReasonLength bytes, whole UTF-8.
  std::string longer(cosim::protocol::kMaxReasonLength - 1, 'a');
  longer += "\xc3\xa9\n tail";
  const std::string cut = cosim::protocol::bounded_reason(longer);
  EXPECT_EQ(cut.size(), cosim::protocol::kMaxReasonLength - 1);
  EXPECT_EQ(cosim::protocol::bounded_reason("two\nlines"), "two lines");
}

}  // namespace
