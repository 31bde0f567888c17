// Solid scene files and the standalone `solid` executable: every malformed file is rejected
// with one line that names the key, the value and what is allowed; every shipped sheet scene
// loads with the paper's sheet in atomic units; the executable maps a bad scene to exit
// status 2 and runs a rigid scene to the end, writing solid.h5. Coupled scenes (with
// [coupling]) load for the solid with the fluid's sections left unread, and their [coupling]
// values are checked like every other key.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/h5_read.hpp"
#include "tests/support/run_command.hpp"
#include "protocol/units.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/config/solid_scene.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::dataset_rows;
using cosim::test::lines;
using cosim::test::RunResult;
using cosim::test::slurp;
const auto& quote = cosim::test::quoted;
using cosim::protocol::PhysicalConstants;
using cosim::solid::SolidScene;
using cosim::solid::SolidSceneError;
using cosim::solid::load_solid_scene;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kBad = kSource / "tests" / "scenes" / "solid_bad";

/// The SolidSceneError text of loading `path`, or "" if it loads.
std::string rejection(const fs::path& path) {
  try {
    load_solid_scene(path.string());
  } catch (const SolidSceneError& e) {
    return e.what();
  }
  return "";
}

struct BadCase {
  const char* file;
  std::vector<std::string> expected;  // substrings of the one-line message
};

