// The session layer (protocol/session/): which stop_t ends a run, the header of bytes that do
// not decode, and, as two processes through launch/run-coupled.sh, a forged success stop_t
// mid-run that both servers refuse, count and log while the run goes on to its end.
#include <gtest/gtest.h>

#include "tests/support/run_compare.hpp"

#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "protocol/message_auth.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/stop_rules.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::protocol::fit_stop;
using cosim::protocol::StopContext;
using cosim::protocol::StopVerdict;

cosimlcm::stop_t stop(const char* sender, std::int64_t step, int code) {
  cosimlcm::stop_t m{};
  m.token = "0123456789abcdef";
  m.sender = sender;
  m.step = step;
  m.exit_code = code;
  return m;
}

// Only the coordinator ends a run with success, and only at its last step once the receiver
// has done its part; error stops of the peer apply within the run's steps.
TEST(Session, StopRules) {
  const StopContext solid_running{"solid", 200, false}, solid_at_end{"solid", 200, true};
  EXPECT_EQ(fit_stop(stop("fluid", 200, 0), solid_at_end).verdict, StopVerdict::Apply);
  for (const auto& [m, c] : std::vector<std::pair<cosimlcm::stop_t, StopContext>>{
           {stop("fluid", 47, 0), solid_running},   // forged mid-run
           {stop("fluid", 200, 0), solid_running},  // the right step, but the solid is not there yet
           {stop("fluid", 47, 0), solid_at_end},
           {stop("solid", 200, 0), solid_at_end},   // names the receiver as its sender
           {stop("fluid", 201, 3), solid_running},  // beyond the run
           {stop("solid", 200, 0), {"fluid", 200, false}},  // the solid never ends a run with 0
           {stop("fluid", 0, 0), {"solid", 0, false}},      // before the handshake
       }) {
    const cosim::protocol::StopFit f = fit_stop(m, c);
    EXPECT_EQ(f.verdict, StopVerdict::Refuse) << m.sender << " " << m.step << " " << m.exit_code;
    ASSERT_TRUE(f.rejection.has_value());
    EXPECT_EQ(f.rejection->what.rfind("stop_t: ", 0), 0u) << f.rejection->what;
    EXPECT_EQ(f.rejection->what.find('\n'), std::string::npos);
  }
  EXPECT_NE(fit_stop(stop("fluid", 47, 0), solid_running).rejection->what.find(
                "exit_code = 0 from 'fluid' at step 47; allowed: at the run's last step (step 200"),
            std::string::npos);
  EXPECT_EQ(fit_stop(stop("fluid", 47, 3), solid_running).verdict, StopVerdict::Apply);
  EXPECT_EQ(fit_stop(stop("solid", -1, 1), {"fluid", 200, false}).verdict, StopVerdict::Apply);
}

// The header of a state message (token, seq, step) reads from bytes that do not decode as a
// whole; nothing from bytes too short or with a broken token.
TEST(Session, StateHeaderOfUndecodableBytes) {
  cosimlcm::solid_state_t m{};
  m.token = "0123456789abcdef";
  m.seq = 41;
  m.step = 17;
  m.num_cgps = 1;
  m.position_lb = {{1.0, 2.0, 3.0}};
  m.impulse_lb = {{0.0, 0.0, 0.0}};
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  ASSERT_GT(m.encode(b.data(), 0, static_cast<int>(b.size())), 0);
  b.resize(b.size() - 7);
  const auto h = cosim::protocol::peek_state_header(b.data(), b.size());
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(h->token, m.token);
  EXPECT_EQ(h->seq, 41);
  EXPECT_EQ(h->step, 17);
  EXPECT_FALSE(cosim::protocol::peek_state_header(b.data(), 20).has_value());
  b[11] = 0;  // token length 0
  EXPECT_FALSE(cosim::protocol::peek_state_header(b.data(), b.size()).has_value());
}

