// The fluid's grid over MPI ranks (DESIGN 8, fluid/mpi/): a fluid-only scene on 1 to 4 ranks
// (launch/mpirun-local.sh: loopback only, more ranks than cores allowed) writes the same
// HDF5 outputs as the serial run, bit for bit; a decomposition that cannot be built is
// refused in one line, for a fluid-only or a coupled scene (coupled scenes over ranks:
// test_mpi_coupled.cpp); a flow that runs away stops as in the serial run; a killed rank stops
// the run with a reason instead of a hang.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/run_compare.hpp"

namespace cosim::test {
namespace {

const fs::path kSource = COSIM_SOURCE_DIR;
const std::string kFluid = FLUID_EXE;

std::string mpirun(int ranks) {
  return "OMP_NUM_THREADS=1 bash " + quoted((kSource / "launch" / "mpirun-local.sh").string()) + " " +
         std::to_string(ranks) + " ";
}

bool have_mpirun() { return std::system("command -v mpirun >/dev/null 2>&1") == 0; }

/// The scene `base` with `replace` pairs substituted, written into `dir`.
fs::path variant(const fs::path& base, const fs::path& dir, const std::vector<std::pair<std::string, std::string>>& replace) {
  std::string text = slurp(base);
  for (const auto& [from, to] : replace) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  const fs::path out = dir / base.filename();
  std::ofstream(out) << text;
  return out;
}

/// Every output of `scene` on 1 to `max_ranks` ranks against the serial run's: identical bits.
void expect_ranks_match_serial(const fs::path& scene, const fs::path& dir, int max_ranks = 4) {
  const fs::path serial = dir / "serial";
  const RunResult s = run_command(quoted(kFluid) + " " + quoted(scene.string()) + " --quiet --output " +
                                      quoted(serial.string()),
                                  dir / "serial_log");
  ASSERT_EQ(s.status, 0) << s.err;
  for (int ranks = 1; ranks <= max_ranks; ++ranks) {
    const fs::path out = dir / ("ranks" + std::to_string(ranks));
    const RunResult m = run_command(mpirun(ranks) + quoted(kFluid) + " " + quoted(scene.string()) +
                                        " --quiet --output " + quoted(out.string()),
                                    dir / ("log" + std::to_string(ranks)));
    ASSERT_EQ(m.status, 0) << ranks << " ranks:\n" << m.out << m.err;
    if (ranks > 1) {
      EXPECT_TRUE(contains(m.out, "slabs along z over " + std::to_string(ranks) + " MPI ranks")) << m.out;
    }
    std::size_t files = 0;
    EXPECT_EQ(compare_outputs(serial, out, &files), "") << ranks << " ranks";
    // monitor.h5, 3 field snapshots, 5 snapshots of each of the 2 y planes.
    EXPECT_EQ(files, 14u) << ranks << " ranks";
  }
}

TEST(Mpi, MpiFluidMatchesSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_fluid");
  const fs::path channel = kSource / "tests" / "scenes" / "mpi_channel.toml";
  {
    SCOPED_TRACE("periodic span, double store");
    expect_ranks_match_serial(channel, dir / "periodic");
  }
  {
    // The first and last slabs' own faces (a moving wall, free slip), the mixed mode's float store.
    SCOPED_TRACE("walls across the span, mixed mode's float store");
    fs::create_directories(dir / "walls");
    const fs::path walls = variant(channel, dir / "walls",
                                   {{"z_min = \"periodic\"", "z_min = \"wall\""},
                                    {"z_max = \"periodic\"", "z_max = \"free_slip\""},
                                    {"threads = 1", "threads = 1\nprecision = \"mixed\""},
                                    {"[output]", "[wall_velocity]\nz_min = [0.02, 0.0, 0.0]\n\n[output]"}});
    expect_ranks_match_serial(walls, dir / "walls");
  }
  {
    // Copy-type x and y faces (periodic) driven by a body force, the mixed mode's float store's compact
    // rows (nx = 32), two grids: a block's step sends its edge planes with their x and y ghosts
    // while it collides its interior planes (fluid/solver/overlapped_step.cpp).
    SCOPED_TRACE("periodic x and y, mixed mode's float store, compact rows, two-grid");
    fs::create_directories(dir / "periodic_xy");
    const fs::path xy = variant(channel, dir / "periodic_xy",
                                {{"nx = 24", "nx = 32"},
                                 {"reynolds = 5\nreference_length_um = 1.0", "tau = 0.8"},
                                 {"[inlet]\nu_max = 0.05\nprofile = \"blasius\"\nboundary_layer_um = 0.5\n",
                                  "[body_force]\nx = 0.00002\ny = 0.00001\nz = 0.000005\n"},
                                 {"x_min = \"inlet\"", "x_min = \"periodic\""},
                                 {"x_max = \"outflow\"", "x_max = \"periodic\""},
                                 {"y_min = \"wall\"", "y_min = \"periodic\""},
                                 {"y_max = \"free_slip\"", "y_max = \"periodic\""},
                                 {"threads = 1", "threads = 1\nprecision = \"mixed\"\npropagation = \"two-grid\""}});
    expect_ranks_match_serial(xy, dir / "periodic_xy");
  }
  {
    // The two-grid propagation (the cases above step in place, the default: each block's one
    // grid, its halo planes exchanged in the state's arrangement of the step, Canonical or
    // Swapped, fill_swapped_ghosts): a block with two grids sends its edge planes while it
    // collides its interior planes (fluid/solver/overlapped_step.cpp).
    SCOPED_TRACE("two-grid, periodic span, double store");
    fs::create_directories(dir / "two_grid");
    const fs::path two_grid = variant(channel, dir / "two_grid", {{"threads = 1", "threads = 1\npropagation = \"two-grid\""}});
    expect_ranks_match_serial(two_grid, dir / "two_grid");
  }
  {
    SCOPED_TRACE("two-grid, walls across the span, mixed mode's float store");
    fs::create_directories(dir / "two_grid_walls");
    const fs::path walls = variant(dir / "walls" / "mpi_channel.toml", dir / "two_grid_walls",
                                   {{"precision = \"mixed\"", "precision = \"mixed\"\npropagation = \"two-grid\""}});
    expect_ranks_match_serial(walls, dir / "two_grid_walls");
  }
}

/// Every output of `scene` on the process grids [1, 2, 1], [1, 1, 2] and [1, 2, 2] ([run]
/// blocks) against the serial run's: identical bits.
void expect_blocks_match_serial(const fs::path& scene, const fs::path& dir,
                                std::vector<std::pair<int, int>> grids = {{2, 1}, {1, 2}, {2, 2}}) {
  fs::create_directories(dir);
  const fs::path serial = dir / "serial";
  const RunResult s = run_command(quoted(kFluid) + " " + quoted(scene.string()) + " --quiet --output " +
                                      quoted(serial.string()),
                                  dir / "serial_log");
  ASSERT_EQ(s.status, 0) << s.err;
  for (const auto& [py, pz] : grids) {
    const std::string name = "blocks_1_" + std::to_string(py) + "_" + std::to_string(pz);
    fs::create_directories(dir / name);
    const fs::path blocked = variant(scene, dir / name,
                                     {{"threads = 1", "threads = 1\nblocks = [1, " + std::to_string(py) + ", " +
                                                          std::to_string(pz) + "]"}});
    const fs::path out = dir / name / "out";
    const RunResult m = run_command(mpirun(py * pz) + quoted(kFluid) + " " + quoted(blocked.string()) +
                                        " --quiet --output " + quoted(out.string()),
                                    dir / name / "log");
    ASSERT_EQ(m.status, 0) << name << ":\n" << m.out << m.err;
    if (py > 1) {
      EXPECT_TRUE(contains(m.out, "blocks along y and z over " + std::to_string(py * pz) + " MPI ranks")) << m.out;
    }
    std::size_t files = 0;
    EXPECT_EQ(compare_outputs(serial, out, &files), "") << name;
    // monitor.h5, 3 field snapshots, 5 snapshots of each of the 2 y planes.
    EXPECT_EQ(files, 14u) << name;
  }
}

// Blocks along y and z (fluid/mpi/block_halo.cpp: the rows along y, then the planes along z
// with the rows' ghosts, so that the y-z edge ghosts get the diagonal block's cells): the
// process grids 1 x 2, 2 x 1 and 2 x 2 write the serial run's outputs bit for bit (monitor
// rows, field snapshots with the vorticity across the block edges, y planes held by one
// block of two). The channel's every boundary kind, in place, double store (the inlet's
// Blasius profile across the blocks along y; the plate and free slip at the ends along y);
// then y periodic across the ranks, walls along z (a moving one), two grids, the mixed
// mode's float store (1 x 2 and 2 x 2; slabs alone: MpiFluidMatchesSerialBitForBit);
// then the single mode (float arithmetic) in place, compact rows (nx = 32), on 2 x 2 blocks.
TEST(Mpi, MpiBlocksInYAndZMatchSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_blocks_yz");
  const fs::path channel = kSource / "tests" / "scenes" / "mpi_channel.toml";
  const std::vector<std::pair<std::string, std::string>> short_run{{"steps = 40", "steps = 20"},
                                                                    {"fields_every = 20", "fields_every = 10"},
                                                                    {"planes_every = 10", "planes_every = 5"}};
  {
    SCOPED_TRACE("channel, in place, double store");
    fs::create_directories(dir / "channel");
    expect_blocks_match_serial(variant(channel, dir / "channel", short_run), dir / "channel");
  }
  {
    SCOPED_TRACE("periodic y across ranks, walls along z, two-grid, mixed");
    fs::create_directories(dir / "periodic_y");
    auto replace = short_run;
    replace.insert(replace.end(), {{"[inlet]\nu_max = 0.05\nprofile = \"blasius\"\nboundary_layer_um = 0.5\n",
                                    "[body_force]\nx = 0.00002\ny = 0.00001\nz = 0.000005\n"},
                                   {"reynolds = 5\nreference_length_um = 1.0", "tau = 0.8"},
                                   {"x_min = \"inlet\"", "x_min = \"periodic\""},
                                   {"x_max = \"outflow\"", "x_max = \"periodic\""},
                                   {"y_min = \"wall\"", "y_min = \"periodic\""},
                                   {"y_max = \"free_slip\"", "y_max = \"periodic\""},
                                   {"z_min = \"periodic\"", "z_min = \"wall\""},
                                   {"z_max = \"periodic\"", "z_max = \"free_slip\""},
                                   {"threads = 1", "threads = 1\nprecision = \"mixed\"\npropagation = \"two-grid\""},
                                   {"[output]", "[wall_velocity]\nz_min = [0.02, 0.0, 0.0]\n\n[output]"}});
    expect_blocks_match_serial(variant(channel, dir / "periodic_y", replace), dir / "periodic_y", {{2, 1}, {2, 2}});
  }
  {
    SCOPED_TRACE("single mode, in place, compact rows");
    fs::create_directories(dir / "single");
    auto replace = short_run;
    replace.insert(replace.end(), {{"nx = 24", "nx = 32"}, {"threads = 1", "threads = 1\nprecision = \"single\""}});
    expect_blocks_match_serial(variant(channel, dir / "single", replace), dir / "single", {{2, 2}});
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The in-place propagation named in the scene (it is the default: the runs above that do
/// not name two-grid step in place): the fluid-only channel on 1 to 3 ranks, each block's one
/// grid, writes the serial run's outputs bit for bit. The coupled runs in place:
/// MpiCoupled.MpiInPlaceMatchesSerialBitForBit (test_mpi_coupled.cpp).
TEST(Mpi, MpiInPlaceMatchesSerialBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_in_place");
  fs::create_directories(dir);
  const fs::path channel = variant(kSource / "tests" / "scenes" / "mpi_channel.toml", dir,
                                   {{"threads = 1", "threads = 1\npropagation = \"in-place\""}});
  expect_ranks_match_serial(channel, dir, 3);
  if (!HasFailure()) fs::remove_all(dir);
}

// Parallel HDF5 (fluid/io/field_writer.cpp, common/hdf5/hdf5_handle.hpp): every rank writes
// its own planes of each snapshot into the file one process writes. 4 ranks hold slabs of
// 2 planes between walls (8 planes, the fewest a wall allows: the one-sided differences
// beside a wall reach the neighbour's second plane) and of 1 or 2 across a periodic span of
// 5 (the differences reach the periodic images on the ranks two away). Every dataset of
// the monitor and of each field and plane snapshot written by 1, 2, 3 and 4 ranks is the
// one-process file's, bit for bit.
TEST(Mpi, ParallelHdf5SnapshotMatchesSerialFile) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_phdf5");
  const fs::path channel = kSource / "tests" / "scenes" / "mpi_channel.toml";
  const std::vector<std::pair<std::string, std::string>> thin{{"steps = 40", "steps = 10"},
                                                               {"fields_every = 20", "fields_every = 5"},
                                                               {"planes_every = 10", "planes_every = 5"}};
  for (const bool walls : {true, false}) {
    SCOPED_TRACE(walls ? "walls across the span" : "periodic span");
    const fs::path case_dir = dir / (walls ? "walls" : "periodic");
    fs::create_directories(case_dir);
    std::vector<std::pair<std::string, std::string>> replace = thin;
    replace.push_back({"nz = 13", walls ? "nz = 8" : "nz = 5"});
    if (walls) {
      replace.push_back({"z_min = \"periodic\"", "z_min = \"wall\""});
      replace.push_back({"z_max = \"periodic\"", "z_max = \"free_slip\""});
    }
    const fs::path scene = variant(channel, case_dir, replace);
    const fs::path serial = case_dir / "serial";
    const RunResult s = run_command(quoted(kFluid) + " " + quoted(scene.string()) + " --quiet --output " +
                                        quoted(serial.string()),
                                    case_dir / "serial_log");
    ASSERT_EQ(s.status, 0) << s.err;
    for (int ranks = 1; ranks <= 4; ++ranks) {
      const fs::path out = case_dir / ("ranks" + std::to_string(ranks));
      const RunResult m = run_command(mpirun(ranks) + quoted(kFluid) + " " + quoted(scene.string()) +
                                          " --quiet --output " + quoted(out.string()),
                                      case_dir / ("log" + std::to_string(ranks)));
      ASSERT_EQ(m.status, 0) << ranks << " ranks:\n" << m.out << m.err;
      if (ranks > 1) {
        EXPECT_TRUE(contains(m.out, "each rank writes its own planes of the snapshots and checkpoints (parallel HDF5)"))
            << m.out;
        EXPECT_TRUE(contains(m.out, "; per rank:")) << m.out;
      }
      std::size_t files = 0;
      EXPECT_EQ(compare_outputs(serial, out, &files), "") << ranks << " ranks";
      // monitor.h5, 3 field snapshots, 3 snapshots of each of the 2 y planes.
      EXPECT_EQ(files, 10u) << ranks << " ranks";
      // No part file left behind.
      for (const auto& e : fs::directory_iterator(out))
        EXPECT_EQ(e.path().string().find(".part"), std::string::npos) << e.path();
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(Mpi, MpiBlocksThatCannotBeBuiltAreRefusedInOneLine) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_blocks");
  const fs::path channel = kSource / "tests" / "scenes" / "mpi_channel.toml";
  // Three blocks asked for, two ranks given.
  const fs::path three = variant(channel, dir, {{"threads = 1", "threads = 1\nblocks = [1, 1, 3]"}});
  const RunResult r = run_command(mpirun(2) + quoted(kFluid) + " " + quoted(three.string()) + " --output " +
                                      quoted((dir / "out").string()),
                                  dir / "log");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_TRUE(contains(r.err, "run.blocks = [1, 1, 3]: 3 blocks for 2 MPI ranks")) << r.err;
  // Said once (rank 0), not once per rank.
  std::size_t said = 0;
  for (std::size_t at = 0; (at = r.err.find("3 blocks for 2 MPI ranks", at)) != std::string::npos; ++at) ++said;
  EXPECT_EQ(said, 1u) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "monitor.h5"));
  // Blocks along x are refused when the scene is read, with its line.
  fs::create_directories(dir / "x");
  const fs::path along_x = variant(channel, dir / "x", {{"threads = 1", "threads = 1\nblocks = [2, 1, 1]"}});
  const RunResult x = run_command(quoted(kFluid) + " " + quoted(along_x.string()) + " --check", dir / "log_x");
  EXPECT_EQ(x.status, 2);
  EXPECT_TRUE(contains(x.err, "run.blocks = [2, 1, 1]: blocks along y and z only: [1, py, pz]")) << x.err;
  EXPECT_EQ(lines(x.err), 1u) << x.err;
  // A coupled scene's grid the same (its fluid ends before it waits for a solid).
  fs::create_directories(dir / "coupled");
  const fs::path coupled =
      variant(kSource / "scenes" / "coupled_small.toml", dir / "coupled", {{"[run]\n", "[run]\nblocks = [1, 1, 3]\n"}});
  const RunResult c = run_command(mpirun(2) + quoted(kFluid) + " " + quoted(coupled.string()) + " --quiet --output " +
                                      quoted((dir / "coupled_out").string()),
                                  dir / "log_coupled");
  EXPECT_EQ(c.status, 2) << c.err;
  const std::string what = "run.blocks = [1, 1, 3]: 3 blocks for 2 MPI ranks";
  EXPECT_TRUE(contains(c.err, what)) << c.err;
  EXPECT_EQ(c.err.find(what), c.err.rfind(what)) << "said more than once:\n" << c.err;
  EXPECT_FALSE(fs::exists(dir / "coupled_out" / "monitor.h5"));
}

/// The first line of `text` that holds `what` ("" if none).
std::string line_with(const std::string& text, const std::string& what) {
  const auto at = text.find(what);
  if (at == std::string::npos) return {};
  const auto begin = text.rfind('\n', at), end = text.find('\n', at);
  return text.substr(begin == std::string::npos ? 0 : begin + 1, end == std::string::npos ? std::string::npos : end - begin - 1);
}

// A flow that runs away stops on 3 ranks as it stops alone: exit 3, the same line (step,
// cell, quantity), the same monitor rows; caught by the monitor's summary of the gathered
// grid (a row every step) and by the watchdog's kernel extrema, reduced over the ranks
// (rows far apart).
TEST(Mpi, MpiUnhealthyFlowStopsAsTheSerialRun) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_unhealthy");
  const fs::path scene = kSource / "tests" / "scenes" / "runaway_force.toml";
  for (const std::string every : {"1", "1000"}) {
    SCOPED_TRACE("--monitor-every " + every);
    const std::string args = quoted(scene.string()) + " --quiet --monitor-every " + every + " --output ";
    const fs::path a = dir / ("serial_" + every), b = dir / ("ranks3_" + every);
    const RunResult s = run_command(quoted(kFluid) + " " + args + quoted(a.string()), a / "log");
    const RunResult m = run_command(mpirun(3) + quoted(kFluid) + " " + args + quoted(b.string()), b / "log");
    EXPECT_EQ(s.status, 3) << s.err;
    EXPECT_EQ(m.status, 3) << m.err;
    const std::string said = line_with(s.err, "fluid: unhealthy flow, run stopped: step ");
    EXPECT_FALSE(said.empty()) << s.err;
    EXPECT_EQ(line_with(m.err, "fluid: unhealthy flow"), said) << m.err;
    EXPECT_EQ(compare_h5(a, b, "monitor.h5"), "");
  }
}

/// The fluid ranks of the run whose command line holds `marker`: pid by rank.
std::vector<pid_t> ranks_of(const std::string& marker, int rank) {
  std::vector<pid_t> out;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string cmdline = slurp(e.path() / "cmdline"), env = slurp(e.path() / "environ");
    for (char& c : cmdline) if (c == '\0') c = ' ';
    if (!contains(cmdline, marker) || !contains(cmdline, kFluid)) continue;
    if (contains(cmdline, "mpirun") || contains(cmdline, "bash")) continue;
    const std::string key = std::string("OMPI_COMM_WORLD_RANK=") + std::to_string(rank);
    if (env.find(key + '\0') != std::string::npos) out.push_back(pid_t(std::stol(name)));
  }
  return out;
}

TEST(Mpi, MpiKilledRankStopsTheRun) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun is not installed (launch/bootstrap.sh)";
  const fs::path dir = scratch("mpi_killed");
  const fs::path out = dir / "out_killed_rank";
  const fs::path channel = kSource / "tests" / "scenes" / "mpi_channel.toml";
  // Long enough to be running when the rank is killed (minutes), with no snapshots.
  const std::string cmd = mpirun(2) + quoted(kFluid) + " " + quoted(channel.string()) +
                          " --quiet --steps 100000000 --fields-every 0 --monitor-every 100000 --output " +
                          quoted(out.string());
  const fs::path status = dir / "status";
  const std::string bg = "(timeout 120 sh -c " + quoted(cmd + " >" + quoted((dir / "stdout").string()) + " 2>" +
                                                        quoted((dir / "stderr").string())) +
                         "; echo $? >" + quoted((dir / "status.tmp").string()) + "; mv " +
                         quoted((dir / "status.tmp").string()) + " " + quoted(status.string()) + ") &";
  ASSERT_EQ(std::system(bg.c_str()), 0);
  const auto start = std::chrono::steady_clock::now();
  const auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  std::vector<pid_t> victim;
  // Running: rank 0 has written the step-0 monitor row.
  while (since() < 60 && (victim.empty() || !fs::exists(out / "monitor.h5"))) {
    victim = ranks_of(out.string(), 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(victim.size(), 1u) << slurp(dir / "stderr");
  ASSERT_FALSE(fs::exists(status)) << "the run ended before a rank was killed: " << slurp(dir / "stderr");
  const double killed_at = since();
  ASSERT_EQ(kill(victim[0], SIGKILL), 0);
  while (since() < 110 && !fs::exists(status)) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(status)) << "no end 110 s after the start";
  const int code = std::stoi(slurp(status));
  const std::string err = slurp(dir / "stderr");
  EXPECT_NE(code, 0) << err;
  EXPECT_NE(code, 124) << "timeout 120 had to stop it: a hang\n" << err;
  // OpenMPI's reason names the rank and the signal.
  EXPECT_TRUE(contains(err, "rank 1") && contains(err, "signal 9")) << err;
  EXPECT_TRUE(ranks_of(out.string(), 0).empty()) << "rank 0 still runs";
  RecordProperty("seconds_from_kill_to_end", std::to_string(since() - killed_at));
}

}  // namespace
}  // namespace cosim::test
