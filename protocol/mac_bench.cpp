// The cost of message authentication (protocol/message_auth.hpp; docs/reliability.md
// section 4): HMAC-SHA-256 of a message (its sender) and its verification (its receiver),
// for the protocol's message sizes, and per LB step of the paper's run (one solid_state_t
// and one fluid_state_t of 200 CGPs each way per step in the serial scheme).
//
//   cosim-mac-bench [--repeat N]
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "protocol/message_auth.hpp"

namespace {

using cosim::protocol::RunKey;

/// Microseconds for one MAC (the sender) and one MAC + verify (sender and receiver).
std::pair<double, double> time_one(const RunKey& key, std::size_t bytes, int repeat) {
  std::vector<std::uint8_t> message(bytes);
  for (std::size_t k = 0; k < bytes; ++k) message[k] = static_cast<std::uint8_t>(k * 131u + 7u);
  const std::string channel = "COSIM_0123abcd_SOLID_STATE";
  using Clock = std::chrono::steady_clock;
  volatile std::uint8_t sink = 0;
  const auto t0 = Clock::now();
  for (int r = 0; r < repeat; ++r) sink = sink ^ cosim::protocol::message_mac(key, channel, message.data(), bytes)[0];
  const auto t1 = Clock::now();
  std::vector<std::uint8_t> signed_message = message;
  cosim::protocol::append_mac(key, channel, signed_message);
  int verified = 0;
  const auto t2 = Clock::now();
  for (int r = 0; r < repeat; ++r) {
    std::vector<std::uint8_t> out = message;
    cosim::protocol::append_mac(key, channel, out);
    verified += cosim::protocol::verified_size(key, channel, out.data(), out.size()).has_value();
  }
  const auto t3 = Clock::now();
  if (verified != repeat) {
    std::fprintf(stderr, "cosim-mac-bench: a MAC did not verify\n");
    std::exit(1);
  }
  const auto us = [repeat](Clock::duration d) { return std::chrono::duration<double, std::micro>(d).count() / repeat; };
  return {us(t1 - t0), us(t3 - t2)};
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 20000;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeat" && i + 1 < argc) {
      repeat = std::atoi(argv[++i]);
      if (repeat < 1) repeat = 1;
    } else {
      std::fprintf(stderr, "usage: cosim-mac-bench [--repeat N]\n");
      return 2;
    }
  }
  RunKey key{};
  for (std::size_t k = 0; k < key.size(); ++k) key[k] = static_cast<std::uint8_t>(k + 1);
  // protocol/README.md section 8a: 65 + 48 n and 61 + 64 n bytes with the launcher's token.
  struct Row {
    const char* what;
    std::size_t bytes;
  };
  const Row rows[] = {{"stop_t (empty reason)", 49},
                      {"solid_state_t, 50 CGPs (coupled_small)", 65 + 48 * 50},
                      {"solid_state_t, 200 CGPs (the paper)", 65 + 48 * 200},
                      {"fluid_state_t, 200 CGPs (the paper)", 61 + 64 * 200}};
  std::printf("HMAC-SHA-256 (OpenSSL), %d repetitions each\n", repeat);
  std::printf("%-42s %8s %12s %18s\n", "message", "bytes", "MAC (us)", "MAC + verify (us)");
  double step = 0.0;
  for (const Row& r : rows) {
    const auto [mac, both] = time_one(key, r.bytes, repeat);
    std::printf("%-42s %8zu %12.2f %18.2f\n", r.what, r.bytes, mac, both);
    if (r.bytes == 65 + 48 * 200 || r.bytes == 61 + 64 * 200) step += both;
  }
  std::printf("per LB step of the paper's run (one solid_state_t and one fluid_state_t, each MAC + verify): %.2f us\n",
              step);
  return 0;
}
