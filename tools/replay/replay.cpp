#include "tools/replay/replay.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/config/scene_config.hpp"
#include "protocol/channels.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/session/peer_link.hpp"
#include "tools/log/lcm_log.hpp"
#include "common/text/text.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/config/solid_scene.hpp"

namespace cosim::replay {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using protocol::fmt;
using protocol::one_line;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr auto kProgressEvery = std::chrono::seconds(2);

const char* side_name(Side s) { return s == Side::Fluid ? "fluid" : "solid"; }

// ---- the log ----

/// The message types, by channel: prefix + message name (protocol/channels.hpp).
using Kind = protocol::MessageKind;

/// The run's LCM log (tools/log/lcm_log.hpp), the servers' MAC trailers kept (message_bytes
/// checks them): read in file order with the offset of every event, so that a logged
/// message can be read again when it is due (a long run's log need not fit in memory).
using logtool::LogEvent;
using logtool::LogReader;

LogReader open_log(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw ReplayError(path + ": no such log file");
  if (fs::is_directory(path, ec))
    throw ReplayError(path + ": is a folder; give the run's LCM log, e.g. OUTPUT/traffic.lcmlog");
  try {
    return LogReader(path, logtool::MacTrailers::keep);
  } catch (const logtool::LogInputError& e) {
    throw ReplayError(e.what());
  }
}

/// The key of the replayed run's MACs (ReplayOptions::key), for the whole replay.
std::optional<protocol::RunKey> g_log_key;

/// The bytes of a logged message before the servers' MAC trailer (protocol/message_auth.hpp):
/// verified with the key; without one, removed where the message decodes to exactly the
/// bytes before it. None: the MAC does not verify (a forger's message), or no decode.
template <class Message>
std::optional<std::size_t> message_bytes(const LogEvent& e) {
  const std::size_t size = e.data.size();
  if (g_log_key) return protocol::verified_size(*g_log_key, e.channel, e.data.data(), size);
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

LogScan scan(LogReader& log) {
  LogScan s;
  LogEvent e;
  while (log.next(e)) {
    const long offset = static_cast<long>(e.offset);
    ++s.events;
    const auto what = protocol::classify_channel(e.channel);
    if (!what) {
      ++s.other_channels;
      continue;
    }
    PrefixTraffic& p = s.prefixes[what->prefix];
    ++p.events;
    const auto run_of = [&](const std::string& token) -> RunTraffic& {
      RunTraffic& r = p.runs[token];
      ++r.messages;
      return r;
    };
    switch (what->kind) {
      case Kind::Hello:
        if (const auto m = decode<cosimlcm::hello_t>(e)) {
          RunTraffic& r = run_of(m->token);
          if (m->role == "fluid" && !r.fluid_hello) r.fluid_hello = *m;
          if (m->role == "solid" && !r.solid_hello) r.solid_hello = *m;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::Welcome:
        if (const auto m = decode<cosimlcm::welcome_t>(e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.welcome || (!r.welcome->accepted && m->accepted)) r.welcome = *m;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::SolidState:
        if (const auto m = decode<cosimlcm::solid_state_t>(e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.solid_states.emplace(m->seq, r.here(offset, m->step, m->iteration)).second) ++r.copies;
          r.max_solid_seq = std::max(r.max_solid_seq, m->seq);
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::FluidState:
        if (const auto m = decode<cosimlcm::fluid_state_t>(e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.fluid_states.emplace(m->seq, r.here(offset, m->step, m->iteration)).second) ++r.copies;
          r.max_fluid_seq = std::max(r.max_fluid_seq, m->seq);
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::Resend:
        if (const auto m = decode<cosimlcm::resend_t>(e)) run_of(m->token);
        else ++s.undecodable;
        break;
      case Kind::Stop:
        if (const auto m = decode<cosimlcm::stop_t>(e)) {
          RunTraffic& r = run_of(m->token);
          // By sender: the replayed server is given the stop_t of the side it does not run.
          auto& [stop, error_stop] = r.stops[m->sender];
          const LoggedStop logged{*m, r.here(offset, m->step, 0)};
          if (!stop) stop = logged;
          if (!error_stop && m->exit_code != 0) error_stop = logged;
        } else {
          ++s.undecodable;
        }
        break;
    }
  }
  return s;
}

std::string join_keys(const auto& map) {
  std::string out;
  for (const auto& [key, value] : map) out += (out.empty() ? "" : ", ") + key;
  return out;
}

/// The run to replay: the log's only prefix and only token with both hello_t, or the ones
/// named on the command line.
struct Selected {
  std::string prefix, token;
  const RunTraffic* run = nullptr;
};

Selected select_run(const LogScan& s, const ReplayOptions& o, const std::string& log) {
  if (s.prefixes.empty())
    throw ReplayError(log + ": no message on a run's channels (PREFIX + HELLO, WELCOME, SOLID_STATE, "
                            "FLUID_STATE, RESEND, STOP) among its " + std::to_string(s.events) +
                      " events; is it the traffic.lcmlog of launch/run-coupled.sh --log?");
  Selected sel;
  if (!o.channel_prefix.empty()) {
    if (!s.prefixes.count(o.channel_prefix))
      throw ReplayError("--channel-prefix = \"" + o.channel_prefix + "\": " + log +
                        " has no channel with it; its prefixes: " + join_keys(s.prefixes));
    sel.prefix = o.channel_prefix;
  } else if (s.prefixes.size() > 1) {
    throw ReplayError(log + ": channels of " + std::to_string(s.prefixes.size()) +
                      " prefixes (" + join_keys(s.prefixes) + "); choose one with --channel-prefix");
  } else {
    sel.prefix = s.prefixes.begin()->first;
  }
  const PrefixTraffic& p = s.prefixes.at(sel.prefix);
  std::map<std::string, const RunTraffic*> runs;  // tokens with both announcements
  for (const auto& [token, r] : p.runs)
    if (r.fluid_hello && r.solid_hello) runs.emplace(token, &r);
  if (!o.token.empty()) {
    const auto it = runs.find(o.token);
    if (it == runs.end())
      throw ReplayError("--token = \"" + o.token + "\": " + log + " has no run with it on " +
                        sel.prefix + "* (a token with a fluid and a solid hello_t); its runs: " +
                        (runs.empty() ? std::string("none") : join_keys(runs)));
    sel.token = o.token;
  } else if (runs.empty()) {
    throw ReplayError(log + ": no run on " + sel.prefix +
                      "*: no token has both a fluid and a solid hello_t (was the log started after "
                      "the handshake?)");
  } else if (runs.size() > 1) {
    throw ReplayError(log + ": " + std::to_string(runs.size()) + " runs on " + sel.prefix + "* (" +
                      join_keys(runs) + "); choose one with --token");
  } else {
    sel.token = runs.begin()->first;
  }
  sel.run = &p.runs.at(sel.token);
  return sel;
}

/// The steps of a state channel's messages (by seq).
std::set<std::int64_t> steps_of(const std::map<std::int64_t, Logged>& messages) {
  std::set<std::int64_t> steps;
  for (const auto& [seq, m] : messages) steps.insert(m.step);
  return steps;
}

std::string step_range(const std::set<std::int64_t>& steps) {
  if (steps.empty()) return "none";
  return std::to_string(*steps.begin()) + ".." + std::to_string(*steps.rbegin()) +
         (static_cast<std::int64_t>(steps.size()) == *steps.rbegin() - *steps.begin() + 1
              ? ""
              : " (" + std::to_string(steps.size()) + " steps, with gaps)");
}

std::int32_t max_iteration(const std::map<std::int64_t, Logged>& messages) {
  std::int32_t k = 0;
  for (const auto& [seq, m] : messages) k = std::max(k, m.iteration);
  return k;
}

/// "steps 0..199", and with sub-iterations "steps 0..60 (143 messages, iterations 0..3)".
std::string describe_states(const std::map<std::int64_t, Logged>& messages) {
  const std::set<std::int64_t> steps = steps_of(messages);
  std::string text = "steps " + step_range(steps);
  if (messages.size() != steps.size())
    text += " (" + std::to_string(messages.size()) + " messages, iterations 0.." +
            std::to_string(max_iteration(messages)) + ")";
  return text;
}

// ---- the comparison ----

/// A value that differs, with its place in the message.
struct FieldDiff {
  std::string field;     ///< e.g. "velocity_lb[17][2]"
  std::int64_t cgp = -1; ///< -1: a field of the whole message
  double replay = 0.0, logged = 0.0, abs = 0.0, rel = 0.0;
};

/// Which message: the sender's seq, its step and sub-iteration.
struct MessageKey {
  std::int64_t seq = 0, step = 0;
  std::int32_t iteration = 0;
};

/// One message's comparison (one step's, in a scheme without sub-iterations).
struct StepResult {
  std::int64_t seq = 0, step = 0, values = 0, differing = 0;
  std::int32_t iteration = 0;
  std::optional<FieldDiff> first, max_abs, max_rel;
};

/// Compares the values of one message, bit for bit, in message order and CGP by CGP, so
/// that the first difference is at the first CGP that differs.
class StepComparer {
 public:
  explicit StepComparer(StepResult& r) : r_(r) {}

  void value(double replay, double logged, const char* field, std::int64_t cgp = -1, int comp = -1) {
    ++r_.values;
    if (std::bit_cast<std::uint64_t>(replay) == std::bit_cast<std::uint64_t>(logged)) return;
    ++r_.differing;
    double abs = std::abs(replay - logged);
    if (std::isnan(abs)) abs = kInf;
    const double scale = std::max(std::abs(replay), std::abs(logged));
    const double rel = abs == 0.0 ? 0.0 : (scale > 0.0 && std::isfinite(scale) ? abs / scale : kInf);
    const auto make = [&] {
      FieldDiff d;
      d.field = field;
      if (cgp >= 0) d.field += "[" + std::to_string(cgp) + "]";
      if (comp >= 0) d.field += "[" + std::to_string(comp) + "]";
      d.cgp = cgp;
      d.replay = replay;
      d.logged = logged;
      d.abs = abs;
      d.rel = rel;
      return d;
    };
    if (!r_.first) r_.first = make();
    if (!r_.max_abs || abs > r_.max_abs->abs) r_.max_abs = make();
    if (!r_.max_rel || rel > r_.max_rel->rel) r_.max_rel = make();
  }

  /// The sizes of a per-CGP array (a difference is a field of the whole message).
  template <class A>
  void size(const A& replay, const A& logged, const char* field) {
    if (replay.size() == logged.size()) return;
    const std::string name = std::string("len(") + field + ")";
    value(double(replay.size()), double(logged.size()), name.c_str());
  }

  /// CGP l of a per-CGP array of numbers, or of [n][3] vectors (their sizes, then values).
  void at(const std::vector<double>& replay, const std::vector<double>& logged, std::size_t l, const char* field) {
    if (l < replay.size() && l < logged.size()) value(replay[l], logged[l], field, std::int64_t(l));
  }
  void at(const std::vector<std::vector<double>>& replay, const std::vector<std::vector<double>>& logged,
          std::size_t l, const char* field) {
    if (l >= replay.size() || l >= logged.size()) return;
    const std::size_t a = replay[l].size(), b = logged[l].size();
    if (a != b) {
      const std::string name = std::string("len(") + field + ")";
      value(double(a), double(b), name.c_str(), std::int64_t(l));
    }
    for (std::size_t c = 0; c < std::min(a, b); ++c)
      value(replay[l][c], logged[l][c], field, std::int64_t(l), int(c));
  }

 private:
  StepResult& r_;
};

/// The CGPs both copies of a per-CGP array have.
template <class A>
std::size_t both(const A& a, const A& b) {
  return std::min(a.size(), b.size());
}

/// fluid_state_t (protocol/README.md section 3), the logged one of the same seq: step,
/// iteration, num_cgps, bulk_velocity_lb, then per CGP rho_lb, velocity_lb, rho_start_lb,
/// velocity_start_lb.
void compare(const cosimlcm::fluid_state_t& a, const cosimlcm::fluid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.step), double(b.step), "step");
  c.value(a.iteration, b.iteration, "iteration");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  c.value(a.bulk_velocity_lb, b.bulk_velocity_lb, "bulk_velocity_lb");
  c.size(a.rho_lb, b.rho_lb, "rho_lb");
  c.size(a.velocity_lb, b.velocity_lb, "velocity_lb");
  c.size(a.rho_start_lb, b.rho_start_lb, "rho_start_lb");
  c.size(a.velocity_start_lb, b.velocity_start_lb, "velocity_start_lb");
  const std::size_t n = std::max({both(a.rho_lb, b.rho_lb), both(a.velocity_lb, b.velocity_lb),
                                   both(a.rho_start_lb, b.rho_start_lb),
                                   both(a.velocity_start_lb, b.velocity_start_lb)});
  for (std::size_t l = 0; l < n; ++l) {
    c.at(a.rho_lb, b.rho_lb, l, "rho_lb");
    c.at(a.velocity_lb, b.velocity_lb, l, "velocity_lb");
    c.at(a.rho_start_lb, b.rho_start_lb, l, "rho_start_lb");
    c.at(a.velocity_start_lb, b.velocity_start_lb, l, "velocity_start_lb");
  }
}

/// solid_state_t (section 3), the logged one of the same seq: step, iteration, substeps,
/// solid_time_s, num_cgps, then per CGP position_lb and impulse_lb.
void compare(const cosimlcm::solid_state_t& a, const cosimlcm::solid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.step), double(b.step), "step");
  c.value(a.iteration, b.iteration, "iteration");
  c.value(a.substeps, b.substeps, "substeps");
  c.value(a.solid_time_s, b.solid_time_s, "solid_time_s");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  c.size(a.position_lb, b.position_lb, "position_lb");
  c.size(a.impulse_lb, b.impulse_lb, "impulse_lb");
  const std::size_t n = std::max(both(a.position_lb, b.position_lb), both(a.impulse_lb, b.impulse_lb));
  for (std::size_t l = 0; l < n; ++l) {
    c.at(a.position_lb, b.position_lb, l, "position_lb");
    c.at(a.impulse_lb, b.impulse_lb, l, "impulse_lb");
  }
}

/// What is compared, as the report names it.
const char* compared_fields(Side side) {
  return side == Side::Fluid ? "step, iteration, num_cgps, bulk_velocity_lb, rho_lb, velocity_lb, rho_start_lb, "
                               "velocity_start_lb"
                             : "step, iteration, substeps, solid_time_s, num_cgps, position_lb, impulse_lb";
}

// ---- the missing peer ----

/// Unanswerable resend requests in a row (nothing fed in between) after which the server is
/// taken to wait for a message the log does not give: about 3 resend_after of waiting. A
/// server given everything the log holds for it asks at most once before it is fed again.
constexpr int kResendsBeforeGap = 3;
/// Copies of a resend_t this close together are one request round (kResendCopies at once).
constexpr auto kSameRound = std::chrono::milliseconds(5);

/// Plays the peer of the replayed server from the log, on the server's bus. Its handlers
/// run inside the server thread's handle calls (memq:// has one queue per lcm_t), so
/// everything below is touched by that thread only while the server runs, and read by the
/// caller after the thread joined.
///
/// The peer's messages go out by causality, with no knowledge of the scheme (docs/replay.md):
/// the logged peer's state messages in seq order (first copies; a seq missing from the log
/// ends the usable ones), each once the handshake is done and the server has published its
/// own state messages up to the highest seq the log shows before it; the peer's first
/// stop_t likewise, after the peer's messages logged before it. In a deterministic run the
/// server published those before it needed the message, so the replay never waits on
/// itself, whatever the message order of the scheme.
/// The transport settings of the peer the replay plays, on the replayed server's bus.
protocol::PeerLink::Settings link_settings(lcm::LCM& bus, const Selected& sel, Side side) {
  protocol::PeerLink::Settings s;
  s.role = side == Side::Fluid ? "solid" : "fluid";
  s.token = sel.token;
  s.channel_prefix = sel.prefix;
  s.bus = &bus;
  return s;
}

class Peer {
 public:
  Peer(lcm::LCM& bus, LogReader& log, const Selected& sel, Side side, const protocol::MessageOrder& order, bool quiet,
       std::ostream& err)
      : bus_(bus), log_(log), run_(*sel.run), token_(sel.token), side_(side), order_(order), quiet_(quiet), err_(err), link_(link_settings(bus, sel, side), err),
        ch_(link_.channels()) {
    const bool fluid = side_ == Side::Fluid;
    const auto& inputs = fluid ? run_.solid_states : run_.fluid_states;
    for (std::int64_t seq = 0;; ++seq) {
      const auto it = inputs.find(seq);
      if (it == inputs.end()) break;
      feed_.push_back(&it->second);
    }
    if (const auto it = run_.stops.find(peer_role()); it != run_.stops.end()) {
      stop_ = it->second.first;
      error_stop_ = it->second.second;
      for (std::size_t i = 0; stop_ && i < feed_.size(); ++i)
        if (feed_[i]->order < stop_->where.order) stop_after_ = i + 1;
    }
    // The session layer's transport (protocol/session/peer_link.hpp) on the server's bus: the
    // bytes checked before decoding, another run's token dropped; no value checks, so that
    // whatever the server publishes is compared with the log.
    subscribed_ = !link_.open() &&
                  link_.subscribe<cosimlcm::hello_t>(ch_.hello, [this](cosimlcm::hello_t&& m) { on_hello(&m); }) &&
                  link_.subscribe<cosimlcm::welcome_t>(ch_.welcome,
                                                       [this](cosimlcm::welcome_t&& m) { on_welcome(&m); }) &&
                  (fluid ? link_.subscribe<cosimlcm::fluid_state_t>(
                               ch_.fluid_state, [this](cosimlcm::fluid_state_t&& m) { on_fluid_state(&m); })
                         : link_.subscribe<cosimlcm::solid_state_t>(
                               ch_.solid_state, [this](cosimlcm::solid_state_t&& m) { on_solid_state(&m); })) &&
                  link_.subscribe<cosimlcm::resend_t>(ch_.resend, [this](cosimlcm::resend_t&& m) { on_resend(&m); });
  }
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;

  bool subscribed() const { return subscribed_; }

  /// After the server returned: what is left on the bus is compared, nothing more is fed.
  void finish() {
    done_ = true;
    while (bus_.handleTimeout(0) > 0) {
    }
  }

  // ---- results ----
  std::int64_t compared = 0, differing = 0, duplicates = 0, resends_answered = 0;
  std::optional<StepResult> first_different;
  std::optional<FieldDiff> max_abs, max_rel;
  std::optional<StepResult> max_abs_at, max_rel_at;  ///< the messages they are in (no diffs kept)
  std::set<std::int64_t> published;         ///< seqs the server published (first copies)
  std::vector<MessageKey> not_in_log;       ///< ... of which the log has no message
  std::optional<std::string> refused;       ///< the handshake's refusal, if any
  bool welcomed = false;                    ///< an accepted welcome_t went out or came back
  std::string log_gap;                      ///< "" or: the input the log lacks
  /// The server was given a stop_t with an error (the logged peer's, or the replay's at
  /// the log's end): the logged run may have ended before what the server published next.
  bool error_stop_given = false;
  std::string failure;                      ///< "" or: the log could not be read during the replay

 private:
  // The server's announcement: the fluid gets the logged solid's hello_t; the solid gets the
  // logged fluid's hello_t and a welcome_t from the coordinator's check (protocol/README.md
  // section 6) of the logged fluid hello_t against the server's own: the logged welcome_t if
  // accepted, else a refusal with the reason.
  void on_hello(const cosimlcm::hello_t* m) {
    if (m->token != token_ || done_) return;
    if (side_ == Side::Fluid) {
      if (m->role == "fluid") link_.publish(ch_.hello, *run_.solid_hello);
      return;
    }
    if (m->role != "solid") return;  // ours, heard back
    const bool first = !welcome_;
    if (first) {
      const protocol::HandshakeResult r = protocol::check_handshake(
          protocol::from_lcm(*run_.fluid_hello), protocol::from_lcm(*m), token_);
      welcome_ = *run_.welcome;
      if (!r.accepted) {
        welcome_->accepted = 0;
        welcome_->reason = r.reason;
        refused = r.reason;
      } else {
        welcomed = true;
      }
      link_.publish(ch_.hello, *run_.fluid_hello);
    }
    link_.publish(ch_.welcome, *welcome_);  // on every hello_t, as the coordinator does
    if (first && welcomed) {
      handshake_done_ = true;
      feed();  // the solid publishes solid_state_t(0) before it awaits anything
    }
  }

  // The fluid's coordinator decided (replaying the fluid): the peer's first messages follow
  // an accepted welcome_t; the fluid now awaits solid_state_t(0).
  void on_welcome(const cosimlcm::welcome_t* m) {
    if (side_ != Side::Fluid || m->token != token_ || seen_welcome_) return;
    seen_welcome_ = true;  // a refusal may be read only after the server returned (finish())
    if (!m->accepted) {
      refused = m->reason;
      return;
    }
    welcomed = true;
    handshake_done_ = true;
    if (feed() == 0) beyond_log(-1, 0);
  }

  void on_fluid_state(const cosimlcm::fluid_state_t* m) {
    if (m->token == token_) output(*m, run_.fluid_states);
  }

  void on_solid_state(const cosimlcm::solid_state_t* m) {
    if (m->token == token_) output(*m, run_.solid_states);
  }

  // The server asks for a peer message again (section 7): every logged one of that step it
  // was fed, bit for bit (in the implicit scheme a step has several); a step not fed yet is
  // ignored. Asked again and again with nothing fed in between, the server waits for a
  // message the log does not give it.
  void on_resend(const cosimlcm::resend_t* m) {
    if (m->token != token_ || done_) return;
    const bool fluid = side_ == Side::Fluid;
    if (m->what != (fluid ? "solid_state" : "fluid_state")) return;
    // A request round is kResendCopies copies sent at once (protocol/README.md 7): one ask.
    const Clock::time_point now = Clock::now();
    const bool same_round = now - last_request_ < kSameRound;
    last_request_ = now;
    if (same_round) return;
    bool answered = false;
    for (std::size_t i = 0; i < next_; ++i)
      if (feed_[i]->step == m->step) {
        guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, feed_[i]->offset); });
        answered = true;
      }
    if (answered) ++resends_answered;
    if (++resends_since_feed_ >= kResendsBeforeGap && !stopped_)
      end_feeding("the " + std::string(side_name(side_)) + " server waits for a " + peer_type() + " of step " +
                  std::to_string(m->step) + " that the log does not give it (asked " +
                  std::to_string(resends_since_feed_) + " times since the last one fed" + last_fed() + ")");
  }

  /// Compares the first copy of a seq with the log, then feeds what is due.
  template <class Message>
  void output(const Message& m, const std::map<std::int64_t, Logged>& logged) {
    if (!published.insert(m.seq).second) {
      ++duplicates;
      return;
    }
    published_up_to_ = std::max(published_up_to_, m.seq);
    if (const auto it = logged.find(m.seq); it == logged.end()) {
      not_in_log.push_back({m.seq, m.step, m.iteration});
    } else {
      guarded([&] {
        const std::optional<Message> l = decode<Message>(log_.at(static_cast<std::uint64_t>(it->second.offset)));
        if (!l) throw std::runtime_error(log_.path() + ": the logged message of seq " + std::to_string(m.seq) +
                                         " (step " + std::to_string(it->second.step) + ") no longer decodes");
        StepResult r;
        r.seq = m.seq;
        r.step = m.step;
        r.iteration = m.iteration;
        compare(m, *l, r);
        record(r);
      });
    }
    progress(m.step);
    if (feed() == 0) beyond_log(m.step, m.iteration);
  }

  void record(StepResult& r) {
    ++compared;
    if (r.differing == 0) return;
    ++differing;
    if (!first_different) first_different = r;
    if (!max_abs || r.max_abs->abs > max_abs->abs) {
      max_abs = r.max_abs;
      max_abs_at = r;
    }
    if (!max_rel || r.max_rel->rel > max_rel->rel) {
      max_rel = r.max_rel;
      max_rel_at = r;
    }
  }

  /// Publishes the peer's messages that are due (class comment); returns how many.
  int feed() {
    if (done_ || stopped_ || !handshake_done_) return 0;
    const bool fluid = side_ == Side::Fluid;
    int fed = 0;
    while (next_ < feed_.size() && published_up_to_ >= trigger(*feed_[next_]) && !stopped_) {
      guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, feed_[next_]->offset); });
      ++next_;
      ++fed;
      resends_since_feed_ = 0;
    }
    if (stop_ && !stopped_ && next_ >= stop_after_ && published_up_to_ >= trigger(stop_->where)) {
      stopped_ = true;
      error_stop_given = stop_->message.exit_code != 0;
      link_.publish(ch_.stop, stop_->message);
      ++fed;
    }
    return fed;
  }

  /// The server's own seq the log shows before `m`.
  std::int64_t trigger(const Logged& m) const {
    return side_ == Side::Fluid ? m.after_fluid : m.after_solid;
  }

  /// The server published a message (of `step`, `iteration`; -1: the handshake) and nothing
  /// was due. With the log's peer messages all given and no stop_t of the peer in it, the
  /// server has gone past the log: at the solid's last message of the run, a log that lost
  /// the coordinator's stop_t gets stop_t(N, 0); otherwise the server awaits what the log
  /// does not hold.
  void beyond_log(std::int64_t step, std::int32_t iteration) {
    if (stopped_ || done_ || next_ < feed_.size() || stop_) return;
    const std::int64_t total = run_.welcome->total_steps;
    if (side_ == Side::Solid && iteration == 0 && step == order_.final_step(total)) {
      stopped_ = true;
      cosimlcm::stop_t s{};
      s.token = token_;
      s.sender = peer_role();
      s.step = total;
      s.exit_code = 0;
      link_.publish(ch_.stop, s);
      return;
    }
    end_feeding("the log has no " + awaited() + " (nor a stop_t with an error)");
  }

  /// The log gives the server nothing more: the logged run's error stop_t of the peer if
  /// there is one (the run ended there), else a stop_t(4) naming `gap`.
  void end_feeding(const std::string& gap) {
    if (stopped_ || done_) return;
    stopped_ = true;
    error_stop_given = true;
    if (error_stop_) {
      link_.publish(ch_.stop, error_stop_->message);
      return;
    }
    log_gap = gap;
    cosimlcm::stop_t s{};
    s.token = token_;
    s.sender = peer_role();
    s.step = next_ > 0 ? feed_[next_ - 1]->step : 0;
    s.exit_code = 4;
    s.reason = "cosim-replay: " + log_gap;
    link_.publish(ch_.stop, s);
  }

  /// The peer message the server awaits after the log's last usable one: by step where a
  /// step has one message, else by seq.
  std::string awaited() const {
    const std::string type = peer_type();
    if (order_.several_per_step && next_ > 0)
      return type + " of seq " + std::to_string(next_) + " (after step " + std::to_string(feed_[next_ - 1]->step) +
             ", iteration " + std::to_string(feed_[next_ - 1]->iteration) + ")";
    if (next_ > 0) return type + " of step " + std::to_string(feed_[next_ - 1]->step + 1);
    if (side_ == Side::Fluid) return type + " of step 0";
    return type + " of step " +
           std::to_string(order_.first_fluid_step(run_.welcome->rigid_steps));
  }

  std::string last_fed() const {
    if (next_ == 0) return ": none";
    const Logged& l = *feed_[next_ - 1];
    return ": step " + std::to_string(l.step) + (order_.several_per_step ? ", iteration " + std::to_string(l.iteration) : "") +
           ", seq " + std::to_string(next_ - 1);
  }

  /// The side this peer plays: the one the replayed server talks to.
  std::string peer_role() const { return side_ == Side::Fluid ? "solid" : "fluid"; }
  std::string peer_type() const { return side_ == Side::Fluid ? "solid_state_t" : "fluid_state_t"; }

  void publish_logged(const std::string& channel, long offset) {
    const LogEvent& e = log_.at(static_cast<std::uint64_t>(offset));
    // Bit for bit as logged, without the servers' MAC (the replayed server has no key).
    const std::optional<std::size_t> size =
        side_ == Side::Fluid ? message_bytes<cosimlcm::solid_state_t>(e) : message_bytes<cosimlcm::fluid_state_t>(e);
    link_.publish_bytes(channel, e.data.data(), size.value_or(e.data.size()));
  }

  /// Runs `f`; an exception (the log cannot be read again) ends the server with stop_t(1):
  /// exceptions must not cross LCM's C dispatch.
  template <class F>
  void guarded(F&& f) {
    try {
      f();
    } catch (const std::exception& e) {
      if (failure.empty()) failure = one_line(e.what());
      if (!stopped_) {
        stopped_ = true;
        error_stop_given = true;
        cosimlcm::stop_t s{};
        s.token = token_;
        s.sender = peer_role();
        s.step = next_ > 0 ? feed_[next_ - 1]->step : -1;
        s.exit_code = 1;
        s.reason = "cosim-replay: " + failure;
        link_.publish(ch_.stop, s);
      }
    }
  }

  void progress(std::int64_t step) {
    if (quiet_) return;
    const Clock::time_point now = Clock::now();
    if (now - last_progress_ < kProgressEvery) return;
    last_progress_ = now;
    err_ << "cosim-replay: step " << step << " of " << run_.welcome->total_steps << ", "
         << compared << " compared, " << differing << " differ\n";
    err_.flush();
  }

  lcm::LCM& bus_;
  LogReader& log_;
  const RunTraffic& run_;
  const std::string token_;
  const Side side_;
  const protocol::MessageOrder& order_;  ///< the scheme's row of the protocol's name table
  const bool quiet_;
  std::ostream& err_;
  protocol::PeerLink link_;  ///< the session layer's transport, on the server's bus
  const protocol::Channels& ch_;
  bool subscribed_ = false;
  std::optional<cosimlcm::welcome_t> welcome_;  ///< what the solid is answered (solid side)
  /// The peer's logged state messages of seq 0, 1, 2, ... (up to the first the log lacks).
  std::vector<const Logged*> feed_;
  std::size_t next_ = 0;          ///< feed_[next_] goes out next
  std::optional<LoggedStop> stop_, error_stop_;  ///< the peer's first stop_t, first with an error
  std::size_t stop_after_ = 0;    ///< stop_ goes out after feed_[0 .. stop_after_ - 1]
  std::int64_t published_up_to_ = -1;  ///< the server's highest seq published
  int resends_since_feed_ = 0;      ///< resend request rounds since the last message fed
  Clock::time_point last_request_{};  ///< the last resend_t's arrival (a round's copies: one)
  bool seen_welcome_ = false, handshake_done_ = false, stopped_ = false, done_ = false;
  Clock::time_point last_progress_ = Clock::now();
};

