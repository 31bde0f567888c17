// cosim-replay (tools/replay, docs/replay.md) against a short coupled run recorded with
// launch/run-coupled.sh --log (two processes; a private network namespace as root): each side
// replays bit for bit, a log perturbed at one step is caught at that step, CGP and field,
// and bad input ends with one line and exit code 2.
//
// The recorded run is made once per test process (gtest_discover_tests runs each case in a
// process of its own) and removed at the end: the small coupled scene cut to 60 LB steps
// (serial scheme), or to 30 LB steps in the implicit or the parallel scheme.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "tests/support/run_command.hpp"
#include "tools/log/lcm_log.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;
using cosim::test::quoted;
using cosim::test::launcher_build_problem;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kReplay = REPLAY_EXE;
const fs::path kFluid = FLUID_EXE;
const fs::path kSolid = SOLID_EXE;

constexpr int kSteps = 60;
constexpr std::int64_t kPerturbedStep = 37;  // in the free phase (rigid_steps = 20)
constexpr std::size_t kPerturbedCgp = 17;
constexpr std::size_t kPerturbedComponent = 0;

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

/// An event read by the project's reader, as lcm::LogFile writes it (its bytes stay `e`'s).
lcm::LogEvent as_written(const cosim::logtool::LogEvent& e) {
  lcm::LogEvent w{};
  w.eventnum = e.number;
  w.timestamp = e.utime;
  w.channel = e.channel;
  w.datalen = static_cast<std::int32_t>(e.data.size());
  w.data = const_cast<std::uint8_t*>(e.data.data());
  return w;
}

fs::path work_dir() {
  return fs::path(::testing::TempDir()) / ("cosim_replay_" + std::to_string(getpid()));
}

/// The small coupled scene with some keys replaced (a line "key = ..." per entry).
fs::path scene_with(const fs::path& p, const std::vector<std::pair<std::string, std::string>>& edits) {
  std::istringstream in(slurp(kSource / "scenes" / "coupled_small.toml"));
  std::ostringstream out;
  for (std::string line; std::getline(in, line);) {
    for (const auto& [key, value] : edits)
      if (line.rfind(key + " ", 0) == 0 || line.rfind(key + "=", 0) == 0) line = key + " = " + value;
    out << line << "\n";
  }
  std::ofstream(p) << out.str();
  return p;
}

struct Recorded {
  fs::path scene, output, log;
  std::string problem;  ///< empty when the run and its log are there
};

/// The launcher's executables must be this build's (the replay links its libraries); empty
/// when they are.
std::string build_problem() { return launcher_build_problem(kSource, kFluid, kSolid); }

/// Runs `rec.scene` through the launcher with --log into `rec.output`.
void record(Recorded& rec) {
  fs::create_directories(rec.output);
  const std::string cmd = "bash " + quoted((kSource / "launch" / "run-coupled.sh").string()) + " " +
                          quoted(rec.scene.string()) + " --output " + quoted(rec.output.string()) +
                          " --log --no-build --quiet >" + quoted((rec.output / "launcher.log").string()) +
                          " 2>&1";
  const int s = std::system(cmd.c_str());
  const int status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  rec.log = rec.output / "traffic.lcmlog";
  if (status != 0 || !fs::exists(rec.log))
    rec.problem = "the recorded run failed (status " + std::to_string(status) + "):\n" +
                  slurp(rec.output / "launcher.log") + slurp(rec.output / "fluid.log") +
                  slurp(rec.output / "solid.log");
}

/// The coupled run with its log, once per test process.
const Recorded& recorded() {
  static const Recorded r = [] {
    Recorded rec;
    const fs::path dir = work_dir();
    fs::remove_all(dir);
    fs::create_directories(dir);
    // The launcher runs the launch scripts' build (COSIM_BUILD_DIR); the replay links this build's libraries:
    // they must be the same build, or a difference would be the two builds'.
    rec.problem = build_problem();
    if (!rec.problem.empty()) return rec;
    rec.scene = scene_with(dir / "scene.toml", {{"steps", std::to_string(kSteps)},
                                                {"rigid_steps", "20"},
                                                {"monitor_every", "20"},
                                                {"fields_every", "0"}});
    rec.output = dir / "run";
    record(rec);
    return rec;
  }();
  return r;
}