const std::vector<BadCase>& bad_cases() {
  static const std::vector<BadCase> cases = {
      {"unknown_key.toml",
       {":3: solid.modle = \"rigid\": unknown key in [solid]; allowed: model, stages,",
        "did you mean \"model\""}},
      {"unknown_section.toml", {":5: [sheets]: unknown section", "did you mean \"sheet\""}},
      {"top_level_key.toml", {":2: substeps = 10: unknown key at the top level"}},
      {"wrong_type.toml", {":6: sheet[0].nx_cg = \"five\": must be an integer, not a string"}},
      {"float_for_integer.toml", {"run.substeps = 1e+05: must be an integer, not a floating"}},
      {"nx_cg_one.toml", {":6: sheet[0].nx_cg = 1: must be an integer from 2 to 65536"}},
      {"sheet_beyond_memory.toml",
       {"sheet[0]: nx_cg x ny_cg = 4096 x 4096 = 16777216 CGPs: the rcgp model needs about",
        "% of this machine's memory", "reduce nx_cg, ny_cg"}},
      {"atoms_per_cgp_huge.toml",
       {"sheet[0].atoms_per_cgp = 1e+308: must be a number of carbon atoms lumped into one CGP"}},
      {"clamped_rows_range.toml",
       {":7: sheet[0].clamped_rows = 10: must be an integer from 1 to ny_cg - 1 = 9"}},
      {"clamped_rows_zero.toml",
       {"sheet[0].clamped_rows = 0: must be an integer from 1 to ny_cg - 1 = 39"}},
      {"unknown_model.toml",
       {":3: solid.model = \"kirchhoff\": unknown solid model; available: " +
        cosim::solid::available_solid_models()}},
      {"bad_flexural_scaling.toml",
       {"solid.flexural_scaling = \"physics\": must be one of \"paper\", \"physical\"",
        "did you mean \"physical\""}},
      {"truncation_range_one.toml", {"solid.truncation_range = 1: must be 2 or 3"}},
      {"stages_too_many.toml", {"solid.stages = 17: must be an integer from 1 to 16"}},
      {"bending_poisson_half.toml", {"solid.bending_poisson = 0.5: must be in [0, 0.5)"}},
      {"missing_mode.toml", {":7: run.mode: missing; \"free\"", "or \"static\""}},
      {"missing_run.toml", {"[run]: missing; the section with mode"}},
      {"perturbation_in_static.toml",
       {":14: [perturbation]: given, but run.mode = \"static\""}},
      {"static_without_load.toml", {"[load]: missing; run.mode = \"static\" needs [load]"}},
      {"negative_spacing.toml", {":6: sheet[0].spacing_um = -0.2561: must be > 0"}},
      {"tip_not_finite.toml",
       {":12: perturbation.tip_displacement_um = nan: must be a finite number"}},
      {"tip_zero.toml", {"perturbation.tip_displacement_um = 0: must be non-zero"}},
      {"base_infinite.toml",
       {"sheet[0].base_um = [0, inf, 0]: must be an array of three finite numbers"}},
      {"second_sheet_bad.toml",
       {":10: sheet[1].theta_deg = \"ninety\": must be a number, not a string"}},
      {"sheet_not_array.toml", {":5: [sheet]: must be an array of tables", "[[sheet]]"}},
      {"no_sheet.toml", {"[[sheet]]: missing; at least one [[sheet]] is required"}},
      {"dt_negative.toml", {":10: run.dt_s = -3e-12: must be > 0"}},
      {"epsilon_zero.toml", {":6: contact.epsilon_eV = 0: must be > 0"}},
      {"gravity_not_finite.toml",
       {":4: solid.gravity_m_s2 = [0, 1e+99, 0]: must be an array of three finite numbers [gx, gy, gz] in "
        "m/s^2, each at most 1e15"}},
      {"gravity_rigid.toml",
       {":4: solid.gravity_m_s2 = [0, -9.81, 0]: not used by solid.model = \"rigid\" (only by rcgp, "
        "corotational)"}},
      {"leading_edge_unknown.toml",
       {":6: sheet[0].leading_edge = \"hinged\": must be one of \"clamped\", \"pinned\""}},
      // [material] (solid/models/elastic_sheet/sheet_material.hpp), [[sheet]] incline_deg and a free run without a
      // perturbation (allowed only under gravity).
      {"material_missing_thickness.toml",
       {":5: material.thickness_m: missing; the sheet's thickness h, metres",
        "[material] needs youngs_modulus_Pa, poisson_ratio, density_kg_m3 and thickness_m"}},
      {"material_poisson_half.toml", {":7: material.poisson_ratio = 0.5: must be in [0, 0.5)"}},
      {"material_youngs_negative.toml", {":6: material.youngs_modulus_Pa = -1400000: must be > 0"}},
      {"material_with_atoms.toml",
       {":13: sheet[0].atoms_per_cgp = 2e+06: not used with [material]: a CGP's mass is density_kg_m3 x "
        "thickness_m x its cell"}},
      {"material_with_rcgp_key.toml",
       {":4: solid.flexural_scaling = \"physical\": not used with [material]"}},
      {"incline_not_number.toml", {":6: sheet[0].incline_deg = \"flat\": must be a number, not a string"}},
      {"free_without_perturbation.toml",
       {"[perturbation]: missing; run.mode = \"free\" needs [perturbation] with tip_displacement_um (or [solid] "
        "gravity_m_s2"}},
      {"syntax_error.toml", {"syntax_error.toml:6:11: TOML syntax error"}},
      // Coupled scenes (with [coupling]): the keys both servers read.
      {"coupling_ttl_missing.toml",
       {":5: coupling.lcm_url = \"udpm://239.255.76.67:7667\": has no ttl=0",
        "packets never leave this machine"}},
      {"coupling_scheme_unknown.toml",
       {":5: coupling.scheme = \"gauss-seidel\": must be one of \"serial\", \"implicit\", \"parallel\""}},
      {"coupling_relaxation_range.toml",
       {":6: coupling.relaxation = 1.5: must be a number in (0, 1] (the implicit scheme's first Aitken "
        "relaxation factor; default 0.5)"}},
      {"coupling_ttl_one.toml",
       {":5: coupling.lcm_url = \"udpm://239.255.76.67:7667?ttl=1\": ttl=1 is not allowed: "
        "the ttl must be 0"}},
      {"coupling_lcm_tcp.toml",
       {":5: coupling.lcm_url = \"tcpq://localhost:7700\": not allowed", "or over memq://"}},
      {"coupling_resend_not_below_peer.toml",
       {":6: coupling.resend_after_s = 2: must be below coupling.peer_timeout_s = 1;"}},
      {"coupling_peer_below_default_resend.toml",
       {":5: coupling.peer_timeout_s = 0.25: must be above coupling.resend_after_s = 0.5 (the "
        "default)"}},
      {"coupling_peer_timeout_zero.toml",
       {":5: coupling.peer_timeout_s = 0: must be a number of seconds in (0, 86400]"}},
      {"coupling_bad_prefix.toml",
       {":5: coupling.channel_prefix = \"RUN-1_\": channel prefix \"RUN-1_\" has a character not "
        "allowed at position 3"}},
      {"coupling_unknown_key.toml",
       {":5: coupling.rigid_step = 100: unknown key in [coupling]; allowed: time_ratio, "
        "rigid_steps,",
        "did you mean \"rigid_steps\""}},
      {"coupling_watchdog_float_factor.toml",
       {":7: watchdog.retry_factor = 1.5: must be an integer, not a floating-point number"}},
      {"coupling_watchdog_energy_growth.toml",
       {":7: watchdog.energy_growth = -1: must be > 0: the largest unexplained energy"}},
      {"coupling_time_ratio_zero.toml",
       {":5: coupling.time_ratio = 0: must be an integer from 1 to 1000000"}},
      {"coupling_load.toml", {":6: [load]: not used in a coupled scene (one with [coupling])"}},
      {"coupling_perturbation_zero.toml",
       {":7: perturbation.tip_displacement_um = 0: must be non-zero"}},
      {"reaction_law_unknown.toml",
       {":7: reaction.law = \"eq18\": must be one of \"momentum_exchange\", \"omit_boundary_velocity\", "
        "\"per_substep_over_time_ratio\", \"eq18_literal\""}},
      {"reaction_law_implicit.toml",
       {":8: reaction.law = \"omit_boundary_velocity\": only \"momentum_exchange\" with "
        "coupling.scheme = \"implicit\""}},
      {"coupling_grid_dx_zero.toml", {":4: grid.dx_um = 0: must be > 0"}},
      {"coupling_unknown_section.toml",
       {":2: [fluids]: unknown section; allowed: [scene], [solid], [contact], [material], [[sheet]], "
        "[perturbation], [output], [grid], [fluid], [coupling], [watchdog], [reaction]; the fluid's [inlet],",
        "did you mean \"fluid\""}},
      {"coupling_output_unknown_key.toml",
       {":8: output.fields_evry = 10: unknown key in [output]; allowed: directory, "
        "sheets_every, fields_every, planes_every, planes_y",
        "did you mean \"fields_every\""}},
      {"sheets_every_negative.toml",
       {":8: output.sheets_every = -10: must be an integer >= 0 (0: no sheet snapshots; N: "
        "sheets_NNNNNN.h5 and sheets.xmf every N LB steps, at the first and the last)"}},
  };
  return cases;
}

