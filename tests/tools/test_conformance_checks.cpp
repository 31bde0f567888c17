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

/// The main session of one marker on a spring (mass 10, stiffness 0.02, dA = 1; lattice
/// units) in the mock fluid's stream, integrated as the library's spring sheet is (A_T
/// symplectic Euler substeps, the trapezoid mean of the positions), with its energy
/// (kinetic + elastic) after every step as solid.h5 gives it (in joules of `unit_J`). Its
/// markers receive `applied` times the reaction -g dA; it reports `reported` times g dA.
Trace sprung_marker(double applied, double reported, double unit_J, bool energy = true) {
  Trace t;
  t.name = "main";
  t.plan = main_plan();
  cosim::protocol::Hello h;
  h.model = "sprung-marker";
  h.num_cgps = 1;
  t.hello = h;
  t.handshake.accepted = true;
  const double mass = 10.0, k = 0.02, dt = 1.0 / kTimeRatio;
  const Eigen::Vector3d anchor(10.0, 0.0, 5.0);
  Eigen::Vector3d x = anchor, v = Eigen::Vector3d::Zero();
  const auto put = [](const Eigen::Vector3d& a) { return std::vector<double>{a[0], a[1], a[2]}; };
  std::int64_t total = 0;
  for (std::int64_t s = 0; s <= t.plan.last_step; ++s) {
    cosimlcm::solid_state_t m{};
    m.seq = m.step = s;
    m.num_cgps = 1;
    const Eigen::Vector3d u = t.plan.flow(s, 1).col(0);
    Eigen::Vector3d j = Eigen::Vector3d::Zero(), mean = 0.5 * x;
    if (s > 0 && s < t.plan.rigid_steps) j = -2.0 * u;  // held: U_B = 0
    if (s >= t.plan.rigid_steps) {
      m.substeps = kTimeRatio;
      for (int q = 0; q < kTimeRatio; ++q) {
        const Eigen::Vector3d g = 2.0 * (v - u), f = -k * (x - anchor);
        j += g / kTimeRatio;
        v += dt / mass * (f - applied * g);
        x += dt * v;
        mean += (q + 1 < kTimeRatio ? 1.0 : 0.5) * x;
      }
      mean /= kTimeRatio;
      j *= reported;
    } else {
      mean = x;
    }
    total += m.substeps;
    m.solid_time_s = double(total) * 1e-9;
    m.position_lb.push_back(put(mean));
    m.impulse_lb.push_back(put(j));
    t.states.push_back(m);
    if (energy) {
      t.energies.step.push_back(s);
      t.energies.total_J.push_back((0.5 * mass * v.squaredNorm() + 0.5 * k * (x - anchor).squaredNorm()) * unit_J);
    }
  }
  if (!energy) t.energies.none = "the solid wrote no solid.h5";
  return t;
}

TEST(ConformanceChecks, EnergyBalanceNamesImpulseAndEnergyThatDisagree) {
  Context c = context();
  c.area_lb = Eigen::VectorXd::Ones(1);
  c.energy_unit_J = 3.5e-17;
  const Trace clean = sprung_marker(1.0, 1.0, c.energy_unit_J);
  const Verdict ok = check_energy_balance({&clean}, c);
  EXPECT_TRUE(ok.pass) << ok.reason;
  EXPECT_TRUE(check_impulse_motion(clean, c).pass) << check_impulse_motion(clean, c).reason;
  const Trace silent = sprung_marker(1.0, 1.0, c.energy_unit_J, false);
  const Verdict na = check_energy_balance({&silent}, c);
  EXPECT_TRUE(na.pass) << na.reason;
  EXPECT_NE(na.reason.find("not applicable: the solid reports no energy"), std::string::npos) << na.reason;
  // J x 2 and x 1/2 of what the dynamics used, and a reaction of the wrong sign.
  const struct {
    double applied, reported;
    const char* words;
  } faults[] = {
      {1.0, 2.0, "J_l is twice the impulse its own dynamics used"},
      {0.5, 1.0, "J_l is twice the impulse its own dynamics used"},
      {1.0, 0.5, "J_l is half the impulse its own dynamics used"},
      {-1.0, 1.0, "the reaction on its markers has the wrong sign"},
  };
  for (const auto& f : faults) {
    const Trace t = sprung_marker(f.applied, f.reported, c.energy_unit_J);
    const Verdict v = check_energy_balance({&t}, c);
    EXPECT_FALSE(v.pass) << f.applied << " " << f.reported << ": " << v.reason;
    EXPECT_NE(v.reason.find(f.words), std::string::npos) << f.applied << " " << f.reported << ": " << v.reason;
  }
}
