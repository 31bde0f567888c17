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
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Core>
#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "tests/support/fake_peer.hpp"
#include "protocol/coupling_scheme.hpp"
#include "protocol/handshake.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/units.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/model/sheet_spec.hpp"
#include "solid/config/solid_scene.hpp"
#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::protocol::Channels;
using cosim::protocol::PhysicalConstants;
using cosim::protocol::UnitConverter;
using cosim::solid::CoupledSolidOptions;
using cosim::solid::SolidScene;

constexpr const char* kToken = "0123456789abcdef";
constexpr int kTimeRatio = 150;
constexpr double kU = 0.01;  // the fake fluid's velocity at every marker, lattice units

fs::path scratch_dir(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_solid_coupled_" + name); }

/// A coupled scene with the fluid's sections (which the solid leaves alone), a 3 x 4 rcgp
/// sheet (12 CGPs) standing in the flow, memq:// and short timeouts.
fs::path write_scene(const fs::path& dir, std::int64_t rigid_steps, double peer_timeout_s = 3.0,
                     double handshake_timeout_s = 3.0, const std::string& model = "rcgp",
                     const std::string& scheme = "serial") {
  const fs::path scene = dir / "coupled.toml";
  std::ofstream(scene) << "[scene]\nname = \"coupled_test\"\n\n"
                          "[grid]\nnx = 16\nny = 16\nnz = 16\ndx_um = 0.2561\n\n"
                          "[fluid]\ntau = 0.8\n\n[inlet]\nu_max = 0.01\n\n"
                          "[run]\nsteps = 4\n\n"
                          "[solid]\nmodel = \""
                       << model << "\"\n\n"
                          "[[sheet]]\nnx_cg = 3\nny_cg = 4\nbase_um = [1.0, 0, 2.0]\n\n"
                          "[coupling]\ntime_ratio = "
                       << kTimeRatio << "\nrigid_steps = " << rigid_steps
                       << "\nhandshake_timeout_s = " << handshake_timeout_s
                       << "\npeer_timeout_s = " << peer_timeout_s
                       << "\nresend_after_s = 0.1\nlcm_url = \"memq://\"\n"
                          "channel_prefix = \"TEST_\"\nscheme = \""
                       << scheme << "\"\n\n"
                          "[output]\ndirectory = \""
                       << (dir / "out").string() << "\"\nfields_every = 0\n";
  return scene;
}

/// A minimal fluid: the coordinator's handshake (check_handshake against its own Hello
/// from the same scene) and a constant sample (rho = 1, u = (kU, 0, 0)) for every step.
/// The knobs make it misbehave for the error tests.
struct FakeFluid {
  FakeFluid(lcm::LCM& bus_, const SolidScene& scene, std::int64_t total_steps_)
      : bus(bus_), ch(scene.coupling->channel_prefix), link("fluid", kToken, scene.coupling->channel_prefix, bus_),
        total_steps(total_steps_), rigid_steps(scene.coupling->rigid_steps),
        parallel((scene.coupling->scheme.scheme == cosim::protocol::CouplingScheme::Parallel)) {
    const UnitConverter u(scene.unit_inputs());
    own.token = kToken;
    own.role = "fluid";
    own.model = "fake";
    own.version = cosim::protocol::kProtocolVersion;
    own.scene_hash = cosim::protocol::scene_hash_of_file(scene.path);
    own.dx_m = u.dx_m();
    own.dt_lb_s = u.dt_lb_s();
    own.sound_speed_m_s = u.inputs().sound_speed_m_s;
    own.air_density_kg_m3 = u.air_density_kg_m3();
    link.on<cosimlcm::hello_t>(ch.hello, [this](const cosimlcm::hello_t& m) { on_hello(nullptr, ch.hello, &m); });
    link.on<cosimlcm::solid_state_t>(ch.solid_state,
                                     [this](const cosimlcm::solid_state_t& m) { on_solid_state(nullptr, ch.solid_state, &m); });
    link.on<cosimlcm::resend_t>(ch.resend, [this](const cosimlcm::resend_t& m) { on_resend(nullptr, ch.resend, &m); });
    link.on<cosimlcm::stop_t>(ch.stop, [this](const cosimlcm::stop_t& m) { on_stop(nullptr, ch.stop, &m); });
  }

  // ---- knobs ----
  std::string refuse;                     ///< non-empty: refuse the handshake with this reason
  bool silent_after_welcome = false;      ///< never send a fluid_state_t
  std::int64_t stop_with_error_at = -1;   ///< instead of fluid_state_t(this step): stop_t(3)
  std::set<std::int64_t> lose_first_copy; ///< steps whose first fluid_state_t is "lost"
  std::int64_t duplicate_step = -1;       ///< send fluid_state_t of this step twice, plus a stale one
  std::int64_t foreign_step = -1;         ///< before this step's message, one with another token
  std::int64_t ask_resend_of = -1;        ///< ask once for solid_state_t of this step again
  std::function<void(cosimlcm::fluid_state_t&)> corrupt;  ///< applied to every fluid_state_t
  /// Raw messages published on FLUID_STATE before the first copy of each fluid_state_t.
  std::function<std::vector<std::vector<std::uint8_t>>(const cosimlcm::fluid_state_t&)> before;

  // ---- what it saw ----
  std::vector<cosimlcm::hello_t> hellos;
  std::vector<cosimlcm::solid_state_t> states;
  std::vector<cosimlcm::resend_t> resends;
  std::vector<cosimlcm::stop_t> stops;
  cosim::protocol::HandshakeResult verdict;
  std::map<std::int64_t, cosimlcm::fluid_state_t> published;

  lcm::LCM& bus;
  Channels ch;
  cosim::test::FakePeerLink link;  ///< receives through the session layer's gate
  std::int64_t total_steps, rigid_steps;
  /// The parallel scheme (protocol/README.md 14): publish fluid_state_t(m) only where
  /// parallel_fluid_state_needed(m), fluid_state_t(0) on solid_state_t(0) included.
  bool parallel = false;
  cosim::protocol::Hello own;
  std::int64_t seq = 0;
  std::set<std::int64_t> answered;
  std::size_t own_stops = 0;  ///< the fake's own stop_t, heard back on the bus

  /// The stop_t the solid published.
  std::size_t solid_stops() const { return stops.size() - own_stops; }

  void on_hello(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::hello_t* m) {
    hellos.push_back(*m);
    cosim::protocol::Hello h;
    h.token = m->token;
    h.role = m->role;
    h.model = m->model;
    h.version = m->version;
    h.scene_hash = m->scene_hash;
    h.dx_m = m->dx_m;
    h.dt_lb_s = m->dt_lb_s;
    h.sound_speed_m_s = m->sound_speed_m_s;
    h.air_density_kg_m3 = m->air_density_kg_m3;
    h.time_ratio = m->time_ratio;
    h.dt_cg_s = m->dt_cg_s;
    h.stable_dt_cg_s = m->stable_dt_cg_s;
    h.num_cgps = m->num_cgps;
    verdict = cosim::protocol::check_handshake(own, h, kToken);
    cosimlcm::welcome_t w{};
    w.token = kToken;
    w.accepted = refuse.empty() && verdict.accepted;
    w.reason = !refuse.empty() ? refuse : verdict.reason;
    w.total_steps = total_steps;
    w.rigid_steps = rigid_steps;
    w.time_ratio = kTimeRatio;
    bus.publish(ch.welcome, &w);
  }

  cosimlcm::fluid_state_t sample(std::int64_t step, int n) {
    cosimlcm::fluid_state_t f{};
    f.token = kToken;
    f.seq = seq++;
    f.step = step;
    f.num_cgps = n;
    f.rho_lb.assign(static_cast<std::size_t>(n), 1.0);
    f.velocity_lb.assign(static_cast<std::size_t>(n), std::vector<double>{kU, 0.0, 0.0});
    f.rho_start_lb = f.rho_lb;
    f.velocity_start_lb = f.velocity_lb;
    if (corrupt) corrupt(f);
    return f;
  }

  void on_solid_state(const lcm::ReceiveBuffer*, const std::string&,
                      const cosimlcm::solid_state_t* m) {
    states.push_back(*m);
    if (!answered.insert(m->step).second) return;  // a copy: answered already
    if (m->step == ask_resend_of) {
      cosimlcm::resend_t r{};
      r.token = kToken;
      r.step = m->step;
      r.what = "solid_state";
      bus.publish(ch.resend, &r);
    }
    if (silent_after_welcome) return;
    const std::int64_t next = m->step + 1;
    if (next == stop_with_error_at || next >= total_steps) {
      cosimlcm::stop_t s{};
      s.token = kToken;
      s.sender = "fluid";
      s.step = m->step + 1;
      s.exit_code = next >= total_steps ? 0 : 3;
      s.reason = next >= total_steps ? "" : "unhealthy flow after step 1: rho = -0.1 at cell (1, 2, 3)";
      for (int k = 0; k < 3; ++k) bus.publish(ch.stop, &s);
      own_stops += 3;
      return;
    }
    if (parallel && m->step == 0 && cosim::protocol::parallel_fluid_state_needed(0, total_steps, rigid_steps)) {
      published[0] = sample(0, m->num_cgps);
      if (lose_first_copy.count(0) == 0) bus.publish(ch.fluid_state, &published[0]);
    }
    if (parallel && !cosim::protocol::parallel_fluid_state_needed(next, total_steps, rigid_steps)) return;
    const cosimlcm::fluid_state_t f = sample(next, m->num_cgps);
    published[next] = f;
    if (next == foreign_step) {
      cosimlcm::fluid_state_t other = f;
      other.token = "fedcba9876543210";
      other.rho_lb.assign(other.rho_lb.size(), -1.0);  // applied, it would end the run
      bus.publish(ch.fluid_state, &other);
    }
    if (lose_first_copy.count(next) != 0) return;  // "lost": sent again on resend_t
    if (before)
      for (const auto& raw : before(f))
        bus.publish(ch.fluid_state, raw.data(), static_cast<unsigned int>(raw.size()));
    bus.publish(ch.fluid_state, &f);
    if (next == duplicate_step) {
      bus.publish(ch.fluid_state, &f);                // a duplicate
      bus.publish(ch.fluid_state, &published[next - 1]);  // and a stale one
    }
  }

  void on_resend(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::resend_t* m) {
    resends.push_back(*m);
    if (m->what != "fluid_state") return;
    const auto it = published.find(m->step);
    if (it != published.end()) bus.publish(ch.fluid_state, &it->second);
  }

  void on_stop(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::stop_t* m) {
    stops.push_back(*m);
  }
};

struct Outcome {
  int code = -1;
  std::string out, err;
};

/// Runs the coupled solid loop on its own thread over `bus`; afterwards, delivers what it
/// left in the queue (its stop_t) to the fake fluid.
Outcome run_solid(const SolidScene& scene, lcm::LCM& bus) {
  Outcome o;
  std::ostringstream out, err;
  CoupledSolidOptions opt;
  opt.token = kToken;
  opt.quiet = true;
  opt.bus = &bus;
  std::thread solid([&] { o.code = cosim::solid::run_coupled_solid(scene, opt, out, err); });
  solid.join();
  while (bus.handleTimeout(0) > 0) {
  }
  o.out = out.str();
  o.err = err.str();
  return o;
}

/// The number after "NAME " in the solid's counter line; -1 if absent.
long long counter(const std::string& out, const std::string& name) {
  const std::size_t at = out.find(", " + name + " ") != std::string::npos
                             ? out.find(", " + name + " ") + 2
                             : out.find("; " + name + " ") != std::string::npos
                                   ? out.find("; " + name + " ") + 2
                                   : std::string::npos;
  if (at == std::string::npos) return -1;
  return std::stoll(out.substr(at + name.size() + 1));
}

Eigen::Vector3d row(const std::vector<std::vector<double>>& rows, std::size_t l) {
  return {rows[l][0], rows[l][1], rows[l][2]};
}

/// Rows of a dataset of an HDF5 file; -1 if it cannot be read.
long long dataset_rows(const fs::path& file, const char* name) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return -1;
  long long rows = -1;
  const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d >= 0) {
    const hid_t space = H5Dget_space(d);
    hsize_t dims[3] = {0, 0, 0};
    if (space >= 0 && H5Sget_simple_extent_dims(space, dims, nullptr) >= 1)
      rows = static_cast<long long>(dims[0]);
    if (space >= 0) H5Sclose(space);
    H5Dclose(d);
  }
  H5Fclose(f);
  return rows;
}

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

