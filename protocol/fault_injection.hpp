// Fault injection in the transport layer (DESIGN 2.2; a test setting): every message a
// server publishes goes through a FaultyTransport, which may drop it, send it twice, hold it
// back until after the next message (reorder) or delay it, each with a chosen probability.
// The protocol (sequence numbers, resends, duplicates dropped by step; protocol/README.md
// section 7) must make a lossy run end bit for bit like a clean one.
//
// The setting is a comma-separated list of key=value (the servers' --faults option or the
// environment variable COSIM_FAULTS):
//
//   drop=P, duplicate=P, reorder=P, delay=P   probabilities in [0, 0.5], default 0, with a
//                                             sum of at most 1 (one draw per message);
//                                             drop = 0.5 on both sides, the documented
//                                             maximum, cannot end a healthy run
//                                             (docs/reliability.md computes it)
//   delay_ms=T                                how long a delayed message is held, (0, 10000]
//   seed=S                                    the random stream (unsigned integer), default 1
//
// Each side draws from its own stream (seed and the side's name), so a run with faults is
// itself reproducible. A message that is held (reordered or delayed) is sent by pump(),
// which the servers call while they wait; a reordered message goes out after the next one
// published, or after 2 ms when none follows.
#pragma once

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace cosim::protocol {

struct FaultSettings {
  double drop = 0.0, duplicate = 0.0, reorder = 0.0, delay = 0.0;
  double delay_ms = 20.0;
  std::uint64_t seed = 1;
  bool any() const { return drop > 0.0 || duplicate > 0.0 || reorder > 0.0 || delay > 0.0; }
};

/// Parses the setting (see above). `origin` names where it came from in the error
/// ("--faults", "COSIM_FAULTS").
/// @post returns the settings, or throws std::invalid_argument with one line naming the
///       origin, the key, its value and what is allowed.
inline FaultSettings parse_fault_settings(std::string_view spec, const std::string& origin) {
  FaultSettings s;
  const std::string allowed_keys = "drop, duplicate, reorder, delay, delay_ms, seed";
  std::size_t start = 0;
  while (start <= spec.size()) {
    const std::size_t comma = std::min(spec.find(',', start), spec.size());
    const std::string item(spec.substr(start, comma - start));
    start = comma + 1;
    if (item.empty()) {
      if (comma >= spec.size()) break;
      continue;
    }
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument(origin + ": \"" + item + "\" is not key=value (keys: " +
                                  allowed_keys + ")");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    char* end = nullptr;
    errno = 0;
    if (key == "seed") {
      const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || errno != 0 || value[0] == '-')
        throw std::invalid_argument(origin + ": seed = \"" + value +
                                    "\"; allowed: an unsigned integer");
      s.seed = v;
      continue;
    }
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || errno != 0 || !std::isfinite(v))
      throw std::invalid_argument(origin + ": " + key + " = \"" + value + "\" is not a number");
    if (key == "delay_ms") {
      if (!(v > 0.0 && v <= 10000.0))
        throw std::invalid_argument(origin + ": delay_ms = " + value + "; allowed: (0, 10000]");
      s.delay_ms = v;
      continue;
    }
    double* target = key == "drop"        ? &s.drop
                     : key == "duplicate" ? &s.duplicate
                     : key == "reorder"   ? &s.reorder
                     : key == "delay"     ? &s.delay
                                          : nullptr;
    if (target == nullptr)
      throw std::invalid_argument(origin + ": unknown key \"" + key + "\"; allowed: " + allowed_keys);
    if (!(v >= 0.0 && v <= 0.5))
      throw std::invalid_argument(origin + ": " + key + " = " + value +
                                  "; allowed: a probability in [0, 0.5]");
    *target = v;
  }
  // One draw decides each message's fate: the bands must fit in [0, 1].
  if (s.drop + s.duplicate + s.reorder + s.delay > 1.0)
    throw std::invalid_argument(origin + ": drop + duplicate + reorder + delay = " +
                                std::to_string(s.drop + s.duplicate + s.reorder + s.delay) +
                                "; allowed: at most 1");
  return s;
}

