// cosim-record's recording (docs/logs.md, "Recording"): every message on a run's channels,
// written to an LCM log in LCM's own format (lcm::LogFile), none lost when the recorder lags
// and none left unwritten when it is stopped.
//
// Why not lcm-logger (Debian's liblcm-bin, LCM 1.3.1), which launch/run-coupled.sh --log used
// before: three of its ways lose messages of a run, and the log is what a user replays
// (measured by launch/record-under-load.sh, docs/logs.md).
// - It subscribes with LCM's default queue of 30 messages: when its main thread falls behind
//   (a busy machine), LCM's receive thread drops every further message of the subscription,
//   from the middle of the run (at nice 19 beside busy loops it kept solid_state_t steps
//   0..13 of 0..29 in one run of five).
// - At SIGINT it discards the messages it has received and not yet written; its writer
//   fsyncs at every flush, so on a busy machine the run's last steps were lost (CI:
//   Replay.ReplayReproducesParallelScheme read a log without steps 28 and 29).
// - Its -f truncated the log of the run a restart continued.
// The recorder subscribes with no queue limit, writes each message at once, appends, and when
// asked to stop keeps receiving until the bus has been quiet (below).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

namespace lcm {
class LCM;
}

namespace cosim::record {

struct RecordOptions {
  std::string log_path;          ///< the LCM log: created, or appended to (never truncated)
  std::string channels;          ///< LCM's channel regex (anchored), e.g. "COSIM_1a2b3c4d_.*"
  /// After the stop request: the bus counts as quiet once LCM has had nothing to hand over
  /// for this long, twice in a row, with this process's UDP receive queues empty.
  std::chrono::milliseconds quiet{100};
  /// Gives up draining after this long (a bus that never falls silent).
  std::chrono::milliseconds drain_limit{30'000};
  /// The receive buffer asked for LCM's UDP sockets: what waits there while the recorder
  /// gets no CPU (the default, net.core.rmem_default, held 55 of a 66-message run); 0 leaves
  /// the system's default.
  int receive_buffer_bytes = 16 << 20;
};

struct RecordResult {
  std::int64_t events = 0;         ///< events written by this recording
  std::int64_t bytes = 0;          ///< bytes they took in the log
  std::int64_t after_stop = 0;     ///< of them, received after the stop request
  bool drained = true;             ///< false when drain_limit ran out
  double drain_s = 0;              ///< time from the stop request to the end
  std::int64_t receive_buffer_bytes = -1;  ///< the smallest UDP receive buffer got; -1: no UDP socket
};

/// Thrown for a log that cannot be opened, appended to or written: one line naming it.
class RecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Why `channels` is not a channel pattern LCM's subscribe takes (GLib's regular expressions,
/// anchored), or "" if it is one.
std::string channels_problem(const std::string& channels);

/// Why `path` may not be appended to, or "" if it may: a missing or empty file, or one
/// starting with LCM's event magic (0xEDA1DA01). A file of another kind is refused, not
/// overwritten.
std::string append_problem(const std::string& path);

/// Bytes waiting in this process's UDP receive queues (/proc/net/udp and udp6, the sockets
/// among /proc/self/fd); 0 where /proc does not tell.
std::int64_t udp_receive_backlog();

/// Asks `bytes` of receive buffer for each of this process's UDP sockets (LCM's: the recorder
/// has no other): SO_RCVBUFFORCE where permitted (root), else SO_RCVBUF (capped by
/// net.core.rmem_max); 0 asks nothing. @return the smallest buffer the kernel granted (it reports twice the
/// payload size asked), -1 when there is no UDP socket.
std::int64_t enlarge_udp_receive_buffers(int bytes);

/// Records `options.channels` of `bus` until `stop_requested()` is true, then drains: keeps
/// receiving until the bus is quiet (RecordOptions::quiet). `on_ready` is called once the
/// subscription is made (for the udpm provider: the multicast group joined) and the receive
/// buffers enlarged (with the smallest granted), before the first message.
/// @throws RecordError (channels, opening, appending, writing), std::runtime_error (LCM).
RecordResult record(lcm::LCM& bus, const RecordOptions& options, const std::function<bool()>& stop_requested,
                    const std::function<void(std::int64_t receive_buffer_bytes)>& on_ready);

}  // namespace cosim::record
