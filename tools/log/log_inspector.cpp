#include "tools/log/log_inspector.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdarg>
#include <cstdio>
#include <ctime>
#include <set>
#include <sstream>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "common/text/text.hpp"

namespace cosim::logtool {

using protocol::one_line;

double ChannelStats::rate_hz() const {
  const double span_s = double(last_utime - first_utime) * 1e-6;
  return (count >= 2 && span_s > 0) ? double(count - 1) / span_s : 0.0;
}

const ChannelStats* PrefixStats::channel(MsgType t) const {
  for (const ChannelStats& c : channels)
    if (c.type == t) return &c;
  return nullptr;
}

const RunStats* PrefixStats::run(const std::string& token) const {
  for (const RunStats& r : runs)
    if (r.token == token) return &r;
  return nullptr;
}

const PrefixStats* LogSummary::prefix(const std::string& p) const {
  for (const PrefixStats& x : prefixes)
    if (x.prefix == p) return &x;
  return nullptr;
}

const RunStats* LogSummary::run(const std::string& token) const {
  for (const PrefixStats& p : prefixes)
    if (const RunStats* r = p.run(token)) return r;
  return nullptr;
}

std::string format_ranges(const Ranges& r, std::size_t max) {
  std::string out;
  for (std::size_t i = 0; i < r.size() && i < max; ++i) {
    if (i > 0) out += ", ";
    out += std::to_string(r[i].first);
    if (r[i].second != r[i].first) {
      out += '-';
      out += std::to_string(r[i].second);
    }
  }
  if (r.size() > max) out += ", ... (" + std::to_string(r.size() - max) + " more)";
  return out;
}

namespace {

std::uint64_t fnv1a(const std::vector<std::uint8_t>& d) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const std::uint8_t b : d) h = (h ^ b) * 0x100000001b3ull;
  return h;
}

std::string fingerprint_label(const std::vector<std::uint8_t>& data) {
  const MsgType t = type_by_fingerprint(data);
  return t != MsgType::unknown ? std::string(type_name(t)) : "unknown " + fingerprint_text(data);
}

// The steps and seqs of one run's state messages on one channel, while reading.
struct StateAcc {
  struct Copy {
    std::int64_t count = 0;
    std::uint64_t hash = 0;
  };
  std::map<std::int64_t, Copy> steps;
  std::map<std::pair<std::int64_t, std::int32_t>, Copy> iterates;
  std::set<std::int64_t> seqs;
  std::int64_t max_seq = 0;

  void add(StateStats& st, std::int64_t seq, std::int64_t step, std::int32_t iteration, std::int64_t num_cgps,
           const std::vector<std::uint8_t>& data) {
    ++st.messages;
    if (st.num_cgps < 0)
      st.num_cgps = num_cgps;
    else if (num_cgps != st.num_cgps)
      ++st.num_cgps_changes;
    const std::uint64_t h = fnv1a(data);
    // A later iterate of a step has its own copies, by (step, iteration).
    Copy* copy = nullptr;
    bool fresh = false;
    if (iteration > 0) {
      const auto r = iterates.try_emplace({step, iteration}, Copy{1, h});
      copy = &r.first->second;
      fresh = r.second;
      if (fresh) ++st.sub_iterations;
    } else {
      const auto r = steps.try_emplace(step, Copy{1, h});
      copy = &r.first->second;
      fresh = r.second;
    }
    if (!fresh) {
      if (copy->count == 1) ++st.steps_duplicated;
      ++copy->count;
      ++st.extra_copies;
      if (copy->hash != h) ++st.copies_differing;
    }
    if (seqs.count(seq) != 0) {
      ++st.seq_duplicated;
    } else {
      if (!seqs.empty() && seq < max_seq) ++st.seq_out_of_order;
      seqs.insert(seq);
      max_seq = seqs.size() == 1 ? seq : std::max(max_seq, seq);
    }
  }

