// The fake fluid of the solid's coupled-run tests (test_solid_coupled.cpp and
// test_solid_coupled_faults.cpp): a coupled scene writer, a minimal fluid answering over
// memq://, the solid loop run on its own thread, and readers of what it printed and wrote.
// The bus arrangement is described at the top of test_solid_coupled.cpp.
#pragma once

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
#include "tests/support/h5_read.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/valid_messages.hpp"

namespace cosim::test::solid_coupled {

namespace fs = std::filesystem;
using cosim::protocol::Channels;
using cosim::protocol::PhysicalConstants;
using cosim::protocol::UnitConverter;
using cosim::solid::CoupledSolidOptions;
using cosim::solid::SolidScene;

using cosim::test::dataset_rows;
using cosim::test::messages::kTimeRatio;
using cosim::test::messages::kToken;
inline constexpr double kU = 0.01;  // the fake fluid's velocity at every marker, lattice units

inline fs::path scratch_dir(const std::string& name) { return cosim::test::fresh_scratch("cosim_test_solid_coupled_" + name); }

/// A coupled scene with the fluid's sections (which the solid leaves alone), a 3 x 4 rcgp
/// sheet (12 CGPs) standing in the flow, memq:// and short timeouts.
inline fs::path write_scene(const fs::path& dir, std::int64_t rigid_steps, double peer_timeout_s = 3.0,
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
inline Outcome run_solid(const SolidScene& scene, lcm::LCM& bus) {
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
inline long long counter(const std::string& out, const std::string& name) {
  const std::size_t at = out.find(", " + name + " ") != std::string::npos
                             ? out.find(", " + name + " ") + 2
                             : out.find("; " + name + " ") != std::string::npos
                                   ? out.find("; " + name + " ") + 2
                                   : std::string::npos;
  if (at == std::string::npos) return -1;
  return std::stoll(out.substr(at + name.size() + 1));
}

inline Eigen::Vector3d row(const std::vector<std::vector<double>>& rows, std::size_t l) {
  return {rows[l][0], rows[l][1], rows[l][2]};
}


}  // namespace cosim::test::solid_coupled
