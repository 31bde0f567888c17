// The LCM message types (protocol/lcm/*.lcm, protocol/README.md) survive a publish and a
// receive bit for bit, over the in-process memq:// provider, on the channels of
// protocol/channels.hpp; channel prefixes are validated.
#include <gtest/gtest.h>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "protocol/handshake.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"

namespace {

using cosim::protocol::Channels;
using Rows3 = std::vector<std::vector<double>>;

constexpr int receive_timeout_ms = 2000;  // a lost message fails the test, never hangs it

constexpr double tiny = 1e-300;
constexpr double huge = std::numeric_limits<double>::max();
constexpr double denormal = std::numeric_limits<double>::denorm_min();
constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr std::int64_t big = std::numeric_limits<std::int64_t>::max();
constexpr std::int64_t most_negative = std::numeric_limits<std::int64_t>::min();

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

#define EXPECT_SAME_BITS(a, b, field) \
  EXPECT_EQ(bits(a), bits(b)) << field << ": " << (a) << " vs " << (b)

void expect_same_rows(const Rows3& sent, const Rows3& got, const char* field) {
  ASSERT_EQ(got.size(), sent.size()) << field;
  for (std::size_t l = 0; l < sent.size(); ++l) {
    ASSERT_EQ(got[l].size(), 3u) << field << "[" << l << "]";
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_SAME_BITS(sent[l][k], got[l][k], std::string(field) + "[" + std::to_string(l) +
                                                  "][" + std::to_string(k) + "]");
  }
}

// n CGPs x 3 components, every entry distinct and including the extreme doubles.
Rows3 rows3(int n, double scale) {
  const double specials[] = {tiny, -0.0, huge, -huge, denormal, -denormal, 1.0 / 3.0, -7.5e-17};
  Rows3 r(static_cast<std::size_t>(n), std::vector<double>(3));
  std::size_t i = 0;
  for (auto& row : r)
    for (auto& v : row) {
      v = i < std::size(specials) ? specials[i] : scale * (static_cast<double>(i) + 0.125);
      ++i;
    }
  return r;
}

template <class Message>
struct Inbox {
  std::vector<Message> messages;
  std::vector<std::string> channels;
};

template <class Message>
void receive(const lcm::ReceiveBuffer*, const std::string& channel, const Message* msg,
             Inbox<Message>* inbox) {
  inbox->messages.push_back(*msg);
  inbox->channels.push_back(channel);
}

// Publishes `sent` on `channel` and handles what arrives: exactly one message on that
// channel, or the test fails (after at most receive_timeout_ms, never hanging).
template <class Message>
Inbox<Message> publish_and_receive(lcm::LCM& bus, const std::string& channel,
                                   const Message& sent) {
  Inbox<Message> inbox;
  lcm::Subscription* sub = bus.subscribeFunction(channel, &receive<Message>, &inbox);
  EXPECT_NE(sub, nullptr) << channel;
  EXPECT_EQ(bus.publish(channel, &sent), 0) << channel;
  EXPECT_GT(bus.handleTimeout(receive_timeout_ms), 0) << channel << ": nothing received";
  EXPECT_EQ(bus.handleTimeout(20), 0) << channel << ": more than one message received";
  bus.unsubscribe(sub);
  EXPECT_EQ(inbox.messages.size(), 1u) << channel;
  for (const auto& c : inbox.channels) EXPECT_EQ(c, channel);
  return inbox;
}

TEST(Protocol, MessagesRoundTrip) {
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  const Channels ch("RUN_7f3a_");
  const std::string token = "run-0123456789abcdef-token";

  {
    cosimlcm::hello_t sent{};
    sent.token = token;
    sent.role = "solid";
    sent.model = "corotational";
    sent.version = cosim::protocol::kProtocolVersion;
    sent.scene_hash = "9e107d9d372bb6826bd81d3542a419d6a1b2c3d4e5f60718293a4b5c6d7e8f90";
    sent.dx_m = 0.2561e-6;
    sent.dt_lb_s = 4.4602233e-10;
    sent.sound_speed_m_s = 331.5;
    sent.air_density_kg_m3 = 1.3035;
    sent.time_ratio = std::numeric_limits<std::int32_t>::max();
    sent.dt_cg_s = tiny;
    sent.stable_dt_cg_s = -0.0;
    sent.num_cgps = std::numeric_limits<std::int32_t>::min();
    const auto inbox = publish_and_receive(bus, ch.hello, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.role, sent.role);
    EXPECT_EQ(got.model, sent.model);
    EXPECT_EQ(got.version, sent.version);
    EXPECT_EQ(got.scene_hash, sent.scene_hash);
    EXPECT_SAME_BITS(sent.dx_m, got.dx_m, "dx_m");
    EXPECT_SAME_BITS(sent.dt_lb_s, got.dt_lb_s, "dt_lb_s");
    EXPECT_SAME_BITS(sent.sound_speed_m_s, got.sound_speed_m_s, "sound_speed_m_s");
    EXPECT_SAME_BITS(sent.air_density_kg_m3, got.air_density_kg_m3, "air_density_kg_m3");
    EXPECT_EQ(got.time_ratio, sent.time_ratio);
    EXPECT_SAME_BITS(sent.dt_cg_s, got.dt_cg_s, "dt_cg_s");
    EXPECT_SAME_BITS(sent.stable_dt_cg_s, got.stable_dt_cg_s, "stable_dt_cg_s");
    EXPECT_EQ(got.num_cgps, sent.num_cgps);
  }

  for (const bool accepted : {true, false}) {
    cosimlcm::welcome_t sent{};
    sent.token = token;
    sent.accepted = accepted;
    sent.reason =
        accepted ? "" : "scene_hash differs: fluid 0a1b, solid 2c3d; start both from one scene";
    sent.total_steps = big;
    sent.rigid_steps = most_negative;
    sent.time_ratio = 150;
    const auto inbox = publish_and_receive(bus, ch.welcome, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.accepted, sent.accepted);
    EXPECT_EQ(got.reason, sent.reason);
    EXPECT_EQ(got.total_steps, sent.total_steps);
    EXPECT_EQ(got.rigid_steps, sent.rigid_steps);
    EXPECT_EQ(got.time_ratio, sent.time_ratio);
  }

  {
    cosimlcm::solid_state_t sent{};
    sent.token = token;
    sent.seq = big - 1;
    sent.step = (std::int64_t{1} << 40) + 12345;
    sent.substeps = 150;
    sent.iteration = 3;
    sent.solid_time_s = 1.2345678901234567e-7;
    sent.num_cgps = 7;
    sent.position_lb = rows3(sent.num_cgps, 3.75);
    sent.impulse_lb = rows3(sent.num_cgps, -2.5e-9);
    sent.impulse_lb[5][1] = nan;
    sent.impulse_lb[6][2] = -inf;
    const auto inbox = publish_and_receive(bus, ch.solid_state, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.seq, sent.seq);
    EXPECT_EQ(got.step, sent.step);
    EXPECT_EQ(got.substeps, sent.substeps);
    EXPECT_EQ(got.iteration, sent.iteration);
    EXPECT_SAME_BITS(sent.solid_time_s, got.solid_time_s, "solid_time_s");
    EXPECT_EQ(got.num_cgps, sent.num_cgps);
    expect_same_rows(sent.position_lb, got.position_lb, "position_lb");
    expect_same_rows(sent.impulse_lb, got.impulse_lb, "impulse_lb");
  }

  {
    cosimlcm::fluid_state_t sent{};
    sent.token = token;
    sent.seq = 0;
    sent.step = most_negative + 1;
    sent.bulk_velocity_lb = 0.10400000000000001;
    sent.num_cgps = 5;
    sent.rho_lb = {1.0, tiny, -0.0, huge, 0.9999999999999999};
    sent.velocity_lb = rows3(sent.num_cgps, 1e-3);
    sent.iteration = 7;
    sent.rho_start_lb = {0.5, 1.0, huge, tiny, 2.0};
    sent.velocity_start_lb = rows3(sent.num_cgps, -2e-3);
    const auto inbox = publish_and_receive(bus, ch.fluid_state, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.seq, sent.seq);
    EXPECT_EQ(got.step, sent.step);
    EXPECT_SAME_BITS(sent.bulk_velocity_lb, got.bulk_velocity_lb, "bulk_velocity_lb");
    EXPECT_EQ(got.num_cgps, sent.num_cgps);
    ASSERT_EQ(got.rho_lb.size(), sent.rho_lb.size());
    for (std::size_t l = 0; l < sent.rho_lb.size(); ++l)
      EXPECT_SAME_BITS(sent.rho_lb[l], got.rho_lb[l], "rho_lb[" + std::to_string(l) + "]");
    expect_same_rows(sent.velocity_lb, got.velocity_lb, "velocity_lb");
    EXPECT_EQ(got.iteration, sent.iteration);
    ASSERT_EQ(got.rho_start_lb.size(), sent.rho_start_lb.size());
    for (std::size_t l = 0; l < sent.rho_start_lb.size(); ++l)
      EXPECT_SAME_BITS(sent.rho_start_lb[l], got.rho_start_lb[l], "rho_start_lb[" + std::to_string(l) + "]");
    expect_same_rows(sent.velocity_start_lb, got.velocity_start_lb, "velocity_start_lb");
  }

  {
    cosimlcm::resend_t sent{};
    sent.token = token;
    sent.step = big;
    sent.what = "fluid_state";
    const auto inbox = publish_and_receive(bus, ch.resend, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.step, sent.step);
    EXPECT_EQ(got.what, sent.what);
  }

  {
    cosimlcm::stop_t sent{};
    sent.token = token;
    sent.step = 987654321012LL;
    sent.exit_code = 4;
    sent.reason = "peer lost: no solid_state_t for step 42 within 5 s (3 resends)";
    const auto inbox = publish_and_receive(bus, ch.stop, sent);
    ASSERT_EQ(inbox.messages.size(), 1u);
    const auto& got = inbox.messages.front();
    EXPECT_EQ(got.token, sent.token);
    EXPECT_EQ(got.step, sent.step);
    EXPECT_EQ(got.exit_code, sent.exit_code);
    EXPECT_EQ(got.reason, sent.reason);
  }
}

// A message on another run's channels (another prefix) never reaches this run's handlers.
TEST(Protocol, OtherPrefixDoesNotCross) {
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  const Channels mine("RUN_A_");
  const Channels other("RUN_AB_");
  Inbox<cosimlcm::stop_t> inbox;
  lcm::Subscription* sub =
      bus.subscribeFunction(mine.stop, &receive<cosimlcm::stop_t>, &inbox);
  cosimlcm::stop_t msg{};
  msg.token = "other";
  msg.reason = "not for this run";
  ASSERT_EQ(bus.publish(other.stop, &msg), 0);
  EXPECT_EQ(bus.handleTimeout(50), 0);
  bus.unsubscribe(sub);
  EXPECT_TRUE(inbox.messages.empty());
}

TEST(Protocol, ChannelPrefixIsValidated) {
  const Channels def;
  EXPECT_EQ(def.prefix, "COSIM_");
  EXPECT_EQ(def.hello, "COSIM_HELLO");
  EXPECT_EQ(def.welcome, "COSIM_WELCOME");
  EXPECT_EQ(def.solid_state, "COSIM_SOLID_STATE");
  EXPECT_EQ(def.fluid_state, "COSIM_FLUID_STATE");
  EXPECT_EQ(def.resend, "COSIM_RESEND");
  EXPECT_EQ(def.stop, "COSIM_STOP");

  const Channels run("run_20240601_0a1B_");
  EXPECT_EQ(run.solid_state, "run_20240601_0a1B_SOLID_STATE");
  const std::string longest(32, 'Z');
  EXPECT_NO_THROW(Channels{longest});
  EXPECT_NO_THROW(Channels{"x"});
  EXPECT_NO_THROW(cosim::protocol::validate_channel_prefix("A_b_9"));

  const std::vector<std::string> bad = {
      "",  longest + "Z", "COSIM-", "COSIM.", "A B", "A\nB", "A*", ".*", "A|B", "Ä_",
      std::string("A\0B", 3)};
  for (const auto& prefix : bad) {
    try {
      const Channels c(prefix);
      ADD_FAILURE() << "prefix of " << prefix.size() << " characters accepted: " << c.hello;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << "not one line: " << what;
      EXPECT_NE(what.find("channel prefix"), std::string::npos) << what;
      EXPECT_NE(what.find("A-Z, a-z, 0-9 and '_'"), std::string::npos) << what;
    }
  }
}

}  // namespace
