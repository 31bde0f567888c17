// Runs that keep their data when things go wrong (launch/run-coupled.sh; the scene and the
// launcher of run_data_helpers.hpp): an interrupt and killed peers that leave checkpoints and
// rows, a full disk (full_disk_shim.c, an LD_PRELOAD library), a dead recorder, and the
// limits of a run: a scene over 64 KiB, a write that outlasts the peer timeout.

#include <gtest/gtest.h>

#include "tests/integration/run_data_helpers.hpp"

namespace {

using namespace cosim::test::run_data;

TEST(RunData, InterruptStopsBothWithCheckpoint) {
  const fs::path dir = scratch("interrupt");
  const fs::path scene = small_scene(dir, 400);
  const fs::path clean = dir / "clean", out = dir / "interrupted";
  expect_done(clean, run_launcher(kSource, scene, clean));
  bool reached = false;  // Ctrl-C to the launcher once the run is under way
  const int status = run_and_signal(scene, out, fs::path("checkpoints") / "solid_00000100.h5", "launcher.pid", SIGINT,
                                    reached);
  ASSERT_TRUE(reached) << logs(out);
  EXPECT_EQ(status, 1) << logs(out);
  EXPECT_EQ(slurp(out / "fluid.exit"), "1\n") << logs(out);
  EXPECT_EQ(slurp(out / "solid.exit"), "4\n") << logs(out);
  const std::string fluid = line_with(slurp(out / "fluid.log"), "interrupted by SIGINT at step ");
  const std::string solid = line_with(slurp(out / "solid.log"), "; checkpoint ");
  ASSERT_FALSE(fluid.empty()) << logs(out);
  ASSERT_FALSE(solid.empty()) << logs(out);
  std::printf("fluid: %s\nsolid: %s\n", fluid.c_str(), solid.c_str());
  const std::string at = "at step ";
  const long step = std::stol(fluid.substr(fluid.find(at) + at.size()));
  char name[32];
  std::snprintf(name, sizeof name, "_%08ld.h5", step);
  for (const char* side : {"fluid", "solid"})
    EXPECT_TRUE(fs::exists(out / "checkpoints" / (std::string(side) + name))) << side << name << "\n" << logs(out);
  EXPECT_NE(solid.find(std::string("solid") + name), std::string::npos) << solid;
  for (const char* side : {"fluid", "solid"})  // no server left running
    EXPECT_NE(kill(std::stoi(slurp(out / (std::string(side) + ".pid"))), 0), 0) << side;
  // The pair of the interrupted step continues the run as if nothing happened.
  expect_done(out, run_launcher(kSource, scene, out, "--restart " + quoted(out.string())));
  for (const char* f : {"monitor.h5", "solid.h5"}) EXPECT_EQ(compare_h5(clean, out, f), "") << f;
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, SurvivorGraceFollowsTimeouts) {
  // A peer timeout above the launcher's old fixed grace (45 s): the fluid must be left to
  // notice the lost solid by itself, write its checkpoint and say why.
  const fs::path dir = scratch("grace");
  const fs::path scene = small_scene(dir, 400, {{"peer_timeout_s = 3", "peer_timeout_s = 47"}});
  const fs::path out = dir / "out";
  bool reached = false;
  std::chrono::steady_clock::time_point killed;
  const int status = run_and_signal(scene, out, fs::path("checkpoints") / "solid_00000060.h5", "solid.pid", SIGKILL,
                                    reached, &killed);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  ASSERT_TRUE(reached) << logs(out);
  EXPECT_EQ(status, 1) << logs(out);  // the killed solid's 137 counts as 1
  EXPECT_EQ(slurp(out / "fluid.exit"), "4\n") << logs(out);
  const std::string reason = line_with(slurp(out / "fluid.log"), "the solid was silent for 47");
  EXPECT_NE(reason.find("; checkpoint "), std::string::npos) << logs(out);
  EXPECT_EQ(slurp(out / "launcher.log").find("still running"), std::string::npos) << logs(out);
  EXPECT_GE(waited, 47.0);
  std::printf("the launcher ended %.1f s after the kill; %s\n", waited, reason.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, KilledSolidLeavesItsRows) {
  const fs::path dir = scratch("killed_solid");
  const fs::path scene = small_scene(dir, 400);
  const fs::path clean = dir / "clean", out = dir / "killed";
  expect_done(clean, run_launcher(kSource, scene, clean));
  bool reached = false;
  const int status = run_and_signal(scene, out, fs::path("checkpoints") / "solid_00000100.h5", "solid.pid", SIGKILL,
                                    reached);
  ASSERT_TRUE(reached) << logs(out);
  EXPECT_EQ(status, 1) << logs(out);
  const std::vector<double> steps = column(out / "solid.h5", "step"), all = column(clean / "solid.h5", "step");
  ASSERT_GE(steps.size(), 100u) << "solid.h5 of the killed solid holds " << steps.size() << " rows\n" << logs(out);
  // Every row it holds is the clean run's, bit for bit.
  const auto killed_sets = read_datasets(out / "solid.h5"), clean_sets = read_datasets(clean / "solid.h5");
  for (const auto& [name, d] : killed_sets) {
    const auto& c = clean_sets.at(name);
    ASSERT_LE(d.bytes.size(), c.bytes.size()) << name;
    EXPECT_TRUE(std::equal(d.bytes.begin(), d.bytes.end(), c.bytes.begin())) << name;
  }
  std::printf("the killed solid left %zu rows (steps 0 to %.0f) of %zu\n", steps.size(), steps.back(), all.size());
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, DiskFullLosesAtMostOneInterval) {
  const fs::path dir = scratch("disk_full");
  const fs::path scene = small_scene(dir, 120);
  for (const char* side : {"fluid", "solid"}) {
    SCOPED_TRACE(std::string("a full disk for the ") + side);
    // What the side writes in a whole run (the shim counting only: a clean run), then a
    // disk that is full after half of it.
    const fs::path clean = dir / (std::string("clean_") + side), out = dir / (std::string("full_") + side);
    const std::string shim = "LD_PRELOAD=" + quoted(kShim.string()) + " COSIM_FULL_DISK_PROGRAM=" + side;
    expect_done(clean, run_launcher(kSource, scene, clean, "",
                                    shim + " COSIM_FULL_DISK_DIR=" + quoted(clean.string()) +
                                        " COSIM_FULL_DISK_BYTES=0 COSIM_FULL_DISK_COUNT=" +
                                        quoted((dir / "count").string())));
    const long long budget = std::stoll(slurp(dir / "count")) / 2;
    ASSERT_GT(budget, 0);
    const int status = run_launcher(kSource, scene, out, "",
                                    shim + " COSIM_FULL_DISK_DIR=" + quoted(out.string()) +
                                        " COSIM_FULL_DISK_BYTES=" + std::to_string(budget));
    EXPECT_GE(status, 1) << logs(out);
    EXPECT_LE(status, 4) << logs(out);
    // One line naming the file that could not be written, and no HDF5 noise.
    const std::string log = slurp(out / (std::string(side) + ".log"));
    const std::string line = last_line(log);
    EXPECT_NE(line.find(out.string()), std::string::npos) << logs(out);
    EXPECT_EQ(log.find("HDF5"), std::string::npos) << logs(out);
    EXPECT_EQ(part_files(out), std::vector<std::string>{}) << logs(out);
    std::printf("%s after %lld bytes: exit %d: %s\n", side, budget, status, line.c_str());
    // What was written is the clean run's; a restart from the newest pair of checkpoints
    // completes it (the disk has room again) as if nothing happened.
    for (const char* f : {"monitor.h5", "solid.h5"}) {
      const auto part = read_datasets(out / f), whole = read_datasets(clean / f);
      for (const auto& [name, d] : part) {
        const auto& c = whole.at(name);
        EXPECT_TRUE(d.bytes.size() <= c.bytes.size() && std::equal(d.bytes.begin(), d.bytes.end(), c.bytes.begin()))
            << f << " " << name;
      }
    }
    expect_done(out, run_launcher(kSource, scene, out, "--restart " + quoted(out.string())));
    for (const char* f : {"monitor.h5", "solid.h5"}) EXPECT_EQ(compare_h5(clean, out, f), "") << f;
  }
  if (!HasFailure()) fs::remove_all(dir);
}

// The recorder (--log) killed mid-run: the run completes, the launcher says in one line that
// the traffic log is partial and exits 5 (launch/run-coupled.sh: both servers 0, the log
// partial).
TEST(RunData, DeadRecorderIsReported) {
  const fs::path dir = scratch("dead_recorder");
  const fs::path scene = small_scene(dir, 200);
  const fs::path out = dir / "run";
  int status = -1;
  std::thread launcher([&] { status = launch(scene, "--output " + quoted(out.string()) + " --log", dir / "run.log"); });
  const bool reached = wait_for(out / "checkpoints" / "solid_00000060.h5", 120);
  const std::string pid = slurp(out / "record.pid");
  if (reached && !pid.empty()) kill(std::stoi(pid), SIGKILL);
  launcher.join();
  ASSERT_TRUE(reached) << slurp(dir / "run.log") << logs(out);
  ASSERT_FALSE(pid.empty()) << slurp(dir / "run.log");
  const std::string text = slurp(dir / "run.log");
  EXPECT_EQ(status, 5) << text << logs(out);
  EXPECT_EQ(slurp(out / "fluid.exit"), "0\n") << logs(out);
  EXPECT_EQ(slurp(out / "solid.exit"), "0\n") << logs(out);
  const std::string line = line_with(text, "cosim-record ended before the run did");
  EXPECT_NE(line.find("killed by signal 9"), std::string::npos) << text;
  EXPECT_NE(line.find((out / "traffic.lcmlog").string() + " is partial"), std::string::npos) << text;
  EXPECT_EQ(text.find("cosim-record ended before"), text.rfind("cosim-record ended before")) << text;
  std::printf("exit %d: %s\n", status, line.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

// A scene file over 64 KiB (HDF5's limit for an attribute in its default file format): it
// runs, and every output keeps its text (the scene_toml attribute, common/hdf5/hdf5_handle.hpp).
TEST(RunData, LongSceneRunsOrIsRefused) {
  const fs::path dir = scratch("long_scene");
  const fs::path scene = small_scene(dir, 20);
  {
    std::ofstream more(scene, std::ios::app);
    for (int k = 0; k < 1500; ++k)
      more << "# a long note, line " << k << ": this scene carries its lab notebook in comments, 80 bytes\n";
  }
  const std::string text = slurp(scene);
  ASSERT_GT(text.size(), 100000u);
  const fs::path out = dir / "run";
  const fs::path log = dir / "run.log";
  ASSERT_EQ(launch(scene, "--output " + quoted(out.string()), log), 0) << slurp(log) << logs(out);
  for (const char* f : {"monitor.h5", "solid.h5", "fields_000000.h5", "sheets_000000.h5"})
    EXPECT_TRUE(root_attribute(out / f, "scene_toml") == text) << f << ": the scene text is not stored whole";
  std::printf("a scene of %zu bytes ran; its text is in every output\n", text.size());
  if (!HasFailure()) fs::remove_all(dir);
}

// Liveness while writing: `fluid --check` warns when the largest file the fluid writes between
// two messages (here a checkpoint of 70^3 cells, about 60 MB, larger than its 19 MB field
// snapshot) takes more than half of the peer timeout at the assumed 30 MB/s
// (fluid/io/snapshots.hpp); the small scene gets no warning.
TEST(RunData, CheckWarnsWhenAWriteOutlastsThePeerTimeout) {
  const fs::path dir = scratch("slow_write");
  const fs::path big = small_scene(dir, 60, {{"nx = 40", "nx = 70"}, {"ny = 30", "ny = 70"}, {"nz = 30", "nz = 70"},
                                             {"peer_timeout_s = 3", "peer_timeout_s = 1"}}, "big");
  const fs::path small = small_scene(dir, 60);
  const fs::path fluid = FLUID_EXE;
  const cosim::test::RunResult warned =
      cosim::test::run_command(quoted(fluid.string()) + " " + quoted(big.string()) + " --check", dir / "big");
  EXPECT_EQ(warned.status, 0) << warned.err;
  const std::string line = line_with(warned.err, "fluid: warning: a checkpoint (one population store) is ");
  EXPECT_NE(line.find(" MB: at 30 MB/s it takes "), std::string::npos) << warned.err;
  EXPECT_NE(line.find("coupling.peer_timeout_s = 1 s"), std::string::npos) << warned.err;
  const cosim::test::RunResult quiet =
      cosim::test::run_command(quoted(fluid.string()) + " " + quoted(small.string()) + " --check", dir / "small");
  EXPECT_EQ(quiet.status, 0) << quiet.err;
  EXPECT_EQ(quiet.err.find("warning"), std::string::npos) << quiet.err;
  std::printf("%s\n", line.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