// ---- the run ----

std::string describe(const FieldDiff& d) {
  return d.field + ": replay " + fmt("%.17g", d.replay) + ", log " + fmt("%.17g", d.logged) +
         " (abs " + fmt("%.3g", d.abs) + ", rel " + fmt("%.3g", d.rel) + ")";
}

/// The last non-empty line of a text.
std::string last_line(const std::string& text) {
  std::istringstream in(text);
  std::string line, last;
  while (std::getline(in, line))
    if (!one_line(line).empty()) last = line;
  return one_line(last);
}

fs::path make_temp_output() {
  std::string pattern = (fs::temp_directory_path() / "cosim-replay-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr)
    throw std::runtime_error("cannot create a temporary output folder " + pattern + ": " +
                             std::strerror(errno));
  return pattern;
}

class Replay {
 public:
  Replay(const ReplayOptions& o, std::ostream& out, std::ostream& err) : o_(o), out_(out), err_(err) {}

  int run() {
    LogReader log = open_log(o_.log_path);
    const LogScan s = scan(log);
    const Selected sel = select_run(s, o_, o_.log_path);
    const RunTraffic& run = *sel.run;
    check_traffic(run, sel);

    const bool fluid = o_.side == Side::Fluid;
    // The scene: the run's own file, its output redirected (never the original run's).
    std::optional<fluid::FluidScene> fscene;
    std::optional<solid::SolidScene> sscene;
    std::string scene_output;
    try {
      if (fluid) {
        fscene = fluid::load_scene(o_.scene_path);
        if (!fscene->coupling) throw ReplayError(not_coupled());
      } else {
        sscene = solid::load_solid_scene(o_.scene_path);
        if (!sscene->coupled()) throw ReplayError(not_coupled());
      }
    } catch (const fluid::SceneError& e) {
      throw ReplayError(e.what());
    } catch (const solid::SolidSceneError& e) {
      throw ReplayError(e.what());
    }
    // Every scheme is replayed the same way (the peer feeds by causality); the scheme only
    // words the report (several messages a step) and the end of a log without stop_t.
    const protocol::SchemeSettings& scheme = fluid ? fscene->coupling->scheme : sscene->coupling->scheme;
    const protocol::MessageOrder& order = protocol::message_order(scheme.scheme);
    per_message_ = order.several_per_step;
    const fs::path output = output_dir();
    if (fluid) {
      fluid::SceneOverrides ov;
      ov.output_dir = output.string();
      fluid::apply_overrides(*fscene, ov);
    } else {
      solid::SolidSceneOverrides ov;
      ov.output_dir = output.string();
      ov.channel_prefix = sel.prefix;
      try {
        solid::apply_overrides(*sscene, ov);
      } catch (const solid::SolidSceneError& e) {
        throw ReplayError(e.what());
      }
    }
    const int threads = fluid && fscene->threads > 0 ? fscene->threads : omp_get_max_threads();

    out_ << "cosim-replay: the " << side_name(o_.side) << " of run " << sel.token << " from "
         << o_.log_path << "\n"
         << "  log: " << s.events << " events, " << run.messages << " of the run on " << sel.prefix
         << "*; solid_state_t " << describe_states(run.solid_states) << ", fluid_state_t "
         << describe_states(run.fluid_states) << "; " << run.copies << " resent or duplicate copies skipped\n"
         << "  scene " << o_.scene_path << "; server output " << output.string();
    if (fluid) out_ << "; " << threads << " OpenMP thread" << (threads == 1 ? "" : "s");
    out_ << "\n";
    out_.flush();

    lcm::LCM bus("memq://");
    if (!bus.good()) throw std::runtime_error("cannot open LCM's in-process bus memq://");
    Peer peer(bus, log, sel, o_.side, order, o_.quiet, err_);
    if (!peer.subscribed()) throw std::runtime_error("cannot subscribe to " + sel.prefix + "* on memq://");

    std::ostringstream server_out, server_err;
    int code = -1;
    std::thread server([&] {
      try {
        if (fluid) {
          // The thread count of the original process (fluid/app/main.cpp); the ICV is per thread.
          if (fscene->threads > 0) omp_set_num_threads(fscene->threads);
          fluid::CoupledFluidOptions fo;
          fo.token = sel.token;
          fo.channel_prefix = sel.prefix;
          fo.quiet = true;
          fo.bus = &bus;
          code = fluid::run_coupled_fluid(*fscene, fo, server_out, server_err);
        } else {
          solid::CoupledSolidOptions so;
          so.token = sel.token;
          so.quiet = true;
          so.bus = &bus;
          code = solid::run_coupled_solid(*sscene, so, server_out, server_err);
        }
      } catch (const std::exception& e) {
        server_err << side_name(o_.side) << ": " << one_line(e.what()) << "\n";
        code = exit_code::system;
      }
    });
    server.join();
    peer.finish();

    const fs::path server_log = output / (std::string(side_name(o_.side)) + ".log");
    std::ofstream(server_log) << server_out.str() << server_err.str();
    return report(peer, run, code, server_err.str(), output, server_log);
  }

 private:
  std::string not_coupled() const {
    return o_.scene_path + ": not a coupled scene (no [coupling] section); give the scene file of the "
                           "logged run";
  }

  void check_traffic(const RunTraffic& run, const Selected& sel) const {
    const std::string where = o_.log_path + ": run " + sel.token + " on " + sel.prefix + "*";
    if (!run.welcome)
      throw ReplayError(where + " has no welcome_t: the coordinator never decided; nothing to replay");
    if (!run.welcome->accepted)
      throw ReplayError(where + ": the handshake was refused (" + one_line(run.welcome->reason) +
                        "); nothing to replay");
    const bool fluid = o_.side == Side::Fluid;
    const auto& outputs = fluid ? run.fluid_states : run.solid_states;
    if (outputs.empty())
      throw ReplayError(where + " has no " + (fluid ? "fluid_state_t" : "solid_state_t") +
                        ": nothing to compare for --side " + side_name(o_.side));
    if (fluid && run.solid_states.empty())
      throw ReplayError(where + " has no solid_state_t to feed the fluid with");
  }

  fs::path output_dir() {
    if (o_.output_dir.empty()) {
      temporary_ = true;
      return make_temp_output();
    }
    const fs::path dir = o_.output_dir;
    std::error_code ec;
    const fs::path log_dir = fs::absolute(o_.log_path).parent_path();
    if (fs::exists(dir, ec) && fs::equivalent(dir, log_dir, ec))
      throw ReplayError("--output = " + o_.output_dir + ": is the logged run's folder (it holds " +
                        o_.log_path + "); the replay would overwrite its outputs: choose another folder");
    fs::create_directories(dir, ec);
    if (ec)
      throw std::runtime_error("cannot create the output folder " + dir.string() + ": " + ec.message());
    return dir;
  }

  int report(const Peer& p, const RunTraffic& run, int code, const std::string& server_err,
             const fs::path& output, const fs::path& server_log) {
    const bool fluid = o_.side == Side::Fluid;
    const char* type = fluid ? "fluid_state_t" : "solid_state_t";
    const char* server = side_name(o_.side);
    const std::string reason = last_line(server_err);
    if (!p.failure.empty()) {
      err_ << "cosim-replay: " << p.failure << "\n";
      return exit_code::system;
    }
    if (p.refused) {
      err_ << "cosim-replay: " << o_.scene_path << " does not match the logged run: "
           << (fluid ? "the fluid's coordinator refused the logged solid hello_t: "
                     : "the coordinator's check of the solid's hello_t against the logged fluid's: ")
           << one_line(*p.refused) << "\n";
      cleanup(output, true);
      return exit_code::bad_input;
    }
    if (!p.welcomed) {  // the server ended before the handshake
      err_ << "cosim-replay: the " << server << " server exited " << code << " before the handshake: "
           << reason << " (its output: " << server_log.string() << ")\n";
      return code == exit_code::bad_input ? exit_code::bad_input : exit_code::server_failed;
    }

    // Logged outputs the server never published; published ones the log lacks (past the end
    // of an incomplete log, or of a run that the peer stopped with an error, they are the
    // log's end, not a difference: the logged server may have stopped before them). By seq.
    const auto& logged = fluid ? run.fluid_states : run.solid_states;
    std::vector<std::int64_t> missing;
    std::vector<MessageKey> not_in_log;
    for (const auto& [seq, m] : logged)
      if (!p.published.count(seq)) missing.push_back(seq);
    for (const MessageKey& k : p.not_in_log)
      if (!p.error_stop_given || k.seq < logged.rbegin()->first) not_in_log.push_back(k);

    const bool different = p.differing > 0 || !not_in_log.empty() || (code == 0 && !missing.empty());
    if (!different && code == 0 && p.log_gap.empty()) {
      out_ << "identical: " << units(p.compared) << " compared (" << type << " " << step_range(steps_of(logged))
           << (per_message_ ? ", iterations 0.." + std::to_string(max_iteration(logged)) : std::string())
           << ", by seq: " << compared_fields(o_.side) << ", bit for bit)\n";
      cleanup(output, false);
      return exit_code::identical;
    }
    if (p.first_different) {
      const StepResult& r = *p.first_different;
      const FieldDiff& d = *r.first;
      out_ << "different: first at " << where(r.step, r.iteration) << " (" << type << "), "
           << (d.cgp >= 0 ? "CGP " + std::to_string(d.cgp) + ", " : std::string()) << describe(d) << "\n";
      out_ << "  at " << where(r.step, r.iteration) << ": " << r.differing << " of " << r.values
           << " values differ; largest abs " << fmt("%.3g", r.max_abs->abs) << " (" << r.max_abs->field
           << "), largest rel " << fmt("%.3g", r.max_rel->rel) << " (" << r.max_rel->field << ")\n";
      out_ << "  over the replay: " << p.differing << " of " << units(p.compared) << " differ; largest abs "
           << fmt("%.3g", p.max_abs->abs) << " (" << where(p.max_abs_at->step, p.max_abs_at->iteration) << ", "
           << p.max_abs->field << "), largest rel " << fmt("%.3g", p.max_rel->rel) << " ("
           << where(p.max_rel_at->step, p.max_rel_at->iteration) << ", " << p.max_rel->field << ")\n";
    } else if (different) {
      out_ << "different: " << units(p.compared) << " compared and identical, but\n";
    } else {
      out_ << "identical so far: " << units(p.compared) << " compared\n";
    }
    if (!not_in_log.empty())
      out_ << "  the server published " << type << " of " << units(not_in_log.size())
           << " the log lacks (first: " << where(not_in_log.front().step, not_in_log.front().iteration) << ")\n";
    if (!missing.empty()) {
      const Logged& first = logged.at(missing.front());
      out_ << "  the server published no " << type << " of " << units(missing.size()) << " of the log (first: "
           << where(first.step, first.iteration) << ")\n";
    }
    if (!p.log_gap.empty()) out_ << "  the replay stopped early: " << p.log_gap << "\n";
    if (code != 0)
      out_ << "  the " << server << " server exited " << code << ": " << reason << "\n";
    out_ << "  server output kept in " << output.string() << "\n";
    out_.flush();
    if (different) return exit_code::different;
    if (!p.log_gap.empty()) {
      err_ << "cosim-replay: " << o_.log_path << ": incomplete log: " << p.log_gap << "\n";
      return exit_code::bad_input;
    }
    err_ << "cosim-replay: the " << server << " server exited " << code << ": " << reason << "\n";
    return exit_code::server_failed;
  }

  /// "59 steps", or in the implicit scheme (several messages a step) "143 messages".
  std::string units(std::size_t n) const {
    const char* unit = per_message_ ? " message" : " step";
    return std::to_string(n) + unit + (n == 1 ? "" : "s");
  }
  std::string units(std::int64_t n) const { return units(static_cast<std::size_t>(n)); }

  /// "step 37", or in the implicit scheme "step 37, iteration 1".
  std::string where(std::int64_t step, std::int32_t iteration) const {
    return "step " + std::to_string(step) + (per_message_ ? ", iteration " + std::to_string(iteration) : std::string());
  }

  /// The default temporary folder goes when the replay is identical or refused.
  void cleanup(const fs::path& output, bool refused) {
    if (!temporary_) return;
    std::error_code ec;
    fs::remove_all(output, ec);
    if (!refused) out_ << "  (the server's output was a temporary folder, removed; keep it with --output DIR)\n";
  }

  const ReplayOptions& o_;
  std::ostream& out_;
  std::ostream& err_;
  bool temporary_ = false;
  bool per_message_ = false;  ///< the scene's scheme has several messages a step (the name table's)
};

}  // namespace

int run_replay(const ReplayOptions& options, std::ostream& out, std::ostream& err) {
  try {
    g_log_key = options.key;
    Replay r(options, out, err);
    return r.run();
  } catch (const ReplayError& e) {
    out.flush();
    err << "cosim-replay: " << one_line(e.what()) << "\n";
    return exit_code::bad_input;
  } catch (const std::exception& e) {
    out.flush();
    err << "cosim-replay: " << one_line(e.what()) << "\n";
    return exit_code::system;
  }
}

}  // namespace cosim::replay
