#include "tools/log/lcm_log.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/channels.hpp"
#include "protocol/message_checks.hpp"

namespace cosim::logtool {

namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kMagic = 0xEDA1DA01u;
constexpr std::size_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;
// LCM's own reader refuses channel lengths outside (0, 1000); LCM limits a channel to 63.
constexpr std::int32_t kMaxChannel = 1000;

std::uint64_t be(const std::uint8_t* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

LogReader::LogReader(const std::string& path, MacTrailers macs) : path_(path), macs_(macs) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw LogInputError(path + ": no such file");
  if (!fs::is_regular_file(st))
    throw LogInputError(path + ": not a regular file; give an LCM log (lcm-logger's output)");
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) throw LogInputError(path + ": cannot open: " + std::strerror(errno));
  file_bytes_ = fs::file_size(path, ec);
  if (file_bytes_ == 0) throw LogInputError(path + ": empty file, not an LCM log (no events)");
  std::uint8_t head[4] = {};
  if (file_bytes_ < kHeaderBytes || std::fread(head, 1, 4, file_) != 4 || be(head, 4) != kMagic) {
    std::fclose(file_);
    file_ = nullptr;
    throw LogInputError(path +
                        ": not an LCM log (it does not start with an LCM event: magic "
                        "0xEDA1DA01, as lcm-logger writes)");
  }
  std::rewind(file_);
}

LogReader::~LogReader() {
  if (file_ != nullptr) std::fclose(file_);
}

bool LogReader::read_exact(void* buf, std::size_t n) {
  if (n == 0) return true;
  const std::size_t got = std::fread(buf, 1, n, file_);
  pos_ += got;
  return got == n;
}

// Scans from byte `from` for the next magic; leaves the file at it. False at the end.
bool LogReader::resync(std::uint64_t from) {
  if (std::fseek(file_, static_cast<long>(from), SEEK_SET) != 0) return false;
  pos_ = from;
  std::uint32_t window = 0;
  int have = 0;
  for (int c; (c = std::fgetc(file_)) != EOF;) {
    ++pos_;
    window = (window << 8) | static_cast<std::uint32_t>(c);
    if (++have >= 4 && window == kMagic) {
      pos_ -= 4;
      std::fseek(file_, static_cast<long>(pos_), SEEK_SET);
      skipped_ += pos_ - from;
      return true;
    }
  }
  skipped_ += pos_ - from;
  return false;
}

bool LogReader::next(LogEvent& event) {
  for (;;) {
    if (file_ == nullptr || pos_ >= file_bytes_) return false;
    const std::uint64_t start = pos_;
    std::uint8_t h[kHeaderBytes];
    if (!read_exact(h, sizeof h)) {
      truncated_ = "the log ends inside the header of an event at byte " + std::to_string(start) +
                   " (lcm-logger stopped mid-write?); the partial event is ignored";
      return false;
    }
    const auto clen = static_cast<std::int32_t>(be(h + 20, 4));
    const auto dlen = static_cast<std::int32_t>(be(h + 24, 4));
    if (be(h, 4) != kMagic || clen <= 0 || clen >= kMaxChannel || dlen < 0) {
      if (!resync(start + 1)) return false;
      continue;
    }
    if (start + kHeaderBytes + std::uint64_t(clen) + std::uint64_t(dlen) > file_bytes_) {
      truncated_ = "the log ends inside event " +
                   std::to_string(static_cast<std::int64_t>(be(h + 4, 8))) + " at byte " +
                   std::to_string(start) +
                   " (lcm-logger stopped mid-write?); the partial event is ignored";
      pos_ = file_bytes_;
      return false;
    }
    event.offset = start;
    event.number = static_cast<std::int64_t>(be(h + 4, 8));
    event.utime = static_cast<std::int64_t>(be(h + 12, 8));
    event.channel.resize(static_cast<std::size_t>(clen));
    event.data.resize(static_cast<std::size_t>(dlen));
    if (!read_exact(event.channel.data(), event.channel.size()) ||
        !read_exact(event.data.data(), event.data.size())) {
      truncated_ = "the log ends inside event at byte " + std::to_string(start);
      return false;
    }
    // Not signed with the run's key: left out, counted.
    if (macs_ == MacTrailers::strip && !strip_mac(event)) continue;
    return true;
  }
}

