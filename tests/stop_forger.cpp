// A forged stop_t mid-run (test ForgedStopIsRefused, protocol/README.md section 8): waits on
// the run's channels until the solid published solid_state_t of step >= --after, then
// publishes stop_t with the RUN'S token (COSIM_RUN_TOKEN, which the launcher gives to its
// --extra command) and exit code 0, three copies claiming each sender ("fluid" and "solid"),
// and exits. Both servers must refuse, count and log them and run to the end.
//
//   stop_forger [--after STEP] [--timeout S]
//
// Channels: $COSIM_CHANNEL_PREFIX, URL $COSIM_LCM_URL (both set by the launcher).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"

namespace {

std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? v : fallback;
}

struct Watch {
  std::string token;
  std::int64_t after = 0;
  std::int64_t seen = -1;
};

void on_solid_state(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::solid_state_t* m, Watch* w) {
  if (m->token == w->token && m->step > w->seen) w->seen = m->step;
}

}  // namespace

int main(int argc, char** argv) {
  std::int64_t after = 47;
  double timeout_s = 300.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--after") after = std::atoll(v.c_str());
    else if (a == "--timeout") timeout_s = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "stop_forger: unknown option %s (allowed: --after STEP, --timeout S)\n", a.c_str());
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
  Watch w{token, after, -1};
  bus.subscribeFunction(prefix + "SOLID_STATE", &on_solid_state, &w);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (w.seen < after) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "stop_forger: no solid_state_t of step %lld within %g s\n", static_cast<long long>(after),
                   timeout_s);
      return 1;
    }
    bus.handleTimeout(20);
  }
  for (const char* sender : {"fluid", "solid"}) {
    cosimlcm::stop_t s{};
    s.token = token;
    s.sender = sender;
    s.step = w.seen;
    s.exit_code = 0;
    s.reason = "";
    for (int k = 0; k < 3; ++k) {
      bus.publish(prefix + "STOP", &s);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  std::printf("stop_forger: published stop_t(exit 0) as 'fluid' and as 'solid' at step %lld, 3 copies each\n",
              static_cast<long long>(w.seen));
  return 0;
}