  template <class It, class Key>
  static void gaps(It begin, It end, Key key, std::int64_t& missing, Ranges& ranges) {
    missing = 0;
    ranges.clear();
    bool first = true;
    std::int64_t prev = 0;
    for (It i = begin; i != end; ++i) {
      const std::int64_t k = key(*i);
      if (!first && k > prev + 1) {
        missing += k - prev - 1;
        ranges.emplace_back(prev + 1, k - 1);
      }
      prev = k;
      first = false;
    }
  }

  void finish(StateStats& st) const {
    st.distinct_steps = std::int64_t(steps.size());
    if (!steps.empty()) {
      st.first_step = steps.begin()->first;
      st.last_step = steps.rbegin()->first;
    }
    gaps(
        steps.begin(), steps.end(), [](const auto& kv) { return kv.first; }, st.steps_missing,
        st.steps_missing_ranges);
    st.steps_duplicated_ranges.clear();
    for (const auto& [step, copy] : steps) {
      if (copy.count < 2) continue;
      if (!st.steps_duplicated_ranges.empty() &&
          st.steps_duplicated_ranges.back().second == step - 1)
        st.steps_duplicated_ranges.back().second = step;
      else
        st.steps_duplicated_ranges.emplace_back(step, step);
    }
    if (!seqs.empty()) {
      st.first_seq = *seqs.begin();
      st.last_seq = *seqs.rbegin();
    }
    gaps(
        seqs.begin(), seqs.end(), [](std::int64_t s) { return s; }, st.seq_missing,
        st.seq_missing_ranges);
  }
};

void count_event(ChannelStats& c, const LogEvent& e) {
  if (c.count == 0) {
    c.first_utime = e.utime;
  } else {
    const std::int64_t gap = e.utime - c.last_utime;
    if (gap > c.largest_gap_us) {
      c.largest_gap_us = gap;
      c.largest_gap_at_utime = e.utime;
    }
  }
  c.last_utime = e.utime;
  ++c.count;
  c.bytes += std::int64_t(e.data.size());
  ++c.fingerprints[fingerprint_label(e.data)];
}

void undecodable(ChannelStats& c, const std::string& why) {
  if (c.undecodable++ == 0) c.first_undecodable = one_line(why);
}

}  // namespace

