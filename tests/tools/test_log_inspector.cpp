// The LCM log inspector (tools/log, `cosim-log`, docs/logs.md) on a synthetic log written
// with lcm::LogFile whose content is known: counts, gaps, missing / duplicated / out-of-order
// steps and seq numbers, an undecodable and a foreign message; one step as text; the HDF5
// export read back with the HDF5 C API; bad input; and LCM's own lcm-logplayer / lcm-logger
// replaying and recording it in a private network namespace (as root).
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "protocol/handshake.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "tools/log/log_inspector.hpp"
#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;
namespace lt = cosim::logtool;

const std::string kPrefix = "COSIM_TEST_";
const std::string kToken = "aaaa000000000001";
const std::string kForeign = "bbbb000000000002";
constexpr int kCgps = 4;
constexpr std::int64_t kT0 = 1'700'000'000'000'000;  // us since 1970

fs::path scratch(const std::string& name) { return cosim::test::fresh_scratch("cosim_log_" + name); }

template <class T>
std::vector<std::uint8_t> encode(const T& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

cosimlcm::solid_state_t solid_state(std::int64_t step, std::int64_t seq, const std::string& token) {
  cosimlcm::solid_state_t m{};
  m.token = token;
  m.seq = seq;
  m.step = step;
  m.substeps = step < 5 ? 0 : 150;
  m.solid_time_s = step < 5 ? 0.0 : double(step - 4) * 0.5e-9;
  m.num_cgps = kCgps;
  for (int l = 0; l < kCgps; ++l) {
    m.position_lb.push_back({l + 0.5, double(step) * 0.25, 2.0});
    m.impulse_lb.push_back({double(step) * 0.125, -0.0625 * l, 0.0});
  }
  return m;
}

cosimlcm::fluid_state_t fluid_state(std::int64_t step, std::int64_t seq) {
  cosimlcm::fluid_state_t m{};
  m.token = kToken;
  m.seq = seq;
  m.step = step;
  m.bulk_velocity_lb = 0.03125;
  m.num_cgps = kCgps;
  for (int l = 0; l < kCgps; ++l) {
    m.rho_lb.push_back(1.0 + 0.0078125 * l);
    m.velocity_lb.push_back({0.015625 * double(step), 0.0, double(l)});
  }
  m.rho_start_lb = m.rho_lb;
  m.velocity_start_lb = m.velocity_lb;
  return m;
}

struct Event {
  std::int64_t utime;
  std::string channel;
  std::vector<std::uint8_t> data;
};

/// The log time of the k-th message on SOLID_STATE (22 of them), with a 0.2 s pause
/// before the 11th (index 11): the channel's largest gap, 210 ms.
std::int64_t solid_time(int k) { return kT0 + 10'000 + 10'000 * k + (k >= 11 ? 200'000 : 0); }

/// The synthetic run: hello_t x2 and an accepted welcome_t (20 steps, 5 rigid, A_T 150);
/// solid_state_t for steps 0..19 with step 7 never sent, steps 3 and 4 logged in the order
/// 4, 3 (seq out of order), step 12 logged twice (a resend: the same bytes, the same seq,
/// after a resend_t), a seq jump from 14 to 16 at step 15; one solid_state_t cut short
/// (undecodable) and one with another run's token; fluid_state_t for steps 1..19 (seq
/// step - 1); stop_t x3; one message on a channel outside the protocol.
std::vector<Event> synthetic_events() {
  std::vector<Event> ev;
  cosimlcm::hello_t hf{};
  hf.token = kToken;
  hf.role = "fluid";
  hf.model = "d3q19-bgk";
  hf.version = cosim::protocol::kProtocolVersion;
  hf.scene_hash = "0123456789abcdef";
  hf.scheme = "serial";
  hf.dx_m = 2.561e-7;
  hf.dt_lb_s = 4.46e-10;
  hf.sound_speed_m_s = 331.5;
  hf.air_density_kg_m3 = 1.3035;
  hf.time_ratio = 150;
  hf.dt_cg_s = hf.dt_lb_s / 150;
  cosimlcm::hello_t hs = hf;
  hs.role = "solid";
  hs.model = "rcgp";
  hs.stable_dt_cg_s = 1e-11;
  hs.num_cgps = kCgps;
  ev.push_back({kT0, kPrefix + "HELLO", encode(hf)});
  ev.push_back({kT0 + 1000, kPrefix + "HELLO", encode(hs)});
  cosimlcm::welcome_t w{};
  w.token = kToken;
  w.accepted = 1;
  w.total_steps = 20;
  w.rigid_steps = 5;
  w.time_ratio = 150;
  w.scheme = "serial";
  ev.push_back({kT0 + 2000, kPrefix + "WELCOME", encode(w)});

  // SOLID_STATE in log order: {step, seq} or a special entry.
  enum Kind { kNormal, kForeignToken, kTruncated };
  struct S {
    std::int64_t step, seq;
    Kind kind;
  };
  const std::vector<S> order = {
      {0, 0, kNormal},   {1, 1, kNormal},   {2, 2, kNormal},       {4, 4, kNormal},
      {3, 3, kNormal},   {5, 5, kNormal},   {5, 5, kForeignToken}, {6, 6, kTruncated},
      {6, 6, kNormal},   {8, 8, kNormal},   {9, 9, kNormal},       {10, 10, kNormal},
      {11, 11, kNormal}, {12, 12, kNormal}, {13, 13, kNormal},     {12, 12, kNormal},
      {14, 14, kNormal}, {15, 16, kNormal}, {16, 17, kNormal},     {17, 18, kNormal},
      {18, 19, kNormal}, {19, 20, kNormal}};
  for (int k = 0; k < int(order.size()); ++k) {
    const S& s = order[std::size_t(k)];
    std::vector<std::uint8_t> bytes =
        encode(solid_state(s.step, s.seq, s.kind == kForeignToken ? kForeign : kToken));
    if (s.kind == kTruncated) bytes.resize(bytes.size() - 10);
    if (k == 15) {  // the fluid asks for step 12 again just before the resend
      cosimlcm::resend_t r{};
      r.token = kToken;
      r.step = 12;
      r.what = "solid_state";
      ev.push_back({solid_time(k) - 2000, kPrefix + "RESEND", encode(r)});
    }
    ev.push_back({solid_time(k), kPrefix + "SOLID_STATE", bytes});
  }
  // The fluid's side is clean: fluid_state_t(n) for n = 1..19, seq n - 1, in order.
  for (std::int64_t n = 1; n < 20; ++n)
    ev.push_back(
        {solid_time(int(n)) + 5000, kPrefix + "FLUID_STATE", encode(fluid_state(n, n - 1))});
  cosimlcm::stop_t stop{};
  stop.token = kToken;
  stop.sender = "fluid";
  stop.step = 20;
  stop.exit_code = 0;
  for (int i = 0; i < 3; ++i)
    ev.push_back({solid_time(21) + 10'000 + 20'000 * i, kPrefix + "STOP", encode(stop)});
  ev.push_back({solid_time(21) + 100'000, "SOMEONE_ELSE", {1, 2, 3}});
  std::stable_sort(ev.begin(), ev.end(),
                   [](const Event& a, const Event& b) { return a.utime < b.utime; });
  return ev;
}

fs::path write_log(const fs::path& dir) {
  const fs::path p = dir / "synthetic.lcmlog";
  lcm::LogFile log(p.string(), "w");
  EXPECT_TRUE(log.good());
  for (Event& e : synthetic_events()) {
    lcm::LogEvent le{};
    le.timestamp = e.utime;
    le.channel = e.channel;
    le.datalen = static_cast<std::int32_t>(e.data.size());
    le.data = e.data.data();
    EXPECT_EQ(log.writeEvent(&le), 0);
  }
  return p;
}

struct Cmd {
  int status = -1;
  std::string out, err;
};

Cmd run_cmd(const std::string& cmd, const fs::path& dir) {
  const fs::path o = dir / "stdout.txt", e = dir / "stderr.txt";
  const int s = std::system((cmd + " >" + o.string() + " 2>" + e.string()).c_str());
  return {WIFEXITED(s) ? WEXITSTATUS(s) : -1, slurp(o), slurp(e)};
}

Cmd cosim_log(const std::string& args, const fs::path& dir) {
  return run_cmd(std::string(COSIM_LOG_EXE) + " " + args, dir);
}

std::size_t lines(const std::string& s) {
  return std::size_t(std::count(s.begin(), s.end(), '\n'));
}

const lt::ChannelStats& channel(const lt::LogSummary& s, lt::MsgType t) {
  const lt::PrefixStats* p = s.prefix(kPrefix);
  EXPECT_NE(p, nullptr);
  const lt::ChannelStats* c = p->channel(t);
  EXPECT_NE(c, nullptr) << lt::type_name(t);
  return *c;
}

TEST(LogInspector, LogInspectorCountsGaps) {
  const fs::path dir = scratch("counts");
  const fs::path log = write_log(dir);
  const lt::LogSummary s = lt::summarize_log(log.string());

  EXPECT_EQ(s.events, 3 + 22 + 19 + 1 + 3 + 1);
  EXPECT_EQ(s.first_utime, kT0);
  EXPECT_EQ(s.skipped_bytes, 0u);
  EXPECT_EQ(s.truncated, "");
  ASSERT_EQ(s.prefixes.size(), 1u);
  EXPECT_EQ(s.prefixes[0].prefix, kPrefix);
  EXPECT_EQ(s.prefixes[0].channels.size(), 6u);
  ASSERT_EQ(s.prefixes[0].runs.size(), 2u);  // the run and the foreign token
  ASSERT_EQ(s.other_channels.size(), 1u);
  EXPECT_EQ(s.other_channels[0].channel, "SOMEONE_ELSE");
  EXPECT_EQ(s.other_channels[0].count, 1);

  // SOLID_STATE, every message: 19 steps + 1 resend + 1 cut short + 1 foreign.
  const lt::ChannelStats& sc = channel(s, lt::MsgType::solid_state);
  EXPECT_EQ(sc.count, 22);
  EXPECT_EQ(sc.first_utime, solid_time(0));
  EXPECT_EQ(sc.last_utime, solid_time(21));
  EXPECT_EQ(sc.largest_gap_us, 210'000);
  EXPECT_EQ(sc.largest_gap_at_utime, solid_time(11));
  EXPECT_NEAR(sc.rate_hz(), 21.0 / 0.41, 1e-9);
  EXPECT_EQ(sc.undecodable, 1);
  EXPECT_NE(sc.first_undecodable.find(
                "solid_state_t: num_cgps = 4 needs 192 bytes of arrays, but 182 are left"), std::string::npos)
      << sc.first_undecodable;
  EXPECT_EQ(sc.fingerprints, (std::map<std::string, std::int64_t>{{"solid_state_t", 22}}));
  EXPECT_EQ(sc.tokens, (std::map<std::string, std::int64_t>{{kToken, 20}, {kForeign, 1}}));

  const lt::ChannelStats& fc = channel(s, lt::MsgType::fluid_state);
  EXPECT_EQ(fc.count, 19);
  EXPECT_EQ(fc.undecodable, 0);
  EXPECT_EQ(channel(s, lt::MsgType::stop).count, 3);
  EXPECT_EQ(channel(s, lt::MsgType::hello).count, 2);

  const lt::RunStats* r = s.run(kToken);
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->fluid_hellos, 1);
  EXPECT_EQ(r->solid_hellos, 1);
  EXPECT_EQ(r->solid_model, "rcgp");
  EXPECT_TRUE(r->accepted);
  EXPECT_EQ(r->total_steps, 20);
  EXPECT_EQ(r->rigid_steps, 5);
  EXPECT_EQ(r->time_ratio, 150);
  EXPECT_EQ(r->stops, 3);
  EXPECT_EQ(r->stop_step, 20);
  EXPECT_EQ(r->stop_exit_code, 0);
  EXPECT_EQ(r->resends, (std::map<std::string, std::int64_t>{{"solid_state", 1}}));

  const lt::StateStats& so = r->solid;
  EXPECT_EQ(so.messages, 20);
  EXPECT_EQ(so.num_cgps, kCgps);
  EXPECT_EQ(so.first_step, 0);
  EXPECT_EQ(so.last_step, 19);
  EXPECT_EQ(so.distinct_steps, 19);
  EXPECT_EQ(so.steps_missing, 1);
  EXPECT_EQ(so.steps_missing_ranges, (lt::Ranges{{7, 7}}));
  EXPECT_EQ(so.steps_duplicated, 1);
  EXPECT_EQ(so.steps_duplicated_ranges, (lt::Ranges{{12, 12}}));
  EXPECT_EQ(so.extra_copies, 1);
  EXPECT_EQ(so.copies_differing, 0);
  EXPECT_EQ(so.first_seq, 0);
  EXPECT_EQ(so.last_seq, 20);
  EXPECT_EQ(so.seq_missing, 2);
  EXPECT_EQ(so.seq_missing_ranges, (lt::Ranges{{7, 7}, {15, 15}}));
  EXPECT_EQ(so.seq_duplicated, 1);
  EXPECT_EQ(so.seq_out_of_order, 1);

  const lt::StateStats& fl = r->fluid;
  EXPECT_EQ(fl.messages, 19);
  EXPECT_EQ(fl.first_step, 1);
  EXPECT_EQ(fl.last_step, 19);
  EXPECT_EQ(fl.steps_missing, 0);
  EXPECT_EQ(fl.steps_duplicated, 0);
  EXPECT_EQ(fl.first_seq, 0);
  EXPECT_EQ(fl.last_seq, 18);
  EXPECT_EQ(fl.seq_missing, 0);
  EXPECT_EQ(fl.seq_duplicated, 0);
  EXPECT_EQ(fl.seq_out_of_order, 0);

  const lt::RunStats* foreign = s.run(kForeign);
  ASSERT_NE(foreign, nullptr);
  EXPECT_EQ(foreign->messages, 1);
  EXPECT_EQ(foreign->solid.messages, 1);
  EXPECT_FALSE(foreign->welcome);

  // The executable prints the same as a table and exits 0.
  const Cmd out = cosim_log("summary " + log.string(), dir);
  EXPECT_EQ(out.status, 0) << out.err;
  EXPECT_EQ(out.err, "");
  EXPECT_EQ(out.out, lt::format_summary(s));
  const auto has = [&](const std::string& text) {
    EXPECT_NE(out.out.find(text), std::string::npos) << "missing \"" << text << "\" in\n"
                                                     << out.out;
  };
  has("log " + log.string() + ": 49 events");
  has("prefix COSIM_TEST_: 6 channels, 2 tokens");
  has("  COSIM_TEST_SOLID_STATE solid_state_t        22     0.010     0.420      51.2     210.0 at "
      "   0.320"
      "           1      2\n");
  has("COSIM_TEST_SOLID_STATE: 1 undecodable; the first: solid_state_t: num_cgps = 4 needs 192 "
      "bytes of arrays, but 182 are left");
  has("token " + kToken + ": 46 messages");
  has("welcome_t accepted: 20 steps, 5 rigid, A_T 150; stop_t at step 20, exit code 0 x3\n");
  has("    resend_t: solid_state x1\n");
  has("    SOLID_STATE  20 messages, 4 CGPs\n"
      "      steps 0..19 (19 distinct): missing 1 (7), duplicated 1 (12), extra copies 1 (not bit "
      "for bit: 0)\n"
      "      seq 0..20: missing 2 (7, 15), duplicated 1, out of order 1\n"
      "      other tokens on the channel: " +
      kForeign + " x1\n");
  has("    FLUID_STATE  19 messages, 4 CGPs\n"
      "      steps 1..19 (19 distinct): missing 0, duplicated 0, extra copies 0 (not bit for bit: "
      "0)\n"
      "      seq 0..18: missing 0, duplicated 0, out of order 0\n");
  has("SOMEONE_ELSE: types by fingerprint: unknown (3 bytes, no fingerprint) x1");
  fs::remove_all(dir);
}

TEST(LogInspector, LogInspectorShowsStep) {
  const fs::path dir = scratch("show");
  const fs::path log = write_log(dir);
  // Step 12: two copies of solid_state_t, the resend_t that asked for it, fluid_state_t(12).
  lt::ShowOptions opt;
  opt.step = 12;
  const std::string all = lt::show_step(log.string(), opt);
  std::size_t events = 0;
  std::istringstream in(all);
  for (std::string line; std::getline(in, line);) events += line.rfind("event ", 0) == 0 ? 1 : 0;
  EXPECT_EQ(events, 4u) << all;
  EXPECT_NE(all.find("COSIM_TEST_RESEND resend_t"), std::string::npos) << all;
  EXPECT_NE(all.find("  what              \"solid_state\"\n"), std::string::npos) << all;

  opt.channel = "SOLID_STATE";
  opt.max_cgps = 2;
  const std::string solid = lt::show_step(log.string(), opt);
  EXPECT_EQ(solid.find("fluid_state_t"), std::string::npos) << solid;
  EXPECT_NE(solid.find("  token             \"" + kToken +
                       "\"\n"
                       "  seq               12\n"
                       "  step              12\n"
                       "  substeps          150\n"
                       "  solid_time_s      4.0000000000000002e-09 s\n"
                       "  num_cgps          4\n"
                       "  cgp  position_lb [dx_LB] (x y z)  impulse_lb [rho_0 dx^3 c] (x y z)\n"
                       "    0  0.5 3 2  1.5 -0 0\n"
                       "    1  1.5 3 2  1.5 -0.0625 0\n"
                       "  ... 2 of 4 CGPs shown (--max-cgps)\n"),
            std::string::npos)
      << solid;

  opt.channel = "FLUID_STATE";
  opt.max_cgps = -1;
  const std::string fluid = lt::show_step(log.string(), opt);
  EXPECT_NE(fluid.find("  cgp  rho_lb [rho_0]  velocity_lb [c] (x y z)\n"
                       "    0  1  0.1875 0 0\n"
                       "    1  1.0078125  0.1875 0 1\n"
                       "    2  1.015625  0.1875 0 2\n"
                       "    3  1.0234375  0.1875 0 3\n"),
            std::string::npos)
      << fluid;

  // The command line: the same text; a step or a channel not in the log is one line, exit 2.
  Cmd r = cosim_log("show " + log.string() + " --step 12 --channel SOLID_STATE --max-cgps 2", dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, solid);
  r = cosim_log("show " + log.string() + " --step 7 --channel SOLID_STATE", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "cosim-log: step 7 is not in " + log.string() +
                       " on SOLID_STATE (its state messages cover steps 0..19)\n");
  r = cosim_log("show " + log.string() + " --step 7 --channel HELLO", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(
      r.err,
      "cosim-log: --channel HELLO: hello_t has no step; allowed: SOLID_STATE, FLUID_STATE, RESEND, "
      "STOP or a channel ending in one of them\n");
  r = cosim_log("show " + log.string() + " --step 3 --max-cgps -5", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("--max-cgps -5"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// Reads a whole dataset of doubles or int64 (by the memory type) and its dimensions.
template <class T>
std::vector<T> read_dataset(hid_t file, const char* name, hid_t mem_type,
                            std::vector<hsize_t>* dims = nullptr) {
  const hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  EXPECT_GE(d, 0) << name;
  if (d < 0) return {};
  const hid_t space = H5Dget_space(d);
  std::vector<hsize_t> dd(std::size_t(H5Sget_simple_extent_ndims(space)));
  H5Sget_simple_extent_dims(space, dd.data(), nullptr);
  hsize_t n = 1;
  for (const hsize_t x : dd) n *= x;
  std::vector<T> v(n);
  if (n > 0) {
    EXPECT_GE(H5Dread(d, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0) << name;
  }
  H5Sclose(space);
  H5Dclose(d);
  if (dims != nullptr) *dims = dd;
  return v;
}

std::string read_string_attribute(hid_t obj, const char* path, const char* name) {
  const hid_t a = H5Aopen_by_name(obj, path, name, H5P_DEFAULT, H5P_DEFAULT);
  EXPECT_GE(a, 0) << path << " " << name;
  if (a < 0) return "";
  const hid_t t = H5Aget_type(a);
  std::string s(H5Tget_size(t), '\0');
  H5Aread(a, t, s.data());
  H5Tclose(t);
  H5Aclose(a);
  return s.substr(0, s.find('\0'));
}

TEST(LogInspector, LogInspectorExportsHdf5) {
  const fs::path dir = scratch("export");
  const fs::path log = write_log(dir);
  const fs::path h5 = dir / "series.h5";
  const Cmd r = cosim_log("export " + log.string() + " " + h5.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(
      r.out,
      "cosim-log: wrote " + h5.string() + ": prefix COSIM_TEST_ token " + kToken +
          ", solid_state 19 steps (1 later copies left out), fluid_state 19 steps (0 left out)\n");

  const hid_t f = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  EXPECT_EQ(read_string_attribute(f, ".", "token"), kToken);
  EXPECT_EQ(read_string_attribute(f, ".", "channel_prefix"), kPrefix);

  // solid_state: steps 0..19 without 7, in step order (3 before 4), the first copy of 12.
  std::vector<hsize_t> dims;
  const auto step = read_dataset<std::int64_t>(f, "solid_state/step", H5T_NATIVE_INT64, &dims);
  std::vector<std::int64_t> want_steps;
  for (std::int64_t n = 0; n < 20; ++n)
    if (n != 7) want_steps.push_back(n);
  EXPECT_EQ(step, want_steps);
  const auto seq = read_dataset<std::int64_t>(f, "solid_state/seq", H5T_NATIVE_INT64);
  EXPECT_EQ(seq, (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 8, 9, 10, 11, 12, 13, 14, 16, 17,
                                            18, 19, 20}));
  const auto utime = read_dataset<std::int64_t>(f, "solid_state/log_utime", H5T_NATIVE_INT64);
  ASSERT_EQ(utime.size(), 19u);
  EXPECT_EQ(utime[3], solid_time(4));    // step 3 was the 5th message on the channel
  EXPECT_EQ(utime[11], solid_time(13));  // step 12's first copy, not the resend
  const auto substeps = read_dataset<std::int32_t>(f, "solid_state/substeps", H5T_NATIVE_INT32);
  ASSERT_EQ(substeps.size(), 19u);
  EXPECT_EQ(substeps[4], 0);
  EXPECT_EQ(substeps[5], 150);
  const auto pos = read_dataset<double>(f, "solid_state/position_lb", H5T_NATIVE_DOUBLE, &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{19, kCgps, 3}));
  const auto imp = read_dataset<double>(f, "solid_state/impulse_lb", H5T_NATIVE_DOUBLE, &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{19, kCgps, 3}));
  for (std::size_t row = 0; row < step.size(); ++row) {
    const cosimlcm::solid_state_t m = solid_state(step[row], 0, kToken);
    for (int l = 0; l < kCgps; ++l)
      for (int k = 0; k < 3; ++k) {
        const std::size_t i = (row * kCgps + std::size_t(l)) * 3 + std::size_t(k);
        ASSERT_EQ(pos[i], m.position_lb[std::size_t(l)][std::size_t(k)]) << "row " << row;
        ASSERT_EQ(imp[i], m.impulse_lb[std::size_t(l)][std::size_t(k)]) << "row " << row;
      }
  }
  EXPECT_EQ(read_string_attribute(f, "solid_state/position_lb", "units").rfind("dx_LB", 0), 0u);
  EXPECT_EQ(read_string_attribute(f, "solid_state/solid_time_s", "units"), "s");

  // fluid_state: steps 1..19, seq step - 1.
  const auto fstep = read_dataset<std::int64_t>(f, "fluid_state/step", H5T_NATIVE_INT64);
  ASSERT_EQ(fstep.size(), 19u);
  EXPECT_EQ(fstep.front(), 1);
  EXPECT_EQ(fstep.back(), 19);
  const auto rho = read_dataset<double>(f, "fluid_state/rho_lb", H5T_NATIVE_DOUBLE, &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{19, kCgps}));
  EXPECT_EQ(rho[std::size_t(5 * kCgps + 3)], 1.0234375);
  const auto vel = read_dataset<double>(f, "fluid_state/velocity_lb", H5T_NATIVE_DOUBLE, &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{19, kCgps, 3}));
  EXPECT_EQ(vel[std::size_t((5 * kCgps + 2) * 3 + 0)], 0.015625 * 6);  // row 5 = step 6
  EXPECT_EQ(vel[std::size_t((5 * kCgps + 2) * 3 + 2)], 2.0);
  EXPECT_EQ(read_string_attribute(f, "fluid_state/velocity_lb", "units"), "c = dx/dt_LB");
  EXPECT_EQ(read_string_attribute(f, "fluid_state/rho_lb", "units"), "rho_0");
  H5Fclose(f);

  // --run: the foreign token exports its one message; an unknown run is one line, exit 2.
  EXPECT_EQ(lt::export_log(log.string(), h5.string(), kForeign).solid_rows, 1);
  const Cmd bad = cosim_log("export " + log.string() + " " + h5.string() + " --run nosuchrun", dir);
  EXPECT_EQ(bad.status, 2);
  EXPECT_EQ(lines(bad.err), 1u) << bad.err;
  EXPECT_NE(bad.err.find("--run nosuchrun: no run with that token"), std::string::npos) << bad.err;
  fs::remove_all(dir);
}

TEST(LogInspector, LogInspectorRefusesBadInput) {
  const fs::path dir = scratch("bad");
  const fs::path log = write_log(dir);
  const auto refused = [&](const std::string& args, const std::string& text) {
    const Cmd r = cosim_log(args, dir);
    EXPECT_EQ(r.status, 2) << args;
    EXPECT_EQ(r.out, "") << args;
    EXPECT_EQ(lines(r.err), 1u) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("cosim-log: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(text), std::string::npos) << args << ": " << r.err;
  };
  refused("summary " + (dir / "nope.lcmlog").string(),
          (dir / "nope.lcmlog").string() + ": no such file");
  std::ofstream(dir / "text.lcmlog") << "this is not a log, just some text that is long enough\n";
  refused("summary " + (dir / "text.lcmlog").string(), "text.lcmlog: not an LCM log");
  std::ofstream(dir / "empty.lcmlog");
  refused("summary " + (dir / "empty.lcmlog").string(), "empty.lcmlog: empty file, not an LCM log");
  refused("summary " + dir.string(), "not a regular file");
  refused("frobnicate " + log.string(),
          "unknown subcommand \"frobnicate\"; allowed: summary, show, export");
  refused("summary " + log.string() + " --bogus", "--bogus");
  refused("", "");
  refused("show " + log.string(), "--step");
  refused("show " + log.string() + " --step twelve", "twelve");
  refused("show " + log.string() + " --step 999", "step 999 is not in");
  refused("show " + log.string() + " --step 3 --channel NOPE",
          "--channel NOPE: not a protocol channel");
  refused("export " + log.string(), "out");
  refused("export " + log.string() + " " + log.string(), "is the log itself");

  // A log cut inside its last event (a logger killed mid-write) is read up to there, with a
  // warning; garbage between events is skipped and counted.
  std::string bytes = slurp(log);
  std::ofstream(dir / "cut.lcmlog", std::ios::binary) << bytes.substr(0, bytes.size() - 2);
  Cmd r = cosim_log("summary " + (dir / "cut.lcmlog").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find(": 48 events"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("warning: the log ends inside event 48 at byte"), std::string::npos)
      << r.out;
  std::ofstream(dir / "junk.lcmlog", std::ios::binary)
      << bytes.substr(0, 211) << "JUNKJUNK" << bytes.substr(211);  // inside the 2nd event's header (the 1st ends at byte 207)
  const lt::LogSummary junk = lt::summarize_log((dir / "junk.lcmlog").string());
  EXPECT_EQ(junk.events, 48);  // the event the junk landed in is lost, the rest is found again
  EXPECT_GT(junk.skipped_bytes, 8u);
  // An unwritable export target is an output error: exit 1, one line, no file left.
  r = cosim_log("export " + log.string() + " " + (dir / "no" / "such" / "dir.h5").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("cannot create"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// LCM's own tools on the project's channels: lcm-logplayer replays the synthetic log onto a
// bus in a private network namespace (lo only, ttl=0) and lcm-logger records it again; the
// recording holds the same messages (the inspector's counts agree). Needs root for unshare.
TEST(LogInspector, LcmLoggerRecordsLogplayerReplay) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root for a private network namespace (unshare -n)";
  if (std::system("command -v unshare >/dev/null && command -v ip >/dev/null && "
                  "command -v lcm-logger >/dev/null && command -v lcm-logplayer >/dev/null") != 0)
    GTEST_SKIP() << "needs unshare, ip, lcm-logger and lcm-logplayer";
  if (std::system("unshare -n true 2>/dev/null") != 0)
    GTEST_SKIP() << "unshare -n is not permitted here (no CAP_SYS_ADMIN)";
  const fs::path dir = scratch("replay");
  const fs::path log = write_log(dir);
  const fs::path again = dir / "again.lcmlog";
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  const fs::path script = dir / "replay.sh";
  std::ofstream(script)
      << "set -e\n"
         "ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo\n"
         "lcm-logger -q -f -c 'COSIM_TEST_.*' --lcm-url='"
      << url << "' " << again.string()
      << " & logger=$!\n"
         // The logger stops however the script ends (it would keep the namespace alive).
         "trap 'kill -INT $logger 2>/dev/null; wait $logger 2>/dev/null' EXIT\n"
         "sleep 1\n"
         "timeout 60 lcm-logplayer --lcm-url='"
      << url << "' " << log.string()
      << "\n"
         "sleep 0.5\n";
  const Cmd r = run_cmd("unshare -n sh " + script.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const lt::LogSummary a = lt::summarize_log(log.string());
  const lt::LogSummary b = lt::summarize_log(again.string());
  EXPECT_EQ(b.events, a.events - 1);  // SOMEONE_ELSE is not on the recorded channels
  EXPECT_TRUE(b.other_channels.empty());
  ASSERT_NE(b.run(kToken), nullptr);
  const lt::StateStats& so = b.run(kToken)->solid;
  EXPECT_EQ(so.steps_missing_ranges, (lt::Ranges{{7, 7}}));
  EXPECT_EQ(so.seq_missing_ranges, (lt::Ranges{{7, 7}, {15, 15}}));
  EXPECT_EQ(so.steps_duplicated, 1);
  EXPECT_EQ(so.seq_out_of_order, 1);
  EXPECT_EQ(channel(b, lt::MsgType::solid_state).undecodable, 1);
  EXPECT_EQ(channel(b, lt::MsgType::solid_state).count, 22);
  // The replay keeps the log's pace: the 210 ms pause is there again (a few ms off on an idle
  // machine; the bounds leave room for a loaded one).
  const std::int64_t gap = channel(b, lt::MsgType::solid_state).largest_gap_us;
  EXPECT_GT(gap, 150'000);
  EXPECT_LT(gap, 1'000'000);
  fs::remove_all(dir);
}

}  // namespace

// launch/lcm-spy.sh --check: the project's types built for Java from Debian's liblcm-java,
// found by fingerprint in lcm-spy's own type database and decoded as lcm-spy decodes them
// (headless). Without Java the script says so in one line and exits 1.
TEST(LogInspector, LcmSpyTypesDecodeLog) {
  const fs::path dir = scratch("spy");
  const fs::path log = write_log(dir);
  const std::string script = std::string(COSIM_SOURCE_DIR) + "/launch/lcm-spy.sh";
  const Cmd r = run_cmd(
      "bash " + script + " --check " + log.string() + " --java-dir " + (dir / "java").string(),
      dir);
  const bool java = std::system("command -v javac >/dev/null && command -v java >/dev/null") == 0 &&
                    fs::exists("/usr/share/java/lcm.jar");
  if (!java) {
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_EQ(lines(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find("lcm-spy.sh: "), std::string::npos) << r.err;
    GTEST_SKIP() << "no Java (javac, /usr/share/java/lcm.jar): " << r.err;
  }
  // Every type found by its fingerprint; the message cut short fails as in lcm-spy
  // (EOFException), so the check exits 1; the foreign token decodes (Java does not look at it).
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  const auto has = [&](const std::string& text) {
    EXPECT_NE(r.out.find(text), std::string::npos) << "missing \"" << text << "\" in\n" << r.out;
  };
  has(log.string() + ": 49 events");
  has("COSIM_TEST_FLUID_STATE                 19       19  {fluid_state_t=19}\n");
  has("COSIM_TEST_HELLO                        2        2  {hello_t=2}\n");
  has("COSIM_TEST_RESEND                       1        1  {resend_t=1}\n");
  has("COSIM_TEST_SOLID_STATE                 22       21  {solid_state_t=22}\n"
      "  first failure: java.io.EOFException: LCMDataInputStream needed 8 bytes, only 6 "
      "available.\n");
  has("COSIM_TEST_STOP                         3        3  {stop_t=3}\n");
  has("COSIM_TEST_WELCOME                      1        1  {welcome_t=1}\n");
  has("SOMEONE_ELSE                            1        0  {unknown 0x0000000000010203=1}\n");
  fs::remove_all(dir);
}
