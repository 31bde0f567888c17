// Snapshots of the sheets (solid/io/sheet_snapshots.hpp; the paper's section 3.2 and Fig. 11:
// the CGPs coloured by their area strain): the writer with an rcgp model of one 5 x 10 sheet,
// read back with the HDF5 C API and sheets.xmf checked as text; and [output] sheets_every as
// the solid's scene parser reads it.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "protocol/units.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/io/sheet_snapshots.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/model/solid_config.hpp"
#include "solid/config/solid_scene.hpp"
#include "tests/support/h5_read.hpp"
#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::read_attribute;
using cosim::test::read_dataset;
using cosim::test::slurp;
using cosim::protocol::PhysicalConstants;
using cosim::protocol::UnitConverter;
using cosim::solid::SheetSnapshotWriter;
using cosim::solid::SheetSpec;
using cosim::solid::SolidConfig;

fs::path scratch(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_sheet_snapshots_" + name); }

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(SheetSnapshots, SnapshotsAreDueAtTheFirstEveryNAndTheLast) {
  using cosim::solid::sheet_snapshot_due;
  EXPECT_FALSE(sheet_snapshot_due(0, 199, 0));
  EXPECT_TRUE(sheet_snapshot_due(0, 199, 50));
  EXPECT_FALSE(sheet_snapshot_due(49, 199, 50));
  EXPECT_TRUE(sheet_snapshot_due(150, 199, 50));
  EXPECT_FALSE(sheet_snapshot_due(198, 199, 50));
  EXPECT_TRUE(sheet_snapshot_due(199, 199, 50));
  EXPECT_TRUE(sheet_snapshot_due(7, 199, 1));
}

// Two snapshots of an rcgp 5 x 10 sheet: at rest (positions the model's, displacement and
// area strain zero) and after a deformation imposed with restore() (the free rows stretched
// across the width: the model's area strain, non-zero; the velocities given). sheets.xmf is
// a temporal collection of the two, quads over the CGPs, rewritten after each snapshot.
TEST(SheetSnapshots, SheetSnapshotsAreWritten) {
  SolidConfig config;
  SheetSpec sheet;
  sheet.nx_cg = 5;
  sheet.ny_cg = 10;
  sheet.base_bohr = Eigen::Vector3d(3.0e-6, 0.0, 3.8e-6) / PhysicalConstants::bohr_m;
  config.sheets = {sheet};
  const auto model = cosim::solid::make_solid_model("rcgp", config);
  const Eigen::Index n = model->num_cgps();
  ASSERT_EQ(n, 50);
  const double um = PhysicalConstants::bohr_m / 1e-6;  // micrometres per bohr

  const fs::path dir = scratch("written") / "out";
  SheetSnapshotWriter w(dir, config);  // creates the folder
  ASSERT_TRUE(fs::is_directory(dir));
  w.write(0, 0.0, *model);
  EXPECT_EQ(w.count(), 1u);
  ASSERT_TRUE(fs::exists(dir / "sheets_000000.h5"));
  ASSERT_TRUE(fs::exists(dir / "sheets.xmf"));
  const std::string xmf1 = slurp(dir / "sheets.xmf");
  EXPECT_EQ(occurrences(xmf1, "<Grid Name=\"step_"), 1u);

  // Deform: the free rows stretched by 4 % across the width, a velocity along the normal.
  cosim::solid::SolidState st = model->state();
  const Eigen::Vector3d ew = cosim::solid::sheet_width_direction(sheet);
  const Eigen::Vector3d nn = cosim::solid::sheet_normal(sheet);
  for (int j = sheet.clamped_rows; j < sheet.ny_cg; ++j)
    for (int i = 0; i < sheet.nx_cg; ++i) {
      const Eigen::Index l = sheet.index(i, j);
      st.positions_bohr.col(l) += 0.04 * (i - 2) * sheet.width_spacing_bohr * ew;
      st.velocities_au.col(l) = (0.01 * j) * nn / UnitConverter::velocity_au_m_s();  // m/s
    }
  model->restore(st);
  const double t1 = 1.5e-7;  // s
  w.write(50, t1, *model);
  w.write(50, t1, *model);  // the same step again replaces it
  EXPECT_EQ(w.count(), 2u);

  const Eigen::Matrix3Xd reference = cosim::solid::flat_sheet_positions(sheet);
  const Eigen::VectorXd strain1 = model->observables().area_strain;
  ASSERT_EQ(strain1.size(), n);
  EXPECT_GT(strain1.maxCoeff(), 0.03);  // the stretched rows

  for (const auto& [step, file] :
       {std::pair{0, dir / "sheets_000000.h5"}, std::pair{50, dir / "sheets_000050.h5"}}) {
    SCOPED_TRACE(file.string());
    std::vector<hsize_t> dims;
    const auto pos = read_dataset<double>(file, "position_um", H5T_NATIVE_DOUBLE, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50, 3}));
    const auto disp = read_dataset<double>(file, "displacement_um", H5T_NATIVE_DOUBLE, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50, 3}));
    const auto vel = read_dataset<double>(file, "velocity_m_s", H5T_NATIVE_DOUBLE, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50, 3}));
    const auto eps = read_dataset<double>(file, "area_strain", H5T_NATIVE_DOUBLE, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50}));
    const auto sh = read_dataset<std::int32_t>(file, "sheet", H5T_NATIVE_INT32, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{50}));
    const auto quads = read_dataset<std::int64_t>(file, "quads", H5T_NATIVE_INT64, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{4 * 9, 4}));
    const auto grid = read_dataset<std::int32_t>(file, "sheet_grid", H5T_NATIVE_INT32, &dims);
    ASSERT_EQ(dims, (std::vector<hsize_t>{1, 2}));
    EXPECT_EQ(grid, (std::vector<std::int32_t>{5, 10}));
    EXPECT_EQ(read_attribute<std::int64_t>(file, "step", H5T_NATIVE_INT64), step);
    EXPECT_DOUBLE_EQ(read_attribute<double>(file, "time_s", H5T_NATIVE_DOUBLE), step ? t1 : 0.0);
    EXPECT_NEAR(read_attribute<double>(file, "time_us", H5T_NATIVE_DOUBLE), step ? 0.15 : 0.0,
                1e-12);

    // The model's state at the time of the snapshot.
    const Eigen::Matrix3Xd x = step ? st.positions_bohr : reference;
    const Eigen::Matrix3Xd v = step ? st.velocities_au : Eigen::Matrix3Xd::Zero(3, n);
    for (Eigen::Index l = 0; l < n; ++l) {
      const auto k = std::size_t(l);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pos[3 * k + std::size_t(c)], x(c, l) * um, 1e-12) << l;
        EXPECT_NEAR(disp[3 * k + std::size_t(c)], (x(c, l) - reference(c, l)) * um, 1e-12) << l;
        EXPECT_NEAR(vel[3 * k + std::size_t(c)], v(c, l) * UnitConverter::velocity_au_m_s(), 1e-12);
      }
      EXPECT_EQ(sh[k], 0);
      if (step == 0) {
        EXPECT_EQ(eps[k], 0.0) << l;
      } else {
        EXPECT_DOUBLE_EQ(eps[k], strain1[l]) << l;
      }
    }
    if (step) {
      EXPECT_GT(*std::max_element(eps.begin(), eps.end()), 0.03);
    }
    // Quads over the 5 x 10 grid, counter-clockwise in (i, j); the first and the last.
    EXPECT_EQ((std::vector<std::int64_t>(quads.begin(), quads.begin() + 4)),
              (std::vector<std::int64_t>{0, 1, 6, 5}));
    EXPECT_EQ((std::vector<std::int64_t>(quads.end() - 4, quads.end())),
              (std::vector<std::int64_t>{43, 44, 49, 48}));
    EXPECT_EQ(*std::max_element(quads.begin(), quads.end()), 49);
  }

  // sheets.xmf: XDMF 3, a temporal collection of the two snapshots, Quadrilateral cells.
  const std::string xmf = slurp(dir / "sheets.xmf");
  EXPECT_EQ(xmf.rfind("<?xml version=\"1.0\" ?>", 0), 0u);
  EXPECT_NE(xmf.find("<Xdmf Version=\"3.0\""), std::string::npos);
  EXPECT_NE(xmf.find("GridType=\"Collection\" CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_EQ(occurrences(xmf, "<Grid Name=\"step_"), 2u);
  EXPECT_EQ(occurrences(xmf, "</Grid>"), 3u);
  EXPECT_NE(xmf.find("<Grid Name=\"step_0\""), std::string::npos);
  EXPECT_NE(xmf.find("<Grid Name=\"step_50\""), std::string::npos);
  EXPECT_NE(xmf.find("<Time Value=\"0\"/>"), std::string::npos);
  EXPECT_NE(xmf.find("<Time Value=\"0.15\"/>"), std::string::npos);
  EXPECT_LT(xmf.find("<Time Value=\"0\"/>"), xmf.find("<Time Value=\"0.15\"/>"));
  EXPECT_EQ(occurrences(xmf, "TopologyType=\"Quadrilateral\" NumberOfElements=\"36\""), 2u);
  EXPECT_EQ(occurrences(xmf, "GeometryType=\"XYZ\""), 2u);
  for (const char* f : {"sheets_000000.h5", "sheets_000050.h5"})
    for (const char* d : {"position_um", "quads", "area_strain", "displacement_um",
                          "velocity_m_s", "sheet"})
      EXPECT_EQ(occurrences(xmf, std::string(f) + ":/" + d + "<"), 1u) << f << ":/" << d;
  EXPECT_EQ(occurrences(xmf, "Center=\"Node\""), 8u);
  EXPECT_NE(xmf.find("Dimensions=\"50 3\">sheets_000050.h5:/position_um"), std::string::npos);
  EXPECT_EQ(occurrences(xmf, "<"), occurrences(xmf, ">"));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_NE(e.path().extension(), ".part") << e.path();
  fs::remove_all(dir.parent_path());
}