const LogEvent& LogReader::at(std::uint64_t offset) {
  if (file_ == nullptr || std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0)
    throw std::runtime_error(path_ + ": cannot seek to byte " + std::to_string(offset) + ": " + std::strerror(errno));
  pos_ = offset;
  if (!next(again_) || again_.offset != offset)
    throw std::runtime_error(path_ + ": the event at byte " + std::to_string(offset) +
                             " can no longer be read (was the log changed during the replay?)");
  return again_;
}

// ---------------------------------------------------------------------------------------
// The servers' MAC trailers

namespace {
std::optional<protocol::RunKey> g_key;
std::int64_t g_unauthenticated = 0;
}  // namespace

void set_log_key(std::optional<protocol::RunKey> key) { g_key = key; }
std::int64_t unauthenticated_events() { return g_unauthenticated; }

bool LogReader::strip_mac(LogEvent& event) {
  const MsgType t = type_by_channel(event.channel);
  if (t == MsgType::unknown) return true;  // not a run's channel: as logged
  if (g_key) {
    const auto n = protocol::verified_size(*g_key, event.channel, event.data.data(), event.data.size());
    if (!n) {
      ++g_unauthenticated;
      return false;
    }
    event.data.resize(*n);
    return true;
  }
  const std::size_t n = event.data.size();
  if (n >= protocol::kMacBytes && !whole_message(t, event.data.data(), n) &&
      whole_message(t, event.data.data(), n - protocol::kMacBytes))
    event.data.resize(n - protocol::kMacBytes);
  return true;
}

// ---------------------------------------------------------------------------------------
// Types, channels, fingerprints

namespace {

// In protocol::MessageKind's order, as MsgType is.
struct TypeInfo {
  MsgType type;
  const char* name;
  std::int64_t fingerprint;
};

const TypeInfo* types() {
  static const TypeInfo t[] = {
      {MsgType::hello, "hello_t", cosimlcm::hello_t::getHash()},
      {MsgType::welcome, "welcome_t", cosimlcm::welcome_t::getHash()},
      {MsgType::solid_state, "solid_state_t", cosimlcm::solid_state_t::getHash()},
      {MsgType::fluid_state, "fluid_state_t", cosimlcm::fluid_state_t::getHash()},
      {MsgType::resend, "resend_t", cosimlcm::resend_t::getHash()},
      {MsgType::stop, "stop_t", cosimlcm::stop_t::getHash()},
  };
  return t;
}
constexpr int kTypes = 6;
static_assert(kTypes == int(protocol::kMessageKinds));

}  // namespace

const char* type_name(MsgType t) {
  return t == MsgType::unknown ? "unknown" : types()[static_cast<int>(t)].name;
}

const char* type_suffix(MsgType t) {
  return t == MsgType::unknown ? ""
                               : protocol::kChannelNames[static_cast<std::size_t>(t)].data();
}

MsgType type_by_channel(std::string_view channel, std::string* prefix) {
  const auto what = protocol::classify_channel(channel);
  if (prefix != nullptr) *prefix = what ? what->prefix : std::string();
  return what ? static_cast<MsgType>(what->kind) : MsgType::unknown;
}

MsgType type_by_fingerprint(const std::vector<std::uint8_t>& data) {
  if (data.size() < 8) return MsgType::unknown;
  const auto fp = static_cast<std::int64_t>(be(data.data(), 8));
  for (int i = 0; i < kTypes; ++i)
    if (types()[i].fingerprint == fp) return types()[i].type;
  return MsgType::unknown;
}