// A stop_t with the run's token and exit code 0, claiming each sender, arrives mid-run
// (tests/integration/stop_forger.cpp, started by the launcher's --extra inside the run's namespace),
// from a forger that holds the run's key too (--key-file OUTPUT/run.key: its MAC verifies),
// so that the stop rules alone stand in its way: both servers refuse, count and log it and
// run to the end; the launcher exits 0 with every row written (it stopped both with 0 and 1
// monitor row and 47 of 200 solid rows before).
TEST(TwoProcess, ForgedStopIsRefused) {
  const fs::path source = COSIM_SOURCE_DIR;
  const fs::path dir = cosim::test::scratch("forged_stop"), out = dir / "out";
  const fs::path scene = source / "scenes" / "coupled_small.toml";
  const std::string extra = "--extra " + cosim::test::quoted("exec " + std::string(STOP_FORGER_EXE) +
                                                             " --after 47 --key-file " +
                                                             cosim::test::quoted((out / "run.key").string()));
  ASSERT_EQ(cosim::test::run_launcher(source, scene, out, extra), 0) << cosim::test::logs(out);
  EXPECT_EQ(cosim::test::slurp(out / "fluid.exit"), "0\n") << cosim::test::logs(out);
  EXPECT_EQ(cosim::test::slurp(out / "solid.exit"), "0\n") << cosim::test::logs(out);
  const std::string fluid_log = cosim::test::slurp(out / "fluid.log"), solid_log = cosim::test::slurp(out / "solid.log");
  EXPECT_NE(cosim::test::slurp(out / "extra.log").find("stop_forger: published stop_t(exit 0)"), std::string::npos)
      << cosim::test::logs(out);
  EXPECT_NE(fluid_log.find("coupled run done, 200 LB steps"), std::string::npos) << fluid_log;
  EXPECT_NE(solid_log.find("coupled run done"), std::string::npos) << solid_log;
  // Logged once per side, counted in the closing counters.
  for (const auto& [log, side] : {std::pair{fluid_log, "fluid"}, std::pair{solid_log, "solid"}}) {
    EXPECT_NE(log.find(std::string(side) + ": refusing messages on channel '"), std::string::npos) << log;
    EXPECT_NE(log.find("STOP' (range): stop_t: "), std::string::npos) << log;
    EXPECT_EQ(log.find("rejected 0"), std::string::npos) << log;
  }
  // Every row: monitor rows at 0, 50, ..., 200; solid rows 0..199 (the solid's last interval
  // is that of step 199, which the fluid's last step spreads).
  const auto monitor = cosim::test::read_datasets(out / "monitor.h5");
  const auto solid = cosim::test::read_datasets(out / "solid.h5");
  ASSERT_TRUE(monitor.count("step")) << "monitor.h5 has no step dataset";
  ASSERT_TRUE(solid.count("step")) << "solid.h5 has no step dataset";
  EXPECT_EQ(monitor.at("step").values.back(), 200.0);
  EXPECT_EQ(solid.at("step").values.size(), 200u);
  EXPECT_EQ(solid.at("step").values.back(), 199.0);
  if (!HasFailure()) fs::remove_all(dir);
}

