// What the run-data tests share (test_run_data.cpp, test_run_data_faults.cpp): the small
// coupled scene they run, the launcher, a run's data files, and waiting for a file.
#pragma once

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

#include "tests/support/h5_read.hpp"
#include "tests/support/run_compare.hpp"
#include "tests/support/scene_edit.hpp"

namespace cosim::test::run_data {

namespace fs = std::filesystem;
using cosim::test::changed_files;
using cosim::test::compare_h5;
using cosim::test::every_file;
using cosim::test::flip_bit;
using cosim::test::expect_run_done;
using cosim::test::logs;
using cosim::test::quoted;
using cosim::test::root_attribute;
using cosim::test::read_datasets;
using cosim::test::run_launcher;
using cosim::test::scratch;
using cosim::test::SceneEdits;
using cosim::test::write_edited_scene;
using cosim::test::slurp;

inline const fs::path kSource = COSIM_SOURCE_DIR;
inline const fs::path kShim = FULL_DISK_SHIM;

/// scenes/coupled_small.toml with `steps` LB steps (20 rigid), monitor rows every 10 steps,
/// field and sheet snapshots every 20, checkpoints every 20, a 3 s peer timeout; `edits`
/// (text -> text) after those. Written as dir/NAME.toml.
inline fs::path small_scene(const fs::path& dir, int steps, const SceneEdits& edits = {},
                            const std::string& name = "small") {
  SceneEdits all = {{"steps = 200", "steps = " + std::to_string(steps)},
                    {"rigid_steps = 50", "rigid_steps = 20"},
                    {"monitor_every = 50", "monitor_every = 10"},
                    {"fields_every = 50", "fields_every = 20"},
                    {"sheets_every = 50", "sheets_every = 20"},
                    {"peer_timeout_s = 10", "peer_timeout_s = 3\ncheckpoint_every = 20"},
                    {"resend_after_s = 0.5", "resend_after_s = 0.05"}};
  all.insert(all.end(), edits.begin(), edits.end());
  return write_edited_scene(kSource / "scenes" / "coupled_small.toml", all, dir / (name + ".toml"));
}

/// run-coupled.sh SCENE ARGS --no-build [--quiet], its lines into `log`; the exit status.
inline int launch(const fs::path& scene, const std::string& args, const fs::path& log, const std::string& env = "",
           bool quiet = true) {
  const std::string cmd = (env.empty() ? "" : "env " + env + " ") + "bash " +
                          quoted((kSource / "launch" / "run-coupled.sh").string()) + " " + quoted(scene.string()) +
                          " " + args + " --no-build" + (quiet ? " --quiet" : "") + " >" + quoted(log.string()) + " 2>&1";
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

/// Every data file of a run's folder (HDF5, XDMF, run.id, the scene copy and provenance), by relative path, with its bytes.
inline std::map<std::string, std::string> data_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string ext = e.path().extension().string();
    if (ext == ".h5" || ext == ".xmf" || ext == ".id" || ext == ".toml") files[fs::relative(e.path(), dir).string()] = slurp(e.path());
  }
  return files;
}

/// The .part files left anywhere under `dir`.
inline std::vector<std::string> part_files(const fs::path& dir) {
  std::vector<std::string> parts;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().string().find(".part") != std::string::npos) parts.push_back(e.path().string());
  return parts;
}

/// The one line of `text` that contains `what` ("" if none).
inline std::string line_with(const std::string& text, const std::string& what) {
  const std::size_t at = text.find(what);
  if (at == std::string::npos) return "";
  const std::size_t begin = text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
  return text.substr(begin, text.find('\n', at) - begin);
}

/// The last line of `text` that is not empty.
inline std::string last_line(std::string text) {
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text.substr(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
}

/// A dataset of an HDF5 file as doubles (empty if it cannot be read).
inline std::vector<double> column(const fs::path& file, const std::string& name) {
  const auto sets = read_datasets(file);
  const auto it = sets.find(name);
  return it == sets.end() ? std::vector<double>{} : it->second.values;
}

/// Waits (at most `seconds`) for `file` to exist.
inline bool wait_for(const fs::path& file, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!fs::exists(file) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return fs::exists(file);
}

/// Runs `scene` into `out` through the launcher and, once `marker` exists (at most 120 s),
/// sends `signal` to the process whose id `pid_file` (under `out`) holds; the launcher's
/// exit status, and in `reached` whether the marker came. `sent` is when the signal went.
inline int run_and_signal(const fs::path& scene, const fs::path& out, const fs::path& marker, const std::string& pid_file,
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

inline void expect_done(const fs::path& out, int status) { expect_run_done(out, status); }

}  // namespace cosim::test::run_data