// No fluid at all: hello_t every 200 ms, then exit 4 after handshake_timeout_s, with stop_t(4)
// published three times.
TEST(SolidCoupled, NoWelcomeReturnsFour) {
  const fs::path dir = scratch_dir("nowelcome");
  const SolidScene scene =
      cosim::solid::load_solid_scene(write_scene(dir, 0, 3.0, 0.5).string());
  lcm::LCM bus("memq://");
  std::vector<cosimlcm::hello_t> hellos;
  std::vector<cosimlcm::stop_t> stops;
  const Channels ch("TEST_");
  bus.subscribeFunction(ch.hello, +[](const lcm::ReceiveBuffer*, const std::string&,
                                      const cosimlcm::hello_t* m, std::vector<cosimlcm::hello_t>* v) {
    v->push_back(*m);
  }, &hellos);
  bus.subscribeFunction(ch.stop, +[](const lcm::ReceiveBuffer*, const std::string&,
                                     const cosimlcm::stop_t* m, std::vector<cosimlcm::stop_t>* v) {
    v->push_back(*m);
  }, &stops);
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("no welcome_t on TEST_WELCOME within handshake_timeout_s = 0.5 s"),
            std::string::npos)
      << r.err;
  EXPECT_GE(hellos.size(), 2u);
  EXPECT_LE(hellos.size(), 4u);
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops[0].exit_code, 4);
  EXPECT_EQ(stops[0].token, kToken);
  fs::remove_all(dir);
}