TEST(SolidScene, BadSolidSceneFilesAreRejected) {
  // Every file in tests/scenes/solid_bad/ has a row, and every row a file.
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(kBad))
    if (e.path().extension() == ".toml") files.push_back(e.path().filename().string());
  EXPECT_EQ(files.size(), bad_cases().size());
  EXPECT_GE(bad_cases().size(), 12u);
  for (const std::string& f : files)
    EXPECT_TRUE(std::any_of(bad_cases().begin(), bad_cases().end(),
                            [&](const BadCase& c) { return f == c.file; }))
        << f << " has no expected message in the table";

  for (const BadCase& c : bad_cases()) {
    const fs::path path = kBad / c.file;
    const std::string msg = rejection(path);
    ASSERT_FALSE(msg.empty()) << c.file << " was accepted";
    EXPECT_EQ(msg.find('\n'), std::string::npos) << c.file << ": more than one line: " << msg;
    EXPECT_EQ(msg.rfind(path.string(), 0), 0u)
        << c.file << ": does not start with the file: " << msg;
    for (const std::string& part : c.expected)
      EXPECT_NE(msg.find(part), std::string::npos)
          << c.file << ": expected \"" << part << "\" in: " << msg;
  }

  const std::string missing = rejection(kBad / "no_such_scene.toml");
  EXPECT_NE(missing.find("no_such_scene.toml: cannot read the scene file: no such file"),
            std::string::npos)
      << missing;
  EXPECT_NE(rejection(kBad).find("not a regular file"), std::string::npos);
}

