// `cosim-log show`: one step's messages decoded to text.
#include <algorithm>
#include <cstdio>
#include <limits>
#include <sstream>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "common/text/text.hpp"
#include "tools/log/log_inspector.hpp"

namespace cosim::logtool {

namespace {

// Doubles with 17 significant digits: the text round-trips to the logged bits.
std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string quoted(const std::string& s) { return protocol::escaped(s); }

void field(std::ostringstream& o, const char* name, const std::string& value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "  %-17s ", name);
  o << buf << value << "\n";
}

// Rows of per-CGP arrays side by side: "cgp  a[0] a[1] a[2]  b[0] ...".
void cgp_rows(
    std::ostringstream& o, std::int32_t n, std::int64_t max_cgps,
    const std::vector<std::pair<std::string, const std::vector<std::vector<double>>*>>& arrays3,
    const std::vector<double>* array1 = nullptr, const char* name1 = nullptr) {
  const std::int64_t shown = max_cgps < 0 ? n : std::min<std::int64_t>(max_cgps, n);
  o << "  "
    << "cgp";
  if (array1 != nullptr) o << "  " << name1;
  for (const auto& a : arrays3) o << "  " << a.first << " (x y z)";
  o << "\n";
  for (std::int64_t l = 0; l < shown; ++l) {
    char idx[24];
    std::snprintf(idx, sizeof idx, "  %3lld", static_cast<long long>(l));
    o << idx;
    if (array1 != nullptr) o << "  " << num((*array1)[std::size_t(l)]);
    for (const auto& a : arrays3) {
      const std::vector<double>& row = (*a.second)[std::size_t(l)];
      o << "  " << num(row[0]) << " " << num(row[1]) << " " << num(row[2]);
    }
    o << "\n";
  }
  if (shown < n) o << "  ... " << shown << " of " << n << " CGPs shown (--max-cgps)\n";
}

}  // namespace

std::string show_step(const std::string& path, const ShowOptions& opt) {
  static const char* const kStepTypes = "SOLID_STATE, FLUID_STATE, RESEND, STOP";
  if (!opt.channel.empty()) {
    MsgType k = type_by_channel(opt.channel);
    for (const MsgType t : {MsgType::hello, MsgType::welcome, MsgType::solid_state,
                            MsgType::fluid_state, MsgType::resend, MsgType::stop})
      if (opt.channel == type_suffix(t)) k = t;
    if (k == MsgType::unknown)
      throw LogInputError("--channel " + opt.channel + ": not a protocol channel; allowed: " +
                          kStepTypes + " or a channel ending in one of them");
    if (k == MsgType::hello || k == MsgType::welcome)
      throw LogInputError("--channel " + opt.channel + ": " + type_name(k) +
                          " has no step; allowed: " + kStepTypes +
                          " or a channel ending in one of them");
  }
  if (opt.max_cgps < -1)
    throw LogInputError("--max-cgps " + std::to_string(opt.max_cgps) + ": allowed 0 or more");

  LogReader reader(path);
  std::ostringstream o;
  std::int64_t shown = 0, first_utime = 0, events = 0;
  std::int64_t lo = std::numeric_limits<std::int64_t>::max(),
               hi = std::numeric_limits<std::int64_t>::min();
  bool channel_seen = false;
  LogEvent e;
  while (reader.next(e)) {
    if (events++ == 0) first_utime = e.utime;
    std::string prefix;
    const MsgType t = type_by_channel(e.channel, &prefix);
    if (t != MsgType::solid_state && t != MsgType::fluid_state && t != MsgType::resend &&
        t != MsgType::stop)
      continue;
    if (!opt.channel.empty() && opt.channel != e.channel && opt.channel != type_suffix(t)) continue;
    channel_seen = true;

    std::ostringstream m;
    std::int64_t step = 0;
    std::string err;
    switch (t) {
      case MsgType::solid_state: {
        cosimlcm::solid_state_t x{};
        if (!(err = decode_as(e.data, x)).empty()) break;
        step = x.step;
        if (step != opt.step) break;
        field(m, "token", quoted(x.token));
        field(m, "seq", std::to_string(x.seq));
        field(m, "step", std::to_string(x.step));
        field(m, "substeps", std::to_string(x.substeps));
        field(m, "solid_time_s", num(x.solid_time_s) + " s");
        field(m, "num_cgps", std::to_string(x.num_cgps));
        cgp_rows(m, x.num_cgps, opt.max_cgps,
                 {{"position_lb [dx_LB]", &x.position_lb},
                  {"impulse_lb [rho_0 dx^3 c]", &x.impulse_lb}});
        break;
      }
      case MsgType::fluid_state: {
        cosimlcm::fluid_state_t x{};
        if (!(err = decode_as(e.data, x)).empty()) break;
        step = x.step;
        if (step != opt.step) break;
        field(m, "token", quoted(x.token));
        field(m, "seq", std::to_string(x.seq));
        field(m, "step", std::to_string(x.step));
        field(m, "bulk_velocity_lb", num(x.bulk_velocity_lb) + " c");
        field(m, "num_cgps", std::to_string(x.num_cgps));
        cgp_rows(m, x.num_cgps, opt.max_cgps, {{"velocity_lb [c]", &x.velocity_lb}}, &x.rho_lb,
                 "rho_lb [rho_0]");
        break;
      }
      case MsgType::resend: {
        cosimlcm::resend_t x{};
        if (!(err = decode_as(e.data, x)).empty()) break;
        step = x.step;
        if (step != opt.step) break;
        field(m, "token", quoted(x.token));
        field(m, "step", std::to_string(x.step));
        field(m, "what", quoted(x.what));
        break;
      }
      case MsgType::stop: {
        cosimlcm::stop_t x{};
        if (!(err = decode_as(e.data, x)).empty()) break;
        step = x.step;
        if (step != opt.step) break;
        field(m, "token", quoted(x.token));
        field(m, "sender", quoted(x.sender));
        field(m, "step", std::to_string(x.step));
        field(m, "exit_code", std::to_string(x.exit_code));
        field(m, "reason", quoted(x.reason));
        break;
      }
      default:
        break;
    }
    if (!err.empty()) continue;  // undecodable: cosim-log summary reports them
    if (t == MsgType::solid_state || t == MsgType::fluid_state) {
      lo = std::min(lo, step);
      hi = std::max(hi, step);
    }
    if (step != opt.step) continue;
    char head[160];
    std::snprintf(head, sizeof head, "event %lld at %.6f s: %s %s (%zu bytes)\n",
                  static_cast<long long>(e.number), double(e.utime - first_utime) * 1e-6,
                  e.channel.c_str(), type_name(t), e.data.size());
    o << (shown > 0 ? "\n" : "") << head << m.str();
    ++shown;
  }
  if (shown == 0) {
    std::string where = path;
    if (!opt.channel.empty()) {
      if (!channel_seen)
        throw LogInputError("--channel " + opt.channel + ": no such channel in " + path +
                            " (see cosim-log summary)");
      where += " on " + opt.channel;
    }
    throw LogInputError("step " + std::to_string(opt.step) + " is not in " + where +
                        (lo <= hi ? " (its state messages cover steps " + std::to_string(lo) +
                                        ".." + std::to_string(hi) + ")"
                                  : " (it has no decodable state messages)"));
  }
  return o.str();
}

}  // namespace cosim::logtool
