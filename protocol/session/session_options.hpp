// What a caller tells a protocol peer about its run, the same for both servers (and for any
// peer built on the session layer): the run's token, quiet progress, an in-process bus, the
// test setting of injected faults, and the checkpoint to continue from.
#pragma once

#include <cstdlib>
#include <optional>
#include <string>

#include "protocol/fault_injection.hpp"
#include "protocol/message_auth.hpp"

namespace lcm {
class LCM;
}

namespace cosim::protocol {

struct SessionOptions {
  /// The run's token (the launcher draws one per run, new_run_token()); every message
  /// carries it.
  std::string token;
  /// No progress lines.
  bool quiet = false;
  /// A bus to use instead of opening the URL: an in-process peer on one memq:// bus (one
  /// queue per lcm_t: the replay tool, the tests). Not owned; the subscriptions made on it
  /// are removed before the run returns.
  lcm::LCM* bus = nullptr;
  /// Faults injected into what this side publishes (fault_injection.hpp; tests).
  FaultSettings faults;
  /// A checkpoint file (OUTPUT/checkpoints/{fluid,solid}_NNNNNNNN.h5) to continue from; the
  /// peer restarts from its own checkpoint of the same step (DESIGN 2.4).
  std::string restart;
  /// The run's id (the launcher's, $COSIM_RUN_ID; OUTPUT/run.id): stamped into every
  /// checkpoint; a restart refuses another run's checkpoint. Empty: not checked.
  std::string run_id;
  /// A restart may run another A_T than its checkpoint's ($COSIM_NEW_TIME_RATIO=1: the
  /// launcher's --new-time-ratio and the watchdog's retry); otherwise it is refused.
  bool new_time_ratio = false;

  /// The run's key (message_auth.hpp; the launcher's $COSIM_RUN_KEY_FILE): every message
  /// carries its MAC and must. None: no MAC (memq:// tests, peers started by hand).
  std::optional<RunKey> key;

  /// run_id, new_time_ratio and the key from the launcher's environment.
  /// @throws std::invalid_argument naming $COSIM_RUN_KEY_FILE and what is wrong with its file.
  void read_environment() {
    key = key_from_environment();
    if (const char* v = std::getenv("COSIM_RUN_ID")) run_id = v;
    if (const char* v = std::getenv("COSIM_NEW_TIME_RATIO")) new_time_ratio = std::string(v) == "1";
  }
};

}  // namespace cosim::protocol