// A fluid that goes silent after the welcome: resend_t for the awaited step every
// resend_after_s, then stop_t(4) three times and 4 after peer_timeout_s, naming the step.
TEST(SolidCoupled, SilentFluidIsLostAfterPeerTimeout) {
  const fs::path dir = scratch_dir("silent");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0, 0.6).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 4);
  fluid.silent_after_welcome = true;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("silent for 0.6 s (peer_timeout_s) while the solid waited for "
                       "fluid_state_t of step 1"),
            std::string::npos)
      << r.err;
  int asked = 0;
  for (const auto& m : fluid.resends)
    if (m.what == "fluid_state") {
      EXPECT_EQ(m.step, 1);
      ++asked;
    }
  EXPECT_GE(asked, 3);  // every 0.1 s for 0.6 s
  ASSERT_EQ(fluid.stops.size(), 3u);
  EXPECT_EQ(fluid.stops[0].exit_code, 4);
  EXPECT_EQ(fluid.stops[0].step, 0);
  EXPECT_EQ(dataset_rows(dir / "out" / "solid.h5", "step"), 1);  // the output is written
  fs::remove_all(dir);
}

// The fluid stops the run with an error: the solid returns 4, naming the peer's code and
// reason, and does not answer with a stop_t of its own.
TEST(SolidCoupled, FluidStopWithErrorReturnsFour) {
  const fs::path dir = scratch_dir("fluidstop");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 10);
  fluid.stop_with_error_at = 2;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("the fluid stopped the run at step 2 with exit code 3: unhealthy flow"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(fluid.states.size(), 2u);
  EXPECT_EQ(fluid.solid_stops(), 0u) << "the solid answered the fluid's stop_t with its own";
  fs::remove_all(dir);
}