/// The servers' setting: `cli` (the --faults value) when given, else the environment's
/// COSIM_FAULTS, else none. Throws std::invalid_argument as parse_fault_settings.
inline FaultSettings fault_settings_from(const std::string* cli) {
  if (cli != nullptr) return parse_fault_settings(*cli, "--faults");
  if (const char* env = std::getenv("COSIM_FAULTS")) return parse_fault_settings(env, "COSIM_FAULTS");
  return {};
}

/// Publishes through an lcm::LCM, injecting the faults of `settings`. With no fault set it
/// publishes at once and draws nothing.
class FaultyTransport {
 public:
  using Clock = std::chrono::steady_clock;

  /// @param stream  a name mixed into the seed ("fluid", "solid"): each side its own stream
  FaultyTransport(lcm::LCM& bus, const FaultSettings& settings, std::string_view stream)
      : bus_(bus), s_(settings), rng_(settings.seed ^ fnv1a(stream)) {}

  /// Publishes encoded bytes on `channel` (or drops, duplicates, holds them).
  /// @return 0, or LCM's error code of an immediate publish.
  int publish_encoded(const std::string& channel, std::vector<std::uint8_t> bytes) {
    if (!s_.any()) return send(channel, bytes);
    return inject(channel, std::move(bytes));
  }

  /// Sends the held messages whose time has come. Call it while waiting.
  void pump() {
    const Clock::time_point now = Clock::now();
    for (auto it = held_.begin(); it != held_.end();) {
      if (it->due <= now) {
        bus_.publish(it->channel, it->bytes.data(), static_cast<unsigned>(it->bytes.size()));
        it = held_.erase(it);
      } else {
        ++it;
      }
    }
  }

  /// Sends every held message now (before the process ends).
  void flush() {
    for (const Held& h : held_) send(h.channel, h.bytes);
    held_.clear();
  }

  std::int64_t dropped() const { return dropped_; }
  std::int64_t duplicated() const { return duplicated_; }
  std::int64_t reordered() const { return reordered_; }
  std::int64_t delayed() const { return delayed_; }
  bool active() const { return s_.any(); }

  /// "dropped N, duplicated N, reordered N, delayed N" (for the servers' counters line).
  std::string summary() const {
    return "injected faults: dropped " + std::to_string(dropped_) + ", duplicated " +
           std::to_string(duplicated_) + ", reordered " + std::to_string(reordered_) +
           ", delayed " + std::to_string(delayed_);
  }

 private:
  struct Held {
    std::string channel;
    std::vector<std::uint8_t> bytes;
    Clock::time_point due;
    bool until_next;  ///< reordered: goes out right after the next message
  };

  int inject(const std::string& channel, std::vector<std::uint8_t> bytes) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double r = u(rng_);
    const Clock::time_point now = Clock::now();
    int rc = 0;
    double edge = s_.drop;
    if (r < edge) {
      ++dropped_;
    } else if (r < (edge += s_.reorder)) {
      ++reordered_;
      held_.push_back({channel, std::move(bytes), now + std::chrono::milliseconds(2), true});
      return 0;  // the messages held for "after the next" stay held until one follows
    } else if (r < (edge += s_.delay)) {
      ++delayed_;
      held_.push_back({channel, std::move(bytes),
                       now + std::chrono::microseconds(static_cast<long long>(s_.delay_ms * 1e3)),
                       false});
    } else {
      rc = send(channel, bytes);
      if (r < edge + s_.duplicate) {
        ++duplicated_;
        send(channel, bytes);
      }
    }
    // Whatever was held back "until the next message" goes out now, after this one.
    for (auto it = held_.begin(); it != held_.end();) {
      if (it->until_next) {
        send(it->channel, it->bytes);
        it = held_.erase(it);
      } else {
        ++it;
      }
    }
    return rc;
  }

  static std::uint64_t fnv1a(std::string_view text) {
    std::uint64_t h = 14695981039346656037ull;
    for (const char c : text) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
    return h;
  }

  int send(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
    return bus_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }

  lcm::LCM& bus_;
  FaultSettings s_;
  std::mt19937_64 rng_;
  std::deque<Held> held_;
  std::int64_t dropped_ = 0, duplicated_ = 0, reordered_ = 0, delayed_ = 0;
};

}  // namespace cosim::protocol
