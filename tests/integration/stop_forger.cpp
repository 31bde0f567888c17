// Forged messages mid-run (tests ForgedStopIsRefused and ForgedMessagesWithoutTheKeyAreRefused;
// protocol/README.md sections 8, 8b): waits on the run's channels until the solid published
// solid_state_t of step >= --after, then publishes with the RUN'S token (COSIM_RUN_TOKEN,
// which the launcher gives to its --extra command) but without the run's key (the launcher
// gives it only to the servers):
//   - stop_t with exit code 0, three copies claiming each sender ("fluid" and "solid");
//   - with --all also stop_t with exit code 3 and a made-up reason claiming each sender, and
//     solid_state_t copies continuing the solid's (seq and step + 1 to + 8, solid_time_s
//     advanced by the last interval, the positions moved by 0.37 lattice units, the
//     impulses doubled): consistent values that pass every value check;
// and exits. Both servers must refuse and count them and run to the end. With --key-file the
// forger holds the run's key too (a process the key leaked to): its messages carry a valid
// MAC, and only the stop rules and the sequencing stand between them and the run.
//
//   stop_forger [--after STEP] [--timeout S] [--all] [--key-file PATH]
//
// Channels: $COSIM_CHANNEL_PREFIX, URL $COSIM_LCM_URL (both set by the launcher).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "protocol/message_auth.hpp"

namespace {

std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? v : fallback;
}

struct Watch {
  std::string token;
  std::int64_t seen = -1;
  std::optional<cosimlcm::solid_state_t> last, before;  ///< the solid's newest two steps
};

// LCM's own decode reads the fields and ignores what follows them (the servers' MAC): a
// forger on the bus sees every value of the run, the token included.
void on_solid_state(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::solid_state_t* m, Watch* w) {
  if (m->token != w->token || m->step <= w->seen) return;
  w->seen = m->step;
  w->before = w->last;
  w->last = *m;
}

/// Publishes `m`, with the MAC of `key` when the forger holds it.
template <class M>
void publish(lcm::LCM& bus, const std::string& channel, const M& m, const std::optional<cosim::protocol::RunKey>& key) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  if (key) cosim::protocol::append_mac(*key, channel, bytes);
  bus.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
}

void publish_stops(lcm::LCM& bus, const std::string& channel, const std::string& token, std::int64_t step, int code,
                   const std::string& reason, const std::optional<cosim::protocol::RunKey>& key) {
  for (const char* sender : {"fluid", "solid"}) {
    cosimlcm::stop_t s{};
    s.token = token;
    s.sender = sender;
    s.step = step;
    s.exit_code = code;
    s.reason = reason;
    for (int k = 0; k < 3; ++k) {
      publish(bus, channel, s, key);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::int64_t after = 47;
  double timeout_s = 300.0;
  bool all = false;
  std::optional<cosim::protocol::RunKey> key;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--all") {
      all = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "stop_forger: %s needs a value\n", a.c_str());
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--after") after = std::atoll(v.c_str());
    else if (a == "--timeout") timeout_s = std::atof(v.c_str());
    else if (a == "--key-file") {
      try {
        key = cosim::protocol::read_key_file(v);
      } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "stop_forger: %s\n", e.what());
        return 2;
      }
    } else {
      std::fprintf(stderr, "stop_forger: unknown option %s (allowed: --after STEP, --timeout S, --all, --key-file PATH)\n",
                   a.c_str());
      return 2;
    }
  }
  const std::string token = env_or("COSIM_RUN_TOKEN", "");
  const std::string prefix = env_or("COSIM_CHANNEL_PREFIX", "COSIM_");
  const std::string url = env_or("COSIM_LCM_URL", "udpm://239.255.76.67:7667?ttl=0");
  if (token.empty()) {
    std::fprintf(stderr, "stop_forger: COSIM_RUN_TOKEN is not set (run it with run-coupled.sh --extra)\n");
    return 2;
  }
  lcm::LCM bus(url);
  if (!bus.good()) {
    std::fprintf(stderr, "stop_forger: cannot open LCM at %s\n", url.c_str());
    return 1;
  }
  Watch w{token, -1, std::nullopt, std::nullopt};
  bus.subscribeFunction(prefix + "SOLID_STATE", &on_solid_state, &w);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (w.seen < after || (all && !w.before)) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "stop_forger: no solid_state_t of step %lld within %g s\n", static_cast<long long>(after),
                   timeout_s);
      return 1;
    }
    bus.handleTimeout(20);
  }
  const std::int64_t at = w.seen;
  int states = 0;
  if (all) {
    // The solid's next messages, made up: what a forger holding the token can do.
    const cosimlcm::solid_state_t& last = *w.last;
    const double dt = last.solid_time_s - w.before->solid_time_s;
    for (std::int64_t k = 1; k <= 8; ++k) {
      cosimlcm::solid_state_t m = last;
      m.seq = last.seq + k;
      m.step = last.step + k;
      m.solid_time_s = last.solid_time_s + double(k) * dt;
      for (auto& p : m.position_lb) p[1] += 0.37;
      for (auto& j : m.impulse_lb)
        for (double& c : j) c *= 2.0;
      for (int copy = 0; copy < 3; ++copy) publish(bus, prefix + "SOLID_STATE", m, key);
      states += 3;
    }
  }
  publish_stops(bus, prefix + "STOP", token, at, 0, "", key);
  if (all) publish_stops(bus, prefix + "STOP", token, at, 3, "forged: a non-finite impulse at CGP 0", key);
  std::printf("stop_forger: published stop_t(exit 0)%s as 'fluid' and as 'solid' at step %lld, 3 copies each",
              all ? " and stop_t(exit 3)" : "", static_cast<long long>(at));
  if (all) std::printf(", and %d solid_state_t of steps %lld to %lld", states, static_cast<long long>(at + 1),
                       static_cast<long long>(at + 8));
  std::printf("\n");
  return 0;
}