// The solid's checks of a fluid_state_t (section 5): a wrong size is malformed (2); a
// non-finite number or rho <= 0 is unhealthy (3). Each ends the run with stop_t(code).
TEST(SolidCoupled, BadFluidStateEndsTheRun) {
  struct Case {
    const char* name;
    std::function<void(cosimlcm::fluid_state_t&)> corrupt;
    int code;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"size",
       [](cosimlcm::fluid_state_t& f) {
         f.num_cgps = 11;
         f.rho_lb.pop_back();
         f.velocity_lb.pop_back();
       },
       2, "fluid_state_t of step 1: num_cgps = 11, expected 12"},
      {"rho", [](cosimlcm::fluid_state_t& f) { f.rho_lb[5] = 0.0; }, 3,
       "fluid_state_t of step 1: CGP 5 (sheet 0, i = 2, j = 1): rho_lb = 0; the density must be > 0"},
      {"nan", [](cosimlcm::fluid_state_t& f) { f.velocity_lb[7][2] = std::nan(""); }, 3,
       "fluid_state_t of step 1: CGP 7 (sheet 0, i = 1, j = 2): velocity_lb[2] = nan is not "
       "finite"},
  };
  for (const Case& c : cases) {
    const fs::path dir = scratch_dir(std::string("bad_") + c.name);
    const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
    lcm::LCM bus("memq://");
    FakeFluid fluid(bus, scene, 4);
    fluid.corrupt = c.corrupt;
    const Outcome r = run_solid(scene, bus);
    EXPECT_EQ(r.code, c.code) << c.name << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    ASSERT_EQ(fluid.stops.size(), 3u) << c.name;
    EXPECT_EQ(fluid.stops[0].exit_code, c.code);
    EXPECT_EQ(fluid.states.size(), 1u) << c.name << ": the bad sample was applied";
    fs::remove_all(dir);
  }
}

