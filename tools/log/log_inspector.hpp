// The log inspector behind `cosim-log` (docs/logs.md): what a recorded LCM log of coupled
// runs holds (channels, counts, rates, gaps, missing or duplicated steps and sequence
// numbers, undecodable and foreign messages), one step's messages as text, and the state
// messages' time series as HDF5. The protocol is protocol/README.md.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tools/log/lcm_log.hpp"

namespace cosim::logtool {

/// Inclusive ranges [first, last] of integers, e.g. missing steps {7, 7}, {40, 45}.
using Ranges = std::vector<std::pair<std::int64_t, std::int64_t>>;

/// One channel of the log, every message on it (all tokens, all types).
struct ChannelStats {
  std::string channel;
  std::string prefix;                     ///< the run's channel prefix; "" outside the protocol
  MsgType type = MsgType::unknown;        ///< by the channel's suffix
  std::int64_t count = 0;                 ///< messages
  std::int64_t bytes = 0;                 ///< message bytes
  std::int64_t first_utime = 0;           ///< log time of the first message, us since 1970
  std::int64_t last_utime = 0;            ///< log time of the last message
  std::int64_t largest_gap_us = 0;        ///< largest time between consecutive messages
  std::int64_t largest_gap_at_utime = 0;  ///< log time of the message that ended it
  /// Messages per type by their LCM fingerprint ("solid_state_t", "unknown 0x...").
  std::map<std::string, std::int64_t> fingerprints;
  std::int64_t undecodable = 0;   ///< fail to decode as the channel's type
  std::string first_undecodable;  ///< why the first of them failed, one line
  /// Decoded messages per token.
  std::map<std::string, std::int64_t> tokens;
  /// Mean rate over the channel's span, (count - 1) / (last - first); 0 for fewer than two
  /// messages or no span.
  double rate_hz() const;
};

/// The steps and sequence numbers of one run's state messages on one channel
/// (solid_state_t or fluid_state_t with the run's token; every copy as logged).
struct StateStats {
  std::int64_t messages = 0;  ///< decoded messages (all copies)
  std::int64_t first_step = 0, last_step = -1;
  std::int64_t distinct_steps = 0;
  std::int64_t steps_missing = 0;  ///< in [first_step, last_step], never logged
  Ranges steps_missing_ranges;
  std::int64_t steps_duplicated = 0;  ///< steps logged more than once (resends)
  Ranges steps_duplicated_ranges;
  std::int64_t extra_copies = 0;      ///< copies beyond each step's first
  std::int64_t copies_differing = 0;  ///< later copies whose bytes differ from the first
                                      ///< (a resend is bit for bit the original)
  std::int64_t first_seq = 0, last_seq = -1;
  std::int64_t seq_missing = 0;  ///< in [first_seq, last_seq], never logged
  Ranges seq_missing_ranges;
  std::int64_t seq_duplicated = 0;    ///< messages whose seq was logged before
  std::int64_t seq_out_of_order = 0;  ///< a new seq below the largest logged before it
  std::int64_t num_cgps = -1;         ///< of the first message; -1 for none
  std::int64_t num_cgps_changes = 0;  ///< messages with another num_cgps than the first
  /// Distinct sub-iterations (iteration > 0: the implicit scheme, protocol/README.md 13);
  /// their copies are counted apart from the steps' (a step's iterates are not resends).
  std::int64_t sub_iterations = 0;
};

/// One run: a channel prefix and a token (protocol/README.md, section 6).
struct RunStats {
  std::string prefix;
  std::string token;
  std::int64_t messages = 0;  ///< decoded messages with this token
  std::int64_t first_utime = 0;
  std::int64_t fluid_hellos = 0, solid_hellos = 0;
  std::string solid_model;  ///< of the solid's hello_t
  bool welcome = false;     ///< a welcome_t was logged
  bool accepted = false;
  std::string refused_reason;
  std::int64_t total_steps = 0, rigid_steps = 0, time_ratio = 0;
  std::int64_t stops = 0;  ///< stop_t messages (each is sent three times)
  std::int64_t stop_step = 0, stop_exit_code = 0;
  std::string stop_reason;                      ///< of the first stop_t
  std::map<std::string, std::int64_t> resends;  ///< resend_t per `what`
  StateStats solid;                             ///< SOLID_STATE
  StateStats fluid;                             ///< FLUID_STATE
};

/// The channels of one prefix and the runs (tokens) seen on them, in order of appearance.
struct PrefixStats {
  std::string prefix;
  std::vector<ChannelStats> channels;  ///< HELLO, WELCOME, SOLID_STATE, ... as present
  std::vector<RunStats> runs;
  const ChannelStats* channel(MsgType t) const;
  const RunStats* run(const std::string& token) const;
};

struct LogSummary {
  std::string path;
  std::uint64_t file_bytes = 0;
  std::int64_t events = 0;
  std::int64_t first_utime = 0, last_utime = 0;
  std::uint64_t skipped_bytes = 0;           ///< corrupt stretches between events
  std::string truncated;                     ///< non-empty: the log ended inside an event
  std::vector<PrefixStats> prefixes;         ///< in order of appearance
  std::vector<ChannelStats> other_channels;  ///< channels without a protocol suffix
  const PrefixStats* prefix(const std::string& p) const;
  /// The run with this token (any prefix); nullptr when none.
  const RunStats* run(const std::string& token) const;
};

/// Reads the whole log once. @throws LogInputError (see LogReader).
LogSummary summarize_log(const std::string& path);

/// The summary as a readable table (what `cosim-log summary` prints).
std::string format_summary(const LogSummary& s);

struct ShowOptions {
  std::int64_t step = 0;
  std::string channel;         ///< a suffix (SOLID_STATE) or a whole channel; "" = all
  std::int64_t max_cgps = -1;  ///< CGP lines per array; -1 = all
};

/// The messages of one step (solid_state_t, fluid_state_t, resend_t, stop_t with that
/// `step`) as text, every field, arrays one CGP per line, in log order.
/// @throws LogInputError when no message of the step (on that channel) is in the log.
std::string show_step(const std::string& path, const ShowOptions& opt);

struct ExportResult {
  std::string prefix, token;
  std::int64_t solid_rows = 0, fluid_rows = 0;
  std::int64_t solid_skipped = 0, fluid_skipped = 0;  ///< later copies of a step left out
};

/// Writes the time series of one run's state messages to `out_path` (HDF5): groups
/// /solid_state and /fluid_state, one row per step in step order (the first copy of each
/// step), datasets step, seq, log_utime, log_time_s and the message's fields, each with a
/// `units` attribute. `run` picks the run by token or prefix; empty: the log's only run
/// with state messages (preferring runs with an accepted welcome_t).
/// @throws LogInputError for a bad log or run choice; std::runtime_error for an HDF5 error.
ExportResult export_log(const std::string& path, const std::string& out_path,
                        const std::string& run = "");

/// "7, 40-45, ..." (at most `max` ranges, then "... (N more)").
std::string format_ranges(const Ranges& r, std::size_t max = 8);

}  // namespace cosim::logtool
