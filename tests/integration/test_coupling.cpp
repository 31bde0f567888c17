// The coupled scheme of DESIGN 2.1 in one process (no transport): the fluid spreads J_l at
// X_l and steps, interpolates rho_l and u_l; the solid takes A_T substeps with the sample
// frozen and returns the impulses. Checks the momentum ledger between the two sides.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "fluid/solver/fluid_solver.hpp"
#include "fluid/ib/immersed_boundary.hpp"
#include "protocol/units.hpp"
#include "solid/coupling/aitken_relaxation.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "tests/support/in_process_coupling.hpp"

namespace {

using namespace cosim;

Eigen::Vector3d fluid_momentum(const fluid::FluidSolver& s) {
  fluid::MacroscopicFields m;
  s.macroscopic(m);  // no body force: rho u = sum_a c_a f_a
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < m.rho.size(); ++i)
    p += m.rho[i] * Eigen::Vector3d(m.ux[i], m.uy[i], m.uz[i]);
  return p;
}

// A free sheet (nothing clamped) in a closed periodic box with a flow through it: every LB
// step the impulse the fluid receives and the one the solid integrates cancel, and the
// total momentum of fluid plus solid is conserved.
TEST(Coupling, ImpulseLedgerBalances) {
  const protocol::UnitConverter units;  // the paper's: dx = 0.2561 um, A_T = 150
  fluid::FluidParams p;
  p.shape = {16, 16, 16};
  p.tau = 0.8;
  fluid::FluidSolver fluid(p);
  fluid.initialize_uniform(1.0, {0.03, 0.01, -0.005});

  solid::SolidConfig config;
  solid::SheetSpec sheet;
  sheet.nx_cg = 4;
  sheet.ny_cg = 4;
  sheet.clamped_rows = 0;  // free: all of its momentum is in the ledger
  sheet.theta_deg = 60.0;
  config.sheets = {sheet};
  solid::ElasticSheetModel model(config, solid::SheetKinematics::Linear);
  const Eigen::Vector3d origin(8.0, 6.0, 7.5);  // the sheet in the middle of the box
  solid::SolidCoupler coupler(model, units, solid::marker_areas_lb(config.sheets, units), origin);

  test::InProcessCoupling loop(fluid, model, coupler);
  // Conserved: fluid + solid + the impulses sent by the solid and not yet applied.
  const auto total = [&] {
    return Eigen::Vector3d(fluid_momentum(fluid) + coupler.momentum_lb() +
                           loop.impulse_in_flight().rowwise().sum());
  };
  const Eigen::Vector3d total0 = total();
  double worst_ledger = 0.0, worst_total = 0.0, largest_solid_speed = 0.0;
  for (int step = 0; step < 1000; ++step) {
    const Eigen::Matrix3Xd impulse = loop.impulse_in_flight();  // what this step spreads
    Eigen::Vector3d applied;  // what the fluid's nodes receive
    const solid::IntervalResult r = loop.step(/*rigid=*/false, &applied);
    ASSERT_EQ(r.substeps, units.inputs().time_ratio);
    // The fluid applied what was sent; the solid integrated minus what it now sends.
    // Relative to the size of the impulses, sum_l |J_l| (their sum can be near zero).
    const double sent_size = impulse.colwise().norm().sum();
    if (sent_size > 0.0)
      worst_ledger = std::max(worst_ledger, (applied - impulse.rowwise().sum()).norm() / sent_size);
    const Eigen::Vector3d handed = r.impulse_lb.rowwise().sum();
    worst_ledger = std::max(worst_ledger, (r.received_impulse_lb + handed).norm() /
                                              r.impulse_lb.colwise().norm().sum());
    worst_total = std::max(worst_total, (total() - total0).norm() / total0.norm());
    largest_solid_speed = std::max(largest_solid_speed, coupler.momentum_lb().norm());
  }
  std::printf("1000 coupled steps: worst per-step ledger mismatch %.2e, worst total momentum "
              "change %.2e (relative); solid momentum up to %.3g of %.3g\n",
              worst_ledger, worst_total, largest_solid_speed, total0.norm());
  EXPECT_LT(worst_ledger, 1e-12);
  EXPECT_LT(worst_total, 1e-12);
  EXPECT_GT(largest_solid_speed, 1e-3 * total0.norm()) << "the sheet must take part";
}

}  // namespace

// Aitken's relaxation (solid/coupling/aitken_relaxation.hpp) on a linear map x -> lambda x + b with
// one eigenvalue, as the added-mass feedback of a uniform sheet would give: the second
// factor is 1 / (1 - lambda) and the iterate after it is the fixed point b / (1 - lambda), to
// round-off, for a divergent plain iteration (lambda = -5) and a slow one (lambda = 0.9).
// The next step starts from the last factor.
TEST(Coupling, AitkenRelaxationSolvesALinearMapInTwoSteps) {
  for (const double lambda : {-5.0, 0.9}) {
    Eigen::Matrix3Xd b(3, 4);
    b << 1, 2, 3, 4, -1, 0.5, 0.25, 8, 3, -2, 7, 1;
    const Eigen::Matrix3Xd fixed = b / (1.0 - lambda);
    const auto g = [&](const Eigen::Matrix3Xd& x) { return Eigen::Matrix3Xd(lambda * x + b); };
    cosim::solid::AitkenRelaxation aitken(0.5);
    aitken.new_step();
    Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 4);
    x = aitken.next(x, g(x));
    EXPECT_DOUBLE_EQ(aitken.omega(), 0.5);
    x = aitken.next(x, g(x));
    EXPECT_NEAR(aitken.omega(), 1.0 / (1.0 - lambda), 1e-12) << lambda;
    EXPECT_LT((x - fixed).norm(), 1e-12 * fixed.norm()) << lambda;
    aitken.new_step();
    EXPECT_NEAR(aitken.step_start(), std::min(1.0 / std::abs(1.0 - lambda), 1.0), 1e-12);
  }
}
