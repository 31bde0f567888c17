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
#include "fluid/coupled_fluid.hpp"
#include "fluid/scene_config.hpp"
#include "protocol/channels.hpp"
#include "protocol/handshake.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/text.hpp"
#include "solid/coupled_solid.hpp"
#include "solid/solid_scene.hpp"

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

/// The message types by channel name: prefix + message name (protocol/README.md section 2).
enum class Kind { Hello, Welcome, SolidState, FluidState, Resend, Stop };
struct Suffix {
  std::string_view name;
  Kind kind;
};
constexpr Suffix kSuffixes[] = {{"HELLO", Kind::Hello},           {"WELCOME", Kind::Welcome},
                                {"SOLID_STATE", Kind::SolidState}, {"FLUID_STATE", Kind::FluidState},
                                {"RESEND", Kind::Resend},         {"STOP", Kind::Stop}};

/// An LCM log read with lcm::LogFile, with the file offset of every event so that a logged
/// message can be read again when it is due (a long run's log need not fit in memory).
class LogReader {
 public:
  explicit LogReader(const std::string& path) : path_(checked(path)), file_(path_, "r") {}

  /// The next event and the offset it starts at; null at the end of the log.
  const lcm::LogEvent* next(long& offset) {
    offset = std::ftell(file_.getFilePtr());
    return file_.readNextEvent();
  }

  /// The event at `offset` (from next()); valid until the next read.
  const lcm::LogEvent& at(long offset) {
    if (std::fseek(file_.getFilePtr(), offset, SEEK_SET) != 0)
      throw std::runtime_error(path_ + ": cannot seek to byte " + std::to_string(offset) + ": " +
                               std::strerror(errno));
    const lcm::LogEvent* e = file_.readNextEvent();
    if (e == nullptr)
      throw std::runtime_error(path_ + ": the event at byte " + std::to_string(offset) +
                               " can no longer be read (was the log changed during the replay?)");
    return *e;
  }

  const std::string& path() const { return path_; }
  bool good() const { return file_.good(); }

 private:
  static const std::string& checked(const std::string& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw ReplayError(path + ": no such log file");
    if (fs::is_directory(path, ec))
      throw ReplayError(path + ": is a folder; give the run's LCM log, e.g. OUTPUT/traffic.lcmlog");
    return path;
  }

  std::string path_;
  lcm::LogFile file_;
};

template <class Message>
std::optional<Message> decode(const lcm::LogEvent& e) {
  Message m{};
  if (m.decode(e.data, 0, e.datalen) < 0) return std::nullopt;
  return m;
}

/// The logged traffic of one run: one channel prefix, one token.
struct RunTraffic {
  std::optional<cosimlcm::hello_t> fluid_hello, solid_hello;  ///< the first of each role
  std::optional<cosimlcm::welcome_t> welcome;  ///< the first accepted one, else the first
  /// By sender: the first stop_t, and the first with a non-zero exit code.
  std::map<std::string, std::pair<std::optional<cosimlcm::stop_t>, std::optional<cosimlcm::stop_t>>> stops;
  /// step -> offset of the first copy (later copies are resends or duplicates, section 7)
  std::map<std::int64_t, long> solid_states, fluid_states;
  std::int64_t messages = 0, copies = 0;
  /// The first step with a sub-iteration (iteration > 0: the implicit scheme), or -1.
  std::int64_t iterated_step = -1;
};

struct PrefixTraffic {
  std::int64_t events = 0;
  std::map<std::string, RunTraffic> runs;  ///< by token
};

struct LogScan {
  std::map<std::string, PrefixTraffic> prefixes;
  std::int64_t events = 0, other_channels = 0, undecodable = 0;
};

/// The prefix of a run's channel and its message type; nullopt for another channel.
std::optional<std::pair<std::string, Kind>> classify(const std::string& channel) {
  for (const Suffix& s : kSuffixes) {
    if (channel.size() <= s.name.size() || !channel.ends_with(s.name)) continue;
    std::string prefix = channel.substr(0, channel.size() - s.name.size());
    try {
      protocol::validate_channel_prefix(prefix);
    } catch (const std::invalid_argument&) {
      continue;
    }
    return std::make_pair(std::move(prefix), s.kind);
  }
  return std::nullopt;
}

