// cosim-replay's reading of the LCM log (docs/replay.md): the log file with each event's
// offset (a logged message is read again when it is due), the decoding of a logged message
// without the servers' MAC, the scan of the log into runs (by channel prefix and token) and
// the choice of the run to replay.
#pragma once

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "protocol/message_auth.hpp"
#include "tools/log/lcm_log.hpp"
#include "tools/replay/replay.hpp"

namespace cosim::replay {

/// The message types, by channel: prefix + message name (protocol/channels.hpp).
using Kind = protocol::MessageKind;

/// The run's LCM log through the one reader of LCM logs (tools/log/lcm_log.hpp), the
/// servers' MAC trailers kept (message_bytes checks them): read in file order with the
/// offset of every event, so that a logged message can be read again when it is due (a long
/// run's log need not fit in memory).
using logtool::LogEvent;
using logtool::LogReader;

/// The log at `path` opened for the replay. @throws ReplayError naming the file: no such
/// file, a folder, or not an LCM log.
LogReader open_log(const std::string& path);

/// The key of the replayed run's MACs (ReplayOptions::key), for the whole replay: set once
/// before the log is read.
void set_log_key(const std::optional<protocol::RunKey>& key);
const std::optional<protocol::RunKey>& log_key();

/// The bytes of a logged message before the servers' MAC trailer (protocol/message_auth.hpp):
/// verified with the key; without one, removed where the message decodes to exactly the
/// bytes before it. None: the MAC does not verify (a forger's message), or no decode.
template <class Message>
std::optional<std::size_t> message_bytes(const LogEvent& e) {
  const std::size_t size = e.data.size();
  if (log_key()) return protocol::verified_size(*log_key(), e.channel, e.data.data(), size);
  Message m{};
  const int used = m.decode(e.data.data(), 0, static_cast<int>(size));
  if (used < 0) return std::nullopt;
  return static_cast<std::size_t>(used) + protocol::kMacBytes == size ? static_cast<std::size_t>(used) : size;
}

template <class Message>
std::optional<Message> decode(const LogEvent& e) {
  const std::optional<std::size_t> size = message_bytes<Message>(e);
  if (!size) return std::nullopt;
  Message m{};
  if (m.decode(e.data.data(), 0, static_cast<int>(*size)) < 0) return std::nullopt;
  return m;
}

/// A logged message of the run with where it stands among the others: the first copy of
/// one seq (a state message) or one stop_t.
struct Logged {
  long offset = 0;           ///< the event's byte offset in the log
  std::int64_t step = 0;     ///< the message's step
  std::int32_t iteration = 0;
  std::int64_t order = 0;    ///< the event's place among the run's messages (1, 2, ...)
  /// The highest fluid_state_t and solid_state_t seq of the run logged before it, -1 for
  /// none. Its sender published it after it had heard the other side's messages up to
  /// these at most, so a server that has published its own up to them can be given it
  /// (docs/replay.md, "How it replays").
  std::int64_t after_fluid = -1, after_solid = -1;
};

struct LoggedStop {
  cosimlcm::stop_t message;
  Logged where;
};

/// The logged traffic of one run: one channel prefix, one token.
struct RunTraffic {
  std::optional<cosimlcm::hello_t> fluid_hello, solid_hello;  ///< the first of each role
  std::optional<cosimlcm::welcome_t> welcome;  ///< the first accepted one, else the first
  /// By sender: the first stop_t, and the first with a non-zero exit code.
  std::map<std::string, std::pair<std::optional<LoggedStop>, std::optional<LoggedStop>>> stops;
  /// seq -> the first copy (later copies are resends or duplicates, section 7)
  std::map<std::int64_t, Logged> solid_states, fluid_states;
  std::int64_t messages = 0, copies = 0;
  /// The highest seq of each state channel logged so far (while scanning: see Logged).
  std::int64_t max_fluid_seq = -1, max_solid_seq = -1;

  Logged here(long offset, std::int64_t step, std::int32_t iteration) const {
    return Logged{offset, step, iteration, messages, max_fluid_seq, max_solid_seq};
  }
};

struct PrefixTraffic {
  std::int64_t events = 0;
  std::map<std::string, RunTraffic> runs;  ///< by token
};

struct LogScan {
  std::map<std::string, PrefixTraffic> prefixes;
  std::int64_t events = 0, other_channels = 0, undecodable = 0;
};

/// Every event of the log, by channel prefix and token.
LogScan scan(LogReader& log);

/// The run to replay: the log's only prefix and only token with both hello_t, or the ones
/// named on the command line.
struct Selected {
  std::string prefix, token;
  const RunTraffic* run = nullptr;
};

Selected select_run(const LogScan& s, const ReplayOptions& o, const std::string& log);

/// The steps of a state channel's messages (by seq).
std::set<std::int64_t> steps_of(const std::map<std::int64_t, Logged>& messages);
/// "0..199", "none", or "0..60 (58 steps, with gaps)".
std::string step_range(const std::set<std::int64_t>& steps);
std::int32_t max_iteration(const std::map<std::int64_t, Logged>& messages);
/// "steps 0..199", and with sub-iterations "steps 0..60 (143 messages, iterations 0..3)".
std::string describe_states(const std::map<std::int64_t, Logged>& messages);

}  // namespace cosim::replay
