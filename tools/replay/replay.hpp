// cosim-replay (issue 6, item 2; docs/replay.md): replays one side of a recorded coupled run.
//
// It reads the LCM log of a run (launch/run-coupled.sh --log, lcm-logger's format), starts
// the chosen server in this process (run_coupled_fluid or run_coupled_solid) on a memq://
// bus with the logged token, and plays the missing peer from the log: the peer's hello_t
// (and, for the solid, the coordinator's welcome_t), then the peer's messages in seq order,
// each once the server has published what the log shows before it (causality: no
// scheme-specific order, so the serial, implicit and parallel schemes of protocol/README.md
// sections 5, 13 and 14 all replay). Every message the server publishes (fluid_state_t, or
// solid_state_t) is compared, bit for bit, with the logged first copy of the same seq.
#pragma once

#include <cstdint>
#include <ostream>
#include <stdexcept>
#include <string>

#include <optional>

#include "common/log/logger.hpp"
#include "protocol/message_auth.hpp"

namespace cosim::replay {

/// The tool's lines: "cosim-replay: ...".
inline log::Logger replay_log() { return log::Logger("cosim-replay"); }

/// Exit codes of cosim-replay (docs/replay.md).
namespace exit_code {
inline constexpr int identical = 0;  ///< every logged message of the side was reproduced bit for bit
inline constexpr int system = 1;     ///< an output folder or the in-process bus could not be made
inline constexpr int bad_input = 2;  ///< command line, log, scene, or the scene does not match the log
inline constexpr int different = 10; ///< a published message differs from the log (or is missing)
inline constexpr int server_failed = 11;  ///< no difference, but the server stopped with a non-zero code
}  // namespace exit_code

/// Input that cannot be replayed; what() is one line naming the file or option, the value
/// and what is allowed.
class ReplayError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Side { Fluid, Solid };

inline const char* side_name(Side s) { return s == Side::Fluid ? "fluid" : "solid"; }

struct ReplayOptions {
  std::string log_path;        ///< the run's LCM log (lcm-logger), e.g. OUTPUT/traffic.lcmlog
  Side side = Side::Fluid;     ///< the server to replay
  std::string scene_path;      ///< the run's scene file (its bytes must hash as the log says)
  std::string output_dir;      ///< the server's output; empty: a fresh temporary folder
  std::string channel_prefix;  ///< empty: the log's only prefix
  std::string token;           ///< empty: the log's only run (a token with both hello_t)
  bool quiet = false;          ///< no progress lines on `err`
  /// The run's key (OUTPUT/run.key, protocol/message_auth.hpp): every logged message's MAC
  /// is verified, those that do not verify are left out. None: MACs removed unverified.
  std::optional<protocol::RunKey> key;
};

/// Runs the replay and prints its report on `out` (and progress and one-line errors on
/// `err`). Returns an exit code of `exit_code`. Exceptions do not escape.
int run_replay(const ReplayOptions& options, std::ostream& out, std::ostream& err);

}  // namespace cosim::replay
