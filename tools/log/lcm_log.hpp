// Reading LCM log files (the format lcm-logger writes) and decoding the project's messages
// from them safely: a malformed message is reported with one line, never decoded into a
// huge allocation or read past its end. The protocol is protocol/README.md.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/message_auth.hpp"

namespace cosim::logtool {

/// The run's key for the servers' MAC trailers (protocol/message_auth.hpp; cosim-log
/// --key-file): with it, every logged message of a run's channel must verify (those that do
/// not are left out and counted, unauthenticated_events()); without it, a trailer is removed
/// unverified wherever the bytes are a whole message only without it.
void set_log_key(std::optional<protocol::RunKey> key);
/// Logged messages left out because their MAC did not verify under the key.
std::int64_t unauthenticated_events();

/// Input the tool refuses (a missing file, not an LCM log, a bad option, a step not in the
/// log): one line naming it; the command line tool exits 2.
class LogInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One event of an LCM log: lcm-logger's event number, its receive time (microseconds since
/// 1970-01-01 UTC), the channel and the message bytes.
struct LogEvent {
  std::int64_t number = 0;
  std::int64_t utime = 0;
  std::string channel;
  std::vector<std::uint8_t> data;
  std::uint64_t offset = 0;  ///< byte offset of the event in the file
};

/// What LogReader::next() does with the servers' MAC trailers of a run's messages.
enum class MacTrailers {
  strip,  ///< verified and removed (set_log_key), as cosim-log reads
  keep,   ///< left in the bytes as logged (cosim-replay checks them itself; tests)
};

/// The one reader of LCM log files (cosim-log, cosim-replay, the tests). Streams the events
/// of an LCM log file, in file order. The format (LCM's eventlog, all
/// integers big-endian): per event the magic 0xEDA1DA01, int64 event number, int64 utime,
/// int32 channel length, int32 data length, the channel, the data. Like LCM's own reader,
/// a corrupt stretch is skipped up to the next magic (counted in skipped_bytes()); a file
/// that ends inside an event (a logger stopped mid-write) ends the log with a warning.
class LogReader {
 public:
  /// @throws LogInputError: no such file, not a regular file, unreadable, empty, or its
  ///         first bytes are not an LCM event.
  explicit LogReader(const std::string& path, MacTrailers macs = MacTrailers::strip);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  /// The next event; false at the end of the log.
  bool next(LogEvent& event);
  /// The event that starts at byte `offset` (a LogEvent::offset from next()) read again,
  /// valid until the next call; next() goes on after it. A long run's log need not be held
  /// in memory: its events are found again when they are due (cosim-replay).
  /// @throws std::runtime_error naming the file and the byte when no event starts there.
  const LogEvent& at(std::uint64_t offset);

  const std::string& path() const { return path_; }
  std::uint64_t file_bytes() const { return file_bytes_; }
  /// Bytes skipped because they were not a well-formed event (corrupt stretches).
  std::uint64_t skipped_bytes() const { return skipped_; }
  /// Non-empty when the log ended inside an event: one line naming the offset.
  const std::string& truncated() const { return truncated_; }

 private:
  bool read_exact(void* buf, std::size_t n);
  /// The event's MAC trailer verified and removed (see set_log_key); false: leave it out.
  bool strip_mac(LogEvent& event);
  bool resync(std::uint64_t from);

  std::string path_;
  MacTrailers macs_ = MacTrailers::strip;
  LogEvent again_;  ///< at()'s event
  std::FILE* file_ = nullptr;
  std::uint64_t file_bytes_ = 0;
  std::uint64_t pos_ = 0;
  std::uint64_t skipped_ = 0;
  std::string truncated_;
};

/// The six message types of the protocol (in protocol::MessageKind's order), and the rest.
enum class MsgType { hello, welcome, solid_state, fluid_state, resend, stop, unknown };

/// "hello_t", ..., "stop_t"; "unknown" for MsgType::unknown.
const char* type_name(MsgType t);
/// The channel suffix of a type: "HELLO", ..., "STOP"; "" for unknown.
const char* type_suffix(MsgType t);
/// The type a run's channel carries (protocol::classify_channel: a valid prefix, then the
/// message's name), and the prefix; MsgType::unknown (prefix empty) for any other channel.
MsgType type_by_channel(std::string_view channel, std::string* prefix = nullptr);
/// Whether the `size` bytes at `data` are exactly one message of type `t` (fingerprint,
/// lengths, counts, nothing after the last field).
bool whole_message(MsgType t, const std::uint8_t* data, std::size_t size);
/// The type whose LCM fingerprint the message starts with; unknown when it has no
/// fingerprint of the project's types.
MsgType type_by_fingerprint(const std::vector<std::uint8_t>& data);
/// The message's fingerprint in hex ("0x..."), or "(n bytes, no fingerprint)".
std::string fingerprint_text(const std::vector<std::uint8_t>& data);

/// Decodes `data` as message type T (cosimlcm::hello_t, ...). Checks the fingerprint, the
/// string lengths and the array sizes against the bytes before the generated decoder runs,
/// and that no byte is left over.
/// @return "" on success; otherwise one line naming the type and what is wrong (`out` is
///         then unspecified).
template <class T>
std::string decode_as(const std::vector<std::uint8_t>& data, T& out);

}  // namespace cosim::logtool
