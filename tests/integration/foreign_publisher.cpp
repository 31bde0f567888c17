// A foreign run on the bus (test ForeignRunIsIgnored, protocol/README.md section 8): publishes
// messages of every protocol type on a run's channels with ANOTHER run token, a few hundred
// per second, until its duration is over or it receives SIGTERM / SIGINT; then it prints how
// many it sent per channel. A coupled run must count them and never apply or answer them.
//
//   foreign_publisher [--duration S] [--rate MSG_PER_S] [--num-cgps N] [--steps N]
//                     [--scene FILE] [--prefix P] [--url URL] [--token T]
//
// Defaults: 30 s, 400 messages/s, 50 CGPs (coupled_small's 5 x 10 sheet), steps 0..200,
// prefix $COSIM_CHANNEL_PREFIX (else COSIM_), URL $COSIM_LCM_URL (else LCM's default with
// ttl=0), a random token different from $COSIM_RUN_TOKEN. --scene FILE puts that file's
// scene hash (FNV-1a 64) into the hello_t, so that only the token tells the runs apart.
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_signal(int) { g_stop = 1; }

using Clock = std::chrono::steady_clock;
using Rows3 = std::vector<std::vector<double>>;

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return (v != nullptr && *v != '\0') ? std::string(v) : fallback;
}

std::string hex16(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

/// FNV-1a 64 of a file's bytes, 16 lowercase hex digits (protocol/README.md section 6).
std::string scene_hash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "0123456789abcdef";
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (std::istreambuf_iterator<char> it(in), end; it != end; ++it) {
    h ^= static_cast<unsigned char>(*it);
    h *= 0x100000001b3ULL;
  }
  return hex16(h);
}

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "foreign_publisher: %s\nusage: foreign_publisher [--duration S] [--rate MSG_PER_S] "
               "[--num-cgps N] [--steps N] [--scene FILE] [--prefix P] [--url URL] [--token T]\n",
               why);
  std::exit(2);
}

/// Garbage-but-finite numbers, deterministic per step.
double garbage(std::int64_t step, std::size_t l, std::size_t c, double scale) {
  const double k = static_cast<double>(step * 131 + static_cast<std::int64_t>(l) * 7 + static_cast<std::int64_t>(c));
  return scale * (0.5 + 0.5 * std::sin(0.37 * k));
}