TEST(SolidScene, CommandLineOverridesAreValidated) {
  SolidScene s = load_solid_scene((kSource / "scenes" / "sheet_free_vibration.toml").string());
  cosim::solid::SolidSceneOverrides o;
  o.substeps = 7;
  o.output_dir = "elsewhere";
  cosim::solid::apply_overrides(s, o);
  EXPECT_EQ(s.substeps, 7);
  EXPECT_EQ(s.output_dir, "elsewhere");
  o = {};
  o.substeps = 0;
  try {
    cosim::solid::apply_overrides(s, o);
    ADD_FAILURE() << "--substeps 0 accepted";
  } catch (const SolidSceneError& e) {
    EXPECT_NE(std::string(e.what()).find("command line: --substeps = 0: must be an integer >= 1"),
              std::string::npos)
        << e.what();
  }
}

// Every shipped sheet scene loads; the paper's sheet (section 3: 5 x 40 CGPs at dx_CG =
// 0.2561 um, 2e6 carbon atoms per CGP) arrives in atomic units, converted from the
// constants of protocol/units.hpp; the default dt is dt_CG = dt_LB / A_T.
TEST(SolidScene, PaperSolidScenesValidate) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kSource / "scenes")) {
    const std::string f = e.path().filename().string();
    if (e.path().extension() != ".toml" || f.rfind("sheet_", 0) != 0) continue;
    ++n;
    EXPECT_EQ(rejection(e.path()), "") << e.path();
  }
  EXPECT_GE(n, 2);

  const SolidScene free = load_solid_scene((kSource / "scenes" / "sheet_free_vibration.toml").string());
  EXPECT_EQ(free.model, "rcgp");
  EXPECT_EQ(free.mode, cosim::solid::SolidRunMode::Free);
  ASSERT_EQ(free.config.sheets.size(), 1u);
  const auto& sheet = free.config.sheets[0];
  EXPECT_EQ(sheet.nx_cg, 5);
  EXPECT_EQ(sheet.ny_cg, 40);
  EXPECT_EQ(sheet.clamped_rows, 1);
  EXPECT_NEAR(sheet.width_spacing_bohr * PhysicalConstants::bohr_m, 0.2561e-6, 1e-18);
  EXPECT_NEAR(sheet.height_spacing_bohr * PhysicalConstants::bohr_m, 0.2561e-6, 1e-18);
  EXPECT_NEAR(sheet.cgp_mass_me * PhysicalConstants::electron_mass_kg, 3.989e-20, 0.001e-20);
  EXPECT_NEAR(free.tip_displacement_bohr * PhysicalConstants::bohr_m, 0.5e-6, 1e-18);
  EXPECT_TRUE(free.dt_is_default);
  EXPECT_NEAR(free.dt_s, 2.9735e-12, 0.0001e-12);  // DESIGN 3
  EXPECT_EQ(free.config.rcgp.flexural_scaling, cosim::solid::FlexuralScaling::Paper);

  const SolidScene load = load_solid_scene((kSource / "scenes" / "sheet_static_load.toml").string());
  EXPECT_EQ(load.mode, cosim::solid::SolidRunMode::Static);
  EXPECT_GT(load.pressure_Pa, 0.0);
  EXPECT_EQ(load.damping_ratio, 1.0);
}

