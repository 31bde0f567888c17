// Determinism and fault tolerance of a coupled run (DESIGN 2.2-2.4; issue "Replay, logs,
// coupled checkpoints, fault tolerance"): two processes through launch/run-coupled.sh on a
// small scene that writes every kind of output (monitor.h5, solid.h5, whole-grid and
// y-plane field snapshots, sheet snapshots). Every dataset of every HDF5 output is
// compared bit for bit (tests/support/run_compare.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "fluid/ib/immersed_boundary.hpp"
#include "fluid/lattice/grid_layout.hpp"
#include "fluid/solver/fluid_solver.hpp"
#include "tests/support/run_compare.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::compare_outputs;
using cosim::test::expect_run_done;
using cosim::test::logs;
using cosim::test::replace_in;
using cosim::test::run_launcher;
using cosim::test::scratch;
using cosim::test::slurp;

const fs::path kSource = COSIM_SOURCE_DIR;

/// scenes/coupled_small.toml, shortened to 120 LB steps (40 rigid), with plane and sheet
/// snapshots added and a short resend interval (a lost message costs 50 ms, not 0.5 s).
/// `checkpoints`: 1000 LB steps instead, checkpoints every 100, snapshots every 200 and a
/// peer timeout of 3 s (the survivor of a killed peer gives up quickly).
fs::path write_scene(const fs::path& dir, bool checkpoints = false, const std::string& scheme = "serial") {
  std::string s = slurp(kSource / "scenes" / "coupled_small.toml");
  const auto set = [&s](const std::string& from, const std::string& to) { replace_in(s, from, to); };
  set("steps = 200", "steps = 120");
  set("rigid_steps = 50", "rigid_steps = 40");
  set("fields_every = 50", "fields_every = 60\nplanes_every = 40\nplanes_y = [0.5]");
  set("sheets_every = 50", "sheets_every = 40");
  set("resend_after_s = 0.5", "resend_after_s = 0.05");
  if (checkpoints) {
    set("steps = 120", "steps = 1000");
    set("fields_every = 60", "fields_every = 500");
    set("planes_every = 40", "planes_every = 200");
    set("sheets_every = 40", "sheets_every = 200");
    set("peer_timeout_s = 10", "peer_timeout_s = 3\ncheckpoint_every = 100");
  }
  // Another scheme (protocol/README.md 13, 14); the implicit one with checkpoints every 40 steps.
  if (scheme == "implicit") set("rigid_steps = 40", "rigid_steps = 40\nscheme = \"implicit\"\ncheckpoint_every = 40");
  else if (scheme != "serial") set("rigid_steps = 40", "rigid_steps = 40\nscheme = \"" + scheme + "\"");
  const fs::path scene = dir / "small.toml";
  std::ofstream(scene) << s;
  return scene;
}

void expect_done(const fs::path& out, int status) { expect_run_done(out, status); }

TEST(Reproducibility, RunsAreBitIdentical) {
  const fs::path dir = scratch("bit_identical");
  const fs::path scene = write_scene(dir);
  const fs::path a = dir / "a", b = dir / "b", one = dir / "one_thread";
  expect_done(a, run_launcher(kSource, scene, a));
  expect_done(b, run_launcher(kSource, scene, b));
  std::size_t files = 0;
  EXPECT_EQ(compare_outputs(a, b, &files), "");
  // The reductions do not depend on the number of threads either (fluid/observables/flow_monitor.cpp
  // adds its row sums in row order): one OpenMP thread gives the same bits.
  expect_done(one, run_launcher(kSource, scene, one, "", "OMP_NUM_THREADS=1"));
  EXPECT_EQ(compare_outputs(a, one), "") << "1 thread and the default differ";
  // monitor.h5, solid.h5, 3 field snapshots, 4 plane snapshots, 4 sheet snapshots
  EXPECT_GE(files, 13u) << "not every kind of output was written";
  std::printf("%zu HDF5 files, every dataset identical bit for bit\n", files);
  if (!HasFailure()) fs::remove_all(dir);
}

/// The "injected faults: dropped N, duplicated N, reordered N, delayed N" counts of a log,
/// summed over its lines.
std::array<long long, 4> injected(const std::string& log) {
  static const std::regex re(
      R"(injected faults: dropped ([0-9]+), duplicated ([0-9]+), reordered ([0-9]+), delayed ([0-9]+))");
  std::array<long long, 4> n{0, 0, 0, 0};
  for (std::sregex_iterator it(log.begin(), log.end(), re), end; it != end; ++it)
    for (std::size_t k = 0; k < 4; ++k) n[k] += std::stoll((*it)[k + 1].str());
  return n;
}

