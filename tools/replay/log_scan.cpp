#include "tools/replay/log_scan.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace cosim::replay {

namespace {

std::optional<protocol::RunKey> g_log_key;

std::string join_keys(const auto& map) {
  std::string out;
  for (const auto& [key, value] : map) out += (out.empty() ? "" : ", ") + key;
  return out;
}

}  // namespace

void set_log_key(const std::optional<protocol::RunKey>& key) { g_log_key = key; }
const std::optional<protocol::RunKey>& log_key() { return g_log_key; }

LogReader open_log(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw ReplayError(path + ": no such log file");
  if (std::filesystem::is_directory(path, ec))
    throw ReplayError(path + ": is a folder; give the run's LCM log, e.g. OUTPUT/traffic.lcmlog");
  try {
    return LogReader(path, logtool::MacTrailers::keep);
  } catch (const logtool::LogInputError& e) {
    throw ReplayError(e.what());
  }
}

LogScan scan(LogReader& log) {
  LogScan s;
  LogEvent event;
  while (log.next(event)) {
    const LogEvent* const e = &event;
    const long offset = static_cast<long>(event.offset);
    ++s.events;
    const auto what = protocol::classify_channel(e->channel);
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
          if (!r.solid_states.emplace(m->seq, r.here(offset, m->step, m->iteration)).second) ++r.copies;
          r.max_solid_seq = std::max(r.max_solid_seq, m->seq);
        } else {
          ++s.undecodable;
        }
        break;
      case Kind::FluidState:
        if (const auto m = decode<cosimlcm::fluid_state_t>(*e)) {
          RunTraffic& r = run_of(m->token);
          if (!r.fluid_states.emplace(m->seq, r.here(offset, m->step, m->iteration)).second) ++r.copies;
          r.max_fluid_seq = std::max(r.max_fluid_seq, m->seq);
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

std::string describe_states(const std::map<std::int64_t, Logged>& messages) {
  const std::set<std::int64_t> steps = steps_of(messages);
  std::string text = "steps " + step_range(steps);
  if (messages.size() != steps.size())
    text += " (" + std::to_string(messages.size()) + " messages, iterations 0.." +
            std::to_string(max_iteration(messages)) + ")";
  return text;
}

}  // namespace cosim::replay