LogSummary summarize_log(const std::string& path) {
  LogReader reader(path);
  LogSummary s;
  s.path = path;
  s.file_bytes = reader.file_bytes();

  // Indices into s.prefixes / channels / runs (the vectors grow while reading).
  std::map<std::string, std::pair<std::size_t, std::size_t>> channel_index;
  std::map<std::string, std::size_t> other_index;
  std::map<std::string, std::size_t> prefix_index;
  std::map<std::pair<std::size_t, std::string>, std::size_t> run_index;
  std::map<std::pair<std::size_t, std::size_t>, std::pair<StateAcc, StateAcc>> acc;

  LogEvent e;
  while (reader.next(e)) {
    if (s.events == 0) s.first_utime = s.last_utime = e.utime;
    s.first_utime = std::min(s.first_utime, e.utime);
    s.last_utime = std::max(s.last_utime, e.utime);
    ++s.events;

    std::string prefix;
    const MsgType type = type_by_channel(e.channel, &prefix);
    if (type == MsgType::unknown) {
      auto [it, fresh] = other_index.try_emplace(e.channel, s.other_channels.size());
      if (fresh) {
        s.other_channels.emplace_back();
        s.other_channels.back().channel = e.channel;
      }
      count_event(s.other_channels[it->second], e);
      continue;
    }
    auto [pit, pfresh] = prefix_index.try_emplace(prefix, s.prefixes.size());
    if (pfresh) {
      s.prefixes.emplace_back();
      s.prefixes.back().prefix = prefix;
    }
    const std::size_t pi = pit->second;
    auto [cit, cfresh] = channel_index.try_emplace(e.channel, pi, s.prefixes[pi].channels.size());
    if (cfresh) {
      s.prefixes[pi].channels.emplace_back();
      ChannelStats& c = s.prefixes[pi].channels.back();
      c.channel = e.channel;
      c.prefix = prefix;
      c.type = type;
    }
    ChannelStats& c = s.prefixes[pi].channels[cit->second.second];
    count_event(c, e);

    const auto run_of = [&](const std::string& token) -> RunStats& {
      ++c.tokens[token];
      auto [rit, rfresh] = run_index.try_emplace({pi, token}, s.prefixes[pi].runs.size());
      if (rfresh) {
        s.prefixes[pi].runs.emplace_back();
        RunStats& r = s.prefixes[pi].runs.back();
        r.prefix = prefix;
        r.token = token;
        r.first_utime = e.utime;
      }
      RunStats& r = s.prefixes[pi].runs[rit->second];
      ++r.messages;
      return r;
    };

    std::string err;
    switch (type) {
      case MsgType::hello: {
        cosimlcm::hello_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        RunStats& r = run_of(m.token);
        if (m.role == "fluid") ++r.fluid_hellos;
        if (m.role == "solid") {
          if (r.solid_hellos++ == 0) r.solid_model = one_line(m.model);
        }
        break;
      }
      case MsgType::welcome: {
        cosimlcm::welcome_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        RunStats& r = run_of(m.token);
        if (!r.welcome || (m.accepted && !r.accepted)) {
          r.welcome = true;
          r.accepted = m.accepted != 0;
          r.refused_reason = one_line(m.reason);
          r.total_steps = m.total_steps;
          r.rigid_steps = m.rigid_steps;
          r.time_ratio = m.time_ratio;
        }
        break;
      }
      case MsgType::solid_state: {
        cosimlcm::solid_state_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        RunStats& r = run_of(m.token);
        const auto ri = run_index.at({pi, m.token});
        acc[{pi, ri}].first.add(r.solid, m.seq, m.step, m.iteration, m.num_cgps, e.data);
        break;
      }
      case MsgType::fluid_state: {
        cosimlcm::fluid_state_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        RunStats& r = run_of(m.token);
        const auto ri = run_index.at({pi, m.token});
        acc[{pi, ri}].second.add(r.fluid, m.seq, m.step, m.iteration, m.num_cgps, e.data);
        break;
      }
      case MsgType::resend: {
        cosimlcm::resend_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        ++run_of(m.token).resends[one_line(m.what)];
        break;
      }
      case MsgType::stop: {
        cosimlcm::stop_t m{};
        if (!(err = decode_as(e.data, m)).empty()) break;
        RunStats& r = run_of(m.token);
        if (r.stops++ == 0) {
          r.stop_step = m.step;
          r.stop_exit_code = m.exit_code;
          r.stop_reason = one_line(m.reason);
        }
        break;
      }
      case MsgType::unknown:
        break;
    }
    if (!err.empty()) undecodable(c, err);
  }
  for (const auto& [key, a] : acc) {
    RunStats& r = s.prefixes[key.first].runs[key.second];
    a.first.finish(r.solid);
    a.second.finish(r.fluid);
  }
  s.skipped_bytes = reader.skipped_bytes();
  s.truncated = reader.truncated();
  return s;
}

// ---------------------------------------------------------------------------------------
// The table

