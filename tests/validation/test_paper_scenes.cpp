// The paper's scenes (section 3; DESIGN 5): every file in scenes/paper/ is a valid coupled
// scene for both processes, and describes what the paper describes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <string>

#include "fluid/config/scene_config.hpp"
#include "protocol/units.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/config/solid_scene.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::protocol::PhysicalConstants;

const fs::path kSource = COSIM_SOURCE_DIR;

TEST(PaperScenes, PaperScenesValidate) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(kSource / "scenes" / "paper")) {
    if (e.path().extension() != ".toml") continue;
    const std::string path = e.path().string();
    names.insert(e.path().stem().string());
    SCOPED_TRACE(path);
    cosim::fluid::FluidScene fluid;
    ASSERT_NO_THROW(fluid = cosim::fluid::load_scene(path));
    cosim::solid::SolidScene solid;
    ASSERT_NO_THROW(solid = cosim::solid::load_solid_scene(path));
    ASSERT_TRUE(fluid.coupling.has_value());
    ASSERT_TRUE(solid.coupling.has_value());
    EXPECT_EQ(fluid.coupling->time_ratio, solid.coupling->time_ratio);
    EXPECT_EQ(fluid.coupling->rigid_steps, solid.coupling->rigid_steps);

    const bool reduced = path.find("_reduced") != std::string::npos;
    const int f = reduced ? 2 : 1;
    EXPECT_EQ(fluid.params.shape.nx, 120 / f);
    EXPECT_EQ(fluid.params.shape.ny, 60 / f);
    EXPECT_EQ(fluid.params.shape.nz, 90 / f);
    EXPECT_NEAR(fluid.dx_um, 0.2561 * f, 1e-12);
    // 15000 rigid steps = 6.7 us at the paper's dt, the same physical time when reduced.
    EXPECT_EQ(fluid.coupling->rigid_steps * f, 15000);
    // tau of about 0.77 at the paper's size for every Re (DESIGN 5).
    if (!reduced) {
      EXPECT_NEAR(fluid.params.tau, 0.768, 0.003);
    }
    ASSERT_TRUE(fluid.reynolds.has_value());

    const auto& sheets = solid.config.sheets;
    const bool pair = path.find("pair_") != std::string::npos;
    ASSERT_EQ(sheets.size(), pair ? 2u : 1u);
    for (const auto& s : sheets) {
      EXPECT_EQ(s.nx_cg, 5);
      EXPECT_EQ(s.ny_cg, 40);
      // W 1.2 um x H 8.8 um of 2e6 carbon atoms per CGP: graphene's areal density.
      const double w_um = s.nx_cg * s.width_spacing_bohr * PhysicalConstants::bohr_m * 1e6;
      const double h_um = s.ny_cg * s.height_spacing_bohr * PhysicalConstants::bohr_m * 1e6;
      EXPECT_NEAR(w_um, 1.2, 1e-9);
      EXPECT_NEAR(h_um, 8.8, 1e-9);
      EXPECT_NEAR(s.cgp_mass_me * PhysicalConstants::electron_mass_kg /
                      (2e6 * PhysicalConstants::carbon_mass_kg), 1.0, 1e-12);
      // Every CGP inside the fluid domain, at least 2 cells (the kernel's reach) from the
      // inlet, outflow and top faces.
      const Eigen::Matrix3Xd x = cosim::solid::flat_sheet_positions(s);
      const double dx_bohr = fluid.dx_um * 1e-6 / PhysicalConstants::bohr_m;
      for (Eigen::Index l = 0; l < x.cols(); ++l) {
        EXPECT_GT(x(0, l) / dx_bohr, 2.0);
        EXPECT_LT(x(0, l) / dx_bohr, fluid.params.shape.nx - 3.0);
        EXPECT_LT(x(1, l) / dx_bohr, fluid.params.shape.ny - 3.0);
        EXPECT_GE(x(2, l) / dx_bohr, 0.0);
        EXPECT_LT(x(2, l) / dx_bohr, double(fluid.params.shape.nz));
      }
    }
  }
  // The paper's cases, each at full size and reduced.
  for (const char* n : {"single_theta00_re40", "single_theta30_re40", "single_theta45_re40",
                        "single_theta60_re40", "single_theta90_re40", "single_theta90_re01",
                        "single_theta90_re10", "single_theta90_re20", "pair_ds01p02_re40",
                        "pair_ds02p05_re40", "pair_ds04p10_re40", "pair_ds08p20_re40",
                        "pair_ds11p50_re40"}) {
    EXPECT_TRUE(names.count(n)) << n;
    EXPECT_TRUE(names.count(std::string(n) + "_reduced")) << n;
  }
}

}  // namespace
