// The solid server's coupled run (solid/coupled/coupled_solid.hpp) against a fake fluid written
// here, in one process over LCM's memq:// provider (protocol/README.md sections 5-9).
//
// memq:// keeps one queue per lcm_t, so the solid and the fake fluid share one bus: the solid
// loop runs on its own std::thread and, whenever it handles the bus, also dispatches the fake
// fluid's handlers, which answer at once (hello_t -> welcome_t, solid_state_t(n) ->
// fluid_state_t(n+1) or stop_t). What the solid published is read after the thread joined,
// so nothing is shared between threads while the loop runs. Each test sets short timeouts
// in its scene, so a broken loop ends the test within seconds instead of hanging it.

#include <gtest/gtest.h>

#include "tests/solid/solid_coupled_fake_fluid.hpp"

namespace {

using namespace cosim::test::solid_coupled;

// The whole protocol once: hello_t until an accepted welcome_t; solid_state_t(0) with the
// initial positions and zero impulses; for fluid_state_t(1..3) an interval of A_T substeps
// each, finite impulses against the flow, solid_time_s = n dt_LB; stop_t(0) ends it with 0.
TEST(SolidCoupled, SolidAnswersHandshakeOverMemq) {
  const fs::path dir = scratch_dir("handshake");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  FakeFluid fluid(bus, scene, 4);
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(r.err, "");

  // The hello passes the coordinator's checks.
  ASSERT_GE(fluid.hellos.size(), 1u);
  const cosimlcm::hello_t& h = fluid.hellos.front();
  EXPECT_EQ(h.role, "solid");
  EXPECT_EQ(h.model, "rcgp");
  EXPECT_EQ(h.version, cosim::protocol::kProtocolVersion);
  EXPECT_EQ(h.num_cgps, 12);
  EXPECT_EQ(h.time_ratio, kTimeRatio);
  EXPECT_EQ(h.scene_hash, fluid.own.scene_hash);
  EXPECT_TRUE(fluid.verdict.accepted) << fluid.verdict.reason;

  const UnitConverter units(scene.unit_inputs());
  ASSERT_EQ(fluid.states.size(), 4u);
  for (std::size_t k = 0; k < fluid.states.size(); ++k) {
    const cosimlcm::solid_state_t& m = fluid.states[k];
    EXPECT_EQ(m.token, kToken);
    EXPECT_EQ(m.step, static_cast<std::int64_t>(k));
    EXPECT_EQ(m.seq, static_cast<std::int64_t>(k));
    ASSERT_EQ(m.num_cgps, 12);
    ASSERT_EQ(m.position_lb.size(), 12u);
    ASSERT_EQ(m.impulse_lb.size(), 12u);
    EXPECT_EQ(m.substeps, k == 0 ? 0 : kTimeRatio) << "step " << k;
    EXPECT_NEAR(m.solid_time_s, static_cast<double>(k) * units.dt_lb_s(), 1e-9 * units.dt_lb_s())
        << "step " << k;
    for (std::size_t l = 0; l < 12; ++l) {
      ASSERT_EQ(m.position_lb[l].size(), 3u);
      ASSERT_EQ(m.impulse_lb[l].size(), 3u);
      EXPECT_TRUE(row(m.position_lb, l).allFinite());
      EXPECT_TRUE(row(m.impulse_lb, l).allFinite());
      if (k == 0) {
        EXPECT_EQ(row(m.impulse_lb, l), Eigen::Vector3d::Zero()) << "CGP " << l;
      } else {
        // Air at kU along x past a sheet that starts at rest: the fluid is held back,
        // J = 2 rho (U_B - u) dA (dA = 1 dx^2 here), U_B the sheet's own speed, which
        // stays below u in these few steps (the sheet gives way, then swings back).
        EXPECT_LT(m.impulse_lb[l][0], 0.0) << "step " << k << " CGP " << l;
        EXPECT_GT(m.impulse_lb[l][0], -4.0 * kU) << "step " << k << " CGP " << l;
      }
    }
  }
  // Step 0 carries the flat sheet in lattice coordinates: X_lb = X / dx + (0, -1/2, 0).
  const Eigen::Matrix3Xd flat = cosim::solid::flat_sheet_positions(scene.config.sheets[0]);
  for (Eigen::Index l = 0; l < flat.cols(); ++l)
    for (Eigen::Index c = 0; c < 3; ++c)
      EXPECT_NEAR(fluid.states[0].position_lb[static_cast<std::size_t>(l)][static_cast<std::size_t>(c)],
                  units.length_lb_from_bohr(flat(c, l)) + (c == 1 ? -0.5 : 0.0), 1e-12);
  EXPECT_NEAR(fluid.states[0].position_lb[0][1], -0.5, 1e-12);  // the bottom row on the wall

  EXPECT_EQ(fluid.solid_stops(), 0u) << "the solid stopped the run itself";
  EXPECT_NE(r.out.find("handshake accepted"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("foreign 0, duplicates 0, stale 0, early 0"), std::string::npos) << r.out;
  EXPECT_EQ(dataset_rows(dir / "out" / "solid.h5", "step"), 4);  // steps 0..3
  EXPECT_EQ(dataset_rows(dir / "out" / "solid.h5", "fluid_force_N"), 4);
  fs::remove_all(dir);
}

// The spin-up (protocol/README.md section 5, step 3): while m < rigid_steps the sheets are
// held: no substeps, solid time unchanged, J = -2 rho u dA exactly, positions unchanged.
TEST(SolidCoupled, RigidSpinUpTakesNoSubsteps) {
  const fs::path dir = scratch_dir("rigid");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 2).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 4);
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  const UnitConverter units(scene.unit_inputs());
  ASSERT_EQ(fluid.states.size(), 4u);
  const int expected_substeps[] = {0, 0, kTimeRatio, kTimeRatio};
  const double expected_time[] = {0, 0, 1, 2};  // dt_LB: max(0, n - max(R, 1) + 1)
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(fluid.states[k].substeps, expected_substeps[k]) << "step " << k;
    EXPECT_NEAR(fluid.states[k].solid_time_s, expected_time[k] * units.dt_lb_s(),
                1e-9 * units.dt_lb_s());
  }
  for (std::size_t l = 0; l < 12; ++l) {
    EXPECT_EQ(row(fluid.states[1].position_lb, l), row(fluid.states[0].position_lb, l));
    EXPECT_DOUBLE_EQ(fluid.states[1].impulse_lb[l][0], -2.0 * kU);  // rho 1, dA 1 dx^2
    EXPECT_EQ(fluid.states[1].impulse_lb[l][1], 0.0);
  }
  fs::remove_all(dir);
}

