// Validation of the immersed boundary: steady flow past a fixed circular cylinder (a
// span-periodic slab) at Re 20 and 40 against Wu and Shu (2009), C_D = 2.091 and 1.565
// (validation-references.md). The cylinder is a ring of fixed markers per span layer; each
// step the momentum-exchange force (DESIGN 2.1) is computed from rho and u interpolated at
// the markers (Eq. 17), J = 2 rho (0 - u) dA, spread (Eqs. 21-24) and the fluid stepped.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"

namespace {

using namespace cosim::fluid;

struct CylinderCase {
  double Re = 20;
  double D = 20;              ///< diameter in cells (the nominal one, used in Re and C_D)
  double U = 0.05;            ///< inlet speed, lattice units
  int nx = 0, ny = 0, nz = 1; ///< domain in cells; y faces free-slip, z periodic
  double x_c = 0;             ///< centre (cells); y centre is the channel mid-plane
  double retraction = 0.0;    ///< markers on the radius D/2 - retraction (cells), Breugem 2012
  double spacing = 1.0;       ///< target marker spacing along the circumference (cells)
  double ramp = 5.0;          ///< start-up time in D/U (see cylinder_drag)
  int max_steps = 0;
  double steady_tol = 1e-3;   ///< stop when the mean C_D over D/U changes by less than this
  Precision precision = Precision::Double;  ///< [run] precision (issue 35)
};

struct CylinderResult {
  double C_D = 0;
  int steps = 0;
  int markers = 0;
  bool steady = false;
  double seconds = 0;
  std::vector<double> history;  ///< C_D at each check (every D/U steps)
};

CylinderResult cylinder_drag(const CylinderCase& c) {
  const double nu = c.U * c.D / c.Re;
  FluidParams p;
  p.shape = {c.nx, c.ny, c.nz};
  p.tau = 0.5 + 3.0 * nu;  // Eq. 13
  p.precision = c.precision;
  // The in-place propagation: the two-grid step's bits (Lattice.InPlaceStepMatchesTwoGridStep)
  // in less than half its time on this one-cell-thick grid (its z ghosts are the plane
  // itself, GridLayout::wraps_z): the same C_D after the same number of steps.
  p.propagation = Propagation::InPlace;
  p.faces[XMin].kind = FaceKind::Inlet;
  p.faces[XMin].inlet_speed = c.U;
  p.faces[XMax].kind = FaceKind::Outflow;
  p.faces[YMin].kind = FaceKind::FreeSlip;
  p.faces[YMax].kind = FaceKind::FreeSlip;
  FluidSolver solver(p);
  solver.initialize_uniform(1.0, {c.U, 0.0, 0.0});
  const ImmersedBoundary ib(solver);

  // Markers: a ring per span layer z = k, on the (possibly retracted) radius, each
  // carrying the surface element dA = (ring circumference / N) x (1 cell of span).
  const double R = 0.5 * c.D - c.retraction;
  const int N = int(std::ceil(2.0 * std::numbers::pi * R / c.spacing));
  const double dA = 2.0 * std::numbers::pi * R / N;
  const double y_c = 0.5 * (c.ny - 1);
  std::vector<Vec3> X;
  for (int k = 0; k < c.nz; ++k)
    for (int l = 0; l < N; ++l) {
      const double th = 2.0 * std::numbers::pi * (l + 0.5) / N;
      X.push_back({c.x_c + R * std::cos(th), y_c + R * std::sin(th), double(k)});
    }
  std::vector<MarkerSample> s(X.size());
  std::vector<Vec3> J(X.size());

  CylinderResult r;
  r.markers = int(X.size());
  const double q_ref = 0.5 * 1.0 * c.U * c.U * c.D * c.nz;  // dynamic pressure x frontal area
  const int check = int(std::ceil(c.D / c.U));
  const auto t0 = std::chrono::steady_clock::now();
  const double ramp_steps = c.ramp * c.D / c.U;
  double sum = 0.0, previous = 0.0;
  int calm_checks = 0;
  for (int n = 1; n <= c.max_steps; ++n) {
    // Start-up: the fluid starts uniform at U and the markers move with it, U_B = U; U_B is
    // brought smoothly to rest over `ramp` D/U. An impulsive start sends a strong pressure
    // wave that rings between the velocity inlet and the pressure outlet; the ramp keeps the
    // acoustic noise on the drag small.
    const double phase = std::min(1.0, n / ramp_steps);
    const Vec3 U_B{c.U * 0.5 * (1.0 + std::cos(std::numbers::pi * phase)), 0.0, 0.0};
    ib.sample(solver, X, s);
    double drag = 0.0;
    for (std::size_t l = 0; l < X.size(); ++l) {
      J[l] = momentum_exchange_force(s[l].rho, s[l].u, U_B);
      for (double& j : J[l]) j *= dA;
      drag -= J[l][0];  // the body receives -J
    }
    ib.spread(solver, X, J);
    solver.step();
    r.steps = n;
    sum += drag / q_ref;
    if (n % check == 0) {
      // Mean over one D/U: averages out the acoustic waves of the impulsive start.
      r.C_D = sum / check;
      sum = 0.0;
      r.history.push_back(r.C_D);
      const bool calm = n > ramp_steps + check && std::abs(r.C_D - previous) < c.steady_tol * r.C_D;
      calm_checks = calm ? calm_checks + 1 : 0;
      if (calm_checks == 2) {
        r.steady = true;
        break;
      }
      previous = r.C_D;
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace

// Wu and Shu (2009), JCP 228, 1963: C_D = 2.091 (Re 20) and 1.565 (Re 40); required within
// 5 %. Choices (measured while building this test; docs/validation.md):
//  - D = 20 cells, U = 0.075 (Ma = 0.13). The Mach number matters at Re 40: with U = 0.15
//    (Ma 0.26) the same setup gave C_D = 1.645 (+5.1 %), with U = 0.075 1.617; a
//    compressibility error of the weakly compressible LBM, not of the immersed boundary.
//  - Markers at spacing ~1 dx on a radius retracted by 0.3 dx (Breugem 2012): the kernel
//    of Eq. 23 spreads the force over +-2 dx, which makes the body look larger; without
//    retraction C_D came out 2 % higher.
//  - Domain 32 D x 40 D (blockage D/H = 2.5 %), centre 10 D behind the inlet. Confinement
//    raises C_D: H = 20 D instead of 40 D adds 1.5 %; 8 D of inlet length instead of 10 D
//    about 1.7 % (Re 20).
//  - Stop when the mean C_D over D/U changes by less than 2e-4 twice running; from the
//    converged runs, that leaves C_D about 0.2 % above its limit.
namespace {

// One Reynolds number of the validation: the case above, its result recorded and printed,
// and C_D required within 5 % of the reference.
CylinderResult check_cylinder_drag(double Re, double C_D_reference, Precision precision = Precision::Double) {
  CylinderCase c;
  c.precision = precision;
  c.Re = Re;
  c.D = 20;
  c.U = 0.075;
  c.nx = 640;
  c.ny = 800;
  c.nz = 1;
  c.x_c = 10 * c.D;
  c.retraction = 0.3;
  c.spacing = 1.0;
  c.steady_tol = 2e-4;
  c.max_steps = int(60 * c.D / c.U);
  const CylinderResult r = cylinder_drag(c);
  const double blockage = c.D / c.ny;
  const double error = r.C_D / C_D_reference - 1.0;
  const std::string tag = "Re" + std::to_string(int(Re)) + "_" + precision_name(precision);
  testing::Test::RecordProperty(tag + "_C_D", std::to_string(r.C_D));
  testing::Test::RecordProperty(tag + "_relative_error", std::to_string(error));
  testing::Test::RecordProperty(tag + "_setup", "D=20 U=0.075 domain 640x800x1 blockage " +
                                                    std::to_string(blockage) +
                                                    " retraction 0.3 markers " +
                                                    std::to_string(r.markers));
  std::printf(
      "cylinder Re %.0f, precision %s: D = %.0f cells, domain %d x %d x %d (blockage D/H = %.3f), %d markers, "
      "retraction %.1f dx: C_D = %.4f after %d steps (%s, %.0f s); Wu and Shu 2009: %.3f "
      "(%+.2f %%)\n",
      Re, precision_name(precision), c.D, c.nx, c.ny, c.nz, blockage, r.markers, c.retraction, r.C_D, r.steps,
      r.steady ? "steady" : "NOT steady", r.seconds, C_D_reference, 100.0 * error);
  EXPECT_TRUE(r.steady) << "C_D still changing after " << r.steps << " steps";
  EXPECT_NEAR(r.C_D, C_D_reference, 0.05 * C_D_reference);
  return r;
}

}  // namespace

// The two Reynolds numbers are two tests, so that CTest runs them side by side and neither
// comes near its timeout on a busy machine.
TEST(ImmersedBoundaryValidation, FixedMarkerCylinderDragRe20) { check_cylinder_drag(20.0, 2.091); }

// The precision modes' C_D at Re 20 against the double run's (issue 35): not in the suite (two
// more runs of this size; docs/results/precision-modes-20261206.md has what they measured);
// run with --gtest_also_run_disabled_tests --gtest_filter='*Precision*'.
TEST(ImmersedBoundaryValidation, DISABLED_FixedMarkerCylinderDragRe20PrecisionModes) {
  const double d = check_cylinder_drag(20.0, 2.091).C_D;
  for (const Precision mode : {Precision::Mixed, Precision::Single}) {
    const double m = check_cylinder_drag(20.0, 2.091, mode).C_D;
    std::printf("Re 20, precision %s: C_D %.6f, double %.6f, relative difference %.2e\n", precision_name(mode), m, d,
                m / d - 1.0);
  }
}

TEST(ImmersedBoundaryValidation, FixedMarkerCylinderDragRe40) { check_cylinder_drag(40.0, 1.565); }
