// The stability watchdog's transport-free parts (DESIGN 6; common/watchdog/watchdog.hpp,
// fluid/watchdog/marker_watch.hpp, solid/watchdog/energy_watch.hpp): each sentinel trips on the state it
// guards with a diagnosis naming the step, the place and the values, and stays quiet on a
// healthy one; the added-mass check warns for a sheet too light for its substeps and not
// for the paper's.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "solid/watchdog/energy_watch.hpp"
#include "fluid/watchdog/marker_watch.hpp"
#include "protocol/units.hpp"
#include "common/watchdog/watchdog.hpp"

namespace {

using cosim::protocol::AddedMass;
using cosim::protocol::EnergyWatch;
using cosim::protocol::MarkerWatch;
using cosim::protocol::WatchdogSettings;
using Vec3 = MarkerWatch::Vec3;

/// A 3 x 4 grid of markers, spacing 1 dx, in the plane x = 10.
std::vector<Vec3> sheet() {
  std::vector<Vec3> x;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 3; ++i) x.push_back({10.0, 1.0 + j, 5.0 + i});
  return x;
}

TEST(Watchdog, CgpSpeedTripsOnAMarkerFasterThanTheLimit) {
  MarkerWatch w(WatchdogSettings{}, 0.3, 150);
  std::vector<Vec3> x = sheet();
  EXPECT_FALSE(w.check_positions(0, x));  // the reference
  for (Vec3& p : x) p[0] += 0.1;           // the whole sheet at 0.1 c: healthy
  EXPECT_FALSE(w.check_positions(1, x));
  x[7][0] += 0.6;  // one CGP at 0.6 c more than the others
  const auto t = w.check_positions(2, x);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sentinel, "cgp_speed");
  EXPECT_EQ(t->step, 2);
  EXPECT_TRUE(t->dt_cure);
  EXPECT_NE(t->diagnosis.find("watchdog cgp_speed at step 2: CGP 7 at (10.7, 3, 6) moved 0.6 dx in one LB step"),
            std::string::npos)
      << t->diagnosis;
  EXPECT_NE(t->diagnosis.find("0.004 dx per substep at A_T = 150; speed 0.6 c = Mach 1.04"), std::string::npos) << t->diagnosis;
  EXPECT_TRUE(cosim::protocol::dt_curable(t->diagnosis));
}

TEST(Watchdog, MarkerSpacingTripsWhenTheSheetFoldsOrTears) {
  WatchdogSettings s;
  s.max_cgp_speed = 1.0;  // a fold within one LB step, not stopped by cgp_speed first
  MarkerWatch fold(s, 0.3, 150), tear(s, 0.3, 150);
  std::vector<Vec3> x = sheet();
  EXPECT_FALSE(fold.check_positions(0, x));
  EXPECT_FALSE(tear.check_positions(0, x));
  std::vector<Vec3> folded = x, torn = x;
  folded[4][1] -= 0.8;  // CGP 4 moves onto its neighbour CGP 1 (distance 0.2 of 1)
  const auto t = fold.check_positions(1, folded);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sentinel, "marker_spacing");
  EXPECT_FALSE(t->dt_cure);
  EXPECT_NE(t->diagnosis.find("CGPs 4 at (10, 1.2, 6) and 1 at (10, 1, 6) are 0.2 dx apart, 0.2 of their first"),
            std::string::npos)
      << t->diagnosis;
  EXPECT_NE(t->diagnosis.find("folds onto itself"), std::string::npos) << t->diagnosis;
  // The top row lifts by 0.6 dx in each of two steps.
  for (int l = 9; l < 12; ++l) torn[static_cast<std::size_t>(l)][1] += 0.6;
  ASSERT_FALSE(tear.check_positions(1, torn));
  for (int l = 9; l < 12; ++l) torn[static_cast<std::size_t>(l)][1] += 0.6;
  const auto u = tear.check_positions(2, torn);
  ASSERT_TRUE(u);
  EXPECT_NE(u->diagnosis.find("2.2 of their first distance 1 dx"), std::string::npos) << u->diagnosis;
  EXPECT_NE(u->diagnosis.find("tears apart"), std::string::npos) << u->diagnosis;
}

TEST(Watchdog, MarkerSamplesTripOnDensityAndMach) {
  MarkerWatch w(WatchdogSettings{}, 0.3, 150);
  const std::vector<Vec3> x = sheet();
  ASSERT_FALSE(w.check_positions(0, x));
  std::vector<double> rho(x.size(), 1.01);
  std::vector<Vec3> u(x.size(), Vec3{0.1, 0.0, 0.0});
  EXPECT_FALSE(w.check_samples(1, rho, u));
  rho[3] = 0.42;
  auto t = w.check_samples(1, rho, u);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sentinel, "marker_density");
  EXPECT_NE(t->diagnosis.find("at step 1: the fluid at CGP 3 at (10, 2, 5): rho = 0.42 outside [0.5, 1.5]"),
            std::string::npos)
      << t->diagnosis;
  rho[3] = 1.0;
  rho[5] = std::nan("");
  t = w.check_samples(1, rho, u);
  ASSERT_TRUE(t);
  EXPECT_NE(t->diagnosis.find("rho or u is not finite"), std::string::npos) << t->diagnosis;
  rho[5] = 1.0;
  u[8] = {0.2, 0.0, 0.0};  // Mach 0.346
  t = w.check_samples(1, rho, u);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sentinel, "marker_mach");
  EXPECT_NE(t->diagnosis.find("CGP 8"), std::string::npos) << t->diagnosis;
  EXPECT_NE(t->diagnosis.find("Mach 0.3464 above run.mach_limit = 0.3"), std::string::npos) << t->diagnosis;
}