TEST(Reproducibility, LossyTransportGivesIdenticalResults) {
  const fs::path dir = scratch("lossy");
  const fs::path scene = write_scene(dir);
  const fs::path clean = dir / "clean", lossy = dir / "lossy";
  expect_done(clean, run_launcher(kSource, scene, clean));
  // 3 % of every side's messages dropped, 3 % duplicated, 3 % reordered, 3 % delayed by
  // 20 ms (each side its own seeded stream; protocol/fault_injection.hpp).
  expect_done(lossy, run_launcher(kSource, scene, lossy, "",
                                  "COSIM_FAULTS=drop=0.03,duplicate=0.03,reorder=0.03,"
                                  "delay=0.03,delay_ms=20,seed=11"));
  const std::string fluid_log = slurp(lossy / "fluid.log"), solid_log = slurp(lossy / "solid.log");
  const auto f = injected(fluid_log), s = injected(solid_log);
  std::printf("injected: fluid dropped %lld, duplicated %lld, reordered %lld, delayed %lld; "
              "solid dropped %lld, duplicated %lld, reordered %lld, delayed %lld\n",
              f[0], f[1], f[2], f[3], s[0], s[1], s[2], s[3]);
  // Each kind of fault happened (on at least one side), so the run proves something.
  for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(f[k] + s[k], 0) << "fault kind " << k << "\n" << logs(lossy);
  EXPECT_EQ(compare_outputs(clean, lossy), "") << logs(lossy);
  if (!HasFailure()) fs::remove_all(dir);
}

/// The implicit scheme's sub-iterations through the same faults, and a restart from its
/// checkpoint of step 80 (taken while step 80 is iterated: the solid keeps the step's start
/// and first sample, the fluid its committed state): both bit for bit the clean run.
TEST(Reproducibility, ImplicitSchemeIsBitIdenticalUnderFaultsAndRestart) {
  const fs::path dir = scratch("implicit");
  const fs::path scene = write_scene(dir, false, "implicit");
  const fs::path clean = dir / "clean", lossy = dir / "lossy", restarted = dir / "restarted", from = dir / "from80";
  expect_done(clean, run_launcher(kSource, scene, clean));
  EXPECT_NE(slurp(clean / "solid.log").find("solid: implicit scheme: 80 steps iterated"), std::string::npos)
      << logs(clean);
  expect_done(lossy, run_launcher(kSource, scene, lossy, "",
                                  "COSIM_FAULTS=drop=0.03,duplicate=0.03,reorder=0.03,"
                                  "delay=0.03,delay_ms=20,seed=11"));
  const auto f = injected(slurp(lossy / "fluid.log")), s = injected(slurp(lossy / "solid.log"));
  for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(f[k] + s[k], 0) << "fault kind " << k << "\n" << logs(lossy);
  EXPECT_EQ(compare_outputs(clean, lossy), "") << logs(lossy);
  fs::create_directories(from);
  for (const char* side : {"fluid", "solid"})
    fs::copy_file(clean / "checkpoints" / (std::string(side) + "_00000080.h5"),
                  from / (std::string(side) + "_00000080.h5"));
  expect_done(restarted, run_launcher(kSource, scene, restarted, "--restart " + cosim::test::quoted(from.string())));
  EXPECT_NE(slurp(restarted / "solid.log").find("restarted from"), std::string::npos) << logs(restarted);
  for (const std::string& file : cosim::test::h5_files(restarted))
    EXPECT_EQ(cosim::test::compare_h5(clean, restarted, file), "") << file;
  if (!HasFailure()) fs::remove_all(dir);
}

