// The conformance kit's checks (tools/conformance/checks.hpp) on made-up traces, without a
// process: a correct held plate passes; the faults the kit exists for fail with a reason that
// names them.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "tools/conformance/checks.hpp"

namespace {

using namespace cosim::conformance;

constexpr int kTimeRatio = 150;
constexpr int kMarkers = 3;

/// The main session of a held plate of three markers (dA = 1) answering J = factor x (-2 rho
/// u dA) with `substeps` per free step.
Trace held_plate(double factor, int substeps = kTimeRatio) {
  Trace t;
  t.name = "main";
  t.plan = main_plan();
  cosim::protocol::Hello h;
  h.model = "plate";
  h.num_cgps = kMarkers;
  t.hello = h;
  t.handshake.accepted = true;
  std::int64_t total = 0;
  for (std::int64_t k = 0; k <= t.plan.last_step; ++k) {
    cosimlcm::solid_state_t m{};
    m.seq = k;
    m.step = k;
    m.substeps = k == 0 || k < t.plan.rigid_steps ? 0 : substeps;
    total += m.substeps;
    m.solid_time_s = double(total) * 1e-9;
    m.num_cgps = kMarkers;
    const Eigen::Matrix3Xd u = t.plan.flow(k, kMarkers);
    for (int l = 0; l < kMarkers; ++l) {
      m.position_lb.push_back({10.0, double(l), 5.0});
      m.impulse_lb.push_back({0.0, 0.0, 0.0});
      if (k > 0)
        for (int c = 0; c < 3; ++c) m.impulse_lb.back()[std::size_t(c)] = factor * -2.0 * u(c, l);
    }
    t.states.push_back(m);
  }
  return t;
}

Context context() {
  Context c;
  c.time_ratio = kTimeRatio;
  c.dt_cg_s = 1e-9;
  c.area_lb = Eigen::VectorXd::Ones(kMarkers);
  return c;
}

TEST(ConformanceChecks, CorrectPlatePasses) {
  const Trace t = held_plate(1.0);
  for (const Verdict& v : {check_initial_state(t), check_finite({&t}), check_substeps(t, context()),
                           check_spin_up_impulse(t, context()), check_impulse_motion(t, context()),
                           check_duplicates(t)})
    EXPECT_TRUE(v.pass) << v.check << ": " << v.reason;
}

TEST(ConformanceChecks, FaultsAreNamed) {
  const Verdict sign = check_spin_up_impulse(held_plate(-1.0), context());
  EXPECT_FALSE(sign.pass);
  EXPECT_NE(sign.reason.find("the sign is reversed"), std::string::npos) << sign.reason;
  const Verdict sum = check_spin_up_impulse(held_plate(kTimeRatio), context());
  EXPECT_FALSE(sum.pass);
  EXPECT_NE(sum.reason.find("not averaged over the A_T substeps"), std::string::npos) << sum.reason;
  const Verdict moving = check_impulse_motion(held_plate(-1.0), context());
  EXPECT_FALSE(moving.pass);
  EXPECT_NE(moving.reason.find("the sign is reversed"), std::string::npos) << moving.reason;
  const Verdict substeps = check_substeps(held_plate(1.0, kTimeRatio + 1), context());
  EXPECT_FALSE(substeps.pass);
  EXPECT_NE(substeps.reason.find("substeps = 151, expected 150"), std::string::npos) << substeps.reason;
  Trace nan = held_plate(1.0);
  nan.states[5].impulse_lb[1][2] = std::nan("");
  const Verdict finite = check_finite({&nan});
  EXPECT_FALSE(finite.pass);
  EXPECT_NE(finite.reason.find("marker 1 impulse_lb[2] = nan"), std::string::npos) << finite.reason;
  Trace twice = held_plate(1.0);
  cosimlcm::solid_state_t again = twice.states[5];
  again.seq = 99;
  twice.states.push_back(again);
  const Verdict dup = check_duplicates(twice);
  EXPECT_FALSE(dup.pass);
  EXPECT_NE(dup.reason.find("was stepped again"), std::string::npos) << dup.reason;
}

TEST(ConformanceChecks, PositionsInMicrometresAreNamed) {
  Context c = context();
  c.dx_m = 0.2561e-6;
  c.position_lb.resize(3, kMarkers);
  for (int l = 0; l < kMarkers; ++l) c.position_lb.col(l) = Eigen::Vector3d(10.0, double(l), 5.0);
  Trace t = held_plate(1.0);
  EXPECT_TRUE(check_lattice_units(t, c).pass) << check_lattice_units(t, c).reason;
  for (std::vector<double>& x : t.states[0].position_lb)
    for (double& v : x) v *= 0.2561;
  const Verdict um = check_lattice_units(t, c);
  EXPECT_FALSE(um.pass);
  EXPECT_NE(um.reason.find("the positions are in um, not in lattice units"), std::string::npos) << um.reason;
}

TEST(ConformanceChecks, ScaleAndLagAreNamedAtRestingMarkers) {
  // Markers at rest: the law is exact, so the bound is round-off.
  const Verdict twice = check_impulse_motion(held_plate(2.0), context());
  EXPECT_FALSE(twice.pass);
  EXPECT_NE(twice.reason.find("J_l is twice the expected impulse"), std::string::npos) << twice.reason;
  const Verdict almost = check_impulse_motion(held_plate(1.0 + 1e-6), context());
  EXPECT_FALSE(almost.pass) << almost.reason;
  Trace late = held_plate(1.0);
  for (std::size_t k = late.states.size() - 1; k >= 2; --k) late.states[k].impulse_lb = late.states[k - 1].impulse_lb;
  const Verdict lag = check_impulse_motion(late, context());
  EXPECT_FALSE(lag.pass);
  EXPECT_NE(lag.reason.find("solid_state_t(6)"), std::string::npos) << lag.reason;
  EXPECT_NE(lag.reason.find("one exchange late"), std::string::npos) << lag.reason;
}

}  // namespace