/// Removes the recorded run when the test process ends.
class RemoveRecordedRun : public ::testing::Environment {
 public:
  void TearDown() override { fs::remove_all(work_dir()); }
};
[[maybe_unused]] ::testing::Environment* const kCleanup =
    ::testing::AddGlobalTestEnvironment(new RemoveRecordedRun);

struct Result {
  int code = -1;
  std::string out;  ///< stdout and stderr
};

Result replay(const std::vector<std::string>& args) {
  fs::create_directories(work_dir());
  const fs::path text = work_dir() / "replay.txt";
  std::string cmd = quoted(kReplay.string());
  for (const std::string& a : args) cmd += " " + quoted(a);
  cmd += " >" + quoted(text.string()) + " 2>&1";
  const int s = std::system(cmd.c_str());
  Result r;
  r.code = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  r.out = slurp(text);
  return r;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(Replay, ReplayReproducesFluidSide) {
  const Recorded& rec = recorded();
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  const Result r = replay({rec.log.string(), "--side", "fluid", "--scene", rec.scene.string(), "--quiet"});
  EXPECT_EQ(r.code, 0) << r.out;
  // fluid_state_t(n) for n = 1 .. N-1 (the last step ends with stop_t, protocol/README.md 5).
  EXPECT_TRUE(contains(r.out, "identical: " + std::to_string(kSteps - 1) +
                                  " steps compared (fluid_state_t 1.." + std::to_string(kSteps - 1)))
      << r.out;
}

TEST(Replay, ReplayReproducesSolidSide) {
  const Recorded& rec = recorded();
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  const fs::path out = work_dir() / "replay_solid";
  const Result r = replay({rec.log.string(), "--side", "solid", "--scene", rec.scene.string(),
                           "--output", out.string(), "--quiet"});
  EXPECT_EQ(r.code, 0) << r.out;
  // solid_state_t(n) for n = 0 .. N-1.
  EXPECT_TRUE(contains(r.out, "identical: " + std::to_string(kSteps) + " steps compared (solid_state_t 0.." +
                                  std::to_string(kSteps - 1)))
      << r.out;
  // The replayed server wrote into --output, not into the logged run's folder.
  EXPECT_TRUE(fs::exists(out / "solid.h5"));
  EXPECT_TRUE(fs::exists(out / "solid.log"));
}

TEST(Replay, ReplayFindsFirstDivergence) {
  const Recorded& rec = recorded();
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  // A copy of the log in which every copy of fluid_state_t(k) has one velocity component
  // changed by 1e-9 relative: the fluid's replay must differ there first, and only there.
  const fs::path perturbed = work_dir() / "perturbed.lcmlog";
  double original = 0.0, changed = 0.0;
  int touched = 0;
  {
    cosim::logtool::LogReader in(rec.log.string(), cosim::logtool::MacTrailers::keep);
    lcm::LogFile out(perturbed.string(), "w");
    ASSERT_TRUE(out.good());
    for (cosim::logtool::LogEvent e; in.next(e);) {
      lcm::LogEvent copy = as_written(e);
      std::vector<char> bytes;
      cosimlcm::fluid_state_t m{};
      if (e.channel.ends_with("FLUID_STATE") && m.decode(e.data.data(), 0, int(e.data.size())) >= 0 &&
          m.step == kPerturbedStep) {
        double& v = m.velocity_lb.at(kPerturbedCgp).at(kPerturbedComponent);
        original = v;
        v *= 1.0 + 1e-9;
        changed = v;
        bytes.resize(static_cast<std::size_t>(m.getEncodedSize()));
        ASSERT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
        copy.data = bytes.data();
        copy.datalen = static_cast<int32_t>(bytes.size());
        ++touched;
      }
      ASSERT_EQ(out.writeEvent(&copy), 0);
    }
  }
  ASSERT_GE(touched, 1) << "no fluid_state_t of step " << kPerturbedStep << " in " << rec.log;
  ASSERT_NE(original, changed);

  // A replay that differs keeps the server's output: under the test's folder, not a temporary one.
  const Result r = replay({perturbed.string(), "--side", "fluid", "--scene", rec.scene.string(), "--quiet",
                           "--output", (work_dir() / "replay_fluid").string()});
  EXPECT_EQ(r.code, 10) << r.out;
  const std::string field = "velocity_lb[" + std::to_string(kPerturbedCgp) + "][" +
                            std::to_string(kPerturbedComponent) + "]";
  const double abs = std::abs(changed - original);
  const double rel = abs / std::max(std::abs(changed), std::abs(original));
  EXPECT_NEAR(rel, 1e-9, 1e-12);
  const std::string diff = field + ": replay " + fmt("%.17g", original) + ", log " + fmt("%.17g", changed) +
                           " (abs " + fmt("%.3g", abs) + ", rel " + fmt("%.3g", rel) + ")";
  EXPECT_TRUE(contains(r.out, "different: first at step " + std::to_string(kPerturbedStep) +
                                  " (fluid_state_t), CGP " + std::to_string(kPerturbedCgp) + ", " + diff))
      << r.out << "\nexpected: " << diff;
  // Only that value differs, so it is also the largest difference at that step and overall.
  EXPECT_TRUE(contains(r.out, "at step " + std::to_string(kPerturbedStep) + ": 1 of "))
      << r.out;
  EXPECT_TRUE(contains(r.out, "largest abs " + fmt("%.3g", abs) + " (" + field + "), largest rel " +
                                  fmt("%.3g", rel) + " (" + field + ")"))
      << r.out;
  EXPECT_TRUE(contains(r.out, "over the replay: 1 of " + std::to_string(kSteps - 1) +
                                  " steps differ; largest abs " + fmt("%.3g", abs) + " (step " +
                                  std::to_string(kPerturbedStep) + ", " + field + ")"))
      << r.out;
  // Replaying the solid, that message is an input: the solid's answer to it, solid_state_t(k),
  // is the first to differ.
  const Result s = replay({perturbed.string(), "--side", "solid", "--scene", rec.scene.string(), "--quiet",
                           "--output", (work_dir() / "replay_solid").string()});
  EXPECT_EQ(s.code, 10) << s.out;
  EXPECT_TRUE(contains(s.out, "different: first at step " + std::to_string(kPerturbedStep) + " (solid_state_t)"))
      << s.out;
}

TEST(Replay, ReplayRejectsBadInput) {
  const auto one_line_exit_2 = [](const Result& r, const std::string& part) {
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(contains(r.out, part)) << r.out;
  };
  one_line_exit_2(replay({"/nonexistent/traffic.lcmlog", "--side", "fluid", "--scene", "x.toml"}),
                  "/nonexistent/traffic.lcmlog: no such log file");
  one_line_exit_2(replay({"log", "--side", "fluid", "--scene", "x.toml", "--bogus"}), "--bogus");
  one_line_exit_2(replay({"log", "--side", "air", "--scene", "x.toml"}), "--side = \"air\": allowed: fluid, solid");

  const Recorded& rec = recorded();
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  // Another scene (one more step): each side's handshake refuses it, naming the hash.
  const fs::path other = scene_with(work_dir() / "other.toml", {{"steps", std::to_string(kSteps + 1)},
                                                                {"rigid_steps", "20"},
                                                                {"monitor_every", "20"},
                                                                {"fields_every", "0"}});
  for (const char* side : {"fluid", "solid"}) {
    const Result r = replay({rec.log.string(), "--side", side, "--scene", other.string(), "--quiet"});
    one_line_exit_2(r, "does not match the logged run");
    EXPECT_TRUE(contains(r.out, "scene_hash mismatch")) << r.out;
  }
  // The logged run's own folder is never the replay's output.
  one_line_exit_2(replay({rec.log.string(), "--side", "solid", "--scene", rec.scene.string(), "--output",
                          rec.output.string()}),
                  "is the logged run's folder");
}

// ---- the implicit and the parallel scheme (protocol/README.md 13, 14) ----

constexpr int kSchemeSteps = 30;
constexpr int kSchemeRigidSteps = 10;

/// The small scene cut to kSchemeSteps LB steps in `scheme`, recorded once per test process.
const Recorded& recorded_scheme(const std::string& scheme) {
  static std::map<std::string, Recorded> runs;
  if (const auto it = runs.find(scheme); it != runs.end()) return it->second;
  Recorded& rec = runs[scheme];
  const fs::path dir = work_dir() / scheme;
  fs::remove_all(dir);
  fs::create_directories(dir);
  rec.problem = build_problem();
  if (!rec.problem.empty()) return rec;
  rec.scene = scene_with(dir / "scene.toml", {{"steps", std::to_string(kSchemeSteps)},
                                              {"rigid_steps", std::to_string(kSchemeRigidSteps)},
                                              {"monitor_every", "10"},
                                              {"fields_every", "0"},
                                              {"sheets_every", "0"}});
  // [coupling] scheme = "..." (the small scene has no scheme key: serial by default).
  std::istringstream in(slurp(rec.scene));
  std::ostringstream out;
  for (std::string line; std::getline(in, line);) {
    out << line << "\n";
    if (line == "[coupling]") out << "scheme = \"" << scheme << "\"\n";
  }
  std::ofstream(rec.scene) << out.str();
  rec.output = dir / "run";
  record(rec);
  return rec;
}

/// What the log holds of each state channel, counted here, independently of cosim-replay:
/// distinct seqs (first copies), their steps, the largest sub-iteration.
struct LoggedStates {
  std::set<std::int64_t> seqs, steps;
  std::int32_t max_iteration = 0;
  std::string range() const { return std::to_string(*steps.begin()) + ".." + std::to_string(*steps.rbegin()); }
};

std::map<std::string, LoggedStates> logged_states(const fs::path& log) {
  std::map<std::string, LoggedStates> states;
  cosim::logtool::LogReader in(log.string(), cosim::logtool::MacTrailers::keep);
  for (cosim::logtool::LogEvent e; in.next(e);) {
    if (e.channel.ends_with("FLUID_STATE")) {
      cosimlcm::fluid_state_t m{};
      if (m.decode(e.data.data(), 0, int(e.data.size())) < 0) continue;
      LoggedStates& s = states["fluid"];
      s.seqs.insert(m.seq);
      s.steps.insert(m.step);
      s.max_iteration = std::max(s.max_iteration, m.iteration);
    } else if (e.channel.ends_with("SOLID_STATE")) {
      cosimlcm::solid_state_t m{};
      if (m.decode(e.data.data(), 0, int(e.data.size())) < 0) continue;
      LoggedStates& s = states["solid"];
      s.seqs.insert(m.seq);
      s.steps.insert(m.step);
      s.max_iteration = std::max(s.max_iteration, m.iteration);
    }
  }
  return states;
}

TEST(Replay, ReplayReproducesImplicitScheme) {
  const Recorded& rec = recorded_scheme("implicit");
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  auto states = logged_states(rec.log);
  ASSERT_FALSE(states["fluid"].seqs.empty());
  ASSERT_FALSE(states["solid"].seqs.empty());
  // The run iterated: several messages a step, so the replay is keyed by seq, not by step.
  ASSERT_GT(states["solid"].max_iteration, 0) << "no sub-iteration in " << rec.log;
  ASSERT_GT(states["fluid"].seqs.size(), states["fluid"].steps.size());
  // The last step is accepted by solid_state_t(N, 0) (protocol/README.md 13).
  EXPECT_EQ(*states["solid"].steps.rbegin(), kSchemeSteps);
  for (const char* side : {"fluid", "solid"}) {
    const LoggedStates& s = states[side];
    const Result r = replay({rec.log.string(), "--side", side, "--scene", rec.scene.string(), "--quiet"});
    EXPECT_EQ(r.code, 0) << side << ":\n" << r.out;
    // Every logged message of the side, compared.
    EXPECT_TRUE(contains(r.out, "identical: " + std::to_string(s.seqs.size()) + " messages compared (" + side +
                                    "_state_t " + s.range() + ", iterations 0.." +
                                    std::to_string(s.max_iteration) + ", by seq"))
        << side << ":\n" << r.out;
  }
}

TEST(Replay, ReplayReproducesParallelScheme) {
  const Recorded& rec = recorded_scheme("parallel");
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  auto states = logged_states(rec.log);
  ASSERT_FALSE(states["fluid"].seqs.empty());
  ASSERT_FALSE(states["solid"].seqs.empty());
  // The parallel order (protocol/README.md 14): no fluid_state_t(N - 1), the last dynamic
  // step's interval being driven by fluid_state_t(N - 2); one message a step.
  EXPECT_EQ(*states["fluid"].steps.rbegin(), kSchemeSteps - 2);
  EXPECT_EQ(*states["solid"].steps.rbegin(), kSchemeSteps - 1);
  for (const char* side : {"fluid", "solid"}) {
    const LoggedStates& s = states[side];
    EXPECT_EQ(s.max_iteration, 0);
    EXPECT_EQ(s.seqs.size(), s.steps.size());
    const Result r = replay({rec.log.string(), "--side", side, "--scene", rec.scene.string(), "--quiet"});
    EXPECT_EQ(r.code, 0) << side << ":\n" << r.out;
    EXPECT_TRUE(contains(r.out, "identical: " + std::to_string(s.seqs.size()) + " steps compared (" + side +
                                    "_state_t " + s.range() + ", by seq"))
        << side << ":\n" << r.out;
  }
}

/// A copy of `log` with velocity_lb[kPerturbedCgp][kPerturbedComponent] (and its
/// velocity_start_lb) of every copy of fluid_state_t seq `seq` multiplied by `factor`;
/// returns that message's step and iteration.
std::pair<std::int64_t, std::int32_t> perturb_fluid_seq(const fs::path& log, const fs::path& out_path,
                                                         std::int64_t seq, double factor) {
  std::pair<std::int64_t, std::int32_t> where{-1, -1};
  cosim::logtool::LogReader in(log.string(), cosim::logtool::MacTrailers::keep);
  lcm::LogFile out(out_path.string(), "w");
  EXPECT_TRUE(out.good());
  for (cosim::logtool::LogEvent e; in.next(e);) {
    lcm::LogEvent copy = as_written(e);
    std::vector<char> bytes;
    cosimlcm::fluid_state_t m{};
    if (e.channel.ends_with("FLUID_STATE") && m.decode(e.data.data(), 0, int(e.data.size())) >= 0 && m.seq == seq) {
      m.velocity_lb.at(kPerturbedCgp).at(kPerturbedComponent) *= factor;
      m.velocity_start_lb.at(kPerturbedCgp).at(kPerturbedComponent) *= factor;
      bytes.resize(static_cast<std::size_t>(m.getEncodedSize()));
      EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
      copy.data = bytes.data();
      copy.datalen = static_cast<int32_t>(bytes.size());
      where = {m.step, m.iteration};
    }
    EXPECT_EQ(out.writeEvent(&copy), 0);
  }
  return where;
}

/// The first fluid_state_t seq of a sub-iteration (iteration > 0).
std::int64_t first_iterated_fluid_seq(const fs::path& log) {
  cosim::logtool::LogReader in(log.string(), cosim::logtool::MacTrailers::keep);
  for (cosim::logtool::LogEvent e; in.next(e);) {
    cosimlcm::fluid_state_t m{};
    if (e.channel.ends_with("FLUID_STATE") && m.decode(e.data.data(), 0, int(e.data.size())) >= 0 && m.iteration > 0)
      return m.seq;
  }
  return -1;
}

TEST(Replay, ReplayFindsFirstDivergenceInImplicitScheme) {
  const Recorded& rec = recorded_scheme("implicit");
  ASSERT_TRUE(rec.problem.empty()) << rec.problem;
  const std::int64_t seq = first_iterated_fluid_seq(rec.log);
  ASSERT_GE(seq, 0) << "no sub-iteration in " << rec.log;
  // A 1e-9 change in one sub-iteration's sample: the fluid's replay names that message by
  // step and iteration, CGP and field.
  const fs::path small = work_dir() / "implicit_small.lcmlog";
  const auto [step, iteration] = perturb_fluid_seq(rec.log, small, seq, 1.0 + 1e-9);
  ASSERT_GE(step, 0);
  const Result f = replay({small.string(), "--side", "fluid", "--scene", rec.scene.string(), "--quiet",
                           "--output", (work_dir() / "implicit_fluid").string()});
  EXPECT_EQ(f.code, 10) << f.out;
  EXPECT_TRUE(contains(f.out, "different: first at step " + std::to_string(step) + ", iteration " +
                                  std::to_string(iteration) + " (fluid_state_t), CGP " +
                                  std::to_string(kPerturbedCgp) + ", velocity_lb[" + std::to_string(kPerturbedCgp) +
                                  "][" + std::to_string(kPerturbedComponent) + "]: "))
      << f.out;
  EXPECT_TRUE(contains(f.out, "over the replay: 1 of ")) << f.out;
  // For the solid it is an input, and a large change may change the number of
  // sub-iterations: the replay then takes another path than the log's, and must still end
  // (exit 10, the first difference reported), not wait for a message the log cannot give.
  const fs::path large = work_dir() / "implicit_large.lcmlog";
  perturb_fluid_seq(rec.log, large, seq, 3.0);
  const Result s = replay({large.string(), "--side", "solid", "--scene", rec.scene.string(), "--quiet",
                           "--output", (work_dir() / "implicit_solid").string()});
  EXPECT_EQ(s.code, 10) << s.out;
  EXPECT_TRUE(contains(s.out, "different: first at step ")) << s.out;
}

}  // namespace
