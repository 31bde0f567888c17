// The solid-model interface, registry, sheet layout and the CGP integrator (DESIGN 2.5,
// 4.3 items 6-7, 4.4).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/units.hpp"
#include "solid/model/model_registry.hpp"
#include "solid/models/rigid/rigid_model.hpp"
#include "solid/models/sprung/sprung_model.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/model/velocity_verlet.hpp"

namespace {

using namespace cosim::solid;
using cosim::protocol::PhysicalConstants;

TEST(SolidModels, UnknownSolidModelListsAvailable) {
  SolidConfig config;
  config.sheets = {SheetSpec{}};
  config.spring.frequency_hz = 5.3238e6;  // the one option a model (sprung) cannot do without
  try {
    (void)make_solid_model("kirchhoff-typo", config);
    FAIL() << "an unknown model name must throw";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg, "unknown solid model \"kirchhoff-typo\"; available: " +
                       available_solid_models());
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line";
    EXPECT_NE(msg.find("rigid"), std::string::npos);
    for (const SolidModelEntry& entry : solid_models())
      EXPECT_NE(msg.find(std::string(entry.name)), std::string::npos) << entry.name;
  }
  // Every registered name builds a model that answers to it.
  for (const SolidModelEntry& entry : solid_models())
    EXPECT_EQ(make_solid_model(entry.name, config)->name(), entry.name);
}

