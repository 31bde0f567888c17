// Runs that keep their data (launch/run-coupled.sh, common/run/checkpoint_file.hpp,
// protocol/checkpoint_identity.hpp): each run its own folder, restarts that refuse another
// run's, scene's or A_T's checkpoint and corrupted ones, interrupts and killed peers that
// leave checkpoints and rows, a full disk, XDMF indexes after a restart, and a finished run
// continued for more steps. Two processes through the launcher on a small scene (a few
// seconds a run).
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/support/run_compare.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::changed_files;
using cosim::test::compare_h5;
using cosim::test::every_file;
using cosim::test::flip_bit;
using cosim::test::expect_run_done;
using cosim::test::logs;
using cosim::test::quoted;
using cosim::test::read_datasets;
using cosim::test::run_launcher;
using cosim::test::scratch;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;
const fs::path kShim = FULL_DISK_SHIM;

/// scenes/coupled_small.toml with `steps` LB steps (20 rigid), monitor rows every 10 steps,
/// field and sheet snapshots every 20, checkpoints every 20, a 3 s peer timeout; `edits`
/// (text -> text) after those. Written as dir/NAME.toml.
fs::path small_scene(const fs::path& dir, int steps, const std::vector<std::pair<std::string, std::string>>& edits = {},
                     const std::string& name = "small") {
  std::string s = slurp(kSource / "scenes" / "coupled_small.toml");
  std::vector<std::pair<std::string, std::string>> all = {
      {"steps = 200", "steps = " + std::to_string(steps)},
      {"rigid_steps = 50", "rigid_steps = 20"},
      {"monitor_every = 50", "monitor_every = 10"},
      {"fields_every = 50", "fields_every = 20"},
      {"sheets_every = 50", "sheets_every = 20"},
      {"peer_timeout_s = 10", "peer_timeout_s = 3\ncheckpoint_every = 20"},
      {"resend_after_s = 0.5", "resend_after_s = 0.05"}};
  all.insert(all.end(), edits.begin(), edits.end());
  for (const auto& [from, to] : all) {
    const std::size_t at = s.find(from);
    if (at == std::string::npos) throw std::runtime_error("scene template lacks " + from);
    s.replace(at, from.size(), to);
  }
  const fs::path scene = dir / (name + ".toml");
  std::ofstream(scene) << s;
  return scene;
}

/// run-coupled.sh SCENE ARGS --no-build [--quiet], its lines into `log`; the exit status.
int launch(const fs::path& scene, const std::string& args, const fs::path& log, const std::string& env = "",
           bool quiet = true) {
  const std::string cmd = (env.empty() ? "" : "env " + env + " ") + "bash " +
                          quoted((kSource / "launch" / "run-coupled.sh").string()) + " " + quoted(scene.string()) +
                          " " + args + " --no-build" + (quiet ? " --quiet" : "") + " >" + quoted(log.string()) + " 2>&1";
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

/// Every data file of a run's folder (HDF5, XDMF, run.id, the scene copy and provenance), by relative path, with its bytes.
std::map<std::string, std::string> data_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string ext = e.path().extension().string();
    if (ext == ".h5" || ext == ".xmf" || ext == ".id" || ext == ".toml") files[fs::relative(e.path(), dir).string()] = slurp(e.path());
  }
  return files;
}

/// The .part files left anywhere under `dir`.
std::vector<std::string> part_files(const fs::path& dir) {
  std::vector<std::string> parts;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().string().find(".part") != std::string::npos) parts.push_back(e.path().string());
  return parts;
}

/// The one line of `text` that contains `what` ("" if none).
std::string line_with(const std::string& text, const std::string& what) {
  const std::size_t at = text.find(what);
  if (at == std::string::npos) return "";
  const std::size_t begin = text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
  return text.substr(begin, text.find('\n', at) - begin);
}

/// The last line of `text` that is not empty.
std::string last_line(std::string text) {
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text.substr(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
}

/// A dataset of an HDF5 file as doubles (empty if it cannot be read).
std::vector<double> column(const fs::path& file, const std::string& name) {
  const auto sets = read_datasets(file);
  const auto it = sets.find(name);
  return it == sets.end() ? std::vector<double>{} : it->second.values;
}

/// Waits (at most `seconds`) for `file` to exist.
bool wait_for(const fs::path& file, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!fs::exists(file) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return fs::exists(file);
}

/// Runs `scene` into `out` through the launcher and, once `marker` exists (at most 120 s),
/// sends `signal` to the process whose id `pid_file` (under `out`) holds; the launcher's
/// exit status, and in `reached` whether the marker came. `sent` is when the signal went.
int run_and_signal(const fs::path& scene, const fs::path& out, const fs::path& marker, const std::string& pid_file,
                   int signal, bool& reached, std::chrono::steady_clock::time_point* sent = nullptr) {
  int status = -1;
  std::thread launcher([&] { status = run_launcher(kSource, scene, out); });
  reached = wait_for(out / marker, 120);
  const std::string pid = slurp(out / pid_file);
  if (sent != nullptr) *sent = std::chrono::steady_clock::now();
  if (reached && !pid.empty()) kill(std::stoi(pid), signal);
  launcher.join();
  return status;
}

void expect_done(const fs::path& out, int status) { expect_run_done(out, status); }

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

/// A string attribute of an HDF5 file's root group ("" if it cannot be read).
std::string root_attribute(const fs::path& file, const char* name) {
  std::string value;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return value;
  if (H5Aexists(f, name) > 0) {
    const hid_t a = H5Aopen(f, name, H5P_DEFAULT);
    const hid_t t = H5Aget_type(a);
    value.resize(H5Tget_size(t));
    if (H5Aread(a, t, value.data()) < 0) value.clear();
    while (!value.empty() && value.back() == '\0') value.pop_back();
    H5Tclose(t);
    H5Aclose(a);
  }
  H5Fclose(f);
  return value;
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
