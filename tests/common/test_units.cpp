// DESIGN section 3: the unit table, derived from constants, against Table 1 and Eq. 31.
#include <gtest/gtest.h>

#include <cmath>

#include "protocol/units.hpp"

namespace {

using cosim::protocol::UnitConverter;

// Relative agreement to four significant digits.
void expect_4_digits(double got, double paper, const char* what) {
  EXPECT_LT(std::abs(got - paper) / std::abs(paper), 5e-4) << what << ": got " << got
                                                           << ", paper " << paper;
}

TEST(Units, UnitsMatchTable1AndEq31) {
  const UnitConverter u;  // the paper's inputs
  expect_4_digits(u.dx_m(), 0.2561e-6, "dx_LB");
  expect_4_digits(u.lattice_speed_m_s(), 574.17, "c = sqrt(3) c_s");
  expect_4_digits(u.dt_lb_s(), 4.4603e-10, "dt_LB (Table 1: 0.44602 ns)");
  expect_4_digits(u.dt_lb_s(), 0.44602233e-9, "dt_LB, Table 1");
  expect_4_digits(u.dt_cg_s(), 2.9735e-12, "dt_CG");
  expect_4_digits(u.dt_cg_s(), 2.9734822e-12, "dt_CG, Table 1");
  expect_4_digits(u.air_density_kg_m3(), 1.3035, "rho_air");
  expect_4_digits(u.force_lb_N(), 2.8184e-8, "F_LB (Table 1)");
  expect_4_digits(u.velocity_ratio(), 3810.1, "B_V (Eq. 31)");
  expect_4_digits(u.force_ratio(), 2.9232, "B_F (Eq. 31)");
  EXPECT_EQ(u.inputs().time_ratio, 150);  // A_T, Eq. 30
}

TEST(Units, ConversionsRoundTrip) {
  const UnitConverter u;
  EXPECT_DOUBLE_EQ(u.velocity_au_from_lb(u.velocity_lb_from_au(0.37)), 0.37);
  EXPECT_DOUBLE_EQ(u.force_au_from_lb(u.force_lb_from_au(-2.5)), -2.5);
  // Eq. 32 is consistent with the SI route: v_CG [m/s] / c = v_LB.
  const double v_au = 1e-4;
  EXPECT_NEAR(u.velocity_lb_from_au(v_au),
              v_au * UnitConverter::velocity_au_m_s() / u.lattice_speed_m_s(), 1e-15);
  // The paper's Re 40 case: tau about 0.770 for U_max/c = 0.104 over H = 8.8 um.
  const double H_cells = 8.8e-6 / u.dx_m();
  const double nu = 0.104 * H_cells / 40.0;
  EXPECT_NEAR(3.0 * nu + 0.5, 0.770, 0.005);
}

TEST(Units, RejectsNonPositiveInputs) {
  cosim::protocol::UnitInputs in;
  in.dx_m = -1.0;
  EXPECT_THROW(UnitConverter{in}, std::invalid_argument);
  in = {};
  in.time_ratio = 0;
  EXPECT_THROW(UnitConverter{in}, std::invalid_argument);
}

}  // namespace
