// Whose checkpoint a file is (protocol/README.md section 10): the scene file it belongs to,
// the run (the launcher's run id, OUTPUT/run.id) and its A_T. Both servers stamp their
// checkpoints with it and check it on --restart, so that a restart never silently continues
// another scene's, another run's or another A_T's checkpoint. Only the scene's run length
// ([run] steps) may differ: continuing a run for more steps. Internal to the servers' .cpp
// files, like checkpoint_file.hpp.
#pragma once

#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "common/run/checkpoint_file.hpp"
#include "common/run/checksum.hpp"
#include "protocol/handshake.hpp"

namespace cosim::protocol {

/// The scene file's bytes with the value of [run] steps left out, hashed: equal for two
/// scene files that differ only in the run's length.
inline std::string scene_hash_except_steps(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read the scene file '" + path + "' to hash it");
  Checksum sum;
  std::string line, section;
  while (std::getline(in, line)) {
    const std::size_t first = line.find_first_not_of(" \t");
    const std::string body = first == std::string::npos ? "" : line.substr(first);
    if (!body.empty() && body[0] == '[') {
      section = body.substr(0, body.find(']') + 1);
    } else if (section == "[run]" && body.rfind("steps", 0) == 0 &&
               body.find_first_not_of(" \t", 5) != std::string::npos && body[body.find_first_not_of(" \t", 5)] == '=') {
      line = "steps =";
    }
    sum.add(line).add("\n");
  }
  return sum.hex();
}

/// What a run stamps into its checkpoints and requires of the one it restarts from.
struct CheckpointIdentity {
  std::string scene_path;  ///< the scene file of this run
  std::string run_id;      ///< the launcher's run id ("" when run without it: not checked)
  std::int64_t time_ratio = 0;  ///< this run's A_T
  bool new_time_ratio = false;  ///< a restart may change A_T (the watchdog's retry)
};

inline void write_identity(CheckpointWriter& w, const CheckpointIdentity& id) {
  w.text("scene_hash", scene_hash_of_file(id.scene_path));
  w.text("scene_hash_except_steps", scene_hash_except_steps(id.scene_path));
  w.text("run_id", id.run_id);
  w.attr("time_ratio", id.time_ratio);
}

/// Throws one line when `r` is a checkpoint of another scene, run or A_T than `id`'s.
inline void check_identity(const CheckpointReader& r, const CheckpointIdentity& id) {
  if (r.text("scene_hash") != scene_hash_of_file(id.scene_path) &&
      (!r.has("scene_hash_except_steps") || r.text("scene_hash_except_steps") != scene_hash_except_steps(id.scene_path)))
    throw std::runtime_error("a checkpoint of another scene (its scene_hash differs from " + id.scene_path +
                             "'s; allowed: the same scene file, only [run] steps changed)");
  const std::string run = r.has("run_id") ? r.text("run_id") : "";
  if (!id.run_id.empty() && !run.empty() && run != id.run_id)
    throw std::runtime_error("a checkpoint of another run (run_id " + run + ", this run is " + id.run_id +
                             "); allowed: a checkpoint of this run, or a new output folder to continue that run in");
  const std::int64_t ratio = r.int64_attr("time_ratio");
  if (ratio != id.time_ratio && !id.new_time_ratio)
    throw std::runtime_error("a checkpoint of a run at A_T = " + std::to_string(ratio) + ", this run has A_T = " +
                             std::to_string(id.time_ratio) +
                             "; allowed: the checkpoint's A_T, or run-coupled.sh --new-time-ratio N to change it "
                             "on purpose (as the watchdog's retry does)");
}

}  // namespace cosim::protocol
