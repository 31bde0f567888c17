// The coupled run as two processes over LCM, started by launch/run-coupled.sh (in a private
// network namespace when root): it completes, and a killed peer stops the other.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using cosim::test::slurp;
using Clock = std::chrono::steady_clock;

const fs::path kSource = COSIM_SOURCE_DIR;

fs::path scratch(const std::string& name) { return cosim::test::fresh_scratch("cosim_" + name); }

/// A coupled scene (the small one by default) with some keys replaced (a line "key = ..." per
/// entry).
fs::path scene_with(const fs::path& dir, const std::vector<std::pair<std::string, std::string>>& edits,
                    const fs::path& source = kSource / "scenes" / "coupled_small.toml") {
  std::istringstream in(slurp(source));
  std::ostringstream out;
  for (std::string line; std::getline(in, line);) {
    for (const auto& [key, value] : edits)
      if (line.rfind(key + " ", 0) == 0 || line.rfind(key + "=", 0) == 0) line = key + " = " + value;
    out << line << "\n";
  }
  const fs::path p = dir / "scene.toml";
  std::ofstream(p) << out.str();
  return p;
}

int run_launcher(const fs::path& scene, const fs::path& output, const std::string& extra = "") {
  const std::string cmd = "bash " + (kSource / "launch" / "run-coupled.sh").string() + " " +
                          scene.string() + " --output " + output.string() +
                          " --no-build --quiet " + extra + " >" + (output / "launcher.log").string() +
                          " 2>&1";
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

TEST(TwoProcess, TwoProcessRunCompletes) {
  const fs::path dir = scratch("two_process");
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const int status = run_launcher(kSource / "scenes" / "coupled_small.toml", out, "--log");
  EXPECT_EQ(status, 0) << slurp(out / "launcher.log") << slurp(out / "fluid.log") << slurp(out / "solid.log");
  EXPECT_EQ(slurp(out / "fluid.exit"), "0\n");
  EXPECT_EQ(slurp(out / "solid.exit"), "0\n");
  EXPECT_TRUE(fs::exists(out / "monitor.h5"));
  EXPECT_TRUE(fs::exists(out / "solid.h5"));
  // --log: cosim-record recorded the run's channels (every LB step in both directions).
  ASSERT_TRUE(fs::exists(out / "traffic.lcmlog")) << slurp(out / "launcher.log");
  EXPECT_GT(fs::file_size(out / "traffic.lcmlog"), 200u * 2u * 100u);
  EXPECT_NE(slurp(out / "fluid.log").find("coupled run done, 200 LB steps"), std::string::npos)
      << slurp(out / "fluid.log");
  fs::remove_all(dir);
}

TEST(TwoProcess, PeerDeathStopsTheOther) {
  const fs::path dir = scratch("peer_death");
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const double timeout_s = 3.0;
  const fs::path scene = scene_with(dir, {{"steps", "100000"}, {"peer_timeout_s", "3"}});
  std::thread launcher([&] { run_launcher(scene, out); });
  // Wait until the run is under way (the solid is past the handshake and stepping).
  const Clock::time_point t0 = Clock::now();
  bool running = false;
  while (Clock::now() - t0 < std::chrono::seconds(60)) {
    if (slurp(out / "fluid.log").find("handshake accepted") != std::string::npos &&
        fs::exists(out / "solid.pid")) {
      running = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(running) << slurp(out / "fluid.log") << slurp(out / "solid.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const pid_t solid = std::stoi(slurp(out / "solid.pid"));
  const Clock::time_point killed = Clock::now();
  ASSERT_EQ(kill(solid, SIGKILL), 0);
  // The fluid notices within its peer timeout, exits 4 with the reason.
  while (!fs::exists(out / "fluid.exit") && Clock::now() - killed < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const double took = std::chrono::duration<double>(Clock::now() - killed).count();
  launcher.join();
  EXPECT_EQ(slurp(out / "solid.exit"), "137\n");
  EXPECT_EQ(slurp(out / "fluid.exit"), "4\n") << slurp(out / "fluid.log");
  EXPECT_LT(took, timeout_s + 5.0);
  EXPECT_NE(slurp(out / "fluid.log").find("the solid was silent for"), std::string::npos)
      << slurp(out / "fluid.log");
  fs::remove_all(dir);
}

// Turek & Hron's FSI2 scene for 0.1 s (400 LB steps): the held cylinder beside the solid's
// sheet in a coupled run with a medium other than air and the ramped inlet. Both processes
// accept the scene (the same units from the shared [fluid] medium, else the handshake
// refuses), and held_body.csv has the cylinder's force, the sheet's (minus the sum of its
// impulses) and their total each 20 steps.
TEST(TwoProcess, HeldBodyBesideTheSheetWritesBothForces) {
  const fs::path dir = scratch("held_body_coupled");
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const fs::path scene =
      scene_with(dir, {{"duration_us", "1.0e5"}, {"sheets_every", "0"}}, kSource / "scenes" / "benchmarks" / "turek_hron_fsi2.toml");
  const int status = run_launcher(scene, out);
  ASSERT_EQ(status, 0) << slurp(out / "launcher.log") << slurp(out / "fluid.log") << slurp(out / "solid.log");
  std::istringstream csv(slurp(out / "held_body.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line,
            "step,time_s,drag_N_per_m,lift_N_per_m,sheet_drag_N_per_m,sheet_lift_N_per_m,total_drag_N_per_m,"
            "total_lift_N_per_m");
  int rows = 0;
  std::vector<double> v;
  while (std::getline(csv, line)) {
    ++rows;
    v.clear();
    std::istringstream fields(line);
    for (std::string f; std::getline(fields, f, ',');) v.push_back(std::stod(f));
    ASSERT_EQ(v.size(), 8u) << line;
    EXPECT_NEAR(v[6], v[2] + v[4], 1e-7 * (std::abs(v[2]) + std::abs(v[4])) + 1e-12) << line;
    EXPECT_NEAR(v[7], v[3] + v[5], 1e-7 * (std::abs(v[3]) + std::abs(v[5])) + 1e-12) << line;
  }
  EXPECT_EQ(rows, 20);
  // At 0.1 s the inlet is at (1 - cos(pi / 20)) / 2 = 0.6 % of its speed: the flow pushes
  // both downstream.
  ASSERT_EQ(v.size(), 8u);
  EXPECT_EQ(v[0], 400);
  EXPECT_GT(v[2], 0.0);
  EXPECT_GT(v[4], 0.0);
  fs::remove_all(dir);
}

}  // namespace
