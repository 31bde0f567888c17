// What a caller tells a protocol peer about its run, the same for both servers (and for any
// peer built on the session layer): the run's token, quiet progress, an in-process bus, the
// test setting of injected faults, and the checkpoint to continue from.
#pragma once

#include <string>

#include "protocol/fault_injection.hpp"

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
};

}  // namespace cosim::protocol
