// cosim-record: records a coupled run's LCM traffic into an LCM log (launch/run-coupled.sh
// --log writes OUTPUT/traffic.lcmlog with it). docs/logs.md, "Recording", describes it.
//
//   cosim-record LOG --channels REGEX [--lcm-url URL] [--receive-buffer BYTES]
//
// It appends to LOG (a new file, or an LCM log: a restart's traffic goes after the run's it
// continues), prints one line once it listens, and records until SIGINT or SIGTERM; then it
// keeps receiving until the bus is quiet, so that nothing sent before is left out, and prints
// what it wrote. Exit status: 0 done, 1 a system error (LCM, writing) or a bus that did not
// fall quiet within 30 s, 2 bad input (command line, URL, a LOG that is not an LCM log).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "common/text/cli_parse.hpp"
#include "protocol/lcm_url.hpp"
#include "common/run/exit_codes.hpp"
#include "protocol/session/interrupt.hpp"
#include "common/log/logger.hpp"
#include "common/text/text.hpp"
#include "tools/record/recorder.hpp"

namespace {

namespace ec = cosim::protocol::exit_code;
using cosim::protocol::one_line;
namespace log = cosim::log;
/// The tool's lines: "cosim-record: ...".
log::Logger tool_log() { return log::Logger("cosim-record"); }

int main_impl(int argc, char** argv) {
  CLI::App app{
      "Records the LCM traffic of a coupled run into an LCM log (appended to, never truncated), "
      "until SIGINT or SIGTERM; then receives until the bus is quiet so that no message sent "
      "before is left out (docs/logs.md).\n"
      "Exit status: 0 done, 1 system error or a bus that did not fall quiet within 30 s, 2 bad "
      "input.",
      tool_log().process()};
  std::string log_path, channels, url(cosim::protocol::kDefaultLcmUrl);
  cosim::record::RecordOptions options;
  app.add_option("log", log_path, "the LCM log: a new file, or an LCM log to append to")->required();
  app.add_option("--channels", channels, "the channels to record: LCM's regex, e.g. 'COSIM_1a2b3c4d_.*'")
      ->required();
  app.add_option("--lcm-url", url, "the run's LCM URL: udpm://GROUP:PORT?ttl=0")->capture_default_str();
  app.add_option("--receive-buffer", options.receive_buffer_bytes,
                 "bytes of socket receive buffer to ask for (what waits there while the recorder gets no "
                 "CPU); 0 keeps the system's default")
      ->capture_default_str();
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, tool_log().process())) return *code;

  if (const auto why = cosim::protocol::lcm_url_problem(url)) {
    tool_log().error() << log::printf_text("--lcm-url \"%s\": %s", one_line(url).c_str(), why->c_str());
    return ec::bad_input;
  }
  if (url.starts_with("memq://")) {
    tool_log().error() << "--lcm-url \"memq://\": LCM's in-process queue cannot be recorded from another process; "
                          "give the run's udpm:// URL";
    return ec::bad_input;
  }
  if (options.receive_buffer_bytes < 0) {
    tool_log().error() << log::printf_text("--receive-buffer %d: must be 0 (the system's default) or a number of bytes", options.receive_buffer_bytes);
    return ec::bad_input;
  }
  if (const std::string why = cosim::record::channels_problem(channels); !why.empty()) {
    tool_log().error() << one_line(why);
    return ec::bad_input;
  }
  if (const std::string why = cosim::record::append_problem(log_path); !why.empty()) {
    tool_log().error() << one_line(why);
    return ec::bad_input;
  }

  // Before LCM starts its receive thread: SIGINT and SIGTERM only end the recording.
  cosim::protocol::catch_interrupts();
  lcm::LCM bus(url);
  if (!bus.good()) {
    tool_log().error() << log::printf_text("cannot open LCM on %s", url.c_str());
    return ec::system;
  }
  options.log_path = log_path;
  options.channels = channels;
  const cosim::record::RecordResult r = cosim::record::record(
      bus, options, [] { return cosim::protocol::interrupted() != 0; },
      [&](std::int64_t buffer) {
        tool_log().info() << log::printf_text("recording %s on %s into %s (socket receive buffer %lld bytes)", channels.c_str(), url.c_str(), log_path.c_str(), static_cast<long long>(buffer));
        std::fflush(stdout);
      });
  tool_log().info() << log::printf_text("%lld events, %lld bytes appended to %s (%lld after the stop request, drained in %.2f s)", static_cast<long long>(r.events), static_cast<long long>(r.bytes), log_path.c_str(), static_cast<long long>(r.after_stop), r.drain_s);
  if (!r.drained) {
    tool_log().error() << log::printf_text("the bus was not quiet %.0f s after the stop request; stopped recording (%s "
                                           "may lack later messages)",
                                           r.drain_s, log_path.c_str());
    return ec::system;
  }
  if (std::fflush(stdout) != 0) return ec::system;
  return ec::ok;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return main_impl(argc, argv);
  } catch (const std::exception& e) {
    tool_log().error() << one_line(e.what());
    return ec::system;
  }
}