// UDP's troubles (section 7): a lost fluid_state_t is asked for again and the run goes on;
// a duplicate and a stale copy are counted, never applied; a message with another run's
// token is counted, never applied; a resend_t for a published solid_state_t is answered
// with the same message, bit for bit (same seq).
TEST(SolidCoupled, LostDuplicateAndForeignMessages) {
  const fs::path dir = scratch_dir("udp");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 0).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 5);
  fluid.lose_first_copy = {2};
  fluid.duplicate_step = 3;
  fluid.foreign_step = 1;
  fluid.ask_resend_of = 1;
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  // The duplicate of step 3 comes after the solid has moved on to step 4, so it counts as
  // stale, like the copy of step 2: either way, never applied. The solid's request for step
  // 2 is a round of kResendCopies copies, each answered: all but the first answer are
  // copies too.
  EXPECT_EQ(counter(r.out, "foreign"), 1) << r.out;
  EXPECT_EQ(counter(r.out, "duplicates") + counter(r.out, "stale"), 2 + cosim::protocol::kResendCopies - 1) << r.out;
  EXPECT_EQ(counter(r.out, "early"), 0) << r.out;
  EXPECT_NE(r.out.find("resend requests 1 answered 1"), std::string::npos) << r.out;
  bool asked_for_2 = false;
  for (const auto& m : fluid.resends) asked_for_2 |= m.what == "fluid_state" && m.step == 2;
  EXPECT_TRUE(asked_for_2);

  // Steps 0..4 once each, and step 1 a second time: the resend, identical to the first.
  std::map<std::int64_t, std::vector<const cosimlcm::solid_state_t*>> by_step;
  for (const auto& m : fluid.states) by_step[m.step].push_back(&m);
  ASSERT_EQ(by_step.size(), 5u);
  ASSERT_EQ(by_step[1].size(), 2u);
  const cosimlcm::solid_state_t& a = *by_step[1][0];
  const cosimlcm::solid_state_t& b = *by_step[1][1];
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_EQ(a.seq, 1);
  std::vector<std::uint8_t> ea(static_cast<std::size_t>(a.getEncodedSize())),
      eb(static_cast<std::size_t>(b.getEncodedSize()));
  a.encode(ea.data(), 0, static_cast<int>(ea.size()));
  b.encode(eb.data(), 0, static_cast<int>(eb.size()));
  EXPECT_EQ(ea, eb);
  for (std::int64_t s : {0, 2, 3, 4}) EXPECT_EQ(by_step[s].size(), 1u) << "step " << s;
  fs::remove_all(dir);
}