namespace {

std::string utc(std::int64_t utime) {
  const std::time_t t = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
  char frac[16];
  std::snprintf(frac, sizeof frac, ".%06lld",
                static_cast<long long>(((utime % 1000000) + 1000000) % 1000000));
  return std::string(buf) + frac + " UTC";
}

std::string printf_s(const char* f, ...) __attribute__((format(printf, 1, 2)));
std::string printf_s(const char* f, ...) {
  char buf[1024];
  va_list ap;
  va_start(ap, f);
  std::vsnprintf(buf, sizeof buf, f, ap);
  va_end(ap);
  return buf;
}

std::string bytes_text(std::uint64_t b) {
  if (b < 10000) return std::to_string(b) + " B";
  if (b < 10000000) return printf_s("%.1f kB", double(b) / 1e3);
  return printf_s("%.1f MB", double(b) / 1e6);
}

std::string state_line(const char* name, const StateStats& st) {
  if (st.messages == 0) return printf_s("    %-12s no decoded messages\n", name);
  std::string out = printf_s(
      "    %-12s %" PRId64 " message%s, %" PRId64 " CGPs%s\n", name, st.messages,
      st.messages == 1 ? "" : "s", st.num_cgps,
      st.num_cgps_changes > 0
          ? printf_s(" (%" PRId64 " messages with another count)", st.num_cgps_changes).c_str()
          : "");
  out += printf_s("      steps %" PRId64 "..%" PRId64 " (%" PRId64 " distinct): missing %" PRId64,
                  st.first_step, st.last_step, st.distinct_steps, st.steps_missing);
  if (st.steps_missing > 0) out += " (" + format_ranges(st.steps_missing_ranges) + ")";
  out += printf_s(", duplicated %" PRId64, st.steps_duplicated);
  if (st.steps_duplicated > 0) out += " (" + format_ranges(st.steps_duplicated_ranges) + ")";
  out += printf_s(", extra copies %" PRId64 " (not bit for bit: %" PRId64 ")", st.extra_copies,
                  st.copies_differing);
  if (st.sub_iterations > 0)
    out += printf_s(", sub-iterations %" PRId64 " (implicit scheme)", st.sub_iterations);
  out += "\n";
  out += printf_s("      seq %" PRId64 "..%" PRId64 ": missing %" PRId64, st.first_seq, st.last_seq,
                  st.seq_missing);
  if (st.seq_missing > 0) out += " (" + format_ranges(st.seq_missing_ranges) + ")";
  out += printf_s(", duplicated %" PRId64 ", out of order %" PRId64 "\n", st.seq_duplicated,
                  st.seq_out_of_order);
  return out;
}

std::string channel_row(const ChannelStats& c, std::int64_t t0, std::size_t width) {
  const double first = double(c.first_utime - t0) * 1e-6;
  const double last = double(c.last_utime - t0) * 1e-6;
  std::string gap = c.count >= 2 ? printf_s("%9.1f at %8.3f", double(c.largest_gap_us) * 1e-3,
                                            double(c.largest_gap_at_utime - t0) * 1e-6)
                                 : printf_s("%9s    %8s", "-", "-");
  std::string rate =
      c.count >= 2 && c.rate_hz() > 0 ? printf_s("%9.1f", c.rate_hz()) : printf_s("%9s", "-");
  return printf_s("  %-*s %-14s %8" PRId64 " %9.3f %9.3f %s %s %11" PRId64 " %6zu\n", int(width),
                  c.channel.c_str(), c.type == MsgType::unknown ? "-" : type_name(c.type), c.count,
                  first, last, rate.c_str(), gap.c_str(), c.undecodable, c.tokens.size());
}

std::string table_head(std::size_t width) {
  return printf_s("  %-*s %-14s %8s %9s %9s %9s %9s    %8s %11s %6s\n", int(width), "channel",
                  "type", "count", "first s", "last s", "rate Hz", "gap ms", "at s", "undecodable",
                  "tokens");
}

// Lines under the table: other types by fingerprint, the first undecodable message.
std::string channel_notes(const ChannelStats& c) {
  std::string out;
  std::string others;
  for (const auto& [label, n] : c.fingerprints) {
    if (c.type != MsgType::unknown && label == type_name(c.type)) continue;
    others += (others.empty() ? "" : ", ") + label + " x" + std::to_string(n);
  }
  if (!others.empty())
    out += "  " + c.channel +
           (c.type == MsgType::unknown ? ": types by fingerprint: "
                                       : ": other types by fingerprint: ") +
           others + "\n";
  if (c.undecodable > 0)
    out += "  " + c.channel + ": " + std::to_string(c.undecodable) +
           " undecodable; the first: " + c.first_undecodable + "\n";
  return out;
}

std::string other_tokens(const PrefixStats& p, MsgType t, const std::string& token) {
  const ChannelStats* c = p.channel(t);
  if (c == nullptr) return "";
  std::string out;
  for (const auto& [tok, n] : c->tokens)
    if (tok != token) out += (out.empty() ? "" : ", ") + tok + " x" + std::to_string(n);
  return out;
}

}  // namespace