// The run key's MAC (protocol/message_auth.hpp): a message verifies under its key and
// channel only; one changed byte, another channel or another key fails; a key file that
// others can read, or that is not 64 hexadecimal digits, is refused with one line.
TEST(Session, MessageMacsAndKeyFiles) {
  using cosim::protocol::RunKey;
  const fs::path dir = cosim::test::scratch("message_mac");
  RunKey key{}, other{};
  for (std::size_t k = 0; k < key.size(); ++k) key[k] = static_cast<std::uint8_t>(3 * k + 1), other[k] = key[k];
  other[5] ^= 1;
  std::vector<std::uint8_t> bytes = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  cosim::protocol::append_mac(key, "P_STOP", bytes);
  ASSERT_EQ(bytes.size(), 9 + cosim::protocol::kMacBytes);
  EXPECT_EQ(cosim::protocol::verified_size(key, "P_STOP", bytes.data(), bytes.size()), std::optional<std::size_t>(9));
  EXPECT_FALSE(cosim::protocol::verified_size(key, "P_HELLO", bytes.data(), bytes.size()));
  EXPECT_FALSE(cosim::protocol::verified_size(other, "P_STOP", bytes.data(), bytes.size()));
  EXPECT_FALSE(cosim::protocol::verified_size(key, "P_STOP", bytes.data(), 9));
  bytes[2] ^= 0x40;
  EXPECT_FALSE(cosim::protocol::verified_size(key, "P_STOP", bytes.data(), bytes.size()));

  const fs::path file = dir / "run.key";
  std::ofstream(file) << std::string(64, 'a') << "\n";
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  const RunKey read = cosim::protocol::read_key_file(file.string());
  for (const std::uint8_t b : read) EXPECT_EQ(b, 0xaa);
  const auto refusal = [&] {
    try {
      cosim::protocol::read_key_file(file.string());
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  fs::permissions(file, fs::perms::group_read | fs::perms::others_read, fs::perm_options::add);
  EXPECT_NE(refusal().find("mode 0644 lets others read it; allowed: readable by its owner only"), std::string::npos)
      << refusal();
  EXPECT_NE(refusal().find(file.string()), std::string::npos) << refusal();
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  std::ofstream(file) << std::string(63, 'a') << "g\n";
  EXPECT_NE(refusal().find("character 64 is not a hexadecimal digit"), std::string::npos) << refusal();
  std::ofstream(file) << "abc\n";
  EXPECT_NE(refusal().find("3 characters; allowed: 64 hexadecimal digits"), std::string::npos) << refusal();
  if (!HasFailure()) fs::remove_all(dir);
}

/// "unauthenticated N (of foreign)" of a server's closing counters; -1 if absent.
long long unauthenticated(const std::string& log) {
  static const std::regex re("unauthenticated ([0-9]+) \\(of foreign\\)");
  std::smatch m;
  return std::regex_search(log, m, re) ? std::stoll(m[1].str()) : -1;
}

// A forger on the run's bus that read the token from a datagram but has not the run's key
// (the launcher gives it to the servers only, protocol/README.md 8b) publishes at step 47:
// stop_t with exit code 0 and with exit code 3 and a made-up reason, each claiming both
// senders, and solid_state_t of steps 48 to 55 continuing the solid's (seq, step and
// solid_time_s; positions moved by 0.37 lattice units, impulses doubled: values that pass
// every check). Every one is refused for its MAC and counted as foreign, none reaches the
// value checks or the stop rules, and every HDF5 output equals the unforged run's bit for bit.
TEST(TwoProcess, ForgedMessagesWithoutTheKeyAreRefused) {
  const fs::path source = COSIM_SOURCE_DIR;
  const fs::path dir = cosim::test::scratch("forged_keyless"), clean = dir / "clean", out = dir / "forged";
  const fs::path scene = source / "scenes" / "coupled_small.toml";
  cosim::test::expect_run_done(clean, cosim::test::run_launcher(source, scene, clean));
  const std::string extra = "--extra " + cosim::test::quoted("exec " + std::string(STOP_FORGER_EXE) + " --after 47 --all");
  cosim::test::expect_run_done(out, cosim::test::run_launcher(source, scene, out, extra));
  const std::string fluid_log = cosim::test::slurp(out / "fluid.log"), solid_log = cosim::test::slurp(out / "solid.log");
  EXPECT_NE(cosim::test::slurp(out / "extra.log")
                .find("stop_forger: published stop_t(exit 0) and stop_t(exit 3) as 'fluid' and as 'solid' at step "),
            std::string::npos)
      << cosim::test::logs(out);
  // The key file: readable by the run's user only.
  const fs::perms perms = fs::status(out / "run.key").permissions();
  EXPECT_EQ(perms & (fs::perms::group_all | fs::perms::others_all), fs::perms::none);
  // Refused for the MAC, logged once per channel, counted as foreign: the fluid the 12 stop_t
  // and 24 solid_state_t, the solid the 12 stop_t (it does not listen on SOLID_STATE).
  for (const auto& [log, side] : {std::pair{fluid_log, "fluid"}, std::pair{solid_log, "solid"}}) {
    EXPECT_NE(log.find(std::string(side) + ": ignoring messages on channel '"), std::string::npos) << log;
    EXPECT_NE(log.find("whose MAC does not verify under this run's key"), std::string::npos) << log;
    EXPECT_EQ(log.find("refusing messages"), std::string::npos) << log;
  }
  EXPECT_EQ(unauthenticated(fluid_log), 36) << fluid_log;
  EXPECT_EQ(unauthenticated(solid_log), 12) << solid_log;
  EXPECT_EQ(cosim::test::compare_outputs(clean, out), "") << cosim::test::logs(out);
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