/// Every dataset of solid.h5 that MalformedMessagesAreRejected compares, read as doubles;
/// empty if the file cannot be read.
std::map<std::string, std::vector<double>> solid_h5(const fs::path& file) {
  std::map<std::string, std::vector<double>> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  for (const char* name :
       {"step", "time_s", "solid_time_s", "marked_displacement_um", "marked_normal_displacement_um",
        "fluid_force_N", "bulk_velocity_m_s", "force_coefficients", "leading_edge_strain",
        "kinetic_energy_J", "elastic_energy_J", "total_energy_J"}) {
    const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    if (d < 0) continue;
    const hid_t space = H5Dget_space(d);
    std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
    if (!v.empty()) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(space);
    H5Dclose(d);
    out.emplace(name, std::move(v));
  }
  H5Fclose(f);
  return out;
}

template <class M>
std::vector<std::uint8_t> encoded(const M& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// Message security (protocol/README.md section 8a): malformed fluid_state_t copies mixed with
// the valid ones (a NaN, rho = 0, a step far ahead; bytes with a hostile num_cgps, a token
// length of 0, a truncation) are counted, logged once, never applied: the run completes with
// the solid.h5 of a clean run, bit for bit. Only refused copies of a step end the run, after
// kRejectedCopiesLimit (3) of them, naming the field.
TEST(SolidCoupled, MalformedMessagesAreRejected) {
  const fs::path clean_dir = scratch_dir("clean"), noisy_dir = scratch_dir("noisy");
  const SolidScene clean_scene = cosim::solid::load_solid_scene(write_scene(clean_dir, 1).string());
  const SolidScene noisy_scene = cosim::solid::load_solid_scene(write_scene(noisy_dir, 1).string());
  lcm::LCM clean_bus("memq://"), noisy_bus("memq://");
  FakeFluid clean(clean_bus, clean_scene, 5), noisy(noisy_bus, noisy_scene, 5);
  noisy.before = [](const cosimlcm::fluid_state_t& good) {
    std::vector<std::vector<std::uint8_t>> out;
    cosimlcm::fluid_state_t m = good;
    m.velocity_lb[4][1] = std::nan("");
    out.push_back(encoded(m));
    m = good;
    m.rho_lb[0] = 0.0;
    out.push_back(encoded(m));
    m = good;
    m.step += 20;
    out.push_back(encoded(m));
    std::vector<std::uint8_t> hostile = encoded(good);
    // num_cgps after the hash (8), the token (4 + 17), seq, step, iteration,
    // bulk_velocity_lb (28).
    const std::size_t at = 8 + 4 + 17 + 28;
    hostile[at] = 0x7f, hostile[at + 1] = hostile[at + 2] = hostile[at + 3] = 0xff;
    out.push_back(hostile);
    std::vector<std::uint8_t> no_token = encoded(good);
    no_token[8] = no_token[9] = no_token[10] = no_token[11] = 0;
    out.push_back(no_token);
    std::vector<std::uint8_t> cut = encoded(good);
    cut.resize(cut.size() - 9);
    out.push_back(cut);
    return out;
  };
  const Outcome c = run_solid(clean_scene, clean_bus);
  ASSERT_EQ(c.code, 0) << c.out << c.err;
  const Outcome n = run_solid(noisy_scene, noisy_bus);
  ASSERT_EQ(n.code, 0) << n.out << n.err;
  EXPECT_EQ(n.err, "");
  EXPECT_EQ(counter(c.out, "rejected"), 0) << c.out;
  EXPECT_EQ(counter(n.out, "rejected"), 3 * 4) << n.out;     // fluid_state_t 1..4
  EXPECT_EQ(counter(n.out, "undecodable"), 3 * 4) << n.out;
  EXPECT_NE(n.out.find("rejected 12 (non-finite 4, range 8)"), std::string::npos) << n.out;
  EXPECT_NE(n.out.find("solid: refusing messages on channel 'TEST_FLUID_STATE' (non-finite): "
                       "fluid_state_t: velocity_lb[4][1] = nan; every number must be finite; such "
                       "messages are counted, never applied"),
            std::string::npos)
      << n.out;
  EXPECT_NE(n.out.find("does not decode as fluid_state_t (fluid_state_t: num_cgps = 2147483647 needs"),
            std::string::npos)
      << n.out;
  // The same solid_state_t went out, and the same solid.h5 came out.
  ASSERT_EQ(clean.states.size(), 5u);
  std::map<std::int64_t, const cosimlcm::solid_state_t*> first;
  for (const auto& m : noisy.states) first.emplace(m.step, &m);
  ASSERT_EQ(first.size(), 5u);
  for (const auto& m : clean.states)
    EXPECT_EQ(encoded(m), encoded(*first[m.step])) << "solid_state_t of step " << m.step;
  const auto a = solid_h5(clean_dir / "out" / "solid.h5"), b = solid_h5(noisy_dir / "out" / "solid.h5");
  ASSERT_EQ(a.size(), 12u);
  for (const auto& [name, values] : a) {
    ASSERT_EQ(b.count(name), 1u) << name;
    ASSERT_EQ(values.size(), b.at(name).size()) << name;
    EXPECT_EQ(std::memcmp(values.data(), b.at(name).data(), values.size() * sizeof(double)), 0) << name;
  }

  // Only refused copies of step 2 (every copy with seq = -1): the third ends the run with 2.
  const fs::path dir = scratch_dir("refused");
  const SolidScene scene = cosim::solid::load_solid_scene(write_scene(dir, 1).string());
  lcm::LCM bus("memq://");
  FakeFluid fluid(bus, scene, 5);
  fluid.corrupt = [](cosimlcm::fluid_state_t& f) {
    if (f.step == 2) f.seq = -1;
  };
  const Outcome r = run_solid(scene, bus);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "solid: fluid_state_t of step 2: seq = -1; allowed: 0 or more (the sender's "
                   "counter) (3 copies refused)\n");
  EXPECT_EQ(fluid.states.size(), 2u);
  ASSERT_EQ(fluid.solid_stops(), 3u);
  EXPECT_EQ(fluid.stops.back().exit_code, 2);
  int asked = 0;
  for (const auto& m : fluid.resends) asked += m.what == "fluid_state" && m.step == 2;
  EXPECT_GE(asked, 2) << "each refused copy is asked for again";

  // Only refused welcome_t (the coordinator answers each hello_t with one): exit 2 after 3.
  const fs::path wdir = scratch_dir("welcome");
  const SolidScene wscene = cosim::solid::load_solid_scene(write_scene(wdir, 1).string());
  lcm::LCM wbus("memq://");
  FakeFluid zero(wbus, wscene, 0);  // welcome_t.total_steps = 0
  const Outcome w = run_solid(wscene, wbus);
  EXPECT_EQ(w.code, 2) << w.out << w.err;
  EXPECT_EQ(w.err, "solid: welcome_t: total_steps = 0; allowed: 1 or more (3 copies refused)\n");
  EXPECT_EQ(zero.hellos.size(), 3u);
  EXPECT_TRUE(zero.states.empty());
  for (const fs::path& d : {clean_dir, noisy_dir, dir, wdir}) fs::remove_all(d);
}

}  // namespace
