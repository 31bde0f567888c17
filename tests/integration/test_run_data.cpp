// Runs that keep their data (launch/run-coupled.sh, common/run/checkpoint_file.hpp,
// protocol/checkpoint_identity.hpp): each run its own folder, restarts that refuse another
// run's, scene's or A_T's checkpoint and corrupted ones, interrupts and killed peers that
// leave checkpoints and rows, a full disk, XDMF indexes after a restart, and a finished run
// continued for more steps. Two processes through the launcher on a small scene (a few
// seconds a run).

#include <gtest/gtest.h>

#include "tests/integration/run_data_helpers.hpp"

namespace {

using namespace cosim::test::run_data;

TEST(RunData, RerunDoesNotTouchAnotherRun) {
  const fs::path dir = scratch("rerun");
  const fs::path scene = small_scene(dir, 60);
  const std::string env = "COSIM_OUTPUT_ROOT=" + quoted((dir / "out").string());
  ASSERT_EQ(launch(scene, "", dir / "first.log", env), 0) << slurp(dir / "first.log");
  std::vector<fs::path> runs;
  for (const auto& e : fs::directory_iterator(dir / "out" / "small")) runs.push_back(e.path());
  ASSERT_EQ(runs.size(), 1u);
  const fs::path first = runs[0];
  const auto before = data_files(first);
  ASSERT_TRUE(before.count("checkpoints/fluid_00000040.h5")) << logs(first);
  // The same scene again, the default folder: a new one; the first run's files untouched.
  ASSERT_EQ(launch(scene, "", dir / "second.log", env), 0) << slurp(dir / "second.log");
  runs.clear();
  for (const auto& e : fs::directory_iterator(dir / "out" / "small")) runs.push_back(e.path());
  ASSERT_EQ(runs.size(), 2u);
  const fs::path second = runs[0] == first ? runs[1] : runs[0];
  EXPECT_TRUE(data_files(first) == before) << "the second run changed the first run's files";
  EXPECT_NE(slurp(first / "run.id"), slurp(second / "run.id"));
  for (const char* f : {"checkpoints/fluid_00000040.h5", "checkpoints/solid_00000040.h5"})
    EXPECT_TRUE(fs::exists(second / f)) << f << "\n" << logs(second);
  // The first run's folder given as --output of a new run: refused in one line, untouched.
  EXPECT_EQ(launch(scene, "--output " + quoted(first.string()), dir / "third.log"), 2);
  const std::string refusal = slurp(dir / "third.log");
  EXPECT_NE(refusal.find("holds an earlier run"), std::string::npos) << refusal;
  EXPECT_EQ(std::count(refusal.begin(), refusal.end(), '\n'), 1) << refusal;
  EXPECT_TRUE(data_files(first) == before) << "a refused run changed the first run's files";
  std::printf("runs in %s and %s; the refusal: %s", first.filename().c_str(), second.filename().c_str(),
              refusal.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, RestartRefusesAnotherRunsCheckpoint) {
  const fs::path dir = scratch("refuse_restart");
  const fs::path scene = small_scene(dir, 60);
  const fs::path a = dir / "a", b = dir / "b";
  expect_done(a, run_launcher(kSource, scene, a));
  expect_done(b, run_launcher(kSource, scene, b));
  const auto files_a = data_files(a), files_b = data_files(b);
  struct Case {
    std::string what, args, expect;
    fs::path scene;
  };
  const fs::path other_scene = small_scene(dir, 60, {{"tau = 0.8", "tau = 0.9"}}, "other");
  fs::create_directories(dir / "mixed");
  fs::copy_file(a / "checkpoints" / "fluid_00000040.h5", dir / "mixed" / "fluid_00000040.h5");
  fs::copy_file(b / "checkpoints" / "solid_00000040.h5", dir / "mixed" / "solid_00000040.h5");
  const std::vector<Case> cases = {
      {"another run's checkpoint into b",
       "--restart " + quoted((a / "checkpoints" / "fluid_00000040.h5").string()) + " --output " + quoted(b.string()),
       "a checkpoint of another run", scene},
      {"another A_T", "--restart " + quoted(a.string()) + " --time-ratio 300", "A_T = 150, this run has A_T = 300",
       scene},
      {"another scene", "--restart " + quoted(a.string()), "a checkpoint of another scene", other_scene},
      {"a pair of two runs", "--restart " + quoted((dir / "mixed").string()) + " --output " + quoted((dir / "m").string()),
       "of run", scene},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const fs::path log = dir / "refused.log";
    const int status = launch(c.scene, c.args, log);
    std::string text = slurp(log);
    for (const fs::path& out : {a, b})
      for (const char* f : {"fluid.log", "solid.log"}) text += slurp(out / f);
    EXPECT_EQ(status, 2) << text;
    const std::string line = line_with(text, c.expect);
    EXPECT_FALSE(line.empty()) << text;
    std::printf("%s: %s\n", c.what.c_str(), line.c_str());
    EXPECT_TRUE(data_files(a) == files_a) << "a refused restart changed a's files";
    EXPECT_TRUE(data_files(b) == files_b) << "a refused restart changed b's files";
  }
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, CorruptCheckpointIsRefused) {
  const fs::path dir = scratch("corrupt");
  const fs::path scene = small_scene(dir, 60);
  const fs::path a = dir / "a";
  expect_done(a, run_launcher(kSource, scene, a));
  for (const auto& [side, dataset] : {std::pair<std::string, std::string>{"fluid", "populations"},
                                      {"solid", "positions_bohr"}}) {
    SCOPED_TRACE(side + " " + dataset);
    const fs::path from = dir / ("flipped_" + side), out = dir / ("out_" + side);
    fs::create_directories(from);
    for (const char* s : {"fluid", "solid"})
      fs::copy_file(a / "checkpoints" / (std::string(s) + "_00000040.h5"), from / (std::string(s) + "_00000040.h5"));
    const fs::path file = from / (side + "_00000040.h5");
    flip_bit(file, dataset);
    EXPECT_EQ(run_launcher(kSource, scene, out, "--restart " + quoted(from.string())), 2) << logs(out);
    const std::string line = line_with(slurp(out / (side + ".log")), "does not match its checksum");
    EXPECT_NE(line.find(file.string()), std::string::npos) << logs(out);
    EXPECT_NE(line.find(dataset), std::string::npos) << logs(out);
    std::printf("%s\n", line.c_str());
  }
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, XdmfAfterRestartOpens) {
  const fs::path dir = scratch("xdmf_restart");
  const fs::path scene = small_scene(dir, 60);
  const fs::path a = dir / "a", from = dir / "from20", fresh = dir / "fresh";
  expect_done(a, run_launcher(kSource, scene, a));
  fs::create_directories(from);
  for (const char* side : {"fluid", "solid"})
    fs::copy_file(a / "checkpoints" / (std::string(side) + "_00000020.h5"), from / (std::string(side) + "_00000020.h5"));
  // Into a new folder (the snapshots before step 20 are not there), and into the run's own
  // folder from its checkpoint of step 20 (they are).
  expect_done(fresh, run_launcher(kSource, scene, fresh, "--restart " + quoted(from.string())));
  expect_done(a, run_launcher(kSource, scene, a, "--restart " + quoted((a / "checkpoints" / "solid_00000020.h5").string())));
  const std::string script = R"(
import sys
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
for name in sys.argv[1:]:
    r = vtkXdmfReader()
    r.SetFileName(name)
    r.UpdateInformation()
    info = r.GetOutputInformation(0)
    key = vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    times = [info.Get(key, k) for k in range(info.Length(key))] if info.Has(key) else []
    cells = []
    for t in times:
        r.UpdateTimeStep(t)
        out = r.GetOutputDataObject(0)
        n = out.GetNumberOfPoints() if out is not None else 0
        if n == 0 and hasattr(out, "GetNumberOfBlocks"):
            it = out.NewIterator(); it.InitTraversal()
            while not it.IsDoneWithTraversal():
                n += it.GetCurrentDataObject().GetNumberOfPoints(); it.GoToNextItem()
        cells.append(n)
    print(name, len(times), "snapshots, points per snapshot", cells)
    if not times or min(cells) == 0:
        sys.exit(1)
)";
  std::ofstream(dir / "read_xdmf.py") << script;
  for (const fs::path& out : {fresh, a}) {
    const std::string cmd = "/usr/bin/python3 " + quoted((dir / "read_xdmf.py").string()) + " " +
                            quoted((out / "fields.xmf").string()) + " " + quoted((out / "sheets.xmf").string()) +
                            " >" + quoted((dir / "vtk.log").string()) + " 2>&1";
    const int s = std::system(cmd.c_str());
    const std::string said = slurp(dir / "vtk.log");
    EXPECT_TRUE(WIFEXITED(s) && WEXITSTATUS(s) == 0) << said;
    EXPECT_EQ(said.find("Dimensions=\"0 0 0\""), std::string::npos);
    EXPECT_EQ(slurp(out / "fields.xmf").find("Dimensions=\"0 0 0\""), std::string::npos) << slurp(out / "fields.xmf");
    std::printf("%s", said.c_str());
  }
  // The fresh folder lists only the snapshots it holds (40 and 60), the run's own all four.
  EXPECT_EQ(slurp(fresh / "fields.xmf").find("fields_000000.h5"), std::string::npos);
  EXPECT_NE(slurp(a / "fields.xmf").find("fields_000000.h5"), std::string::npos);
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(RunData, ContinueFinishedRun) {
  const fs::path dir = scratch("continue");
  const fs::path scene = small_scene(dir, 60);
  const fs::path run = dir / "run", longer = dir / "longer";
  expect_done(run, run_launcher(kSource, scene, run, "--log"));
  const std::string traffic = slurp(run / "traffic.lcmlog");
  ASSERT_FALSE(traffic.empty()) << logs(run);
  // The same scene, 100 LB steps: from step 0, and the finished run continued from its last
  // checkpoint (40) in its own folder.
  const fs::path scene100 = small_scene(dir, 100, {}, "small100");
  expect_done(longer, run_launcher(kSource, scene100, longer));
  const std::string log = (dir / "continue.log").string();
  ASSERT_EQ(launch(scene100, "--restart " + quoted(run.string()) + " --log", log), 0) << slurp(log) << logs(run);
  EXPECT_NE(slurp(log).find("restarting run"), std::string::npos) << slurp(log);
  // The continuation's traffic goes after the first run's, which stays as it was.
  const std::string both = slurp(run / "traffic.lcmlog");
  EXPECT_GT(both.size(), traffic.size());
  EXPECT_EQ(both.compare(0, traffic.size(), traffic), 0) << "the first run's log was overwritten";
  const std::string recorder = slurp(run / "record.log");
  EXPECT_NE(recorder.find("cosim-record: recording "), recorder.rfind("cosim-record: recording ")) << recorder;
  for (const char* f : {"monitor.h5", "solid.h5", "fields_000080.h5", "fields_000100.h5"})
    EXPECT_EQ(compare_h5(longer, run, f), "") << f;
  // The first attempt's provenance and scene copy are kept; the continuation's are beside them.
  for (const char* f : {"scene.toml", "provenance_fluid.toml", "provenance_solid.toml", "scene.2.toml",
                        "provenance_fluid.2.toml", "provenance_solid.2.toml"})
    EXPECT_TRUE(fs::exists(run / f)) << f;
  EXPECT_EQ(slurp(run / "scene.toml"), slurp(scene)) << "the first attempt's scene copy was overwritten";
  EXPECT_EQ(slurp(run / "scene.2.toml"), slurp(scene100));
  EXPECT_NE(slurp(run / "provenance_fluid.2.toml").find("scene_copy = \"scene.2.toml\""), std::string::npos)
      << slurp(run / "provenance_fluid.2.toml");
  // Any other change of the scene is refused.
  const fs::path other = small_scene(dir, 120, {{"u_max = 0.05", "u_max = 0.04"}}, "other");
  EXPECT_EQ(launch(other, "--restart " + quoted(run.string()), log), 2) << slurp(log);
  if (!HasFailure()) fs::remove_all(dir);
}

// Launches started in the same second: each default folder created by the launch that gets it
// (mkdir, not a name chosen and created later), and of two launches given the same new
// --output one runs and the other is refused (run.id claimed with O_EXCL).
TEST(RunData, ConcurrentLaunchesGetTheirOwnFolders) {
  const fs::path dir = scratch("concurrent");
  const fs::path scene = small_scene(dir, 30);
  constexpr int kLaunches = 4;
  const std::string env = "COSIM_OUTPUT_ROOT=" + quoted((dir / "out").string());
  std::vector<int> status(kLaunches, -1);
  {
    std::vector<std::thread> launches;
    for (int i = 0; i < kLaunches; ++i)
      launches.emplace_back([&, i] { status[std::size_t(i)] = launch(scene, "", dir / ("l" + std::to_string(i) + ".log"), env); });
    for (std::thread& t : launches) t.join();
  }
  std::vector<fs::path> runs;
  for (const auto& e : fs::directory_iterator(dir / "out" / "small")) runs.push_back(e.path());
  ASSERT_EQ(runs.size(), std::size_t(kLaunches));
  std::set<std::string> ids;
  for (int i = 0; i < kLaunches; ++i) EXPECT_EQ(status[std::size_t(i)], 0) << slurp(dir / ("l" + std::to_string(i) + ".log"));
  for (const fs::path& r : runs) {
    EXPECT_EQ(slurp(r / "fluid.exit"), "0\n") << logs(r);
    EXPECT_EQ(slurp(r / "solid.exit"), "0\n") << logs(r);
    ids.insert(slurp(r / "run.id"));
  }
  EXPECT_EQ(ids.size(), std::size_t(kLaunches)) << "two launches wrote into one folder";
  // The same new --output twice at once: one run, one refusal, the run's files its own.
  const fs::path shared = dir / "shared";
  int a = -1, b = -1;
  std::thread ta([&] { a = launch(scene, "--output " + quoted(shared.string()), dir / "a.log"); });
  std::thread tb([&] { b = launch(scene, "--output " + quoted(shared.string()), dir / "b.log"); });
  ta.join();
  tb.join();
  EXPECT_EQ(std::min(a, b), 0) << slurp(dir / "a.log") << slurp(dir / "b.log");
  EXPECT_EQ(std::max(a, b), 2) << slurp(dir / "a.log") << slurp(dir / "b.log");
  const std::string refusal = slurp(dir / (a == 2 ? "a.log" : "b.log"));
  EXPECT_EQ(std::count(refusal.begin(), refusal.end(), '\n'), 1) << refusal;
  EXPECT_EQ(slurp(shared / "fluid.exit"), "0\n") << logs(shared);
  EXPECT_EQ(slurp(shared / "solid.exit"), "0\n") << logs(shared);
  std::printf("%d folders for %d launches; the shared --output's refusal: %s", int(runs.size()), kLaunches,
              refusal.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

// A folder whose run.id was deleted names its run by its checkpoints: another run's
// checkpoint is refused there, its own accepted (and run.id written back).
TEST(RunData, RestartWithoutRunIdAsksTheCheckpoints) {
  const fs::path dir = scratch("no_run_id");
  const fs::path scene = small_scene(dir, 60);
  const fs::path a = dir / "a", b = dir / "b";
  expect_done(a, run_launcher(kSource, scene, a));
  expect_done(b, run_launcher(kSource, scene, b));
  const std::string id_a = slurp(a / "run.id");
  fs::remove(a / "run.id");
  const auto files_a = data_files(a);
  const fs::path log = dir / "restart.log";
  EXPECT_EQ(launch(scene, "--restart " + quoted((b / "checkpoints" / "fluid_00000040.h5").string()) + " --output " +
                              quoted(a.string()), log),
            2)
      << slurp(log);
  EXPECT_NE(slurp(log).find("a checkpoint of another run"), std::string::npos) << slurp(log);
  EXPECT_TRUE(data_files(a) == files_a) << "a refused restart changed the folder";
  const fs::path scene100 = small_scene(dir, 100, {}, "small");
  EXPECT_EQ(launch(scene100, "--restart " + quoted(a.string()), log), 0) << slurp(log) << logs(a);
  EXPECT_EQ(slurp(a / "run.id"), id_a);
  if (!HasFailure()) fs::remove_all(dir);
}

// A restart into the run's own folder that one side refuses (its checkpoint damaged: the
// other side's is sound and read first) changes no file of the folder, not even the logs:
// each server writes its series, scene copy and provenance only once the other's first
// message shows it accepted its checkpoint, and the launcher takes back its own lines.
TEST(RunData, OneSidedRefusalTouchesNothing) {
  const fs::path dir = scratch("one_sided");
  const fs::path scene = small_scene(dir, 60);
  const fs::path run = dir / "run";
  ASSERT_EQ(launch(scene, "--output " + quoted(run.string()) + " --log", dir / "first.log"), 0) << slurp(dir / "first.log");
  for (const auto& [side, dataset] : {std::pair<std::string, std::string>{"solid", "positions_bohr"},
                                      {"fluid", "populations"}}) {
    SCOPED_TRACE("the " + side + " refuses");
    const fs::path file = run / "checkpoints" / (side + "_00000040.h5");
    fs::copy_file(file, dir / "sound.h5", fs::copy_options::overwrite_existing);
    flip_bit(file, dataset);
    const auto before = every_file(run);
    const fs::path log = dir / ("refused_" + side + ".log");
    const int status = launch(scene, "--restart " + quoted(run.string()) + " --log", log);
    const std::string text = slurp(log);
    EXPECT_EQ(status, 2) << text;
    // The refusing side's one line, as the launcher repeats it.
    const std::string reason = line_with(text, "run-coupled: " + side + " exited 2: ");
    EXPECT_NE(reason.find("--restart " + file.string()), std::string::npos) << text;
    EXPECT_NE(reason.find("does not match its checksum"), std::string::npos) << text;
    EXPECT_NE(reason.find(dataset), std::string::npos) << text;
    EXPECT_NE(text.find("every file of " + run.string() + " is as it was"), std::string::npos) << text;
    const std::string changed = changed_files(before, every_file(run));
    EXPECT_EQ(changed, "") << text;
    std::printf("%s refused: exit %d: %s\n", side.c_str(), status, reason.c_str());
    fs::copy_file(dir / "sound.h5", file, fs::copy_options::overwrite_existing);
  }
  // The sound pair continues the run in its folder.
  const fs::path scene100 = small_scene(dir, 100, {}, "small");
  EXPECT_EQ(launch(scene100, "--restart " + quoted(run.string()), dir / "continued.log"), 0) << slurp(dir / "continued.log");
  EXPECT_EQ(column(run / "monitor.h5", "step").size(), 11u);
  if (!HasFailure()) fs::remove_all(dir);
}

// A restart from a checkpoint file into a new folder (--restart FILE --output NEW) shows
// what a run shows: the progress line and the closing summary, no stray errors or usage text.
TEST(RunData, RestartIntoANewFolderShowsProgress) {
  const fs::path dir = scratch("restart_new_folder");
  const fs::path scene = small_scene(dir, 60);
  const fs::path a = dir / "a", fresh = dir / "new";
  ASSERT_EQ(launch(scene, "--output " + quoted(a.string()), dir / "a.log"), 0) << slurp(dir / "a.log");
  const fs::path log = dir / "restart.log";
  const int status = launch(scene,
                            "--restart " + quoted((a / "checkpoints" / "fluid_00000040.h5").string()) + " --output " +
                                quoted(fresh.string()),
                            log, "COSIM_PROGRESS_EVERY_S=0.2", false);
  const std::string text = slurp(log);
  EXPECT_EQ(status, 0) << text << logs(fresh);
  EXPECT_EQ(text.find("stat:"), std::string::npos) << text;
  EXPECT_EQ(text.find("usage:"), std::string::npos) << text;
  EXPECT_EQ(text.find("error:"), std::string::npos) << text;
  EXPECT_NE(text.find("step 60/60"), std::string::npos) << "no progress line\n" << text;
  EXPECT_NE(text.find("fluid: coupled run done, 60 LB steps"), std::string::npos) << "no summary\n" << text;
  EXPECT_NE(text.find("run-coupled: fluid exit 0, solid exit 0; outputs in " + fresh.string()), std::string::npos) << text;
  std::printf("%s", text.c_str());
  if (!HasFailure()) fs::remove_all(dir);
}

// The launcher takes the scene's URL, timeouts and steps from the fluid (`fluid --print`),
// never from TOML of its own: a literal string URL on another port, numbers with underscores,
// comments after the values.
TEST(RunData, LauncherReadsTheSceneAsTheServersDo) {
  const fs::path dir = scratch("scene_as_servers");
  const fs::path scene = small_scene(
      dir, 30,
      {{"time_ratio = 150", "time_ratio = 1_50   # A_T\nlcm_url = 'udpm://239.255.76.67:7668?ttl=0'  # literal, port 7668\n"
                            "handshake_timeout_s = 1_80"}});
  const fs::path fluid = FLUID_EXE;
  const cosim::test::RunResult p = cosim::test::run_command(
      quoted(fluid.string()) + " " + quoted(scene.string()) +
          " --print coupling.lcm_url,coupling.handshake_timeout_s,coupling.peer_timeout_s,coupling.time_ratio,run.steps",
      dir / "print");
  ASSERT_EQ(p.status, 0) << p.err;
  EXPECT_EQ(p.out,
            "coupling.lcm_url=udpm://239.255.76.67:7668?ttl=0\ncoupling.handshake_timeout_s=180\n"
            "coupling.peer_timeout_s=3\ncoupling.time_ratio=150\nrun.steps=30\n");
  const cosim::test::RunResult bad = cosim::test::run_command(
      quoted(fluid.string()) + " " + quoted(scene.string()) + " --print coupling.nonsense", dir / "print_bad");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--print coupling.nonsense: not a key the fluid prints (allowed: "), std::string::npos) << bad.err;
  // A run with its traffic log: the recorder listens where the servers talk.
  const fs::path out = dir / "run";
  ASSERT_EQ(launch(scene, "--output " + quoted(out.string()) + " --log", dir / "run.log"), 0) << slurp(dir / "run.log")
                                                                                              << logs(out);
  EXPECT_GT(fs::file_size(out / "traffic.lcmlog"), 1000u) << slurp(out / "record.log");
  EXPECT_NE(slurp(out / "record.log").find("7668"), std::string::npos) << slurp(out / "record.log");
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