/// The watchdog's retry in the implicit scheme (protocol/README.md 10, 13): a restart at
/// another A_T from a checkpoint taken while a step is iterated, as run-coupled.sh runs it
/// (--restart with --new-time-ratio). The checkpoint's solid_state_t(40, 0) holds the old A_T's
/// impulses; the fluid must spread, and commit, those of the iterate the solid goes on from.
/// Step 40 is the first free step, so the state at its start does not depend on A_T: the
/// retry must give every HDF5 output of a run at the new A_T from step 0, bit for bit. With
/// the default tolerance step 40 takes several iterates; with tolerance 0.5 its first iterate
/// converges (the fluid commits the step on the message that began it).
TEST(Reproducibility, ImplicitRetryAtNewTimeRatioIsConsistent) {
  const fs::path dir = scratch("implicit_retry");
  for (const std::string tolerance : {"", "0.5"}) {
    SCOPED_TRACE("coupling.tolerance = " + (tolerance.empty() ? std::string("1e-4 (default)") : tolerance));
    const fs::path case_dir = dir / (tolerance.empty() ? "default" : "loose");
    fs::create_directories(case_dir);
    fs::path scene = write_scene(case_dir, false, "implicit");
    if (!tolerance.empty()) {
      const std::string key = "scheme = \"implicit\"";
      std::string s = slurp(scene);
      s.replace(s.find(key), key.size(), key + "\ntolerance = " + tolerance);
      std::ofstream(scene) << s;
    }
    const fs::path a150 = case_dir / "a150", a300 = case_dir / "a300", retried = case_dir / "retried",
                   from = case_dir / "from40";
    expect_done(a150, run_launcher(kSource, scene, a150));
    expect_done(a300, run_launcher(kSource, scene, a300, "--time-ratio 300"));
    fs::create_directories(from);
    for (const char* side : {"fluid", "solid"})
      fs::copy_file(a150 / "checkpoints" / (std::string(side) + "_00000040.h5"),
                    from / (std::string(side) + "_00000040.h5"));
    expect_done(retried, run_launcher(kSource, scene, retried,
                                      "--restart " + cosim::test::quoted(from.string()) + " --new-time-ratio 300"));
    const std::string solid_log = slurp(retried / "solid.log");
    EXPECT_NE(solid_log.find("the checkpoint ran A_T = 150, this run A_T = 300"), std::string::npos) << logs(retried);
    EXPECT_NE(solid_log.find("step 40's first iterate computed again at A_T = 300"), std::string::npos)
        << logs(retried);
    std::size_t files = 0;
    for (const std::string& file : cosim::test::h5_files(retried)) {
      EXPECT_EQ(cosim::test::compare_h5(a300, retried, file), "") << file;
      ++files;
    }
    EXPECT_GE(files, 2u);  // solid.h5 and monitor.h5 at least
    // The loose case accepts every step's first iterate (step 40's included).
    if (!tolerance.empty()) {
      EXPECT_NE(solid_log.find("1 iterations a step on average, at most 1 "), std::string::npos) << logs(retried);
    }
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The parallel scheme (protocol/README.md 14) through the same faults: its message order has
/// both sides a message ahead, and fluid_state_t(0) and the spin-up's hand-over to be
/// recovered by the same resends; every HDF5 output equals the clean run's bit for bit.
TEST(Reproducibility, ParallelLossyTransportGivesIdenticalResults) {
  const fs::path dir = scratch("parallel_lossy");
  const fs::path scene = write_scene(dir, false, "parallel");
  const fs::path clean = dir / "clean", lossy = dir / "lossy";
  expect_done(clean, run_launcher(kSource, scene, clean));
  expect_done(lossy, run_launcher(kSource, scene, lossy, "",
                                  "COSIM_FAULTS=drop=0.03,duplicate=0.03,reorder=0.03,"
                                  "delay=0.03,delay_ms=20,seed=11"));
  const auto f = injected(slurp(lossy / "fluid.log")), s = injected(slurp(lossy / "solid.log"));
  std::printf("injected: fluid dropped %lld, duplicated %lld, reordered %lld, delayed %lld; "
              "solid dropped %lld, duplicated %lld, reordered %lld, delayed %lld\n",
              f[0], f[1], f[2], f[3], s[0], s[1], s[2], s[3]);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(f[k] + s[k], 0) << "fault kind " << k << "\n" << logs(lossy);
  EXPECT_EQ(compare_outputs(clean, lossy), "") << logs(lossy);
  if (!HasFailure()) fs::remove_all(dir);
}

/// The fault injector's documented maximum (protocol/fault_injection.hpp: drop = 0.5 on both
/// sides) cannot end a healthy run (docs/reliability.md): three seeds, each ends done on both
/// sides with every HDF5 output the clean run's bit for bit (with one resend_t per round and
/// no closing exchange, each of the three ended "peer lost", exit 4). 60 LB steps (20 rigid), and the
/// peer timeout 20 resend intervals (1 s, 0.05 s), the ratio of the shipped scenes (10 s,
/// 0.5 s): a mid-run wait gets the rounds it has in those scenes, and the closing exchange
/// is needed whenever all three copies of the success stop_t are lost (1 run in 8).
TEST(Reliability, RunEndsDoneUnderTheDocumentedLoss) {
  const fs::path dir = scratch("documented_loss");
  std::string s = slurp(kSource / "scenes" / "coupled_small.toml");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"steps = 200", "steps = 60"},
                                 {"rigid_steps = 50", "rigid_steps = 20"},
                                 {"fields_every = 50", "fields_every = 30"},
                                 {"sheets_every = 50", "sheets_every = 30"},
                                 {"peer_timeout_s = 10", "peer_timeout_s = 1"},
                                 {"resend_after_s = 0.5", "resend_after_s = 0.05"}})
    replace_in(s, from, to);
  const fs::path scene = dir / "small.toml";
  std::ofstream(scene) << s;
  const fs::path clean = dir / "clean";
  expect_done(clean, run_launcher(kSource, scene, clean));
  for (const int seed : {4, 5, 6}) {
    const fs::path lossy = dir / ("seed" + std::to_string(seed));
    expect_done(lossy, run_launcher(kSource, scene, lossy, "", "COSIM_FAULTS=drop=0.5,seed=" + std::to_string(seed)));
    const auto f = injected(slurp(lossy / "fluid.log")), d = injected(slurp(lossy / "solid.log"));
    std::printf("seed %d: dropped %lld (fluid) and %lld (solid)\n", seed, f[0], d[0]);
    EXPECT_GT(f[0], 0) << logs(lossy);
    EXPECT_GT(d[0], 0) << logs(lossy);
    EXPECT_EQ(compare_outputs(clean, lossy), "") << logs(lossy);
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// Restarting from a checkpoint at step 700 of a complete run, into a fresh folder, gives
/// the same solid.h5 and monitor.h5 (every row from step 0: they are carried in the
/// checkpoints) and the same snapshots after step 700, bit for bit.
TEST(Reproducibility, CheckpointRestartIsBitIdentical) {
  const fs::path dir = scratch("checkpoint_restart");
  const fs::path scene = write_scene(dir, true);
  const fs::path full = dir / "full", restarted = dir / "restarted", from = dir / "from700";
  expect_done(full, run_launcher(kSource, scene, full));
  // The newest three checkpoints of each side are kept: 700, 800, 900.
  fs::create_directories(from);
  for (const char* side : {"fluid", "solid"}) {
    ASSERT_TRUE(fs::exists(full / "checkpoints" / (std::string(side) + "_00000900.h5"))) << logs(full);
    ASSERT_FALSE(fs::exists(full / "checkpoints" / (std::string(side) + "_00000500.h5")));
  }
  // Restart from 700 (the newest common step of a folder holding only 700).
  for (const char* side : {"fluid", "solid"})
    fs::copy_file(full / "checkpoints" / (std::string(side) + "_00000700.h5"),
                  from / (std::string(side) + "_00000700.h5"));
  expect_done(restarted, run_launcher(kSource, scene, restarted, "--restart " + cosim::test::quoted(from.string())));
  EXPECT_NE(slurp(restarted / "fluid.log").find("restarted from"), std::string::npos) << logs(restarted);
  EXPECT_NE(slurp(restarted / "solid.log").find("restarted from"), std::string::npos) << logs(restarted);
  // Every HDF5 file of the restarted run equals the full run's.
  std::size_t files = 0;
  for (const std::string& f : cosim::test::h5_files(restarted)) {
    EXPECT_EQ(cosim::test::compare_h5(full, restarted, f), "") << f;
    ++files;
  }
  // solid.h5, monitor.h5, fields_001000, plane 800 and 1000, sheets 800 and 999
  EXPECT_GE(files, 7u);
  if (!HasFailure()) fs::remove_all(dir);
}

/// The parallel scheme's checkpoints (protocol/README.md 14) hold fluid_state_t(N) in flight
/// too. 60 LB steps (40 rigid), a checkpoint every 13: the newest three are 26 (spin-up, the
/// serial order), 39 (D - 1: fluid_state_t(39) drives both solid_state_t(39) and (40)) and 52
/// (free); a restart from each gives every HDF5 output of the full run bit for bit.
TEST(Reproducibility, ParallelCheckpointRestartIsBitIdentical) {
  const fs::path dir = scratch("parallel_checkpoint_restart");
  const fs::path scene = write_scene(dir, false, "parallel");
  {
    std::string s = slurp(scene);
    for (const auto& [from, to] : {std::pair<std::string, std::string>{"steps = 120", "steps = 60"},
                                   {"peer_timeout_s = 10", "peer_timeout_s = 10\ncheckpoint_every = 13"}}) {
      const std::size_t at = s.find(from);
      ASSERT_NE(at, std::string::npos) << from;
      s.replace(at, from.size(), to);
    }
    std::ofstream(scene) << s;
  }
  const fs::path full = dir / "full";
  expect_done(full, run_launcher(kSource, scene, full));
  for (const char* step : {"00000026", "00000039", "00000052"}) {
    const fs::path from = dir / (std::string("from") + step), restarted = dir / (std::string("restarted") + step);
    fs::create_directories(from);
    for (const char* side : {"fluid", "solid"}) {
      const fs::path f = full / "checkpoints" / (std::string(side) + "_" + step + ".h5");
      ASSERT_TRUE(fs::exists(f)) << f << "\n" << logs(full);
      fs::copy_file(f, from / f.filename());
    }
    expect_done(restarted, run_launcher(kSource, scene, restarted, "--restart " + cosim::test::quoted(from.string())));
    EXPECT_NE(slurp(restarted / "solid.log").find("restarted from"), std::string::npos) << logs(restarted);
    std::size_t files = 0;
    for (const std::string& f : cosim::test::h5_files(restarted)) {
      EXPECT_EQ(cosim::test::compare_h5(full, restarted, f), "") << "restart from " << step << ": " << f;
      ++files;
    }
    EXPECT_GE(files, 4u) << step;  // solid.h5, monitor.h5, fields_000060, plane 40 or 60, sheets
  }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The float store in a coupled run (`[run] precision = "mixed"`, before issue 35 "single"), with the
/// implicit scheme, whose sub-iterations keep and restore the committed floats: a restart from
/// its checkpoint of step 80 (the store's floats) gives every HDF5 output bit for bit.
TEST(Reproducibility, SinglePrecisionCoupledRestartIsBitIdentical) {
  const fs::path dir = scratch("single_precision");
  const fs::path scene = write_scene(dir, false, "implicit");
  {
    std::string s = slurp(scene);
    const std::size_t at = s.find("steps = 120");
    ASSERT_NE(at, std::string::npos);
    s.insert(at, "precision = \"mixed\"\n");
    std::ofstream(scene) << s;
  }
  const fs::path clean = dir / "clean", restarted = dir / "restarted", from = dir / "from80";
  expect_done(clean, run_launcher(kSource, scene, clean));
  EXPECT_NE(slurp(clean / "fluid.log").find("floats (mixed: float store, double arithmetic)"), std::string::npos) << logs(clean);
  fs::create_directories(from);
  for (const char* side : {"fluid", "solid"})
    fs::copy_file(clean / "checkpoints" / (std::string(side) + "_00000080.h5"),
                  from / (std::string(side) + "_00000080.h5"));
  expect_done(restarted, run_launcher(kSource, scene, restarted, "--restart " + cosim::test::quoted(from.string())));
  EXPECT_NE(slurp(restarted / "fluid.log").find("restarted from"), std::string::npos) << logs(restarted);
  std::size_t files = 0;
  for (const std::string& file : cosim::test::h5_files(restarted)) {
    EXPECT_EQ(cosim::test::compare_h5(clean, restarted, file), "") << file;
    ++files;
  }
  EXPECT_GE(files, 4u);
  if (!HasFailure()) fs::remove_all(dir);
}

/// The checkpoints (checkpoints/*.h5) of two runs of two scene files that differ only in how
/// the fluid computes (e.g. [run] propagation), compared bit for bit where they must agree:
/// every dataset but the run's identity (run_id, scene_hash, scene_hash_except_steps); the
/// messages in flight without their session token (the LCM string after the 8-byte
/// fingerprint); the populations at every interior cell of the nx x ny x nz grid. Ghost slots
/// that no step reads (a wall's ghost whose neighbour along c_q is a ghost too) hold what each
/// propagation's fill left there. "" when they agree; `count` gets the files compared.
std::string compare_checkpoints(const fs::path& a, const fs::path& b, cosim::fluid::GridShape shape,
                                bool single, std::size_t* count) {
  using cosim::test::read_datasets;
  const std::vector<std::string> files = cosim::test::h5_files(a);
  std::string r;
  if (files != cosim::test::h5_files(b)) r += "the checkpoints folders hold other files\n";
  const cosim::fluid::GridLayout layout(shape, single ? 16 : 8);
  for (const std::string& f : files) {
    const auto da = read_datasets(a / f), db = read_datasets(b / f);
    if (da.empty() || da.size() != db.size()) r += f + ": other datasets\n";
    for (const auto& [name, x] : da) {
      const auto it = db.find(name);
      if (it == db.end()) {
        r += f + " " + name + ": missing\n";
        continue;
      }
      const cosim::test::Dataset& y = it->second;
      if (name == "run_id" || name == "scene_hash" || name == "scene_hash_except_steps") continue;
      if (name.rfind("in_flight_", 0) == 0) {
        // fingerprint (8), token length (4, big endian, with its NUL), token, the rest.
        const auto rest = [](const std::vector<unsigned char>& m) {
          if (m.size() < 12) return m;
          const std::size_t len = (std::size_t(m[8]) << 24) | (std::size_t(m[9]) << 16) | (std::size_t(m[10]) << 8) | m[11];
          return std::vector<unsigned char>(m.begin() + std::ptrdiff_t(std::min(m.size(), 12 + len)), m.end());
        };
        if (rest(x.bytes) != rest(y.bytes) || x.bytes.size() != y.bytes.size()) r += f + " " + name + " differs\n";
        continue;
      }
      if (name == "populations") {
        const std::size_t stride = layout.stride(), size = x.type_size;
        if (x.bytes.size() != 19 * stride * size || y.bytes.size() != x.bytes.size()) {
          r += f + " populations: " + std::to_string(x.bytes.size()) + " bytes, not 19 x the layout's stride\n";
          continue;
        }
        std::size_t differ = 0;
        for (std::size_t q = 0; q < 19; ++q)
          for (int z = 0; z < shape.nz; ++z)
            for (int yy = 0; yy < shape.ny; ++yy)
              for (int xx = 0; xx < shape.nx; ++xx) {
                const std::size_t k = (q * stride + std::size_t(layout.index(xx, yy, z))) * size;
                differ += std::memcmp(&x.bytes[k], &y.bytes[k], size) != 0;
              }
        if (differ > 0) r += f + " populations: " + std::to_string(differ) + " interior values differ\n";
        continue;
      }
      if (x.bytes != y.bytes || x.dims != y.dims) r += f + " " + name + " differs\n";
    }
  }
  if (count != nullptr) *count = files.size();
  return r;
}

/// The in-place (AA-pattern) propagation in a coupled run (the default, `[run] propagation`;
/// the schemes then run the whole LB step after the solid's message,
/// FluidDomain::bulk_before_impulses): for each scheme, every HDF5 output of fluid and solid
/// bit for bit the two-grid run's, in both stores; their checkpoints (every 40 steps) too, as
/// compare_checkpoints says; and a restart of the in-place parallel run from its checkpoint of
/// step 80 writes the two-grid run's outputs bit for bit.
TEST(Reproducibility, InPlaceCoupledRunWritesTheTwoGridBits) {
  const fs::path dir = scratch("in_place_coupled");
  for (const std::string scheme : {"serial", "parallel", "implicit"})
    for (const std::string precision : {"double", "mixed"}) {
      const std::string name = scheme + "_" + precision;
      const fs::path sub = dir / name;
      fs::create_directories(sub);
      const fs::path two_grid_scene = write_scene(sub, false, scheme);
      std::string text = slurp(two_grid_scene);
      if (scheme != "implicit") replace_in(text, "peer_timeout_s = 10", "peer_timeout_s = 10\ncheckpoint_every = 40");
      replace_in(text, "steps = 120", "precision = \"" + precision + "\"\nsteps = 120");
      // In place: the default (no propagation key).
      const fs::path in_place_scene = sub / "in_place.toml";
      std::ofstream(in_place_scene) << text;
      replace_in(text, "steps = 120", "propagation = \"two-grid\"\nsteps = 120");
      std::ofstream(two_grid_scene) << text;
      const fs::path two_grid = sub / "two_grid", in_place = sub / "in_place";
      expect_done(two_grid, run_launcher(kSource, two_grid_scene, two_grid));
      expect_done(in_place, run_launcher(kSource, in_place_scene, in_place));
      EXPECT_NE(slurp(in_place / "fluid.log").find("in-place propagation"), std::string::npos) << logs(in_place);
      EXPECT_NE(slurp(two_grid / "fluid.log").find("two-grid propagation"), std::string::npos) << logs(two_grid);
      std::size_t files = 0, checkpoints = 0;
      EXPECT_EQ(compare_outputs(two_grid, in_place, &files), "") << name << "\n" << logs(in_place);
      const auto grid = [&text](const char* key) {
        std::smatch m;
        return std::regex_search(text, m, std::regex(std::string("\\n") + key + " = ([0-9]+)")) ? std::stoi(m[1]) : 0;
      };
      EXPECT_EQ(compare_checkpoints(two_grid / "checkpoints", in_place / "checkpoints",
                                    {grid("nx"), grid("ny"), grid("nz")},
                                    precision == "mixed", &checkpoints),
                "")
          << name;
      // monitor.h5, solid.h5, 3 field, 4 plane and 4 sheet snapshots; fluid and solid at 40, 80
      EXPECT_GE(files, 13u) << name;
      EXPECT_GE(checkpoints, 4u) << name;
      std::printf("%s: %zu HDF5 outputs identical bit for bit, %zu checkpoints agree\n", name.c_str(), files,
                  checkpoints);
      if (scheme == "parallel" && precision == "double") {
        const fs::path from = sub / "from80", restarted = sub / "restarted";
        fs::create_directories(from);
        for (const char* side : {"fluid", "solid"})
          fs::copy_file(in_place / "checkpoints" / (std::string(side) + "_00000080.h5"),
                        from / (std::string(side) + "_00000080.h5"));
        expect_done(restarted,
                    run_launcher(kSource, in_place_scene, restarted, "--restart " + cosim::test::quoted(from.string())));
        EXPECT_NE(slurp(restarted / "fluid.log").find("restarted from"), std::string::npos) << logs(restarted);
        for (const std::string& file : cosim::test::h5_files(restarted))
          EXPECT_EQ(cosim::test::compare_h5(two_grid, restarted, file), "") << "restart from 80: " << file;
      }
    }
  if (!HasFailure()) fs::remove_all(dir);
}

/// The checkpoint's populations (FluidRun::checkpoint, SerialDomain::write_store: the store
/// of state()) of an abort of `aborted` now, against `two_grid`'s: the interior values that
/// differ (the ghosts are the propagation's own, as compare_checkpoints says), or -1 for
/// another step count.
template <class T>
long long abort_checkpoint_differs(const cosim::fluid::FluidSolver& two_grid, const cosim::fluid::FluidSolver& aborted) {
  using namespace cosim::fluid;
  if (aborted.step_count() != two_grid.step_count()) return -1;
  const BasicPopulationField<T>* a;
  const BasicPopulationField<T>* b;
  if constexpr (sizeof(T) == sizeof(double)) {
    a = &two_grid.state();
    b = &aborted.state();
  } else {
    a = &two_grid.state_single();
    b = &aborted.state_single();
  }
  const GridShape& s = two_grid.shape();
  long long differ = 0;
  for (int q = 0; q < 19; ++q)
    for (int z = 0; z < s.nz; ++z)
      for (int y = 0; y < s.ny; ++y)
        for (int x = 0; x < s.nx; ++x) {
          const std::ptrdiff_t i = two_grid.layout().index(x, y, z);
          differ += std::memcmp(a->q(q) + i, b->q(q) + i, sizeof(T)) != 0;
        }
  return differ;
}

/// The coupled step in place is split around its sample (FluidSolver::step_reading,
/// FluidDomain::step_near; fluid/schemes/scheme_context.cpp): the cells the sample at the
/// markers reads, the forced ones and the faces' margins first, fluid_state_t out, then the
/// rest while the solid computes. A run that ends at any phase of that step (waiting for
/// solid_state_t, the watchdog on its positions after the spread, fluid_state_t out with the
/// rest not run, the step done) writes the populations of the checkpoint a two-grid run
/// writes there, bit for bit, for the state of the committed step; the sample published
/// before the rest and the kernel's extrema (the health check) are the two-grid run's too.
/// An abort reads the state as a checkpoint does: `probe` is read so at every phase (the
/// rows left run at the read), `run` beside it only at the end, its sample every step (its
/// steps alternate between the two arrangements; probe's begin Canonical, after the reads).
/// Markers that move from step to step (the rows left change; some wrap around a periodic
/// face), both stores, the paper's channel and grids with outflow, inlet, wall and free slip
/// faces on y and z next to the rows left.
TEST(Reproducibility, SplitStepInPlaceKeepsAbortCheckpointWhole) {
  using namespace cosim::fluid;
  std::vector<FluidParams> grids;
  grids.push_back(blasius_channel({23, 15, 14}, 0.62, 0.05, 3.0));
  {
    FluidParams p;  // outflow at x_min, inlet at x_max; a wall, free slip on z, outflows on y
    p.shape = {17, 13, 12};
    p.faces[XMin].kind = FaceKind::Outflow;
    p.faces[XMin].outflow_density = 1.01;
    p.faces[XMax].kind = FaceKind::Inlet;
    p.faces[XMax].inlet_speed = 0.04;
    p.faces[YMin].kind = p.faces[YMax].kind = FaceKind::Outflow;
    p.faces[ZMin].kind = FaceKind::Wall;
    p.faces[ZMin].wall_velocity = {0.01, 0.0, 0.0};
    p.faces[ZMax].kind = FaceKind::FreeSlip;
    grids.push_back(p);
    FluidParams box;  // periodic every way (the kernel's x faces)
    box.shape = {16, 14, 15};
    grids.push_back(box);
  }
  for (FluidParams& p : grids) p.body_force = {2e-6, 0.0, -1e-6};
  int split = 0;
  for (std::size_t g = 0; g < grids.size(); ++g)
    for (const Precision precision : {Precision::Double, Precision::Mixed}) {
      SCOPED_TRACE("grid " + std::to_string(g) + ", " + precision_name(precision));
      FluidParams p = grids[g];
      p.precision = precision;
      p.propagation = Propagation::TwoGrid;
      FluidSolver two_grid(p);
      p.propagation = Propagation::InPlace;
      FluidSolver probe(p), run(p);
      const auto flow = [](int x, int y, int z) {
        return CellState{1.0 + 0.01 * std::sin(0.7 * x + 0.3 * z), 0.03 + 0.005 * std::cos(0.5 * y),
                         0.004 * std::sin(0.4 * z + 0.2 * x), -0.003 * std::cos(0.3 * x)};
      };
      two_grid.initialize(flow);
      probe.initialize(flow);
      run.initialize(flow);
      const ImmersedBoundary ib_two(two_grid), ib_in(probe);
      const bool kernels_x_faces = probe.boundaries().in_place_x_faces().all();
      const auto same_checkpoint = [&](const FluidSolver& aborted, const std::string& phase) {
        const long long d = precision == Precision::Double ? abort_checkpoint_differs<double>(two_grid, aborted)
                                                           : abort_checkpoint_differs<float>(two_grid, aborted);
        EXPECT_EQ(d, 0) << "an abort " << phase << " (-1: another step count)";
      };
      for (int n = 0; n < 8; ++n) {
        SCOPED_TRACE("step " + std::to_string(n));
        // A 2 x 3 patch of markers that moves; at odd steps it sits across z = 0.
        std::vector<Vec3> X, J;
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 3; ++b) {
            const double z = (n % 2 == 1 ? -0.6 : 5.2) + 0.8 * b + 0.1 * std::sin(n);
            X.push_back({7.3 + 0.9 * a + 0.2 * n, 4.1 + 0.7 * b + 0.3 * std::cos(n), z < 0 ? z + p.shape.nz : z});
            J.push_back({1e-3 * std::sin(n + a + b), -5e-4 * std::cos(n + b), 3e-4 * (a - b)});
          }
        // Awaiting solid_state_t(n): the two-grid bulk has run.
        two_grid.begin_step();
        same_checkpoint(probe, "waiting for solid_state_t");
        // solid_state_t(n) read, its impulses spread (the markers' watchdog checkpoints here).
        ib_two.spread(two_grid, X, J);
        ib_in.spread(probe, X, J);
        ib_in.spread(run, X, J);
        same_checkpoint(probe, "after the spread");
        two_grid.finish_step();
        const std::vector<std::array<int, 3>> read = ib_in.marker_nodes(X).cells;
        probe.step_reading(read);
        run.step_reading(read);
        if (kernels_x_faces) {
          EXPECT_TRUE(probe.rest_pending() && run.rest_pending()) << "the step did not split";
        }
        split += run.rest_pending();
        // fluid_state_t(n + 1) carries the sample taken before the rest.
        std::vector<MarkerSample> s_two(X.size()), s_probe(X.size()), s_run(X.size());
        ib_two.sample(two_grid, X, s_two);
        ib_in.sample(probe, X, s_probe);
        ib_in.sample(run, X, s_run);
        for (std::size_t l = 0; l < X.size(); ++l) {
          EXPECT_EQ(std::memcmp(&s_two[l], &s_probe[l], sizeof(MarkerSample)), 0) << "marker " << l;
          EXPECT_EQ(std::memcmp(&s_two[l], &s_run[l], sizeof(MarkerSample)), 0) << "marker " << l;
        }
        same_checkpoint(probe, "after fluid_state_t, the rest not run");
        run.finish_rest();
        same_checkpoint(probe, "after the step");
        const KernelExtrema &e_two = two_grid.last_step_extrema(), &e_in = run.last_step_extrema();
        EXPECT_EQ(std::memcmp(&e_two.rho_min, &e_in.rho_min, sizeof(double)), 0);
        EXPECT_EQ(std::memcmp(&e_two.rho_max, &e_in.rho_max, sizeof(double)), 0);
        EXPECT_EQ(std::memcmp(&e_two.u2_max, &e_in.u2_max, sizeof(double)), 0);
        EXPECT_EQ(e_two.finite, e_in.finite);
      }
      same_checkpoint(run, "after the last step");
    }
  EXPECT_GE(split, 8 * 2 * 2);  // the channel and the box split at every step, in both stores
}

/// The solid is killed (SIGKILL) after its checkpoint of step 100: the fluid notices within
/// its peer timeout, writes its own checkpoint and exits 4 naming the reason and the file;
/// a restart from the checkpoints folder completes the run, identical to an uninterrupted one.
TEST(Reproducibility, KilledPeerLeavesCheckpointAndReason) {
  const fs::path dir = scratch("killed_peer");
  const fs::path scene = write_scene(dir, true);
  const fs::path clean = dir / "clean", killed = dir / "killed";
  expect_done(clean, run_launcher(kSource, scene, clean));

  int status = -1;
  std::thread launcher([&] { status = run_launcher(kSource, scene, killed); });
  const fs::path marker = killed / "checkpoints" / "solid_00000100.h5";
  for (int k = 0; k < 1200 && !fs::exists(marker); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const bool reached = fs::exists(marker);
  const std::string pid = slurp(killed / "solid.pid");
  if (reached && !pid.empty()) std::system(("kill -9 " + pid).c_str());
  launcher.join();
  ASSERT_TRUE(reached) << "the solid never wrote its checkpoint of step 100\n" << logs(killed);
  EXPECT_NE(status, 0) << logs(killed);
  EXPECT_EQ(slurp(killed / "fluid.exit"), "4\n") << logs(killed);
  const std::string fluid_log = slurp(killed / "fluid.log");
  EXPECT_NE(fluid_log.find("the solid was silent"), std::string::npos) << logs(killed);
  const std::size_t at = fluid_log.find("; checkpoint ");
  ASSERT_NE(at, std::string::npos) << "no checkpoint named in the reason\n" << logs(killed);
  std::printf("fluid's reason: %s\n", fluid_log.substr(fluid_log.rfind("coupled run stopped")).c_str());
  // The checkpoint the reason names exists.
  std::string file = fluid_log.substr(at + 13);
  file = file.substr(0, file.find('\n'));
  EXPECT_TRUE(fs::exists(file)) << file;

  // Continue in the same folder.
  expect_done(killed, run_launcher(kSource, scene, killed, "--restart " + cosim::test::quoted((killed / "checkpoints").string())));
  EXPECT_EQ(compare_outputs(clean, killed), "") << logs(killed);
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
