// The solid's side of each coupling scheme (solid/schemes/): every scheme name of the
// protocol has one, from the one registry, and each says its own message order
// (protocol/README.md sections 5, 13 and 14): what the inbox orders fluid_state_t by, the
// first one awaited, the window of steps, and when the solid has done its part of the run.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <string_view>

#include "protocol/coupling_scheme.hpp"
#include "solid/schemes/solid_scheme.hpp"

namespace {

using cosim::protocol::CouplingScheme;
using cosim::protocol::SchemeSettings;
using cosim::solid::make_solid_scheme;

SchemeSettings settings(CouplingScheme s) {
  SchemeSettings out;
  out.scheme = s;
  out.implicit.max_iterations = 7;
  return out;
}

TEST(SolidSchemes, EveryProtocolSchemeHasOneSolidSide) {
  for (const cosim::protocol::MessageOrder& order : cosim::protocol::kMessageOrders) {
    const std::string_view name = order.name;
    EXPECT_EQ(cosim::protocol::scheme_from_name(name), order.scheme) << name;
    const auto scheme = make_solid_scheme(settings(order.scheme));
    ASSERT_NE(scheme, nullptr) << name;
    EXPECT_EQ(scheme->name(), name);
  }
}

TEST(SolidSchemes, SerialAnswersEachStepOnce) {
  const auto s = make_solid_scheme(settings(CouplingScheme::Serial));
  EXPECT_EQ(s->key(41, 12), 12);            // ordered by step
  EXPECT_EQ(s->first_key(0), 1);            // fluid_state_t(1) answers solid_state_t(0)
  EXPECT_EQ(s->awaited_step(5, 4), 5);      // fluid_state_t(n + 1) answers solid_state_t(n)
  EXPECT_EQ(s->lowest_fluid_step(), 1);
  EXPECT_EQ(s->final_step(100), 99);
  EXPECT_EQ(s->iterations_allowed(), 1);
  EXPECT_FALSE(s->at_end(98, 100));
  EXPECT_TRUE(s->at_end(99, 100));
  EXPECT_FALSE(s->at_end(0, 0));  // before the handshake
}

TEST(SolidSchemes, ImplicitOrdersByTheFluidSeqAndClosesWithStepN) {
  const auto s = make_solid_scheme(settings(CouplingScheme::Implicit));
  EXPECT_EQ(s->key(41, 12), 41);  // several messages per step: the fluid's seq
  EXPECT_EQ(s->first_key(3), 0);
  EXPECT_EQ(s->awaited_step(41, 11), 12);
  EXPECT_EQ(s->final_step(100), 100);  // fluid_state_t(N) answers, solid_state_t(N) closes
  EXPECT_EQ(s->iterations_allowed(), 7);
  EXPECT_FALSE(s->at_end(99, 100));
  EXPECT_TRUE(s->at_end(100, 100));
}

TEST(SolidSchemes, ParallelAwaitsTheStepItDrives) {
  const auto s = make_solid_scheme(settings(CouplingScheme::Parallel));
  EXPECT_EQ(s->key(41, 12), 12);
  EXPECT_EQ(s->first_key(0), 0);  // free from step 1: fluid_state_t(0) drives 0 -> 1
  EXPECT_EQ(s->first_key(1), 0);
  EXPECT_EQ(s->first_key(5), 1);  // the spin-up in the serial order
  EXPECT_EQ(s->awaited_step(7, 7), 7);
  EXPECT_EQ(s->lowest_fluid_step(), 0);
  EXPECT_EQ(s->final_step(100), 99);
  EXPECT_NE(s->announcement().find("parallel scheme"), std::string::npos);
}

// The protocol's one name table (protocol/coupling_scheme.hpp): each row is the message order
// of its scheme, the same one the solid's scheme answers by (the fluid's side and the replay
// read the same rows): the fluid_state_t the fluid publishes, the first one the solid awaits,
// the last step of the run's state messages.
TEST(SolidSchemes, NameTableIsEachSchemesMessageOrder) {
  using cosim::protocol::message_order;
  const auto& serial = message_order(CouplingScheme::Serial);
  const auto& parallel = message_order(CouplingScheme::Parallel);
  const auto& implicit = message_order(CouplingScheme::Implicit);
  for (std::int64_t m = -1; m <= 101; ++m) {
    EXPECT_EQ(serial.fluid_publishes(m, 100, 5), m >= 1 && m <= 99) << m;
    for (std::int64_t rigid : {0, 1, 5})
      EXPECT_EQ(parallel.fluid_publishes(m, 100, rigid), cosim::protocol::parallel_fluid_state_needed(m, 100, rigid))
          << m << " " << rigid;
  }
  EXPECT_FALSE(serial.several_per_step);
  EXPECT_FALSE(parallel.several_per_step);
  EXPECT_TRUE(implicit.several_per_step);
  EXPECT_EQ(implicit.first_fluid_step(5), 1);  // fluid_state_t(1, 0) has seq 0
  EXPECT_EQ(implicit.first_fluid_key(5), 0);
  for (const cosim::protocol::MessageOrder& order : cosim::protocol::kMessageOrders) {
    EXPECT_STREQ(cosim::protocol::scheme_name(order.scheme), order.name);
    const auto s = make_solid_scheme(settings(order.scheme));
    for (std::int64_t rigid : {0, 1, 5}) EXPECT_EQ(s->first_key(rigid), order.first_fluid_key(rigid)) << order.name;
    EXPECT_EQ(s->final_step(100), order.final_step(100)) << order.name;
    EXPECT_EQ(s->key(41, 12), order.several_per_step ? 41 : 12) << order.name;
  }
}

}  // namespace
