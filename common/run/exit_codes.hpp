// The exit codes of both servers and of every protocol peer (protocol/README.md section 9),
// defined once, and the run-ending condition a session returns.
#pragma once

#include <string>

namespace cosim::protocol {

namespace exit_code {
inline constexpr int ok = 0;         ///< done: the run reached its last step
inline constexpr int system = 1;     ///< output, or LCM could not be opened or published to
inline constexpr int bad_input = 2;  ///< scene, command line, refused handshake, malformed message
inline constexpr int unhealthy = 3;  ///< non-finite or unhealthy flow or solid, a watchdog sentinel
inline constexpr int peer_lost = 4;  ///< the peer was silent past a timeout, or stopped with an error
}  // namespace exit_code

/// A run-ending condition: the exit code, the one-line reason, and whether this side
/// announces it to the peer with stop_t (its own errors; not a refused handshake or the
/// peer's own stop_t).
struct Ending {
  int code = exit_code::ok;
  std::string reason;
  bool publish_stop = false;
};

}  // namespace cosim::protocol