// A coupled scene (one file for both servers): the solid reads its sections, [grid] dx_um
// and [coupling], and leaves the fluid's sections ([grid] nx/ny/nz, [fluid], [inlet],
// [boundaries], [wall_velocity], [body_force], [run], [output] fields_every, planes_every,
// planes_y) unread, even where they hold what the solid would refuse; [output] sheets_every
// is the solid's.
TEST(SolidScene, CoupledSceneParses) {
  const fs::path dir = fs::temp_directory_path() /
                       ("cosim_test_solid_scene_" + std::to_string(getpid()) + "_coupled");
  fs::create_directories(dir);
  const fs::path path = dir / "coupled.toml";
  std::ofstream(path) << "[scene]\nname = \"sheet_in_flow\"\n\n"
                         "[grid]\nnx = 120\nny = 60\nnz = 90\ndx_um = 0.5\n\n"
                         "[fluid]\nreynolds = 40\nreference_length_um = 8.8\n\n"
                         "[inlet]\nu_max = 0.104\nprofile = \"blasius\"\nboundary_layer_um = 1.5\n\n"
                         "[boundaries]\nx_min = \"inlet\"\nx_max = \"outflow\"\ny_min = \"wall\"\n"
                         "y_max = \"free_slip\"\nz_min = \"periodic\"\nz_max = \"periodic\"\n\n"
                         "[wall_velocity]\ny_min = [0, 0, 0]\n\n[body_force]\nx = 0\n\n"
                         "[run]\nsteps = 45000\nmonitor_every = 500\nmode = \"not the solid's\"\n\n"
                         "[solid]\nmodel = \"rigid\"\n\n"
                         "[[sheet]]\nnx_cg = 5\nny_cg = 40\nbase_um = [7.68, 0, 11.5]\n\n"
                         "[coupling]\ntime_ratio = 300\nrigid_steps = 15000\nhandshake_timeout_s = 60\n"
                         "peer_timeout_s = 10\nresend_after_s = 0.25\n"
                         "lcm_url = \"udpm://239.255.76.67:7667?ttl=0\"\nchannel_prefix = \"RUN_ab12_\"\n\n"
                         "[output]\ndirectory = \"out/sheet_in_flow\"\nfields_every = 1000\n"
                         "planes_every = 100\nplanes_y = [0.5]\nsheets_every = 500\n";
  const SolidScene s = load_solid_scene(path.string());
  EXPECT_TRUE(s.coupled());
  ASSERT_TRUE(s.coupling.has_value());
  const cosim::solid::CouplingSettings& c = *s.coupling;
  EXPECT_EQ(c.time_ratio, 300);
  EXPECT_EQ(c.rigid_steps, 15000);
  EXPECT_EQ(c.handshake_timeout_s, 60.0);
  EXPECT_EQ(c.peer_timeout_s, 10.0);
  EXPECT_EQ(c.resend_after_s, 0.25);
  EXPECT_EQ(c.lcm_url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(c.channel_prefix, "RUN_ab12_");
  EXPECT_EQ(s.name, "sheet_in_flow");
  EXPECT_EQ(s.model, "rigid");
  EXPECT_EQ(s.output_dir, "out/sheet_in_flow");
  EXPECT_EQ(s.sheets_every, 500);
  ASSERT_EQ(s.config.sheets.size(), 1u);
  EXPECT_NEAR(s.config.sheets[0].base_bohr[2] * PhysicalConstants::bohr_m, 11.5e-6, 1e-18);
  // Units for the handshake: dx from [grid], A_T from [coupling], the air of Table 1.
  EXPECT_DOUBLE_EQ(s.dx_m, 0.5e-6);
  const cosim::protocol::UnitInputs in = s.unit_inputs();
  EXPECT_DOUBLE_EQ(in.dx_m, 0.5e-6);
  EXPECT_EQ(in.time_ratio, 300);
  EXPECT_EQ(in.sound_speed_m_s, cosim::protocol::UnitInputs{}.sound_speed_m_s);
  const cosim::protocol::UnitConverter u(in);
  EXPECT_DOUBLE_EQ(s.dt_s, u.dt_lb_s() / 300);

  // The defaults of [coupling], and of [grid] dx_um (Table 1); [coupling] may be empty.
  std::ofstream(path) << "[[sheet]]\n\n[coupling]\n";
  const SolidScene d = load_solid_scene(path.string());
  ASSERT_TRUE(d.coupled());
  EXPECT_EQ(d.coupling->time_ratio, 150);
  EXPECT_EQ(d.coupling->rigid_steps, 0);
  EXPECT_EQ(d.coupling->handshake_timeout_s, 120.0);
  EXPECT_EQ(d.coupling->peer_timeout_s, 30.0);
  EXPECT_EQ(d.coupling->resend_after_s, 0.5);
  EXPECT_EQ(d.coupling->lcm_url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(d.coupling->channel_prefix, "COSIM_");
  EXPECT_DOUBLE_EQ(d.dx_m, 0.2561e-6);
  EXPECT_NEAR(d.dt_s, 2.9735e-12, 0.0001e-12);
  EXPECT_EQ(d.model, "rcgp");

  // memq:// (one process) is allowed; the standalone scenes stay standalone.
  std::ofstream(path) << "[[sheet]]\n\n[coupling]\nlcm_url = \"memq://\"\n";
  EXPECT_EQ(load_solid_scene(path.string()).coupling->lcm_url, "memq://");
  EXPECT_FALSE(
      load_solid_scene((kSource / "scenes" / "sheet_free_vibration.toml").string()).coupled());
  fs::remove_all(dir);
}

// The command line's --channel-prefix and --lcm-url go through the file's checks, and only
// with a coupled scene; --substeps only with a standalone one.
TEST(SolidScene, CoupledCommandLineOverridesAreValidated) {
  const fs::path dir = fs::temp_directory_path() /
                       ("cosim_test_solid_scene_" + std::to_string(getpid()) + "_overrides");
  fs::create_directories(dir);
  const fs::path path = dir / "coupled.toml";
  std::ofstream(path) << "[[sheet]]\n\n[coupling]\n";
  SolidScene s = load_solid_scene(path.string());
  cosim::solid::SolidSceneOverrides o;
  o.channel_prefix = "RUN_0123456789abcdef_";
  o.lcm_url = "memq://";
  cosim::solid::apply_overrides(s, o);
  EXPECT_EQ(s.coupling->channel_prefix, "RUN_0123456789abcdef_");
  EXPECT_EQ(s.coupling->lcm_url, "memq://");

  const auto refused = [&](SolidScene scene, const cosim::solid::SolidSceneOverrides& ov) {
    try {
      cosim::solid::apply_overrides(scene, ov);
    } catch (const SolidSceneError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  o = {};
  o.channel_prefix = "a b";
  EXPECT_NE(refused(s, o).find("command line: --channel-prefix = \"a b\": channel prefix \"a b\" "
                               "has a character not allowed at position 1"),
            std::string::npos)
      << refused(s, o);
  o = {};
  o.lcm_url = "udpm://239.255.76.67:7667?ttl=3";
  EXPECT_NE(refused(s, o).find("command line: --lcm-url = \"udpm://239.255.76.67:7667?ttl=3\": "
                               "ttl=3 is not allowed"),
            std::string::npos)
      << refused(s, o);
  o = {};
  o.substeps = 10;
  EXPECT_NE(refused(s, o).find("command line: --substeps = 10: only for a standalone scene"),
            std::string::npos)
      << refused(s, o);
  const SolidScene standalone =
      load_solid_scene((kSource / "scenes" / "sheet_free_vibration.toml").string());
  o = {};
  o.lcm_url = "memq://";
  EXPECT_NE(refused(standalone, o).find("--lcm-url = \"memq://\": only for a coupled scene"),
            std::string::npos);
  fs::remove_all(dir);
}

// The perturbation's shape is the static deflection of a uniformly loaded cantilever,
// w = (6 s^2 - 4 s^3 + s^4) / 3: w(0) = w'(0) = 0 at the clamp, moment w'' and shear w''' zero
// at the free end, w'''' constant (the load), w(1) = 1.
TEST(SolidScene, PerturbationIsTheUniformLoadDeflection) {
  using cosim::solid::cantilever_load_shape;
  const double h = 1e-3;
  const auto d1 = [&](double s) {
    return (cantilever_load_shape(s + h) - cantilever_load_shape(s - h)) / (2 * h);
  };
  const auto d2 = [&](double s) {
    return (cantilever_load_shape(s + h) - 2 * cantilever_load_shape(s) +
            cantilever_load_shape(s - h)) / (h * h);
  };
  EXPECT_EQ(cantilever_load_shape(0.0), 0.0);
  EXPECT_NEAR(cantilever_load_shape(1.0), 1.0, 1e-15);
  EXPECT_NEAR(d1(0.0), 0.0, 1e-5);
  EXPECT_NEAR(d2(1.0), 0.0, 1e-5);
  EXPECT_NEAR((d2(1.0 + h) - d2(1.0 - h)) / (2 * h), 0.0, 1e-4);
  EXPECT_NEAR((d2(0.5 + h) - 2 * d2(0.5) + d2(0.5 - h)) / (h * h), 8.0, 1e-2);  // 24 / 3
}

// ---- the executable ----

/// Runs `solid ARGS` with stdout and stderr captured in files of a scratch directory
/// (`args` is the whole command line when with_exe is false).
RunResult run_solid(const std::string& args, const fs::path& scratch, bool with_exe = true) {
  return cosim::test::run_command((with_exe ? quote(SOLID_EXE) + " " : std::string()) + args, scratch);
}

fs::path scratch_dir(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_solid_scene_" + name); }

TEST(SolidExecutable, BadSolidSceneExitsTwoWithOneLine) {
  const fs::path scratch = scratch_dir("bad");
  for (const char* f : {"nx_cg_one.toml", "unknown_model.toml", "syntax_error.toml"}) {
    const fs::path bad = kBad / f;
    const RunResult r = run_solid(quote(bad.string()) + " --quiet", scratch);
    EXPECT_EQ(r.status, 2) << f;
    EXPECT_EQ(lines(r.err), 1u) << f << ": " << r.err;
    EXPECT_EQ(r.err, rejection(bad) + "\n");
    EXPECT_EQ(r.out, "") << f;
  }
  // Command-line errors, from CLI11 or from validating an override: also 2, one line.
  const std::string scene = quote((kSource / "scenes" / "sheet_free_vibration.toml").string());
  for (const std::string& args : {std::string("--no-such-option"), scene + " --substeps abc",
                                  scene + " --substeps 0", std::string("")}) {
    const RunResult c = run_solid(args, scratch);
    EXPECT_EQ(c.status, 2) << args;
    EXPECT_EQ(lines(c.err), 1u) << args << ": " << c.err;
  }

  // A dt above the model's stable step 2 / omega_max: 2, one line naming run.dt_s, its value
  // and the largest allowed step.
  const fs::path big_dt = scratch / "big_dt.toml";
  std::ofstream(big_dt) << "[solid]\nmodel = \"rcgp\"\n\n[[sheet]]\n\n[run]\nmode = \"free\"\n"
                           "substeps = 10\ndt_s = 1e-9\n\n[perturbation]\ntip_displacement_um = 0.1\n";
  const RunResult d = run_solid(quote(big_dt.string()) + " --quiet", scratch);
  EXPECT_EQ(d.status, 2) << d.out << d.err;
  EXPECT_EQ(lines(d.err), 1u) << d.err;
  EXPECT_NE(d.err.find("run.dt_s = 1e-09: above the stable step"), std::string::npos) << d.err;
  EXPECT_NE(d.err.find("the largest allowed is"), std::string::npos) << d.err;
  fs::remove_all(scratch);
}

// A coupled scene: without a token, 2 and one line saying where the token comes from;
// --check builds the model and prints the header without any LCM; --token with a standalone
// scene is refused.
TEST(SolidExecutable, CoupledSceneNeedsAToken) {
  const fs::path scratch = scratch_dir("coupled");
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  const fs::path scene = scratch / "coupled.toml";
  std::ofstream(scene) << "[grid]\nnx = 16\nny = 16\nnz = 16\n\n[run]\nsteps = 10\n\n"
                          "[solid]\nmodel = \"rigid\"\n\n[[sheet]]\nnx_cg = 2\nny_cg = 3\n\n"
                          "[coupling]\nlcm_url = \"memq://\"\n";
  const std::string out = " --output " + quote((scratch / "out").string());
  const RunResult r = run_solid("env -u COSIM_RUN_TOKEN " + quote(SOLID_EXE) + " " +
                                    quote(scene.string()) + " --quiet" + out,
                                scratch, false);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("needs the run's token: --token TOKEN or the environment variable "
                       "COSIM_RUN_TOKEN"),
            std::string::npos)
      << r.err;

  const RunResult c = run_solid(quote(scene.string()) + " --check" + out, scratch);
  EXPECT_EQ(c.status, 0) << c.out << c.err;
  EXPECT_NE(c.out.find("solid: coupled scene"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("A_T = 150"), std::string::npos) << c.out;
  EXPECT_FALSE(fs::exists(scratch / "out"));

  const RunResult t = run_solid(
      quote((kSource / "scenes" / "sheet_free_vibration.toml").string()) + " --token abc", scratch);
  EXPECT_EQ(t.status, 2) << t.out << t.err;
  EXPECT_NE(t.err.find("command line: --token: only for a coupled scene"), std::string::npos)
      << t.err;
  fs::remove_all(scratch);
}

// A load so large that the energy overflows at the first substep: exit 3, one line naming
// the substep and a CGP; the finite record of substep 0 is written.
TEST(SolidExecutable, NonFiniteStateExitsThreeWithOneLine) {
  const fs::path scratch = scratch_dir("overflow");
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  const fs::path scene = scratch / "overflow.toml";
  std::ofstream(scene) << "[solid]\nmodel = \"rcgp\"\n\n[[sheet]]\n\n[run]\nmode = \"static\"\n"
                          "substeps = 10\nrecord_every = 1\n\n[load]\npressure_Pa = 1e300\n";
  const RunResult r = run_solid(quote(scene.string()) + " --quiet --output " +
                                    quote((scratch / "out").string()),
                                scratch);
  EXPECT_EQ(r.status, 3) << r.out << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("substep 1"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("CGP"), std::string::npos) << r.err;
  EXPECT_EQ(dataset_rows(scratch / "out" / "solid.h5", "time_s"), 1);
  fs::remove_all(scratch);
}

// A tiny rigid sheet in both modes: nothing moves, the run finishes (exit 0) and solid.h5
// holds a row at substep 0, every record_every substeps and the last substep.
TEST(SolidExecutable, SolidStandaloneRunsRigid) {
  const fs::path scratch = scratch_dir("rigid");
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  const std::string common =
      "[solid]\nmodel = \"rigid\"\n\n[[sheet]]\nnx_cg = 2\nny_cg = 3\n\n"
      "[[sheet]]\nnx_cg = 3\nny_cg = 4\nbase_um = [0, 0, 2]\ntheta_deg = 0\n\n";
  const fs::path free_scene = scratch / "rigid_free.toml";
  std::ofstream(free_scene) << "[scene]\nname = \"rigid_free\"\n\n" << common
                            << "[run]\nmode = \"free\"\nsubsteps = 10\nrecord_every = 3\n\n"
                               "[perturbation]\ntip_displacement_um = 0.1\n";
  const fs::path static_scene = scratch / "rigid_static.toml";
  std::ofstream(static_scene) << common
                              << "[run]\nmode = \"static\"\nsubsteps = 4\ndt_s = 1e-12\n\n"
                                 "[load]\npressure_Pa = 2.5\n";

  const fs::path out_free = scratch / "out_free";
  const RunResult r = run_solid(quote(free_scene.string()) + " --quiet --output " +
                                    quote(out_free.string()),
                                scratch);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("2 sheet(s), 18 CGPs"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(out_free / "solid.h5"));
  EXPECT_EQ(dataset_rows(out_free / "solid.h5", "time_s"), 5);  // 0, 3, 6, 9, 10
  EXPECT_EQ(dataset_rows(out_free / "solid.h5", "marked_displacement_um"), 5);
  EXPECT_EQ(dataset_rows(out_free / "solid.h5", "total_energy_J"), 5);

  const fs::path out_static = scratch / "out_static";
  const RunResult s = run_solid(quote(static_scene.string()) + " --quiet --substeps 2 --output " +
                                    quote(out_static.string()),
                                scratch);
  EXPECT_EQ(s.status, 0) << s.out << s.err;
  EXPECT_NE(s.out.find("final normal deflection 0 um"), std::string::npos) << s.out;
  EXPECT_EQ(dataset_rows(out_static / "solid.h5", "time_s"), 2);  // 0 and the last

  // --check validates and prints the header only: no output directory appears.
  const fs::path out_check = scratch / "out_check";
  const RunResult c = run_solid(quote(free_scene.string()) + " --check --output " +
                                    quote(out_check.string()),
                                scratch);
  EXPECT_EQ(c.status, 0) << c.err;
  EXPECT_FALSE(fs::exists(out_check));
  fs::remove_all(scratch);
}

}  // namespace