std::string fingerprint_text(const std::vector<std::uint8_t>& data) {
  char buf[48];
  if (data.size() < 8) {
    std::snprintf(buf, sizeof buf, "(%zu bytes, no fingerprint)", data.size());
    return buf;
  }
  std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(be(data.data(), 8)));
  return buf;
}

namespace {
template <class T>
MsgType type_of();
template <>
MsgType type_of<cosimlcm::hello_t>() {
  return MsgType::hello;
}
template <>
MsgType type_of<cosimlcm::welcome_t>() {
  return MsgType::welcome;
}
template <>
MsgType type_of<cosimlcm::solid_state_t>() {
  return MsgType::solid_state;
}
template <>
MsgType type_of<cosimlcm::fluid_state_t>() {
  return MsgType::fluid_state;
}
template <>
MsgType type_of<cosimlcm::resend_t>() {
  return MsgType::resend;
}
template <>
MsgType type_of<cosimlcm::stop_t>() {
  return MsgType::stop;
}
}  // namespace

// "" when `data` is a well-formed message of type t, else the reason. The fingerprint is
// checked here, so that the reason can name the type the bytes are; the layout (string
// lengths, counts, arrays, nothing left over) by the servers' own check
// (protocol/message_checks.hpp, check_encoding).
template <class T>
std::string check_layout(MsgType t, const std::vector<std::uint8_t>& data) {
  const std::string name = type_name(t);
  if (data.size() < 8)
    return "not a " + name + ": " + std::to_string(data.size()) +
           " bytes, shorter than a fingerprint";
  const auto fp = static_cast<std::int64_t>(be(data.data(), 8));
  if (fp != types()[static_cast<int>(t)].fingerprint) {
    const MsgType other = type_by_fingerprint(data);
    return "not a " + name + ": its fingerprint " + fingerprint_text(data) +
           (other != MsgType::unknown ? std::string(" is ") + type_name(other) + "'s"
                                      : std::string(" is none of the protocol's types"));
  }
  return protocol::check_encoding(static_cast<const T*>(nullptr), data.data(), data.size())
      .value_or("");
}

bool whole_message(MsgType t, const std::uint8_t* data, std::size_t size) {
  const auto ok = [&](const auto* type) { return !protocol::check_encoding(type, data, size).has_value(); };
  switch (t) {
    case MsgType::hello: return ok(static_cast<const cosimlcm::hello_t*>(nullptr));
    case MsgType::welcome: return ok(static_cast<const cosimlcm::welcome_t*>(nullptr));
    case MsgType::solid_state: return ok(static_cast<const cosimlcm::solid_state_t*>(nullptr));
    case MsgType::fluid_state: return ok(static_cast<const cosimlcm::fluid_state_t*>(nullptr));
    case MsgType::resend: return ok(static_cast<const cosimlcm::resend_t*>(nullptr));
    case MsgType::stop: return ok(static_cast<const cosimlcm::stop_t*>(nullptr));
    case MsgType::unknown: break;
  }
  return false;
}

template <class T>
std::string decode_as(const std::vector<std::uint8_t>& data, T& out) {
  const MsgType t = type_of<T>();
  std::string err = check_layout<T>(t, data);
  if (!err.empty()) return err;
  try {
    const int used = out.decode(data.data(), 0, static_cast<int>(data.size()));
    if (used != static_cast<int>(data.size()))
      return std::string(type_name(t)) + ": the generated decoder failed (" + std::to_string(used) +
             ")";
  } catch (const std::exception& e) {
    return std::string(type_name(t)) + ": the generated decoder failed: " + e.what();
  }
  return "";
}

template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::hello_t&);
template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::welcome_t&);
template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::solid_state_t&);
template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::fluid_state_t&);
template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::resend_t&);
template std::string decode_as(const std::vector<std::uint8_t>&, cosimlcm::stop_t&);

}  // namespace cosim::logtool