TEST(SolidModels, SheetLayoutMatchesSpec) {
  const SheetSpec paper;
  EXPECT_EQ(paper.nx_cg, 5);
  EXPECT_EQ(paper.ny_cg, 40);
  EXPECT_EQ(paper.num_cgps(), 200);
  EXPECT_EQ(paper.marked_cgp(), 39 * 5 + 2);  // middle of the top edge (Fig. 4)
  // dx_CG = 0.2561 um (A_L = 1) and 2e6 carbon atoms = 4.0e-20 kg per CGP (DESIGN 4.3).
  EXPECT_NEAR(paper.width_spacing_bohr * PhysicalConstants::bohr_m, 0.2561e-6, 1e-12);
  EXPECT_NEAR(paper.height_spacing_bohr * PhysicalConstants::bohr_m, 0.2561e-6, 1e-12);
  EXPECT_NEAR(paper.cgp_mass_me * PhysicalConstants::electron_mass_kg / 4.0e-20, 1.0, 0.005);
  for (Eigen::Index l = 0; l < paper.num_cgps(); ++l) EXPECT_EQ(paper.is_clamped(l), l < 5);

  for (const double theta : {0.0, 30.0, 45.0, 60.0, 90.0}) {
    SheetSpec s;
    s.theta_deg = theta;
    s.width_spacing_bohr = 2.0;  // a rectangular lattice, like the RCGP's
    s.height_spacing_bohr = 3.0;
    s.base_bohr = {10.0, 3.0, -7.0};
    const Eigen::Matrix3Xd x = flat_sheet_positions(s);
    ASSERT_EQ(x.cols(), 200);
    const Eigen::Vector3d n = sheet_normal(s);
    const Eigen::Vector3d e_w = sheet_width_direction(s);
    EXPECT_NEAR(n.norm(), 1.0, 1e-15);
    EXPECT_NEAR(n.dot(e_w), 0.0, 1e-15);
    EXPECT_NEAR(n.y(), 0.0, 1e-15);
    for (int j = 0; j < s.ny_cg; ++j)
      for (int i = 0; i < s.nx_cg; ++i) {
        const Eigen::Vector3d p = x.col(s.index(i, j));
        EXPECT_NEAR((p - s.base_bohr).dot(n), 0.0, 1e-12) << "flat, through the base point";
        EXPECT_NEAR(p.y() - s.base_bohr.y(), 3.0 * j, 1e-12) << "rows stand on the plate";
        if (i + 1 < s.nx_cg) {
          EXPECT_NEAR((x.col(s.index(i + 1, j)) - p).norm(), 2.0, 1e-12);
        }
        if (j + 1 < s.ny_cg) {
          EXPECT_NEAR((x.col(s.index(i, j + 1)) - p - Eigen::Vector3d(0, 3.0, 0)).norm(), 0.0,
                      1e-12);
        }
      }
    // The bottom row is centred on the base point; the marked CGP tops the middle column.
    EXPECT_NEAR((x.col(s.index(2, 0)) - s.base_bohr).norm(), 0.0, 1e-12);
    EXPECT_NEAR((x.col(s.marked_cgp()) - s.base_bohr - Eigen::Vector3d(0, 117.0, 0)).norm(), 0.0,
                1e-12);
  }
  // Angle of attack: 90 deg faces the flow (normal along x), 0 deg is parallel to it.
  SheetSpec facing;
  facing.theta_deg = 90.0;
  EXPECT_NEAR((sheet_normal(facing) - Eigen::Vector3d::UnitX()).norm(), 0.0, 1e-15);
  SheetSpec parallel;
  parallel.theta_deg = 0.0;
  EXPECT_NEAR((sheet_normal(parallel) - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-15);

  SheetSpec bad;
  bad.clamped_rows = 40;
  EXPECT_THROW(check_sheet_spec(bad), std::invalid_argument);
  bad = SheetSpec{};
  bad.height_spacing_bohr = -1.0;
  EXPECT_THROW((void)flat_sheet_positions(bad), std::invalid_argument);
  bad = SheetSpec{};
  bad.nx_cg = 1;
  EXPECT_THROW(check_sheet_spec(bad), std::invalid_argument);
}

TEST(SolidModels, RigidModelHoldsSheetsAndReportsForces) {
  SheetSpec g1;
  g1.theta_deg = 0.0;
  SheetSpec g2 = g1;
  g2.base_bohr = {0.0, 0.0, 4.0 * g1.width_spacing_bohr};  // a pair, span-wise gap
  SolidConfig config;
  config.sheets = {g1, g2};
  const auto model = make_solid_model("rigid", config);
  ASSERT_EQ(model->num_cgps(), 400);
  EXPECT_EQ(model->name(), "rigid");
  EXPECT_TRUE(std::isinf(model->stable_time_step()));
  const Eigen::Matrix3Xd x0 = model->positions();
  EXPECT_EQ(x0.leftCols(200), flat_sheet_positions(g1));
  EXPECT_EQ(x0.rightCols(200), flat_sheet_positions(g2));
  EXPECT_TRUE((model->masses().array() == g1.cgp_mass_me).all());

  Eigen::Matrix3Xd f(3, 400);
  for (Eigen::Index l = 0; l < 400; ++l)
    f.col(l) = Eigen::Vector3d(1.0 + 0.01 * static_cast<double>(l), -0.5, 0.25);
  for (int k = 0; k < 150; ++k) model->substep(0.123, f);
  EXPECT_EQ(model->positions(), x0);
  EXPECT_TRUE(model->velocities().isZero(0.0));

  const SolidObservables o = model->observables();
  ASSERT_EQ(o.total_external_force_au.size(), 2u);
  ASSERT_EQ(o.marked_displacement_bohr.size(), 2u);
  const Eigen::Vector3d f1 = f.leftCols(200).rowwise().sum();
  const Eigen::Vector3d f2 = f.rightCols(200).rowwise().sum();
  EXPECT_NEAR((o.total_external_force_au[0] - f1).norm(), 0.0, 1e-12 * f1.norm());
  EXPECT_NEAR((o.total_external_force_au[1] - f2).norm(), 0.0, 1e-12 * f2.norm());
  EXPECT_EQ(o.marked_displacement_bohr[0], Eigen::Vector3d::Zero());
  EXPECT_EQ(o.kinetic_energy_au, 0.0);
  EXPECT_EQ(o.elastic_energy_au, 0.0);
  EXPECT_TRUE(o.area_strain.size() == 400 && o.area_strain.isZero(0.0));

  // Checkpoint round trip into a fresh model of the same scene.
  const SolidState saved = model->state();
  RigidModel fresh(config);
  fresh.restore(saved);
  EXPECT_EQ(fresh.observables().total_external_force_au[1], o.total_external_force_au[1]);

  // Wrong input is refused, never applied.
  EXPECT_THROW(model->substep(0.1, Eigen::Matrix3Xd::Zero(3, 399)), std::invalid_argument);
  EXPECT_THROW(model->substep(0.0, f), std::invalid_argument);
  EXPECT_THROW(model->substep(std::numeric_limits<double>::quiet_NaN(), f),
               std::invalid_argument);
  SolidState other = saved;
  other.model = "rcgp";
  EXPECT_THROW(fresh.restore(other), std::invalid_argument);
  SolidState moving = saved;
  moving.velocities_au(0, 17) = 1e-3;
  EXPECT_THROW(fresh.restore(moving), std::invalid_argument);
  EXPECT_THROW(RigidModel(SolidConfig{}), std::invalid_argument);
}

// Harmonic wells F = -k X around the origin for particle 0; particle 1 is clamped
// (inverse mass 0) and pushed by an external force. The velocity-Verlet map of a harmonic
// oscillator conserves E~ = m |V|^2 / (2 (1 - (w dt)^2 / 4)) + k |X|^2 / 2 exactly, so it
// has no energy drift, and its positions are X0 cos(w_d t) with cos(w_d dt) = 1 - (w dt)^2/2,
// a period too short by the fraction (w dt)^2 / 24 (Hairer, Lubich, Wanner 2003, I.5).
struct OscillatorRun {
  double max_energy_error = 0.0;         ///< max |E - E0| / E0 of the true energy
  double max_shadow_energy_error = 0.0;  ///< max |E~ - E~0| / E~0
  double period = 0.0;                   ///< mean period from downward zero crossings
  double clamped_motion = 0.0;
};

OscillatorRun run_oscillator(double dt, int steps) {
  const double m = 2.0, k = 8.0;
  const double w = std::sqrt(k / m);
  Eigen::Matrix3Xd x(3, 2), v = Eigen::Matrix3Xd::Zero(3, 2);
  x.col(0) = Eigen::Vector3d(1.0, 0.5, -0.3);
  x.col(1) = Eigen::Vector3d(4.0, 5.0, 6.0);
  const Eigen::Matrix3Xd x_clamped = x;
  const Eigen::VectorXd inv_mass = Eigen::Vector2d(1.0 / m, 0.0);
  Eigen::Matrix3Xd f_ext = Eigen::Matrix3Xd::Zero(3, 2);
  f_ext.col(1) = Eigen::Vector3d(3.0, -2.0, 1.0);
  const auto spring = [k](const Eigen::Matrix3Xd& pos, Eigen::Matrix3Xd& f) {
    f = -k * pos;
    f.col(1).setZero();
  };
  Eigen::Matrix3Xd f_int(3, 2);
  spring(x, f_int);

  const double shadow = 1.0 / (1.0 - 0.25 * w * w * dt * dt);
  const auto energy = [&](double vfac) {
    return 0.5 * m * vfac * v.col(0).squaredNorm() + 0.5 * k * x.col(0).squaredNorm();
  };
  const double e0 = energy(1.0), s0 = energy(shadow);
  OscillatorRun r;
  std::vector<double> crossings;
  for (int n = 0; n < steps; ++n) {
    const double x_before = x(0, 0);
    velocity_verlet_substep(x, v, inv_mass, f_int, f_ext, dt, spring);
    const double x_after = x(0, 0);
    if (x_before > 0.0 && x_after <= 0.0)
      crossings.push_back(dt * (n + x_before / (x_before - x_after)));
    r.max_energy_error = std::max(r.max_energy_error, std::abs(energy(1.0) - e0) / e0);
    r.max_shadow_energy_error =
        std::max(r.max_shadow_energy_error, std::abs(energy(shadow) - s0) / s0);
  }
  r.period = (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  r.clamped_motion = (x.col(1) - x_clamped.col(1)).norm() + v.col(1).norm();
  return r;
}

TEST(SolidModels, VelocityVerletConservesOscillatorEnergy) {
  const double w = 2.0;
  const double period = 2.0 * std::numbers::pi / w;
  const double dt = 0.01;  // w dt = 0.02, about 314 substeps per period
  const OscillatorRun coarse = run_oscillator(dt, 100000);  // about 318 periods
  const OscillatorRun fine = run_oscillator(0.5 * dt, 200000);

  // No drift: the discrete invariant holds to round-off over 1e5 substeps, and the true
  // energy stays within its O(dt^2) band (w dt)^2 / 4.
  EXPECT_LT(coarse.max_shadow_energy_error, 1e-12);
  EXPECT_LT(coarse.max_energy_error, 1.01 * 0.25 * (w * dt) * (w * dt));
  EXPECT_GT(coarse.max_energy_error, 0.9 * 0.25 * (w * dt) * (w * dt));
  EXPECT_NEAR(coarse.max_energy_error / fine.max_energy_error, 4.0, 0.05);

  // Period: exactly the discrete one, 2 pi / w_d, and second order in dt against 2 pi / w.
  const double w_d = std::acos(1.0 - 0.5 * w * w * dt * dt) / dt;
  EXPECT_NEAR(coarse.period / (2.0 * std::numbers::pi / w_d), 1.0, 1e-9);
  const double err_coarse = (coarse.period - period) / period;
  const double err_fine = (fine.period - period) / period;
  EXPECT_NEAR(err_coarse / (-(w * dt) * (w * dt) / 24.0), 1.0, 0.01);
  EXPECT_NEAR(err_coarse / err_fine, 4.0, 0.05);

  // A CGP with zero inverse mass (clamped) does not move under any force.
  EXPECT_EQ(coarse.clamped_motion, 0.0);
}

// The sprung plate (solid/models/sprung/sprung_model.hpp): released from a translation q0 in
// vacuum it oscillates as q0 cos(omega t) with omega^2 = k / M (velocity Verlet's phase error
// (omega dt)^2 / 24 per radian), every CGP with the plate; a steady force F moves it by F / k;
// its state restores exactly and a state that is not a translation is refused.
TEST(SolidModels, SprungPlateOscillatesAtItsSpringFrequency) {
  SolidConfig config;
  config.sheets = {SheetSpec{}};
  config.sheets[0].theta_deg = 30.0;  // a normal off the axes
  const double f = 5.3238e6;
  config.spring.frequency_hz = f;
  SprungModel model(config);
  const Eigen::Matrix3Xd x0 = model.positions();
  const Eigen::Vector3d n = sheet_normal(config.sheets[0]);
  const double omega = 2.0 * std::numbers::pi * f * PhysicalConstants::time_au_s;  // rad / t_AU
  EXPECT_NEAR(model.stable_time_step() * omega, 2.0, 1e-12);
  ASSERT_EQ(model.vacuum_eigenfrequencies_hz().size(), 1u);
  EXPECT_EQ(model.vacuum_eigenfrequencies_hz()[0], f);

  SolidState st = model.state();
  const double q0 = 0.4;  // bohr
  for (Eigen::Index l = 0; l < model.num_cgps(); ++l) st.positions_bohr.col(l) += q0 * n;
  model.restore(st);
  const double dt = 0.01 / omega;
  const Eigen::Matrix3Xd none = Eigen::Matrix3Xd::Zero(3, model.num_cgps());
  const int steps = int(std::round(2.0 * std::numbers::pi / (omega * dt)));  // one period
  for (int k = 0; k < steps; ++k) model.substep(dt, none);
  const double t = steps * dt;
  const double expected = q0 * std::cos(omega * t * (1.0 - (omega * dt) * (omega * dt) / 24.0));
  for (Eigen::Index l = 0; l < model.num_cgps(); ++l) {
    const Eigen::Vector3d d = model.positions().col(l) - x0.col(l);
    EXPECT_NEAR(n.dot(d), expected, 1e-6 * q0) << "CGP " << l;
    EXPECT_NEAR((d - n.dot(d) * n).norm(), 0.0, 1e-12) << "CGP " << l << " left the normal";
  }
  const SolidObservables o = model.observables();
  const double m = model.masses().sum();
  EXPECT_NEAR((o.kinetic_energy_au + o.elastic_energy_au) / (0.5 * m * omega * omega * q0 * q0), 1.0, 1e-4);

  // Restart: the state restores bit for bit and continues as the straight run.
  const SolidState mid = model.state();
  SprungModel twin(config);
  twin.restore(mid);
  Eigen::Matrix3Xd push = Eigen::Matrix3Xd::Zero(3, model.num_cgps());
  push.colwise() += 1e-9 * n;
  for (int k = 0; k < 10; ++k) {
    model.substep(dt, push);
    twin.substep(dt, push);
  }
  EXPECT_TRUE(model.positions() == twin.positions());
  EXPECT_TRUE(model.velocities() == twin.velocities());

  // A state in which one CGP left the plate is refused, in one line.
  SolidState bent = model.state();
  bent.positions_bohr.col(7) += 0.1 * n;
  try {
    twin.restore(bent);
    FAIL() << "a bent state must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("does not move with its plate"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line";
  }
  // Without a spring frequency there is no model.
  config.spring.frequency_hz = 0.0;
  EXPECT_THROW(SprungModel{config}, std::invalid_argument);
}

}  // namespace
