#include "tools/record/recorder.hpp"

#include <glib.h>
#include <lcm/lcm.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

namespace cosim::record {

namespace fs = std::filesystem;

namespace {

/// The first four bytes of every event of an LCM log (big-endian 0xEDA1DA01).
constexpr std::array<unsigned char, 4> kEventMagic{0xED, 0xA1, 0xDA, 0x01};

/// What the LCM handler writes into, and what it counts.
struct Sink {
  lcm::LogFile* log = nullptr;
  std::string path;
  RecordResult* result = nullptr;
  bool stopping = false;
  std::string error;  ///< the first write error; recording ends with it
};

void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
  auto* sink = static_cast<Sink*>(user);
  if (!sink->error.empty()) return;
  lcm::LogEvent ev{};
  ev.timestamp = rbuf->recv_utime;
  ev.channel = channel;
  ev.datalen = static_cast<std::int32_t>(rbuf->data_size);
  ev.data = rbuf->data;
  // Written and flushed at once: what was received is in the file, whatever stops us later.
  if (sink->log->writeEvent(&ev) != 0 || std::fflush(sink->log->getFilePtr()) != 0) {
    sink->error = "cannot write " + sink->path + ": " + std::strerror(errno);
    return;
  }
  ++sink->result->events;
  sink->result->bytes += 4 + 8 + 8 + 4 + 4 + static_cast<std::int64_t>(ev.channel.size()) + rbuf->data_size;
  if (sink->stopping) ++sink->result->after_stop;
}

/// This process's sockets: file descriptor -> inode ("socket:[INODE]" links in /proc/self/fd).
std::map<int, std::string> own_sockets() {
  std::map<int, std::string> sockets;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/proc/self/fd", ec)) {
    std::error_code lec;
    const std::string target = fs::read_symlink(e.path(), lec).string();
    if (lec || !target.starts_with("socket:[") || !target.ends_with("]")) continue;
    sockets[std::atoi(e.path().filename().c_str())] = target.substr(8, target.size() - 9);
  }
  return sockets;
}

}  // namespace

std::string channels_problem(const std::string& channels) {
  if (channels.empty()) return "--channels \"\": give the run's channels, e.g. 'COSIM_1a2b3c4d_.*'";
  // As lcm_subscribe compiles it (GLib's regex, anchored at both ends).
  GError* error = nullptr;
  GRegex* regex = g_regex_new(("^" + channels + "$").c_str(), GRegexCompileFlags(0), GRegexMatchFlags(0), &error);
  if (regex != nullptr) {
    g_regex_unref(regex);
    return "";
  }
  std::string why = "--channels \"" + channels + "\": not a regular expression LCM takes";
  if (error != nullptr) {
    why += std::string(" (") + error->message + ")";
    g_error_free(error);
  }
  return why;
}

std::string append_problem(const std::string& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) return "";
  if (!fs::is_regular_file(status)) return path + ": not a regular file; give an LCM log file to create or append to";
  if (fs::file_size(path, ec) == 0) return "";
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 4> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  if (!in || head != kEventMagic)
    return path + ": exists and is not an LCM log (it does not start with the event magic 0xEDA1DA01); "
                  "refusing to append to it: give a new file or an LCM log";
  return "";
}

std::int64_t udp_receive_backlog() {
  std::set<std::string> inodes;
  for (const auto& [fd, inode] : own_sockets()) inodes.insert(inode);
  if (inodes.empty()) return 0;
  std::int64_t bytes = 0;
  for (const char* table : {"/proc/net/udp", "/proc/net/udp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // the header
    // sl local_address rem_address st tx_queue:rx_queue tr:tm->when retrnsmt uid timeout inode ...
    while (std::getline(in, line)) {
      std::istringstream f(line);
      std::string sl, local, remote, st, queues, timer, retr, uid, timeout, inode;
      if (!(f >> sl >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode)) continue;
      if (!inodes.contains(inode)) continue;
      const auto colon = queues.find(':');
      if (colon == std::string::npos) continue;
      bytes += std::strtoll(queues.c_str() + colon + 1, nullptr, 16);
    }
  }
  return bytes;
}

std::int64_t enlarge_udp_receive_buffers(int bytes) {
  std::int64_t smallest = -1;
  for (const auto& [fd, inode] : own_sockets()) {
    int type = 0;
    socklen_t len = sizeof type;
    if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_DGRAM) continue;
    // As root past net.core.rmem_max; else up to it.
    if (bytes > 0 && setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) != 0)
      setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
    int got = 0;
    len = sizeof got;
    if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &len) == 0 && (smallest < 0 || got < smallest)) smallest = got;
  }
  return smallest;
}

RecordResult record(lcm::LCM& bus, const RecordOptions& options, const std::function<bool()>& stop_requested,
                    const std::function<void(std::int64_t receive_buffer_bytes)>& on_ready) {
  using Clock = std::chrono::steady_clock;
  if (const std::string why = channels_problem(options.channels); !why.empty()) throw RecordError(why);
  if (const std::string why = append_problem(options.log_path); !why.empty()) throw RecordError(why);
  lcm::LogFile log(options.log_path, "a");
  if (!log.good())
    throw RecordError("cannot open " + options.log_path + " for appending: " + std::strerror(errno));

  RecordResult result;
  Sink sink{&log, options.log_path, &result, false, {}};
  // LCM's C interface: its C++ wrapper hides a failed subscription behind a non-null object.
  lcm_subscription_t* sub = lcm_subscribe(bus.getUnderlyingLCM(), options.channels.c_str(), &on_message, &sink);
  if (sub == nullptr) throw std::runtime_error("cannot subscribe to channels \"" + options.channels + "\"");
  // No limit on the messages LCM holds for us: its default (30) drops the rest when we lag.
  lcm_subscription_set_queue_capacity(sub, 0);
  result.receive_buffer_bytes = enlarge_udp_receive_buffers(options.receive_buffer_bytes);
  on_ready(result.receive_buffer_bytes);

  const int quiet_ms = static_cast<int>(options.quiet.count());
  while (!stop_requested() && sink.error.empty()) {
    if (bus.handleTimeout(quiet_ms) < 0) throw std::runtime_error("LCM failed while receiving");
  }

  // Drain: the peers have ended (or are ending); whatever they sent is in LCM's queue or in
  // the socket's. Quiet twice in a row, with the socket empty, is the end.
  sink.stopping = true;
  const auto stop_at = Clock::now();
  int quiet_rounds = 0;
  while (quiet_rounds < 2 && sink.error.empty()) {
    if (Clock::now() - stop_at > options.drain_limit) {
      result.drained = false;
      break;
    }
    const int got = bus.handleTimeout(quiet_ms);
    if (got < 0) throw std::runtime_error("LCM failed while receiving");
    quiet_rounds = (got == 0 && udp_receive_backlog() == 0) ? quiet_rounds + 1 : 0;
  }
  result.drain_s = std::chrono::duration<double>(Clock::now() - stop_at).count();
  lcm_unsubscribe(bus.getUnderlyingLCM(), sub);
  if (!sink.error.empty()) throw RecordError(sink.error);
  return result;
}

}  // namespace cosim::record
