// The sheet in air (issue 16): a coupled scene released from a held deflection in a fluid
// at rest ([perturbation] in a coupled scene), and the readings of the paper's Eqs. 18-20
// that [reaction] law chooses (solid/coupling/reaction_law.hpp). Both servers' real parsers and the
// solid's real set-up (SolidRun), coupled in one process (tests/support/in_process_coupling.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fluid/config/scene_config.hpp"
#include "protocol/config/reaction_settings.hpp"
#include "protocol/units.hpp"
#include "solid/coupling/reaction_law.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/coupled/solid_run.hpp"
#include "solid/config/solid_scene.hpp"
#include "tests/support/in_process_coupling.hpp"

namespace {

using namespace cosim;
namespace fs = std::filesystem;
using protocol::PhysicalConstants;
using protocol::config::ReactionLaw;

const fs::path kScene = fs::path(COSIM_SOURCE_DIR) / "tests" / "scenes" / "still_air_release.toml";
constexpr double kTipUm = 0.05;

double fluid_momentum_x(const fluid::FluidSolver& s) {
  fluid::MacroscopicFields m;
  s.macroscopic(m);
  double p = 0.0;
  for (std::size_t i = 0; i < m.rho.size(); ++i) p += m.rho[i] * m.ux[i];
  return p;
}

/// The marked CGP's displacement along the sheet's normal from its place in `reference`, um.
double marked_normal_um(const solid::SolidRun& run, const Eigen::Matrix3Xd& reference_lb) {
  const solid::SheetSpec& sh = run.scene().config.sheets[0];
  const Eigen::Index m = sh.marked_cgp();
  const Eigen::Matrix3Xd x = const_cast<solid::SolidRun&>(run).coupler().positions_lb();
  return (x.col(m) - reference_lb.col(m)).dot(solid::sheet_normal(sh)) * run.units().dx_m() * 1e6;
}

struct Release {
  double tip_um = 0.0;           ///< the marked CGP after the steps
  double fluid_px = 0.0;         ///< the fluid's x momentum after the steps
  double worst_ledger = 0.0;     ///< |received + handed| / sum |J| over the steps
};

/// Runs `steps` LB steps of `scene` with the fluid of the same file, in one process.
Release release(const solid::SolidScene& scene, int steps, const Eigen::Matrix3Xd& reference_lb) {
  const fluid::FluidScene fs_ = fluid::load_scene(scene.path);
  fluid::FluidSolver fluid(fs_.params);
  fluid::initialize_flow(fluid, fs_);
  solid::SolidRun run(scene);
  EXPECT_FALSE(run.build().has_value());
  test::InProcessCoupling loop(fluid, run.model(), run.coupler());
  Release out;
  for (int k = 0; k < steps; ++k) {
    const solid::IntervalResult r = loop.step();
    const double size = r.impulse_lb.colwise().norm().sum();
    if (size > 0.0)
      out.worst_ledger = std::max(out.worst_ledger,
                                  (r.received_impulse_lb + r.impulse_lb.rowwise().sum()).norm() / size);
  }
  out.tip_um = marked_normal_um(run, reference_lb);
  out.fluid_px = fluid_momentum_x(fluid);
  return out;
}

/// The CGP positions of the scene's sheets as built, without the perturbation, lattice units.
Eigen::Matrix3Xd undeflected_lb(solid::SolidScene scene) {
  scene.tip_displacement_bohr = 0.0;
  solid::SolidRun run(scene);
  EXPECT_FALSE(run.build().has_value());
  return run.coupler().positions_lb();
}

TEST(SheetInAir, PerturbationInCoupledScene) {
  // Both servers read the file: the fluid at rest, no inlet; the solid's [perturbation].
  const fluid::FluidScene f = fluid::load_scene(kScene.string());
  EXPECT_EQ(f.initial, fluid::InitialFlow::Rest);
  const solid::SolidScene s = solid::load_solid_scene(kScene.string());
  ASSERT_TRUE(s.coupled());
  EXPECT_NEAR(s.tip_displacement_bohr * PhysicalConstants::bohr_m * 1e6, kTipUm, 1e-15);

  // Step 0: the top row displaced by the tip deflection along the normal, every CGP at rest;
  // the header says so.
  const Eigen::Matrix3Xd reference = undeflected_lb(s);
  solid::SolidRun run(s);
  ASSERT_FALSE(run.build().has_value());
  EXPECT_NEAR(marked_normal_um(run, reference), kTipUm, 1e-12);
  EXPECT_EQ(run.model().velocities().cwiseAbs().maxCoeff(), 0.0);
  std::ostringstream header;
  run.print_header(header, "TEST_");
  EXPECT_NE(header.str().find("initial  tip deflection 0.05 um along each sheet's normal, at rest"),
            std::string::npos)
      << header.str();

  // Released in still air: the sheet swings back towards the plane and pushes the air.
  const Release r = release(s, 20, reference);
  std::printf("after 20 LB steps: marked CGP %.6g um (held %.3g um), fluid x momentum %.4g, "
              "ledger %.2e\n", r.tip_um, kTipUm, r.fluid_px, r.worst_ledger);
  EXPECT_TRUE(std::isfinite(r.tip_um));
  EXPECT_LT(r.tip_um, kTipUm);
  EXPECT_GT(r.tip_um, -kTipUm);
  EXPECT_LT(r.fluid_px, 0.0) << "the sheet moves towards -x (its normal is +x) and drags the air";
  EXPECT_LT(r.worst_ledger, 1e-12);

  // A model without dynamics keeps its built positions.
  solid::SolidScene rigid = s;
  rigid.model = "rigid";
  solid::SolidRun rr(rigid);
  ASSERT_FALSE(rr.build().has_value());
  EXPECT_EQ(marked_normal_um(rr, reference), 0.0);
}

TEST(SheetInAir, ReactionLawVariantsRun) {
  // The laws as pure functions (lattice units): Eq. 18 as f~_beta - f_beta, U_B left out,
  // 1 / A_T per substep, Eq. 18 as printed.
  EXPECT_DOUBLE_EQ(solid::momentum_exchange_g_da(2.0, 0.3, 0.1), 0.4);
  EXPECT_DOUBLE_EQ(solid::omit_boundary_velocity_g_da(2.0, 0.1), -0.2);
  EXPECT_DOUBLE_EQ(solid::per_substep_over_time_ratio_g_da(2.0, 0.3, 0.1, 4), 0.1);
  EXPECT_DOUBLE_EQ(solid::eq18_literal_g_da(2.0, 0.3), 0.6);
  for (const ReactionLaw law : {ReactionLaw::MomentumExchange, ReactionLaw::OmitBoundaryVelocity,
                                ReactionLaw::PerSubstepOverTimeRatio, ReactionLaw::Eq18Literal})
    EXPECT_EQ(solid::reaction_g_da(law, 0.0, 0.3, 0.1, 150), 0.0);

  // Parsed from [reaction] law of a coupled scene.
  const fs::path dir = fs::path(::testing::TempDir()) / "cosim_reaction_law";
  fs::create_directories(dir);
  std::ostringstream text;
  text << std::ifstream(kScene).rdbuf() << "\n[reaction]\nlaw = \"eq18_literal\"\n";
  std::ofstream(dir / "eq18.toml") << text.str();
  EXPECT_EQ(solid::load_solid_scene((dir / "eq18.toml").string()).reaction_law, ReactionLaw::Eq18Literal);

  // Each law, a few steps coupled from the same release: finite, momentum conserved between
  // the phases, and distinct.
  const solid::SolidScene base = solid::load_solid_scene(kScene.string());
  EXPECT_EQ(base.reaction_law, ReactionLaw::MomentumExchange);
  const Eigen::Matrix3Xd reference = undeflected_lb(base);
  std::vector<Release> results;
  for (const ReactionLaw law : {ReactionLaw::MomentumExchange, ReactionLaw::OmitBoundaryVelocity,
                                ReactionLaw::PerSubstepOverTimeRatio, ReactionLaw::Eq18Literal}) {
    solid::SolidScene s = base;
    s.reaction_law = law;
    const Release r = release(s, 10, reference);
    std::printf("%-28s marked CGP %.9g um, fluid x momentum %.6g, ledger %.2e\n",
                std::string(protocol::config::reaction_law_name(law)).c_str(), r.tip_um, r.fluid_px,
                r.worst_ledger);
    EXPECT_TRUE(std::isfinite(r.tip_um) && std::isfinite(r.fluid_px));
    EXPECT_LT(std::abs(r.tip_um), 2.0 * kTipUm);
    EXPECT_LT(r.worst_ledger, 1e-12);
    for (const Release& o : results) {
      EXPECT_GT(std::abs(r.tip_um - o.tip_um), 1e-9 * kTipUm);
      EXPECT_GT(std::abs(r.fluid_px - o.fluid_px), 1e-9 * std::abs(o.fluid_px));
    }
    results.push_back(r);
  }
}

}  // namespace