/// The SolidSceneError text of loading `text` as a scene file, or "" if it loads.
std::string rejection(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
  try {
    cosim::solid::load_solid_scene(path.string());
  } catch (const cosim::solid::SolidSceneError& e) {
    return e.what();
  }
  return "";
}

// [output] sheets_every: an integer >= 0, default 0, in standalone and coupled scenes; a
// coupled scene also carries the fluid's [output] keys.
TEST(SheetSnapshots, SheetsEveryIsReadAndChecked) {
  const fs::path dir = scratch("scene");
  const fs::path path = dir / "scene.toml";
  const std::string standalone =
      "[solid]\nmodel = \"rigid\"\n\n[[sheet]]\n\n[run]\nmode = \"free\"\nsubsteps = 10\n\n"
      "[perturbation]\ntip_displacement_um = 0.1\n\n[output]\n";
  const std::string coupled = "[[sheet]]\n\n[coupling]\n\n[output]\nfields_every = 50\n"
                              "planes_every = 10\nplanes_y = [0.5]\n";

  EXPECT_EQ(rejection(path, standalone), "");
  EXPECT_EQ(cosim::solid::load_solid_scene(path.string()).sheets_every, 0);
  EXPECT_EQ(rejection(path, standalone + "sheets_every = 25\n"), "");
  EXPECT_EQ(cosim::solid::load_solid_scene(path.string()).sheets_every, 25);
  EXPECT_EQ(rejection(path, coupled + "sheets_every = 50\n"), "");
  EXPECT_EQ(cosim::solid::load_solid_scene(path.string()).sheets_every, 50);

  std::string msg = rejection(path, standalone + "sheets_every = -1\n");
  EXPECT_NE(msg.find(":14: output.sheets_every = -1: must be an integer >= 0 (0: no sheet "
                     "snapshots; N: sheets_NNNNNN.h5 and sheets.xmf every N substeps"),
            std::string::npos)
      << msg;
  msg = rejection(path, coupled + "sheets_every = -50\n");
  EXPECT_NE(msg.find(":9: output.sheets_every = -50: must be an integer >= 0 (0: no sheet "
                     "snapshots; N: sheets_NNNNNN.h5 and sheets.xmf every N LB steps"),
            std::string::npos)
      << msg;
  msg = rejection(path, standalone + "sheets_every = 2.5\n");
  EXPECT_NE(msg.find("output.sheets_every = 2.5: must be an integer, not a floating-point number"),
            std::string::npos)
      << msg;
  msg = rejection(path, standalone + "sheet_every = 5\n");
  EXPECT_NE(msg.find("output.sheet_every = 5: unknown key in [output]; allowed: directory, "
                     "sheets_every (did you mean \"sheets_every\"?)"),
            std::string::npos)
      << msg;
  fs::remove_all(dir);
}

}  // namespace