TEST(Watchdog, MarkerReferenceSurvivesACheckpoint) {
  MarkerWatch a(WatchdogSettings{}, 0.3, 150), b(WatchdogSettings{}, 0.3, 150);
  std::vector<Vec3> x = sheet();
  ASSERT_FALSE(a.check_positions(0, x));
  b.restore(a.reference());
  x[0][0] += 0.6;
  const auto ta = a.check_positions(1, x), tb = b.check_positions(1, x);
  ASSERT_TRUE(ta && tb);
  EXPECT_EQ(ta->diagnosis, tb->diagnosis);
  MarkerWatch::Reference bad = a.reference();
  bad.distance.pop_back();
  EXPECT_THROW(b.restore(bad), std::invalid_argument);
}

TEST(Watchdog, EnergyGrowthTripsOnEnergyTheWorkDoesNotExplain) {
  EnergyWatch w(10.0, 1e-30);
  ASSERT_FALSE(w.check(0, 0.0, 0.0));  // E(0): the sheet at rest
  // The fluid does work and the energy follows it (stored, then dissipated): healthy.
  double e = 0.0;
  for (int n = 1; n <= 100; ++n) {
    const double work = n < 50 ? 1e-16 : -0.5e-16;
    e += work;
    ASSERT_FALSE(w.check(n, e * (1.0 + 1e-3), work)) << "step " << n;
  }
  // An energy that jumps by orders of magnitude without work.
  const auto t = w.check(101, 1e-12, 0.0);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sentinel, "energy_growth");
  EXPECT_TRUE(t->dt_cure);
  EXPECT_NE(t->diagnosis.find("watchdog energy_growth at step 101"), std::string::npos) << t->diagnosis;
  EXPECT_TRUE(cosim::protocol::dt_curable(t->diagnosis));
  // A non-finite energy trips too.
  EnergyWatch v(10.0, 1e-30);
  ASSERT_FALSE(v.check(0, 1.0, 0.0));
  EXPECT_TRUE(v.check(1, std::nan(""), 0.0));
}

TEST(Watchdog, SettingsAreValidatedKeyByKey) {
  WatchdogSettings s;
  EXPECT_EQ(cosim::protocol::set_watchdog_value(s, "rho_max", 1.3), "");
  EXPECT_EQ(s.rho_max, 1.3);
  EXPECT_NE(cosim::protocol::set_watchdog_value(s, "rho_min", 1.2).find("must be in (0, 1)"), std::string::npos);
  EXPECT_NE(cosim::protocol::set_watchdog_value(s, "max_cgp_speed", 2.0).find("must be in (0, 1]"), std::string::npos);
  EXPECT_NE(cosim::protocol::set_watchdog_value(s, "retry_factor", 1.0).find("from 2 to 16"), std::string::npos);
  EXPECT_NE(cosim::protocol::set_watchdog_value(s, "no_such_key", 1.0).find("allowed: health_every, rho_min"),
            std::string::npos);
  EXPECT_EQ(cosim::protocol::watchdog_consistency_problem(s), "");
}

/// The added-mass numbers of the paper's CGP (2e6 carbon atoms, dA = dx^2, dx = 0.2561 um,
/// A_T = 150): the fluid's reaction relaxes it over many substeps; no warning. A CGP of 200
/// atoms at A_T = 4000 relaxes in about a third of a substep: the warning names the ratio,
/// its threshold and the A_T that would do.
TEST(Watchdog, AddedMassWarnsForASheetTooLightForItsSubsteps) {
  const double dx = 0.2561e-6, m_carbon = 12.0 * 1.66053906660e-27;
  const double rho_air = cosim::protocol::UnitConverter{}.air_density_kg_m3();
  const AddedMass paper = cosim::protocol::added_mass(2e6 * m_carbon, dx * dx, rho_air, dx, 150);
  EXPECT_NEAR(paper.mass_ratio, 1.82, 0.01);
  EXPECT_NEAR(paper.relaxation_substeps, 136.6, 0.5);
  EXPECT_EQ(cosim::protocol::added_mass_warning(paper, 1.0, 150), "");
  const AddedMass light = cosim::protocol::added_mass(200 * m_carbon, dx * dx, rho_air, dx, 4000);
  const std::string w = cosim::protocol::added_mass_warning(light, 1.0, 4000);
  EXPECT_NE(w.find("m / (rho_air dA dx) = 0.000182"), std::string::npos) << w;
  EXPECT_NE(w.find("below 2 x relaxation_substeps_min / A_T = 0.0005"), std::string::npos) << w;
  EXPECT_NE(w.find("= 0.364 substeps"), std::string::npos) << w;
  EXPECT_NE(w.find("raise coupling.time_ratio to at least 10988"), std::string::npos) << w;
  EXPECT_NE(w.find("expect the watchdog to stop this run"), std::string::npos) << w;
}

}  // namespace
