// Coupled scenes over MPI ranks (DESIGN 8, fluid/mpi/led_domain.hpp): the fluid's grid in
// slabs along z over 1 to 4 ranks (launch/run-coupled.sh --ranks N: launch/mpirun-local.sh
// in the run's private network namespace, more ranks than cores allowed), the coordinator
// and the session on rank 0, the solid as always. Every HDF5 output of the fluid and of the
// solid equals the serial run's bit for bit, in each coupling scheme, with a sheet whose
// markers' kernels straddle the slab edges; a checkpoint written by the ranks (each its own
// range of the store, parallel HDF5) restarts on the same or another number of ranks (or in
// one process) bit for bit; no rank holds the whole grid; a killed rank ends the run.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "fluid/domain/decomposition.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/run_compare.hpp"

namespace cosim::test {
namespace {

const fs::path kSource = COSIM_SOURCE_DIR;
constexpr int kNz = 30;             // scenes/coupled_small.toml's nz
constexpr double kDxUm = 0.2561;    // and dx
const std::string kOneThread = "OMP_NUM_THREADS=1";

bool have_mpirun() { return std::system("command -v mpirun >/dev/null 2>&1") == 0; }

/// scenes/coupled_small.toml shortened to 60 LB steps (20 rigid), with plane snapshots, the
/// sheet moved 1.5 cells up along z (its markers at z = 14.5 .. 18.5 cells: kernels over the
/// planes 13 .. 20, across the slab edges at 15 of 2 slabs, 20 of 3 and 16 of 4), in
/// `scheme`, with `extra` added to [coupling]; `single`: the single-precision store on a grid
/// 48 cells long (rows of 48 floats end one value into the next row: the store's compact rows).
fs::path write_scene(const fs::path& dir, const std::string& scheme, const std::string& extra = "",
                     bool single = false) {
  std::string s = slurp(kSource / "scenes" / "coupled_small.toml");
  const auto set = [&s](const std::string& from, const std::string& to) { replace_in(s, from, to); };
  set("steps = 200", "steps = 60");
  set("monitor_every = 50", "monitor_every = 20");
  set("fields_every = 50", "fields_every = 30\nplanes_every = 20\nplanes_y = [0.5]");
  set("sheets_every = 50", "sheets_every = 30");
  set("resend_after_s = 0.5", "resend_after_s = 0.05");
  set("rigid_steps = 50", "rigid_steps = 20\nscheme = \"" + scheme + "\"" + (extra.empty() ? "" : "\n" + extra));
  set("base_um = [3.0734, 0.0, 3.8415]", "base_um = [3.0734, 0.0, 4.22565]");
  if (single) {
    set("nx = 40", "nx = 48");
    set("steps = 60", "steps = 60\nprecision = \"mixed\"");
  }
  fs::create_directories(dir);
  const fs::path scene = dir / ("small_" + scheme + (single ? "_single" : "") + ".toml");
  std::ofstream(scene) << s;
  return scene;
}

/// How many markers of the run's first sheet snapshot have a kernel (4 nodes along z from
/// floor(z) - 1, periodic) that reaches nodes of two slabs of `slabs`.
int straddling(const fs::path& run, int slabs) {
  const auto d = read_datasets(run / "sheets_000000.h5");
  const auto it = d.find("position_um");
  if (it == d.end()) return -1;
  std::vector<int> owner(kNz);
  for (int r = 0; r < slabs; ++r) {
    const fluid::Slab s = fluid::slab_of(kNz, slabs, r);
    for (int z = s.z0; z < s.z0 + s.nz; ++z) owner[std::size_t(z)] = r;
  }
  int n = 0;
  for (std::size_t k = 2; k < it->second.values.size(); k += 3) {
    const int first = int(std::floor(it->second.values[k] / kDxUm)) - 1;
    std::set<int> ranks;
    for (int i = 0; i < 4; ++i) ranks.insert(owner[std::size_t(((first + i) % kNz + kNz) % kNz)]);
    n += ranks.size() > 1;
  }
  return n;
}

TEST(MpiCoupled, MpiCoupledMatchesSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_coupled");
  for (const std::string scheme : {"serial", "parallel", "implicit"}) {
    SCOPED_TRACE(scheme + " scheme");
    const fs::path scene = write_scene(dir / scheme, scheme);
    const fs::path serial = dir / scheme / "serial";
    expect_run_done(serial, run_launcher(kSource, scene, serial, "", kOneThread));
    for (int slabs = 2; slabs <= 4; ++slabs)
      EXPECT_GT(straddling(serial, slabs), 0) << "no marker's kernel crosses an edge of " << slabs << " slabs";
    // `run_scene` over `ranks` ranks into `name`, its fluid log saying `says`: the serial run's outputs.
    const auto expect_matches = [&](const fs::path& run_scene, int ranks, const std::string& name,
                                    const std::string& says) {
      const fs::path out = dir / scheme / name;
      expect_run_done(out, run_launcher(kSource, run_scene, out, "--ranks " + std::to_string(ranks), kOneThread));
      if (!says.empty()) {
        EXPECT_TRUE(contains(slurp(out / "fluid.log"), says)) << logs(out);
      }
      std::size_t files = 0;
      EXPECT_EQ(compare_outputs(serial, out, &files), "") << name;
      // monitor.h5, solid.h5, 3 field, 4 plane and 3 sheet snapshots.
      EXPECT_EQ(files, 12u) << name;
    };
    for (int ranks = 1; ranks <= 4; ++ranks)
      expect_matches(scene, ranks, "ranks" + std::to_string(ranks),
                     ranks > 1 ? "slabs along z over " + std::to_string(ranks) + " MPI ranks" : "");
    // The runs above step in place (the default: each block's one grid, its halo planes
    // exchanged in the arrangement of the step's state); the two-grid propagation over 2 and 3
    // ranks (edge planes sent while the interior collides) against the same serial run.
    std::string text = slurp(scene);
    replace_in(text, "steps = 60", "steps = 60\npropagation = \"two-grid\"");
    const fs::path two_grid = dir / scheme / ("two_grid_" + scene.filename().string());
    std::ofstream(two_grid) << text;
    for (int ranks = 2; ranks <= 3; ++ranks)
      expect_matches(two_grid, ranks, "two_grid_ranks" + std::to_string(ranks), "two-grid propagation");
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The in-place propagation named in the scene, in the schemes whose one-process step splits
/// around its sample (FluidDomain::step_near: the rest of the step after fluid_state_t; a grid
/// over ranks steps whole): 1, 2 and 3 ranks write the one-process run's outputs bit for bit.
TEST(MpiCoupled, MpiInPlaceMatchesSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_coupled_in_place");
  for (const std::string scheme : {"serial", "parallel"}) {
    SCOPED_TRACE(scheme + " scheme");
    const fs::path scene = write_scene(dir / scheme, scheme);
    std::string text = slurp(scene);
    replace_in(text, "steps = 60", "steps = 60\npropagation = \"in-place\"");
    std::ofstream(scene) << text;
    const fs::path serial = dir / scheme / "serial";
    expect_run_done(serial, run_launcher(kSource, scene, serial, "", kOneThread));
    EXPECT_TRUE(contains(slurp(serial / "fluid.log"), "in-place propagation")) << logs(serial);
    for (int ranks = 1; ranks <= 3; ++ranks) {
      const fs::path out = dir / scheme / ("ranks" + std::to_string(ranks));
      expect_run_done(out, run_launcher(kSource, scene, out, "--ranks " + std::to_string(ranks), kOneThread));
      EXPECT_TRUE(contains(slurp(out / "fluid.log"), "in-place propagation")) << logs(out);
      std::size_t files = 0;
      EXPECT_EQ(compare_outputs(serial, out, &files), "") << ranks << " ranks";
      EXPECT_EQ(files, 12u) << ranks << " ranks";  // as MpiCoupledMatchesSerialBitForBit
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The populations of a fluid checkpoint (the whole grid's store, ghosts included).
std::vector<unsigned char> populations(const fs::path& file) {
  const auto d = read_datasets(file);
  const auto it = d.find("populations");
  return it == d.end() ? std::vector<unsigned char>{} : it->second.bytes;
}

/// `from`'s checkpoints of `step` alone in a folder of their own.
fs::path pair_of(const fs::path& from, const std::string& step, const fs::path& into) {
  fs::create_directories(into);
  for (const char* side : {"fluid", "solid"})
    fs::copy_file(from / "checkpoints" / (std::string(side) + "_" + step + ".h5"),
                  into / (std::string(side) + "_" + step + ".h5"));
  return into;
}

// A run over 2 ranks with checkpoints every 20 LB steps, restarted from step 40 on 2 ranks,
// on 3 and in one process, ends with the outputs of the run straight through, bit for bit;
// the checkpoint written by the ranks holds the serial run's store. The implicit scheme's checkpoint of
// step 40 is written while step 40 is iterated: the kept (committed) state, written. The
// single store's compact rows: the serial scheme again on a grid of rows that spill.
TEST(MpiCoupled, MpiCheckpointRestartIsBitIdentical) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_restart");
  for (const auto& [scheme, single] : {std::pair<std::string, bool>{"serial", false}, {"implicit", false}, {"serial", true}}) {
    const std::string name = scheme + (single ? "_single" : "");
    SCOPED_TRACE(name);
    const fs::path scene = write_scene(dir / name, scheme, "checkpoint_every = 20", single);
    const fs::path straight = dir / name / "straight", serial = dir / name / "serial";
    expect_run_done(straight, run_launcher(kSource, scene, straight, "--ranks 2", kOneThread));
    expect_run_done(serial, run_launcher(kSource, scene, serial, "", kOneThread));
    const std::string step = "00000040";
    const std::vector<unsigned char> gathered = populations(straight / "checkpoints" / ("fluid_" + step + ".h5"));
    EXPECT_FALSE(gathered.empty());
    EXPECT_TRUE(gathered == populations(serial / "checkpoints" / ("fluid_" + step + ".h5")))
        << "the checkpoint written by 2 ranks is not the serial run's store";
    const fs::path from = pair_of(straight, step, dir / name / "from40");
    for (const int ranks : {2, 3, 0}) {
      const fs::path out = dir / name / ("restarted_on_" + std::to_string(ranks));
      const std::string args =
          "--restart " + quoted(from.string()) + (ranks > 0 ? " --ranks " + std::to_string(ranks) : "");
      expect_run_done(out, run_launcher(kSource, scene, out, args, kOneThread));
      EXPECT_TRUE(contains(slurp(out / "fluid.log"), "restarted from")) << logs(out);
      const std::vector<std::string> files = h5_files(out);
      EXPECT_GE(files.size(), 5u) << logs(out);
      for (const std::string& f : files) EXPECT_EQ(compare_h5(straight, out, f), "") << f << ", restarted on " << ranks;
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// How many markers of the run's first sheet snapshot have a kernel (4 nodes along y from
/// floor(y) - 1, the lattice y = y_um / dx - 1/2: the plate at y = 0) that reaches nodes of
/// two blocks of `py` along a grid of kNy rows.
int straddling_y(const fs::path& run, int py, int kNy) {
  const auto d = read_datasets(run / "sheets_000000.h5");
  const auto it = d.find("position_um");
  if (it == d.end()) return -1;
  std::vector<int> owner(kNy);
  for (int r = 0; r < py; ++r) {
    const fluid::Slab s = fluid::slab_of(kNy, py, r);
    for (int y = s.z0; y < s.z0 + s.nz; ++y) owner[std::size_t(y)] = r;
  }
  int n = 0;
  for (std::size_t k = 1; k < it->second.values.size(); k += 3) {
    const int first = int(std::floor(it->second.values[k] / kDxUm - 0.5)) - 1;
    std::set<int> ranks;
    for (int i = 0; i < 4; ++i)
      if (first + i >= 0 && first + i < kNy) ranks.insert(owner[std::size_t(first + i)]);
    n += ranks.size() > 1;
  }
  return n;
}

// Blocks along y and z (fluid/mpi/block_halo.cpp) in a coupled run: the channel 16 rows high
// (the sheet's markers at y = -0.5 .. 8.5 cells), so that the markers have kernels across the
// block edge along y (at row 8 of 2 blocks) and along z (plane 15),
// so rank 0 sums samples of nodes of up to four ranks and each rank spreads onto its own.
// Every output of the fluid and of the solid on the process grids 2 x 2 (each coupling
// scheme) and 1 x 2 (y only; the serial scheme) is the serial run's, bit for bit; the
// checkpoint that the 2 x 2 blocks write (each its rows of its planes, parallel HDF5) holds
// the serial run's store, and restarts on 2 x 2 blocks as the run straight through.
TEST(MpiCoupled, MpiBlocksInYAndZMatchSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_coupled_blocks");
  for (const std::string scheme : {"serial", "parallel", "implicit"}) {
    SCOPED_TRACE(scheme + " scheme");
    const fs::path scene = write_scene(dir / scheme, scheme, "checkpoint_every = 20");
    {
      std::string text = slurp(scene);
      replace_in(text, "ny = 30", "ny = 16");
      std::ofstream(scene) << text;
    }
    const fs::path serial = dir / scheme / "serial";
    expect_run_done(serial, run_launcher(kSource, scene, serial, "", kOneThread));
    EXPECT_GT(straddling_y(serial, 2, 16), 0) << "no marker's kernel crosses the block edge along y";
    EXPECT_GT(straddling(serial, 2), 0) << "no marker's kernel crosses the block edge along z";
    std::vector<std::pair<int, int>> grids{{2, 2}};
    if (scheme == "serial") grids.push_back({2, 1});
    for (const auto& [py, pz] : grids) {
      const std::string name = "blocks_1_" + std::to_string(py) + "_" + std::to_string(pz);
      std::string text = slurp(scene);
      replace_in(text, "[run]\n", "[run]\nblocks = [1, " + std::to_string(py) + ", " + std::to_string(pz) + "]\n");
      const fs::path blocked = dir / scheme / (name + ".toml");
      std::ofstream(blocked) << text;
      const fs::path out = dir / scheme / name;
      expect_run_done(out, run_launcher(kSource, blocked, out, "--ranks " + std::to_string(py * pz), kOneThread));
      EXPECT_TRUE(contains(slurp(out / "fluid.log"), "blocks along y and z over " + std::to_string(py * pz)))
          << logs(out);
      std::size_t files = 0;
      EXPECT_EQ(compare_outputs(serial, out, &files), "") << name;
      const std::string step = "00000040";
      const std::vector<unsigned char> written = populations(out / "checkpoints" / ("fluid_" + step + ".h5"));
      EXPECT_FALSE(written.empty());
      EXPECT_TRUE(written == populations(serial / "checkpoints" / ("fluid_" + step + ".h5")))
          << name << ": the checkpoint written by the blocks is not the serial run's store";
      if (scheme != "serial" || py * pz != 4) continue;
      const fs::path from = pair_of(out, step, dir / scheme / (name + "_from40"));
      const fs::path restarted = dir / scheme / (name + "_restarted");
      expect_run_done(restarted,
                      run_launcher(kSource, blocked, restarted, "--restart " + quoted(from.string()) + " --ranks 4",
                                   kOneThread));
      EXPECT_TRUE(contains(slurp(restarted / "fluid.log"), "restarted from")) << logs(restarted);
      for (const std::string& f : h5_files(restarted)) EXPECT_EQ(compare_h5(out, restarted, f), "") << f;
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

// Parallel HDF5 (each rank writes its own range of the store, no rank gathers it): a
// checkpoint written on 3 ranks restarts on 2, on 1 and in one process, and one written in
// one process restarts on 3, 2 and 1 ranks, each ending with the outputs of the run straight
// through bit for bit; the checkpoints of 3 ranks and of one process hold the same store.
TEST(MpiCoupled, ParallelCheckpointRestartsOnAnyRankCount) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_phdf5_restart");
  const fs::path scene = write_scene(dir, "serial", "checkpoint_every = 20");
  const std::string step = "00000040";
  const fs::path on3 = dir / "written_on_3", alone = dir / "written_alone";
  expect_run_done(on3, run_launcher(kSource, scene, on3, "--ranks 3", kOneThread));
  expect_run_done(alone, run_launcher(kSource, scene, alone, "", kOneThread));
  const std::vector<unsigned char> store = populations(on3 / "checkpoints" / ("fluid_" + step + ".h5"));
  EXPECT_FALSE(store.empty());
  EXPECT_TRUE(store == populations(alone / "checkpoints" / ("fluid_" + step + ".h5")))
      << "the checkpoint written by 3 ranks is not the one-process run's store";
  for (const auto& [written, ranks_list] :
       {std::pair<fs::path, std::vector<int>>{on3, {2, 1, 0}}, {alone, {3, 2, 1}}}) {
    const fs::path from = pair_of(written, step, dir / ("from_" + written.filename().string()));
    for (const int ranks : ranks_list) {
      SCOPED_TRACE(written.filename().string() + ", restarted " +
                   (ranks > 0 ? "on " + std::to_string(ranks) + " ranks" : "in one process"));
      const fs::path out = dir / (written.filename().string() + "_restarted_" + std::to_string(ranks));
      const std::string args =
          "--restart " + quoted(from.string()) + (ranks > 0 ? " --ranks " + std::to_string(ranks) : "");
      expect_run_done(out, run_launcher(kSource, scene, out, args, kOneThread));
      EXPECT_TRUE(contains(slurp(out / "fluid.log"), "restarted from")) << logs(out);
      const std::vector<std::string> files = h5_files(out);
      EXPECT_GE(files.size(), 5u) << logs(out);
      for (const std::string& f : files) EXPECT_EQ(compare_h5(alone, out, f), "") << f;
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The per-rank peaks of the fluid's end-of-run line (peak_memory_line), or its one peak.
std::vector<double> peaks_of(const fs::path& run) {
  const std::string log = slurp(run / "fluid.log");
  std::vector<double> v;
  const std::string one = "fluid: peak memory ", per = "; per rank:";
  const std::size_t at = log.find(one);
  if (at == std::string::npos) return v;
  const std::size_t eol = log.find('\n', at);
  const std::string line = log.substr(at, eol == std::string::npos ? std::string::npos : eol - at);
  const std::size_t list = line.find(per);
  std::istringstream in(list == std::string::npos ? line.substr(one.size()) : line.substr(list + per.size()));
  double x = 0;
  while (in >> x) v.push_back(x);
  return v;
}

// No rank holds the whole grid: on 4 ranks each rank's peak memory over a run of 4 steps
// that writes field snapshots at steps 0, 2 and 4 and a checkpoint at step 2 (the largest
// resident set, reached while one of them is written: the populations and the snapshot's
// fields of its planes) is at most 0.35 of the one-process run's. A grid of 2.3 million
// cells, so that the populations (350 MB in one process) dominate the processes' own memory.
TEST(MpiCoupled, NoRankHoldsTheWholeGrid) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_memory");
  std::string s = slurp(kSource / "scenes" / "coupled_small.toml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"nx = 40", "nx = 160"},
           {"ny = 30", "ny = 120"},
           {"nz = 30", "nz = 120"},
           {"steps = 200", "steps = 4"},
           {"monitor_every = 50", "monitor_every = 2"},
           {"fields_every = 50", "fields_every = 2"},
           {"sheets_every = 50", "sheets_every = 2"},
           {"resend_after_s = 0.5", "resend_after_s = 0.05"},
           {"peer_timeout_s = 10", "peer_timeout_s = 120"},
           {"rigid_steps = 50", "rigid_steps = 2\ncheckpoint_every = 2"}})
    replace_in(s, from, to);
  fs::create_directories(dir);
  const fs::path scene = dir / "large.toml";
  std::ofstream(scene) << s;
  const fs::path alone = dir / "alone", on4 = dir / "ranks4";
  expect_run_done(alone, run_launcher(kSource, scene, alone, "", kOneThread));
  expect_run_done(on4, run_launcher(kSource, scene, on4, "--ranks 4", kOneThread));
  EXPECT_TRUE(fs::exists(on4 / "checkpoints" / "fluid_00000002.h5")) << logs(on4);
  EXPECT_TRUE(fs::exists(on4 / "fields_000004.h5")) << logs(on4);
  const std::vector<double> one = peaks_of(alone), ranks = peaks_of(on4);
  ASSERT_EQ(one.size(), 1u) << logs(alone);
  ASSERT_EQ(ranks.size(), 4u) << logs(on4);
  for (std::size_t r = 0; r < ranks.size(); ++r)
    EXPECT_LE(ranks[r], 0.35 * one[0]) << "rank " << r << ": " << ranks[r] << " MiB, one process " << one[0] << " MiB";
  if (!HasFailure()) fs::remove_all(dir);
}

/// The fluid rank `rank` among the children of mpirun (`mpirun_pid`): its pid, or 0.
pid_t rank_of(pid_t mpirun_pid, int rank) {
  const std::string key = "OMPI_COMM_WORLD_RANK=" + std::to_string(rank) + '\0';
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = slurp(e.path() / "stat");
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    std::string state;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid == mpirun_pid && contains(slurp(e.path() / "environ"), key)) return pid_t(std::stol(name));
  }
  return 0;
}

// One fluid rank killed in a coupled run over 2 ranks: mpirun ends the fluid, the solid
// notices the silent fluid within its peer timeout and writes its checkpoint, and the
// launcher ends with an error that names the rank and the signal: no hang.
TEST(MpiCoupled, MpiKilledRankStopsTheCoupledRun) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_coupled_killed");
  const fs::path scene = write_scene(dir, "serial");
  std::string text = slurp(scene);
  replace_in(text, "steps = 60", "steps = 1000000");
  replace_in(text, "fields_every = 30", "fields_every = 0");
  replace_in(text, "planes_every = 20", "planes_every = 0");
  replace_in(text, "sheets_every = 30", "sheets_every = 0");
  replace_in(text, "monitor_every = 20", "monitor_every = 1000");
  replace_in(text, "peer_timeout_s = 10", "peer_timeout_s = 3");
  std::ofstream(scene) << text;
  const fs::path out = dir / "out";
  int status = -1;
  std::thread launcher([&] { status = run_launcher(kSource, scene, out, "--ranks 2", kOneThread); });
  const auto start = std::chrono::steady_clock::now();
  const auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  pid_t victim = 0;
  // Running: past the rigid steps (the release line), rank 1 found under mpirun.
  while (since() < 60 && (victim == 0 || !contains(slurp(out / "fluid.log"), "sheet released"))) {
    const std::string pid = slurp(out / "fluid.pid");
    if (!pid.empty()) victim = rank_of(pid_t(std::stol(pid)), 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_NE(victim, 0) << logs(out);
  const double killed_at = since();
  ASSERT_EQ(kill(victim, SIGKILL), 0);
  launcher.join();
  const double took = since() - killed_at;
  EXPECT_NE(status, 0) << logs(out);
  EXPECT_LT(took, 60.0) << "the run took " << took << " s to end after the kill";
  const std::string said = slurp(out / "launcher.log");
  EXPECT_TRUE(contains(said, "rank 1") && contains(said, "signal 9")) << said;
  EXPECT_EQ(slurp(out / "solid.exit"), "4\n") << logs(out);
  EXPECT_TRUE(fs::exists(out / "checkpoints")) << logs(out);
  RecordProperty("seconds_from_kill_to_end", std::to_string(took));
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace cosim::test