LogScan scan(LogReader& log) {
  LogScan s;
  long offset = 0;
  while (const lcm::LogEvent* e = log.next(offset)) {
    ++s.events;
    const auto what = classify(e->channel);
    if (!what) {
      ++s.other_channels;
      continue;
    }
    PrefixTraffic& p = s.prefixes[what->first];
    ++p.events;
    const auto run_of = [&](const std::string& token) -> RunTraffic& {
      RunTraffic& r = p.runs[token];
      ++r.messages;
      return r;
    };
    switch (what->second) {
      case Kind::Hello:
        if (const auto m = decode<cosimlcm::hello_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          if (m->role == "fluid" && !r.fluid_hello) r.fluid_hello = *m;
          if (m->role == "solid" && !r.solid_hello) r.solid_hello = *m;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::Welcome:
        if (const auto m = decode<cosimlcm::welcome_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.welcome || (!r.welcome->accepted && m->accepted)) r.welcome = *m;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::SolidState:
        if (const auto m = decode<cosimlcm::solid_state_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.solid_states.emplace(m->step, offset).second) ++r.copies;
          if (m->iteration > 0 && r.iterated_step < 0) r.iterated_step = m->step;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::FluidState:
        if (const auto m = decode<cosimlcm::fluid_state_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.fluid_states.emplace(m->step, offset).second) ++r.copies;
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::Resend:
        if (const auto m = decode<cosimlcm::resend_t>(*e)) run_of(m->token);
        else ++s.undecodable;
        break;
      case Kind::Stop:
        if (const auto m = decode<cosimlcm::stop_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          // By sender: the replayed server is given the stop_t of the side it does not run.
          auto& [stop, error_stop] = r.stops[m->sender];
          if (!stop) stop = *m;
          if (!error_stop && m->exit_code != 0) error_stop = *m;
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

std::string step_range(const std::map<std::int64_t, long>& steps) {
  if (steps.empty()) return "none";
  return std::to_string(steps.begin()->first) + ".." + std::to_string(steps.rbegin()->first) +
         (static_cast<std::int64_t>(steps.size()) ==
                  steps.rbegin()->first - steps.begin()->first + 1
              ? ""
              : " (" + std::to_string(steps.size()) + " steps, with gaps)");
}

// ---- the comparison ----

/// A value that differs, with its place in the message.
struct FieldDiff {
  std::string field;     ///< e.g. "velocity_lb[17][2]"
  std::int64_t cgp = -1; ///< -1: a field of the whole message
  double replay = 0.0, logged = 0.0, abs = 0.0, rel = 0.0;
};

/// One step's comparison.
struct StepResult {
  std::int64_t step = 0, values = 0, differing = 0;
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

  /// Rows of [n][3] vectors: sizes, then the values of CGP l.
  void rows(const std::vector<std::vector<double>>& replay, const std::vector<std::vector<double>>& logged,
            std::size_t l, const char* field) {
    const std::size_t a = l < replay.size() ? replay[l].size() : 0;
    const std::size_t b = l < logged.size() ? logged[l].size() : 0;
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

/// fluid_state_t (protocol/README.md section 3): seq, num_cgps, bulk_velocity_lb, then per
/// CGP rho_lb and velocity_lb.
void compare(const cosimlcm::fluid_state_t& a, const cosimlcm::fluid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.seq), double(b.seq), "seq");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  c.value(a.bulk_velocity_lb, b.bulk_velocity_lb, "bulk_velocity_lb");
  if (a.rho_lb.size() != b.rho_lb.size()) c.value(double(a.rho_lb.size()), double(b.rho_lb.size()), "len(rho_lb)");
  if (a.velocity_lb.size() != b.velocity_lb.size())
    c.value(double(a.velocity_lb.size()), double(b.velocity_lb.size()), "len(velocity_lb)");
  const std::size_t n = std::max(std::min(a.rho_lb.size(), b.rho_lb.size()),
                                 std::min(a.velocity_lb.size(), b.velocity_lb.size()));
  for (std::size_t l = 0; l < n; ++l) {
    if (l < a.rho_lb.size() && l < b.rho_lb.size()) c.value(a.rho_lb[l], b.rho_lb[l], "rho_lb", std::int64_t(l));
    if (l < a.velocity_lb.size() && l < b.velocity_lb.size()) c.rows(a.velocity_lb, b.velocity_lb, l, "velocity_lb");
  }
}

/// solid_state_t (section 3): seq, substeps, solid_time_s, num_cgps, then per CGP
/// position_lb and impulse_lb.
void compare(const cosimlcm::solid_state_t& a, const cosimlcm::solid_state_t& b, StepResult& r) {
  StepComparer c(r);
  c.value(double(a.seq), double(b.seq), "seq");
  c.value(a.substeps, b.substeps, "substeps");
  c.value(a.solid_time_s, b.solid_time_s, "solid_time_s");
  c.value(a.num_cgps, b.num_cgps, "num_cgps");
  if (a.position_lb.size() != b.position_lb.size())
    c.value(double(a.position_lb.size()), double(b.position_lb.size()), "len(position_lb)");
  if (a.impulse_lb.size() != b.impulse_lb.size())
    c.value(double(a.impulse_lb.size()), double(b.impulse_lb.size()), "len(impulse_lb)");
  const std::size_t n = std::max(std::min(a.position_lb.size(), b.position_lb.size()),
                                 std::min(a.impulse_lb.size(), b.impulse_lb.size()));
  for (std::size_t l = 0; l < n; ++l) {
    if (l < a.position_lb.size() && l < b.position_lb.size()) c.rows(a.position_lb, b.position_lb, l, "position_lb");
    if (l < a.impulse_lb.size() && l < b.impulse_lb.size()) c.rows(a.impulse_lb, b.impulse_lb, l, "impulse_lb");
  }
}

// ---- the missing peer ----

/// Plays the peer of the replayed server from the log, on the server's bus. Its handlers
/// run inside the server thread's handle calls (memq:// has one queue per lcm_t), so
/// everything below is touched by that thread only while the server runs, and read by the
/// caller after the thread joined.
class Peer {
 public:
  Peer(lcm::LCM& bus, LogReader& log, const Selected& sel, Side side, bool quiet, std::ostream& err)
      : bus_(bus), log_(log), run_(*sel.run), token_(sel.token), side_(side), ch_(sel.prefix),
        quiet_(quiet), err_(err) {
    subs_.push_back(bus_.subscribe(ch_.hello, &Peer::on_hello, this));
    subs_.push_back(bus_.subscribe(ch_.welcome, &Peer::on_welcome, this));
    subs_.push_back(side_ == Side::Fluid ? bus_.subscribe(ch_.fluid_state, &Peer::on_fluid_state, this)
                                         : bus_.subscribe(ch_.solid_state, &Peer::on_solid_state, this));
    subs_.push_back(bus_.subscribe(ch_.resend, &Peer::on_resend, this));
  }
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;
  ~Peer() {
    for (lcm::Subscription* s : subs_)
      if (s != nullptr) bus_.unsubscribe(s);
  }

  bool subscribed() const {
    return std::none_of(subs_.begin(), subs_.end(), [](const lcm::Subscription* s) { return s == nullptr; });
  }

  /// After the server returned: what is left on the bus is compared, nothing more is fed.
  void finish() {
    done_ = true;
    while (bus_.handleTimeout(0) > 0) {
    }
  }

  // ---- results ----
  std::int64_t compared = 0, differing_steps = 0, duplicates = 0, resends_answered = 0;
  std::optional<StepResult> first_different;
  std::optional<FieldDiff> max_abs, max_rel;
  std::int64_t max_abs_step = -1, max_rel_step = -1;
  std::set<std::int64_t> published;         ///< steps the server published (first copies)
  std::vector<std::int64_t> not_in_log;     ///< ... of which the log has no message
  std::optional<std::string> refused;       ///< the handshake's refusal, if any
  bool welcomed = false;                    ///< an accepted welcome_t went out or came back
  std::string log_gap;                      ///< "" or: the input the log lacks
  std::string failure;                      ///< "" or: the log could not be read during the replay

 private:
  // The server's announcement: the fluid gets the logged solid's hello_t; the solid gets the
  // logged fluid's hello_t and a welcome_t from the coordinator's check (protocol/README.md
  // section 6) of the logged fluid hello_t against the server's own: the logged welcome_t if
  // accepted, else a refusal with the reason.
  void on_hello(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::hello_t* m) {
    if (m->token != token_ || done_) return;
    if (side_ == Side::Fluid) {
      if (m->role == "fluid") bus_.publish(ch_.hello, &*run_.solid_hello);
      return;
    }
    if (m->role != "solid") return;  // ours, heard back
    if (!welcome_) {
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
      bus_.publish(ch_.hello, &*run_.fluid_hello);
    }
    bus_.publish(ch_.welcome, &*welcome_);  // on every hello_t, as the coordinator does
  }

  // The fluid's coordinator decided (replaying the fluid): solid_state_t(0) follows an
  // accepted welcome_t (section 5).
  void on_welcome(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::welcome_t* m) {
    if (side_ != Side::Fluid || m->token != token_ || seen_welcome_) return;
    seen_welcome_ = true;  // a refusal may be read only after the server returned (finish())
    if (!m->accepted) {
      refused = m->reason;
      return;
    }
    welcomed = true;
    feed(0);
  }

  // The fluid's output of step n; it now waits for solid_state_t(n).
  void on_fluid_state(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::fluid_state_t* m) {
    if (m->token != token_) return;
    if (output(m->step, *m, run_.fluid_states)) feed(m->step);
  }

  // The solid's output of step n; it now waits for fluid_state_t(n + 1).
  void on_solid_state(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::solid_state_t* m) {
    if (m->token != token_) return;
    if (output(m->step, *m, run_.solid_states)) feed(m->step + 1);
  }

  // The server asks for a peer message again (section 7): the logged one, bit for bit, if
  // it was fed already; a step not reached yet is ignored.
  void on_resend(const lcm::ReceiveBuffer*, const std::string&, const cosimlcm::resend_t* m) {
    if (m->token != token_ || done_) return;
    const bool fluid = side_ == Side::Fluid;
    if (m->what != (fluid ? "solid_state" : "fluid_state") || m->step > fed_) return;
    const auto& inputs = fluid ? run_.solid_states : run_.fluid_states;
    if (const auto it = inputs.find(m->step); it != inputs.end()) {
      guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, it->second); });
      ++resends_answered;
    }
  }

  /// Compares the first copy of a step with the log; true if it was the first copy.
  template <class Message>
  bool output(std::int64_t step, const Message& m, const std::map<std::int64_t, long>& logged) {
    if (!published.insert(step).second) {
      ++duplicates;
      return false;
    }
    const auto it = logged.find(step);
    if (it == logged.end()) {
      not_in_log.push_back(step);
      return true;
    }
    guarded([&] {
      const std::optional<Message> l = decode<Message>(log_.at(it->second));
      if (!l) throw std::runtime_error(log_.path() + ": the logged message of step " +
                                       std::to_string(step) + " no longer decodes");
      StepResult r;
      r.step = step;
      compare(m, *l, r);
      record(r);
    });
    progress(step);
    return true;
  }

  void record(const StepResult& r) {
    ++compared;
    if (r.differing == 0) return;
    ++differing_steps;
    if (!first_different) first_different = r;
    if (!max_abs || r.max_abs->abs > max_abs->abs) {
      max_abs = r.max_abs;
      max_abs_step = r.step;
    }
    if (!max_rel || r.max_rel->rel > max_rel->rel) {
      max_rel = r.max_rel;
      max_rel_step = r.step;
    }
  }

  /// The peer's message of `step`, which the server now waits for; if the log has none,
  /// the run's end (solid: step = total_steps, the logged stop_t) or the logged run's error
  /// stop_t, else a stop_t(4) naming the gap.
  void feed(std::int64_t step) {
    if (done_ || stopped_) return;
    const bool fluid = side_ == Side::Fluid;
    const auto& inputs = fluid ? run_.solid_states : run_.fluid_states;
    if (const auto it = inputs.find(step); it != inputs.end()) {
      guarded([&] { publish_logged(fluid ? ch_.solid_state : ch_.fluid_state, it->second); });
      fed_ = std::max(fed_, step);
      return;
    }
    stopped_ = true;
    const bool end = !fluid && step >= run_.welcome->total_steps;
    const auto logged = run_.stops.find(peer_role());
    if (end && logged != run_.stops.end() && logged->second.first) {
      bus_.publish(ch_.stop, &*logged->second.first);
      return;
    }
    if (!end && logged != run_.stops.end() && logged->second.second) {  // the logged run ended here with an error
      bus_.publish(ch_.stop, &*logged->second.second);
      return;
    }
    cosimlcm::stop_t s{};
    s.token = token_;
    s.sender = peer_role();
    s.step = end ? run_.welcome->total_steps : step;
    s.exit_code = end ? 0 : 4;
    if (!end) {
      log_gap = "the log has no " + std::string(fluid ? "solid_state_t" : "fluid_state_t") +
                " of step " + std::to_string(step) + " (nor a stop_t with an error)";
      s.reason = "cosim-replay: " + log_gap;
    }
    bus_.publish(ch_.stop, &s);
  }

  /// The side this peer plays: the one the replayed server talks to.
  std::string peer_role() const { return side_ == Side::Fluid ? "solid" : "fluid"; }

  void publish_logged(const std::string& channel, long offset) {
    const lcm::LogEvent& e = log_.at(offset);
    bus_.publish(channel, e.data, static_cast<unsigned int>(e.datalen));
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
        cosimlcm::stop_t s{};
        s.token = token_;
        s.sender = peer_role();
        s.step = fed_;
        s.exit_code = 1;
        s.reason = "cosim-replay: " + failure;
        bus_.publish(ch_.stop, &s);
      }
    }
  }

  void progress(std::int64_t step) {
    if (quiet_) return;
    const Clock::time_point now = Clock::now();
    if (now - last_progress_ < kProgressEvery) return;
    last_progress_ = now;
    err_ << "cosim-replay: step " << step << " of " << run_.welcome->total_steps << ", "
         << compared << " compared, " << differing_steps << " differ\n";
    err_.flush();
  }

  lcm::LCM& bus_;
  LogReader& log_;
  const RunTraffic& run_;
  const std::string token_;
  const Side side_;
  const protocol::Channels ch_;
  const bool quiet_;
  std::ostream& err_;
  std::vector<lcm::Subscription*> subs_;
  std::optional<cosimlcm::welcome_t> welcome_;  ///< what the solid is answered (solid side)
  bool seen_welcome_ = false, stopped_ = false, done_ = false;
  std::int64_t fed_ = -1;  ///< the last step whose peer message went out
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

std::string steps(std::size_t n) { return std::to_string(n) + (n == 1 ? " step" : " steps"); }

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
    LogReader log(o_.log_path);
    if (!log.good())
      throw ReplayError(o_.log_path + ": cannot be opened as an LCM log: " + std::strerror(errno));
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
    if (fluid ? fscene->coupling->scheme.parallel_scheme() : sscene->coupling->scheme.parallel_scheme())
      throw ReplayError(o_.scene_path + " runs coupling.scheme = \"parallel\" (protocol/README.md 14); "
                        "cosim-replay replays the serial scheme only");
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
         << "*; solid_state_t steps " << step_range(run.solid_states) << ", fluid_state_t steps "
         << step_range(run.fluid_states) << "; " << run.copies << " resent or duplicate copies skipped\n"
         << "  scene " << o_.scene_path << "; server output " << output.string();
    if (fluid) out_ << "; " << threads << " OpenMP thread" << (threads == 1 ? "" : "s");
    out_ << "\n";
    out_.flush();

    lcm::LCM bus("memq://");
    if (!bus.good()) throw std::runtime_error("cannot open LCM's in-process bus memq://");
    Peer peer(bus, log, sel, o_.side, o_.quiet, err_);
    if (!peer.subscribed()) throw std::runtime_error("cannot subscribe to " + sel.prefix + "* on memq://");

    std::ostringstream server_out, server_err;
    int code = -1;
    std::thread server([&] {
      try {
        if (fluid) {
          // The thread count of the original process (fluid/main.cpp); the ICV is per thread.
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
    if (run.iterated_step >= 0)
      throw ReplayError(where + " ran the implicit scheme (solid_state_t of step " + std::to_string(run.iterated_step) +
                        " has sub-iterations, protocol/README.md 13); cosim-replay replays the serial scheme only");
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
    // of an incomplete log, they are the log's gap, not a difference).
    const auto& logged = fluid ? run.fluid_states : run.solid_states;
    std::vector<std::int64_t> missing, not_in_log;
    for (const auto& [step, offset] : logged)
      if (!p.published.count(step)) missing.push_back(step);
    for (const std::int64_t step : p.not_in_log)
      if (p.log_gap.empty() || step < logged.rbegin()->first) not_in_log.push_back(step);

    const bool different = p.differing_steps > 0 || !not_in_log.empty() || (code == 0 && !missing.empty());
    if (!different && code == 0 && p.log_gap.empty()) {
      out_ << "identical: " << p.compared << " steps compared (" << type << " "
           << step_range(logged) << ": "
           << (fluid ? "seq, num_cgps, bulk_velocity_lb, rho_lb, velocity_lb"
                     : "seq, substeps, solid_time_s, num_cgps, position_lb, impulse_lb")
           << ", bit for bit)\n";
      cleanup(output, false);
      return exit_code::identical;
    }
    if (p.first_different) {
      const StepResult& r = *p.first_different;
      const FieldDiff& d = *r.first;
      out_ << "different: first at step " << r.step << " (" << type << "), "
           << (d.cgp >= 0 ? "CGP " + std::to_string(d.cgp) + ", " : std::string()) << describe(d) << "\n";
      out_ << "  at step " << r.step << ": " << r.differing << " of " << r.values
           << " values differ; largest abs " << fmt("%.3g", r.max_abs->abs) << " (" << r.max_abs->field
           << "), largest rel " << fmt("%.3g", r.max_rel->rel) << " (" << r.max_rel->field << ")\n";
      out_ << "  over the replay: " << p.differing_steps << " of " << p.compared
           << " steps differ; largest abs " << fmt("%.3g", p.max_abs->abs) << " (step "
           << p.max_abs_step << ", " << p.max_abs->field << "), largest rel "
           << fmt("%.3g", p.max_rel->rel) << " (step " << p.max_rel_step << ", " << p.max_rel->field
           << ")\n";
    } else if (different) {
      out_ << "different: " << steps(std::size_t(p.compared)) << " compared and identical, but\n";
    } else {
      out_ << "identical so far: " << steps(std::size_t(p.compared)) << " compared\n";
    }
    if (!not_in_log.empty())
      out_ << "  the server published " << type << " of " << steps(not_in_log.size())
           << " the log lacks (first: step " << not_in_log.front() << ")\n";
    if (!missing.empty())
      out_ << "  the server published no " << type << " of " << steps(missing.size())
           << " of the log (first: step " << missing.front() << ")\n";
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
};

}  // namespace

int run_replay(const ReplayOptions& options, std::ostream& out, std::ostream& err) {
  try {
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