Rows3 rows3(std::size_t n, std::int64_t step, double scale, double offset) {
  Rows3 r(n, std::vector<double>(3));
  for (std::size_t l = 0; l < n; ++l)
    for (std::size_t c = 0; c < 3; ++c) r[l][c] = offset + garbage(step, l, c, scale);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  double duration_s = 30.0, rate = 400.0;
  int num_cgps = 50;
  std::int64_t steps = 200;
  std::string scene, prefix = env_or("COSIM_CHANNEL_PREFIX", "COSIM_"),
                     url = env_or("COSIM_LCM_URL", "udpm://239.255.76.67:7667?ttl=0"), token;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) usage(("missing the value of " + a).c_str());
    const std::string v = argv[++i];
    if (a == "--duration") duration_s = std::atof(v.c_str());
    else if (a == "--rate") rate = std::atof(v.c_str());
    else if (a == "--num-cgps") num_cgps = std::atoi(v.c_str());
    else if (a == "--steps") steps = std::atoll(v.c_str());
    else if (a == "--scene") scene = v;
    else if (a == "--prefix") prefix = v;
    else if (a == "--url") url = v;
    else if (a == "--token") token = v;
    else usage(("unknown option " + a).c_str());
  }
  if (!(duration_s > 0.0) || !(rate > 0.0) || num_cgps < 1 || steps < 1) usage("bad value");

  const std::string run_token = env_or("COSIM_RUN_TOKEN", "");
  std::random_device rd;
  std::mt19937_64 rng((static_cast<std::uint64_t>(rd()) << 32) ^ rd());
  while (token.empty() || token == run_token) token = hex16(rng());

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);

  lcm::LCM bus(url);
  if (!bus.good()) {
    std::fprintf(stderr, "foreign_publisher: cannot open LCM at %s\n", url.c_str());
    return 1;
  }
  const std::string ch_hello = prefix + "HELLO", ch_welcome = prefix + "WELCOME",
                    ch_solid = prefix + "SOLID_STATE", ch_fluid = prefix + "FLUID_STATE",
                    ch_resend = prefix + "RESEND", ch_stop = prefix + "STOP";
  std::map<std::string, std::int64_t> sent;
  std::int64_t failed = 0;
  const auto publish = [&](const std::string& channel, const auto& m) {
    if (bus.publish(channel, &m) == 0) ++sent[channel];
    else ++failed;
  };
  std::printf("foreign_publisher: token %s (run's %s), channels %s*, %s, %g s at %g msg/s, "
              "%d CGPs\n",
              token.c_str(), run_token.empty() ? "unset" : run_token.c_str(), prefix.c_str(),
              url.c_str(), duration_s, rate, num_cgps);
  std::fflush(stdout);

  // Plausible units of coupled_small (dx = 0.2561 um, c_s = 331.5 m/s, A_T = 150).
  const double dx_m = 0.2561e-6, c_s = 331.5, dt_lb = dx_m / (std::sqrt(3.0) * c_s);
  cosimlcm::hello_t solid_hello{};
  solid_hello.token = token;
  solid_hello.role = "solid";
  solid_hello.model = "rcgp";
  solid_hello.version = "3";  // protocol/README.md (this process links no project library)
  solid_hello.scene_hash = scene.empty() ? "0123456789abcdef" : scene_hash(scene);
  solid_hello.dx_m = dx_m;
  solid_hello.dt_lb_s = dt_lb;
  solid_hello.sound_speed_m_s = c_s;
  solid_hello.air_density_kg_m3 = 1.3035;
  solid_hello.time_ratio = 150;
  solid_hello.dt_cg_s = dt_lb / 150.0;
  solid_hello.stable_dt_cg_s = 1.1325e-11;
  solid_hello.num_cgps = num_cgps;
  cosimlcm::hello_t fluid_hello = solid_hello;
  fluid_hello.role = "fluid";
  fluid_hello.model = "d3q19-bgk-guo";
  fluid_hello.stable_dt_cg_s = 0.0;
  fluid_hello.num_cgps = 0;

  cosimlcm::welcome_t welcome{};
  welcome.token = token;
  welcome.accepted = 1;
  welcome.reason = "";
  welcome.total_steps = 7;  // not the run's 200
  welcome.rigid_steps = 3;
  welcome.time_ratio = 150;
  cosimlcm::welcome_t refused = welcome;
  refused.accepted = 0;
  refused.reason = "handshake refused: foreign_publisher says no";

  std::int64_t solid_seq = 0, fluid_seq = 0, step = 0;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
  const Clock::time_point start = Clock::now();
  const Clock::time_point end = start + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double>(duration_s));
  Clock::time_point next = start;
  std::size_t k = 0;  // which message of the round comes next
  constexpr std::size_t kRound = 14;
  while (g_stop == 0 && Clock::now() < end) {
    const std::size_t n = static_cast<std::size_t>(num_cgps);
    const std::size_t wrong = n + 3;
    switch (k) {
      case 0: publish(ch_hello, solid_hello); break;
      case 1: publish(ch_hello, fluid_hello); break;
      case 2: publish(ch_welcome, welcome); break;
      case 3: publish(ch_welcome, refused); break;
      case 4:
      case 5: {  // the run's CGP count, then a wrong one
        const std::size_t m = k == 4 ? n : wrong;
        cosimlcm::solid_state_t s{};
        s.token = token;
        s.seq = solid_seq++;
        s.step = step;
        s.substeps = step < 50 ? 0 : 150;
        s.solid_time_s = static_cast<double>(std::max<std::int64_t>(0, step - 49)) * dt_lb;
        s.num_cgps = static_cast<std::int32_t>(m);
        s.position_lb = rows3(m, step, 20.0, 1.0);  // inside the 40 x 30 x 30 channel
        s.impulse_lb = rows3(m, step, 0.5, -0.25);  // huge for a lattice impulse
        publish(ch_solid, s);
        break;
      }
      case 6:
      case 7: {
        const std::size_t m = k == 6 ? n : wrong;
        cosimlcm::fluid_state_t f{};
        f.token = token;
        f.seq = fluid_seq++;
        f.step = step;
        f.num_cgps = static_cast<std::int32_t>(m);
        f.rho_lb.resize(m);
        for (std::size_t l = 0; l < m; ++l) f.rho_lb[l] = 0.5 + garbage(step, l, 0, 2.0);
        f.velocity_lb = rows3(m, step, 0.4, -0.2);
        f.rho_start_lb = f.rho_lb;
        f.velocity_start_lb = f.velocity_lb;
        publish(ch_fluid, f);
        break;
      }
      case 8:
      case 9: {
        cosimlcm::resend_t r{};
        r.token = token;
        r.step = step;
        r.what = k == 8 ? "solid_state" : "fluid_state";
        publish(ch_resend, r);
        break;
      }
      case 10:
      case 11: {  // a resend of an early step: one the real senders still keep
        cosimlcm::resend_t r{};
        r.token = token;
        r.step = step % 3;
        r.what = k == 10 ? "solid_state" : "fluid_state";
        publish(ch_resend, r);
        break;
      }
      case 12:
      case 13: {
        cosimlcm::stop_t s{};
        s.token = token;
        s.sender = k == 12 ? "fluid" : "solid";
        s.step = step;
        s.exit_code = k == 12 ? 0 : 3;
        s.reason = k == 12 ? "" : "foreign_publisher: an unhealthy foreign run";
        publish(ch_stop, s);
        break;
      }
      default: break;
    }
    if (++k == kRound) {
      k = 0;
      step = (step + 1) % (steps + 1);
    }
    next += period;
    const Clock::time_point now = Clock::now();
    if (next > now) std::this_thread::sleep_for(next - now);
    else if (now - next > std::chrono::seconds(1)) next = now;  // fell behind: do not burst
  }

  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  std::int64_t total = 0;
  for (const auto& [channel, count] : sent) total += count;
  std::printf("foreign_publisher: sent %lld messages in %.1f s (%s)%s:",
              static_cast<long long>(total), wall, g_stop != 0 ? "signalled" : "duration over",
              failed > 0 ? (", " + std::to_string(failed) + " publish failures").c_str() : "");
  for (const std::string& channel : {ch_hello, ch_welcome, ch_solid, ch_fluid, ch_resend, ch_stop})
    std::printf(" %s %lld", channel.c_str(), static_cast<long long>(sent[channel]));
  std::printf("\n");
  std::fflush(stdout);
  return failed > 0 && total == 0 ? 1 : 0;
}