// A model without dynamics (rigid) has no stable-step limit; it announces the largest finite
// double, which the coordinator's checks accept, and runs: the sheet does not move.
// The parallel scheme's order (protocol/README.md 14) against a fake fluid that publishes only
// the fluid_state_t the scheme needs: with 2 rigid steps of 5, fluid_state_t(1) drives the
// spin-up's solid_state_t(1) and the first free one, (2); fluid_state_t(2) drives (3),
// fluid_state_t(3) drives (4), and no fluid_state_t(4) is needed. With no spin-up the first
// free interval is driven by fluid_state_t(0); a lost first copy of it is asked for again.
TEST(SolidCoupled, ParallelSchemeOrder) {
  for (const std::int64_t rigid : {2, 0}) {
    const fs::path dir = scratch_dir("parallel" + std::to_string(rigid));
    const SolidScene scene =
        cosim::solid::load_solid_scene(write_scene(dir, rigid, 3.0, 3.0, "rcgp", "parallel").string());
    ASSERT_TRUE((scene.coupling->scheme.scheme == cosim::protocol::CouplingScheme::Parallel));
    lcm::LCM bus("memq://");
    FakeFluid fluid(bus, scene, 5);
    if (rigid == 0) fluid.lose_first_copy = {0};
    const Outcome r = run_solid(scene, bus);
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    const UnitConverter units(scene.unit_inputs());
    std::vector<std::int64_t> published;
    for (const auto& [step, m] : fluid.published) published.push_back(step);
    const std::vector<std::int64_t> expected =
        rigid == 2 ? std::vector<std::int64_t>{1, 2, 3} : std::vector<std::int64_t>{0, 1, 2, 3};
    EXPECT_EQ(published, expected);
    ASSERT_EQ(fluid.states.size(), 5u) << r.out << r.err;
    const std::int64_t dynamic_from = std::max<std::int64_t>(rigid, 1);
    for (std::size_t k = 0; k < 5; ++k) {
      EXPECT_EQ(fluid.states[k].step, static_cast<std::int64_t>(k));
      EXPECT_EQ(fluid.states[k].substeps, std::int64_t(k) < dynamic_from ? 0 : kTimeRatio) << "step " << k;
      const double t = double(std::max<std::int64_t>(0, std::int64_t(k) - dynamic_from + 1));
      EXPECT_NEAR(fluid.states[k].solid_time_s, t * units.dt_lb_s(), 1e-9 * units.dt_lb_s()) << "step " << k;
    }
    if (rigid == 0) {
      EXPECT_GE(counter(r.out, "resends asked"), 1) << r.out;
    }
    EXPECT_EQ(dataset_rows(dir / "out" / "solid.h5", "step"), 5) << r.out;
    fs::remove_all(dir);
  }
}

TEST(SolidCoupled, RigidModelPassesTheHandshake) {
  const fs::path dir = scratch_dir("rigidmodel");
  const SolidScene scene =
      cosim::solid::load_solid_scene(write_scene(dir, 0, 3.0, 3.0, "rigid").string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 3);
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  ASSERT_FALSE(fluid.hellos.empty());
  EXPECT_EQ(fluid.hellos[0].stable_dt_cg_s, std::numeric_limits<double>::max());
  EXPECT_TRUE(fluid.verdict.accepted) << fluid.verdict.reason;
  ASSERT_EQ(fluid.states.size(), 3u);
  EXPECT_EQ(fluid.states[2].substeps, kTimeRatio);
  for (std::size_t l = 0; l < 12; ++l) {  // to round-off: a mean and a sum over 150 substeps
    EXPECT_LT((row(fluid.states[2].position_lb, l) - row(fluid.states[0].position_lb, l)).norm(), 1e-12);
    EXPECT_NEAR(fluid.states[2].impulse_lb[l][0], -2.0 * kU, 1e-13);
  }
  fs::remove_all(dir);
}

// A refused handshake: the solid prints the coordinator's reason and returns 2, publishing
// no solid_state_t.
TEST(SolidCoupled, RefusedWelcomeReturnsTwo) {
  const fs::path dir = scratch_dir("refused");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 4);
  fluid.refuse = "handshake refused: scene_hash mismatch: the fluid read 'aaaa', the solid 'bbbb'";
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "solid: " + fluid.refuse + "\n");
  EXPECT_TRUE(fluid.states.empty());
  fs::remove_all(dir);
}

}  // namespace