std::string format_summary(const LogSummary& s) {
  std::ostringstream o;
  const double span = double(s.last_utime - s.first_utime) * 1e-6;
  o << "log " << s.path << ": " << s.events << " events, " << bytes_text(s.file_bytes) << ", "
    << printf_s("%.3f", span) << " s from " << utc(s.first_utime) << "\n";
  if (s.skipped_bytes > 0)
    o << "warning: " << s.skipped_bytes << " bytes between events were not LCM events (skipped)\n";
  if (!s.truncated.empty()) o << "warning: " << s.truncated << "\n";
  o << "times in s from the log's first event; gap: the largest time between two messages of a "
       "channel, in ms, and when it ended\n";

  std::size_t width = 7;
  for (const PrefixStats& p : s.prefixes)
    for (const ChannelStats& c : p.channels) width = std::max(width, c.channel.size());
  for (const ChannelStats& c : s.other_channels) width = std::max(width, c.channel.size());

  for (const PrefixStats& p : s.prefixes) {
    o << "\nprefix " << p.prefix << ": " << p.channels.size() << " channels, " << p.runs.size()
      << (p.runs.size() == 1 ? " token" : " tokens") << "\n";
    o << table_head(width);
    std::vector<const ChannelStats*> sorted;
    for (const ChannelStats& c : p.channels) sorted.push_back(&c);
    std::sort(sorted.begin(), sorted.end(),
              [](const ChannelStats* a, const ChannelStats* b) { return a->type < b->type; });
    for (const ChannelStats* c : sorted) o << channel_row(*c, s.first_utime, width);
    for (const ChannelStats* c : sorted) o << channel_notes(*c);
    for (const RunStats& r : p.runs) {
      o << "  token " << r.token << ": " << r.messages
        << (r.messages == 1 ? " message" : " messages") << " from "
        << printf_s("%.3f", double(r.first_utime - s.first_utime) * 1e-6) << " s; hello_t fluid "
        << r.fluid_hellos << ", solid " << r.solid_hellos;
      if (!r.solid_model.empty()) o << " (model " << r.solid_model << ")";
      if (!r.welcome)
        o << "; no welcome_t";
      else if (r.accepted)
        o << "; welcome_t accepted: " << r.total_steps << " steps, " << r.rigid_steps
          << " rigid, A_T " << r.time_ratio;
      else
        o << "; welcome_t refused: " << r.refused_reason;
      if (r.stops > 0) {
        o << "; stop_t at step " << r.stop_step << ", exit code " << r.stop_exit_code;
        if (!r.stop_reason.empty()) o << " (" << r.stop_reason << ")";
        o << " x" << r.stops;
      } else {
        o << "; no stop_t";
      }
      o << "\n";
      if (!r.resends.empty()) {
        o << "    resend_t:";
        for (const auto& [what, n] : r.resends) o << " " << what << " x" << n;
        o << "\n";
      }
      o << state_line("SOLID_STATE", r.solid);
      if (const std::string t = other_tokens(p, MsgType::solid_state, r.token); !t.empty())
        o << "      other tokens on the channel: " << t << "\n";
      o << state_line("FLUID_STATE", r.fluid);
      if (const std::string t = other_tokens(p, MsgType::fluid_state, r.token); !t.empty())
        o << "      other tokens on the channel: " << t << "\n";
    }
  }
  if (!s.other_channels.empty()) {
    o << "\nchannels outside the protocol (no HELLO, WELCOME, SOLID_STATE, FLUID_STATE, RESEND, "
         "STOP suffix)\n";
    o << table_head(width);
    for (const ChannelStats& c : s.other_channels) o << channel_row(c, s.first_utime, width);
    for (const ChannelStats& c : s.other_channels) o << channel_notes(c);
  }
  return o.str();
}

}  // namespace cosim::logtool
