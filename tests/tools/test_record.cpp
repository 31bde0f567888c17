// cosim-record (tools/record, docs/logs.md "Recording"): every message of a run in the log,
// whether the recorder lags or is stopped at once; appended to, never truncated; bad input
// refused in one line. The UDP cases run in a private network namespace (root: unshare -n;
// lo only, ttl=0); lcm-logplayer (Debian's liblcm-bin) plays a prepared log onto that bus.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <system_error>
#include <vector>

#include "cosimlcm/solid_state_t.hpp"
#include "tests/support/run_command.hpp"
#include "tools/log/lcm_log.hpp"
#include "tools/record/recorder.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::contains;
using cosim::test::lines;
using cosim::test::quoted;
using cosim::test::slurp;

const std::string kChannel = "COSIM_TEST_SOLID_STATE";
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";
/// More than LCM's default queue of 30 messages a subscription, which a lagging lcm-logger
/// overflows, and more bytes than the socket's default receive buffer (net.core.rmem_default,
/// 208 KiB) holds: 100 messages of 80 CGPs, about 4 kB each.
constexpr int kMessages = 100;
constexpr int kCgps = 80;

std::vector<std::uint8_t> message(int k) {
  cosimlcm::solid_state_t m{};
  m.token = "aaaa000000000001";
  m.seq = k;
  m.step = k;
  m.num_cgps = kCgps;
  for (int l = 0; l < kCgps; ++l) {
    m.position_lb.push_back({l + 0.5, 0.25 * k, 2.0});
    m.impulse_lb.push_back({0.125 * k, 0.0, 0.0});
  }
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

struct Logged {
  std::string channel;
  std::vector<std::uint8_t> data;
};

std::vector<Logged> read_log(const fs::path& p) {
  std::vector<Logged> out;
  std::error_code ec;
  if (!fs::is_regular_file(p, ec) || fs::file_size(p, ec) == 0) return out;  // none recorded
  cosim::logtool::LogReader in(p.string(), cosim::logtool::MacTrailers::keep);
  for (cosim::logtool::LogEvent e; in.next(e);) out.push_back({e.channel, e.data});
  return out;
}

/// The messages 0..kMessages-1 on kChannel, 1 ms apart, and one on a channel not recorded.
fs::path write_source_log(const fs::path& dir) {
  const fs::path p = dir / "source.lcmlog";
  lcm::LogFile out(p.string(), "w");
  std::int64_t t = 1'700'000'000'000'000;
  for (int k = 0; k < kMessages; ++k) {
    std::vector<std::uint8_t> b = message(k);
    lcm::LogEvent ev{};
    ev.timestamp = t += 1000;
    ev.channel = kChannel;
    ev.datalen = static_cast<std::int32_t>(b.size());
    ev.data = b.data();
    EXPECT_EQ(out.writeEvent(&ev), 0);
    if (k == kMessages / 2) {
      ev.channel = "SOMEONE_ELSE";
      EXPECT_EQ(out.writeEvent(&ev), 0);
    }
  }
  return p;
}

void expect_messages(const std::vector<Logged>& log, std::size_t from) {
  ASSERT_GE(log.size(), from + kMessages);
  for (int k = 0; k < kMessages; ++k) {
    EXPECT_EQ(log[from + std::size_t(k)].channel, kChannel) << k;
    EXPECT_EQ(log[from + std::size_t(k)].data, message(k)) << "message " << k;
  }
}

std::string record_exe() { return COSIM_RECORD_EXE; }

/// Why the namespace cases cannot run here, or "".
std::string namespace_problem() {
  if (geteuid() != 0) return "needs root for a private network namespace (unshare -n)";
  if (std::system("command -v unshare >/dev/null && command -v ip >/dev/null && command -v lcm-logplayer >/dev/null") != 0)
    return "needs unshare, ip and lcm-logplayer";
  if (std::system("unshare -n true 2>/dev/null") != 0) return "unshare -n is not permitted here (no CAP_SYS_ADMIN)";
  return "";
}

/// In a private network namespace: cosim-record on `log`, stopped (SIGSTOP) once it listens,
/// `source` played onto the bus meanwhile, then continued and at once asked to stop (SIGINT).
/// Everything sent waits in its socket: a recorder that dropped what it had not handled, or
/// what overflowed a queue, would lose it.
cosim::test::RunResult record_while_stopped(const fs::path& dir, const fs::path& source, const fs::path& log) {
  const fs::path script = dir / "record.sh";
  std::ofstream(script)
      << "set -e\n"
         "ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo\n"
      << quoted(record_exe()) << " " << quoted(log.string()) << " --channels 'COSIM_TEST_.*' --lcm-url '" << kUrl
      << "' >" << quoted((dir / "rec.out").string()) << " 2>" << quoted((dir / "rec.err").string())
      << " & r=$!\n"
         // The recorder ends however the script ends (it would keep the namespace alive).
         "trap 'kill -CONT $r 2>/dev/null; kill -INT $r 2>/dev/null' EXIT\n"
         "for k in $(seq 400); do grep -q '^cosim-record: recording ' "
      << quoted((dir / "rec.out").string())
      << " && break; sleep 0.05; done\n"
         "kill -STOP $r\n"
         "timeout 60 lcm-logplayer --lcm-url='"
      << kUrl << "' " << quoted(source.string())
      << "\n"
         "kill -CONT $r; kill -INT $r\n"
         "s=0; wait $r || s=$?\n"
         "trap - EXIT\n"
         "exit $s\n";
  return cosim::test::run_command("unshare -n sh " + quoted(script.string()), dir);
}

TEST(Record, KeepsEveryMessageOfAStoppedRecorder) {
  if (const std::string why = namespace_problem(); !why.empty()) GTEST_SKIP() << why;
  const fs::path dir = cosim::test::fresh_scratch("cosim_record_stopped");
  const fs::path source = write_source_log(dir);
  const fs::path log = dir / "traffic.lcmlog";
  const cosim::test::RunResult r = record_while_stopped(dir, source, log);
  ASSERT_EQ(r.status, 0) << r.out << r.err << slurp(dir / "rec.out") << slurp(dir / "rec.err");
  const std::vector<Logged> got = read_log(log);
  EXPECT_EQ(got.size(), std::size_t(kMessages)) << slurp(dir / "rec.out");
  expect_messages(got, 0);
  EXPECT_TRUE(contains(slurp(dir / "rec.out"), "cosim-record: " + std::to_string(kMessages) + " events"))
      << slurp(dir / "rec.out");
  EXPECT_EQ(slurp(dir / "rec.err"), "");
  fs::remove_all(dir);
}

TEST(Record, AppendsToItsLog) {
  if (const std::string why = namespace_problem(); !why.empty()) GTEST_SKIP() << why;
  const fs::path dir = cosim::test::fresh_scratch("cosim_record_append");
  const fs::path source = write_source_log(dir);
  const fs::path log = dir / "traffic.lcmlog";
  ASSERT_EQ(record_while_stopped(dir, source, log).status, 0) << slurp(dir / "rec.err");
  const std::string first = slurp(log);
  // A second recording (a restart's) goes after the first, which stays as it was.
  ASSERT_EQ(record_while_stopped(dir, source, log).status, 0) << slurp(dir / "rec.err");
  const std::string both = slurp(log);
  ASSERT_GT(both.size(), first.size());
  EXPECT_EQ(both.substr(0, first.size()), first);
  const std::vector<Logged> got = read_log(log);
  EXPECT_EQ(got.size(), std::size_t(2 * kMessages));
  expect_messages(got, 0);
  expect_messages(got, kMessages);
  fs::remove_all(dir);
}

// In one process over memq://: the messages published before the first receive, with the
// stop already requested, are all written (the drain), and only the recorded channels.
TEST(Record, DrainsWhatCameBeforeTheStop) {
  const fs::path dir = cosim::test::fresh_scratch("cosim_record_drain");
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  cosim::record::RecordOptions options;
  options.log_path = (dir / "traffic.lcmlog").string();
  options.channels = "COSIM_TEST_.*";
  const cosim::record::RecordResult r = cosim::record::record(
      bus, options, [] { return true; },
      [&](std::int64_t) {
        for (int k = 0; k < kMessages; ++k) {
          const std::vector<std::uint8_t> b = message(k);
          bus.publish(kChannel, b.data(), static_cast<unsigned>(b.size()));
          if (k == kMessages / 2) bus.publish("SOMEONE_ELSE", b.data(), static_cast<unsigned>(b.size()));
        }
      });
  EXPECT_TRUE(r.drained);
  EXPECT_EQ(r.events, kMessages);
  EXPECT_EQ(r.after_stop, kMessages);
  EXPECT_EQ(r.bytes, std::int64_t(fs::file_size(options.log_path)));
  const std::vector<Logged> got = read_log(options.log_path);
  EXPECT_EQ(got.size(), std::size_t(kMessages));
  expect_messages(got, 0);
  fs::remove_all(dir);
}

// Bad input: one line naming it, exit 2, nothing written or changed.
TEST(Record, RefusesBadInput) {
  const fs::path dir = cosim::test::fresh_scratch("cosim_record_bad");
  const fs::path notes = dir / "notes.txt";
  std::ofstream(notes) << "a user's notes, not an LCM log\n";
  const std::string exe = quoted(record_exe());
  struct Case {
    std::string args, says;
  };
  const std::vector<Case> cases = {
      {quoted(notes.string()) + " --channels 'COSIM_.*'", "is not an LCM log"},
      {quoted(dir.string()) + " --channels 'COSIM_.*'", "not a regular file"},
      {quoted((dir / "a.lcmlog").string()) + " --channels 'COSIM_.*' --lcm-url 'udpm://239.255.76.67:7667?ttl=1'",
       "ttl=1"},
      {quoted((dir / "a.lcmlog").string()) + " --channels 'COSIM_.*' --lcm-url memq://", "memq://"},
      {quoted((dir / "a.lcmlog").string()) + " --channels ''", "--channels"},
      {quoted((dir / "a.lcmlog").string()) + " --channels 'COSIM_(.*'", "not a regular expression"},
      {quoted((dir / "a.lcmlog").string()), "--channels"},
      {quoted((dir / "a.lcmlog").string()) + " --channels 'COSIM_.*' --chanels x", "did you mean"},
      {quoted((dir / "a.lcmlog").string()) + " --channels 'COSIM_.*' --receive-buffer -5", "--receive-buffer -5"},
  };
  for (const Case& c : cases) {
    const cosim::test::RunResult r = cosim::test::run_command(exe + " " + c.args, dir / "run");
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(lines(r.err), 1u) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c.args;
  }
  EXPECT_EQ(slurp(notes), "a user's notes, not an LCM log\n");
  EXPECT_FALSE(fs::exists(dir / "a.lcmlog"));
  fs::remove_all(dir);
}

}  // namespace
