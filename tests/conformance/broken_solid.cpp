// A deliberately broken solid for ConformanceKitCatchesBrokenSolids: a held plate of the
// scene's markers written on the raw protocol (plain LCM and the generated types, no session
// layer: misbehaving on purpose is its job), with one fault chosen by --fault, from LB step
// --from on (default 1):
//   none             correct (J = -2 rho u dA, the markers held)
//   sign             J = +2 rho u dA
//   no-average       J summed over the A_T substeps, not averaged (A_T times too large)
//   double           J = 2 x (-2 rho u dA)
//   half             J = 1/2 x (-2 rho u dA)
//   over-time-ratio  J divided by A_T once more
//   late             J of the previous fluid_state_t (one exchange late; the first its own)
//   no-resend        resend_t is never answered
//   substeps         A_T - 1 substeps per free LB step
//   nan              a NaN impulse at the first free step
//   broken-solid SCENE --fault F [--from STEP] [--output DIR] [--channel-prefix P] [--quiet]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <functional>
#include <optional>
#include <limits>
#include <string>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/session/announcement.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "solid/config/solid_scene.hpp"

using namespace cosim;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  std::string scene_path, fault = "none", prefix;
  std::int64_t from = 1;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--fault" && k + 1 < argc) fault = argv[++k];
    else if (a == "--from" && k + 1 < argc) from = std::atoll(argv[++k]);
    else if (a == "--channel-prefix" && k + 1 < argc) prefix = argv[++k];
    else if (a == "--output" && k + 1 < argc) ++k;
    else if (a == "--quiet") continue;
    else scene_path = a;
  }
  const solid::SolidScene scene = solid::load_solid_scene(scene_path);
  const protocol::UnitConverter units(scene.unit_inputs());
  const Eigen::Matrix3Xd x0 = solid::marker_positions_lb(scene.config.sheets, units);
  const std::vector<double> area = solid::marker_areas_lb(scene.config.sheets, units);
  const auto n = static_cast<std::size_t>(x0.cols());
  const int a_t = scene.coupling->time_ratio;
  const std::string token = std::getenv("COSIM_RUN_TOKEN") ? std::getenv("COSIM_RUN_TOKEN") : "";
  const protocol::Channels ch(prefix.empty() ? scene.coupling->channel_prefix : prefix);
  lcm::LCM bus(scene.coupling->lcm_url);
  if (!bus.good()) return 1;

  cosimlcm::hello_t hello = protocol::to_lcm(protocol::announcement(
      "solid", token, "broken-" + fault, scene.path, scene.coupling->scheme.scheme, units, a_t));
  hello.stable_dt_cg_s = std::numeric_limits<double>::max();
  hello.num_cgps = static_cast<std::int32_t>(n);

  bool welcomed = false, stopped = false;
  int stop_code = 0;
  std::int64_t rigid = 0, last = -1, seq = 0, substeps_total = 0;
  std::deque<cosimlcm::solid_state_t> kept;
  std::optional<cosimlcm::fluid_state_t> previous;  // the fault "late" answers this one
  Clock::time_point heard = Clock::now();
  const auto publish = [&](cosimlcm::solid_state_t m) {
    bus.publish(ch.solid_state, &m);
    kept.push_back(std::move(m));
    if (kept.size() > 2) kept.pop_front();
  };
  const auto state = [&](std::int64_t step, const cosimlcm::fluid_state_t* sample) {
    const bool on = step >= from;
    const cosimlcm::fluid_state_t* f = sample != nullptr && on && fault == "late" && previous ? &*previous : sample;
    cosimlcm::solid_state_t m{};
    m.token = token;
    m.seq = seq++;
    m.step = step;
    const bool free_step = f != nullptr && step >= rigid;
    m.substeps = free_step ? (fault == "substeps" ? a_t - 1 : a_t) : 0;
    substeps_total += m.substeps;
    m.solid_time_s = double(substeps_total) * units.dt_cg_s();
    m.num_cgps = static_cast<std::int32_t>(n);
    m.position_lb.assign(n, std::vector<double>(3));
    m.impulse_lb.assign(n, std::vector<double>(3, 0.0));
    for (std::size_t l = 0; l < n; ++l)
      for (std::size_t c = 0; c < 3; ++c) {
        m.position_lb[l][c] = x0(Eigen::Index(c), Eigen::Index(l));
        if (f == nullptr) continue;
        double j = -2.0 * f->rho_lb[l] * area[l] * f->velocity_lb[l][c];  // U_B = 0: the plate is held
        if (on && fault == "sign") j = -j;
        if (on && fault == "no-average") j *= a_t;
        if (on && fault == "double") j *= 2.0;
        if (on && fault == "half") j *= 0.5;
        if (on && fault == "over-time-ratio") j /= a_t;
        m.impulse_lb[l][c] = j;
      }
    if (sample != nullptr) previous = *sample;
    if (fault == "nan" && free_step && step == rigid) m.impulse_lb[0][0] = std::nan("");
    publish(std::move(m));
  };

  struct Handler {
    std::function<void(const cosimlcm::welcome_t*)> welcome;
    std::function<void(const cosimlcm::fluid_state_t*)> fluid;
    std::function<void(const cosimlcm::resend_t*)> resend;
    std::function<void(const cosimlcm::stop_t*)> stop;
    void on_welcome(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::welcome_t* m) { welcome(m); }
    void on_fluid(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::fluid_state_t* m) { fluid(m); }
    void on_resend(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::resend_t* m) { resend(m); }
    void on_stop(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::stop_t* m) { stop(m); }
  } h;
  h.welcome = [&](const cosimlcm::welcome_t* m) {
    if (m->token != token || welcomed) return;
    welcomed = true;
    rigid = m->rigid_steps;
    state(0, nullptr);
    last = 0;
    heard = Clock::now();
  };
  h.fluid = [&](const cosimlcm::fluid_state_t* m) {
    if (m->token != token || !welcomed) return;
    heard = Clock::now();
    if (m->step != last + 1) return;  // a duplicate or an old copy
    state(m->step, m);
    last = m->step;
  };
  h.resend = [&](const cosimlcm::resend_t* m) {
    if (m->token != token || m->what != "solid_state" || fault == "no-resend") return;
    for (const cosimlcm::solid_state_t& s : kept)
      if (s.step == m->step) bus.publish(ch.solid_state, &s);
  };
  h.stop = [&](const cosimlcm::stop_t* m) {
    if (m->token != token || m->sender != "fluid") return;
    stopped = true;
    stop_code = m->exit_code;
  };
  bus.subscribe(ch.welcome, &Handler::on_welcome, &h);
  bus.subscribe(ch.fluid_state, &Handler::on_fluid, &h);
  bus.subscribe(ch.resend, &Handler::on_resend, &h);
  bus.subscribe(ch.stop, &Handler::on_stop, &h);

  Clock::time_point next_hello = Clock::now(), next_resend = Clock::now();
  while (!stopped) {
    if (!welcomed && Clock::now() >= next_hello) {
      bus.publish(ch.hello, &hello);
      next_hello = Clock::now() + std::chrono::milliseconds(200);
    }
    bus.handleTimeout(20);
    const auto silent = Clock::now() - heard;
    if (welcomed && silent > std::chrono::duration<double>(scene.coupling->resend_after_s) && Clock::now() >= next_resend) {
      cosimlcm::resend_t r{};
      r.token = token;
      r.step = last + 1;
      r.what = "fluid_state";
      bus.publish(ch.resend, &r);
      next_resend = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(scene.coupling->resend_after_s));
    }
    if (welcomed && Clock::now() - heard > std::chrono::duration<double>(scene.coupling->peer_timeout_s)) {
      cosimlcm::stop_t s{};
      s.token = token;
      s.sender = "solid";
      s.step = last;
      s.exit_code = 4;
      s.reason = "the fluid was silent";
      for (int k = 0; k < 3; ++k) bus.publish(ch.stop, &s);
      return 4;
    }
  }
  return stop_code == 0 ? 0 : 4;
}
