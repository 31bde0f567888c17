// cosim-log: inspects an LCM log of coupled runs (launch/run-coupled.sh --log writes
// OUTPUT/traffic.lcmlog with lcm-logger). docs/logs.md describes it.
//
//   cosim-log summary LOG
//   cosim-log show LOG --step N [--channel SUFFIX] [--max-cgps K]
//   cosim-log export LOG OUT.h5 [--run TOKEN|PREFIX]
//
// Exit status: 0 done, 1 an output or system error, 2 bad input (no such file, not an LCM
// log, an unknown subcommand or option, a step not in the log), one line on stderr.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "common/text/cli_parse.hpp"
#include "common/log/logger.hpp"
#include "common/text/text.hpp"
#include "tools/log/log_inspector.hpp"

namespace {

using cosim::protocol::one_line;
namespace lt = cosim::logtool;

namespace log = cosim::log;
/// The tool's lines: "cosim-log: ...".
log::Logger tool_log() { return log::Logger("cosim-log"); }

constexpr int kExitOk = 0;
constexpr int kExitSystem = 1;
constexpr int kExitBadInput = 2;

int main_impl(int argc, char** argv) {
  CLI::App app{
      "Inspects an LCM log of coupled runs (lcm-logger's format; launch/run-coupled.sh --log).\n"
      "Exit status: 0 done, 1 output/system error, 2 bad input (file, option, step).",
      tool_log().process()};
  app.require_subcommand(1);
  std::string key_file;
  app.add_option("--key-file", key_file,
                 "the run's key (OUTPUT/run.key): verify every message's MAC and leave out those that do not "
                 "verify (default: MACs removed unverified)");
  std::string log_path, out_path, run, channel;
  std::int64_t step = 0, max_cgps = -1;

  CLI::App* summary = app.add_subcommand(
      "summary",
      "per channel: type, count, first/last time, rate, largest gap; per run: steps and seq "
      "numbers missing, duplicated, out of order; undecodable and foreign messages");
  summary->add_option("log", log_path, "LCM log file")->required();

  CLI::App* show = app.add_subcommand(
      "show", "the messages of one step decoded to text (every field, one CGP per line)");
  show->add_option("log", log_path, "LCM log file")->required();
  show->add_option("--step", step, "the LB step")->required();
  show->add_option(
      "--channel", channel,
      "only this channel: a suffix (SOLID_STATE, FLUID_STATE, RESEND, STOP) or a whole name");
  show->add_option("--max-cgps", max_cgps, "at most K CGP lines per message (default: all)");

  CLI::App* exp = app.add_subcommand(
      "export", "one run's solid_state_t and fluid_state_t as HDF5 time series in step order");
  exp->add_option("log", log_path, "LCM log file")->required();
  exp->add_option("out", out_path, "output HDF5 file (overwritten)")->required();
  exp->add_option("--run", run,
                  "the run's token or channel prefix (needed when the log holds several)");

  // An unknown first word is named as a subcommand, not as a stray argument.
  if (argc >= 2 && argv[1][0] != '-') {
    const std::string sub = argv[1];
    if (sub != "summary" && sub != "show" && sub != "export") {
      tool_log().error() << "unknown subcommand \"" << one_line(sub) << "\"; allowed: summary, show, export (see "
                         << tool_log().process() << " --help)";
      return kExitBadInput;
    }
  }
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, tool_log().process())) return *code;

  try {
    if (!key_file.empty()) {
      try {
        lt::set_log_key(cosim::protocol::read_key_file(key_file));
      } catch (const std::invalid_argument& e) {
        throw lt::LogInputError(std::string("--key-file: ") + e.what());
      }
    }
    if (summary->parsed()) {
      std::fputs(lt::format_summary(lt::summarize_log(log_path)).c_str(), stdout);
    } else if (show->parsed()) {
      lt::ShowOptions opt;
      opt.step = step;
      opt.channel = channel;
      opt.max_cgps = max_cgps;
      std::fputs(lt::show_step(log_path, opt).c_str(), stdout);
    } else if (exp->parsed()) {
      const lt::ExportResult r = lt::export_log(log_path, out_path, run);
      tool_log().info() << log::printf_text("wrote %s: prefix %s token %s, solid_state %lld steps (%lld later copies left out), fluid_state %lld steps (%lld left out)", out_path.c_str(), r.prefix.c_str(), r.token.c_str(), static_cast<long long>(r.solid_rows), static_cast<long long>(r.solid_skipped), static_cast<long long>(r.fluid_rows), static_cast<long long>(r.fluid_skipped));
    }
  } catch (const lt::LogInputError& e) {
    tool_log().error() << one_line(e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    tool_log().error() << one_line(e.what());
    return kExitSystem;
  }
  if (lt::unauthenticated_events() > 0)
    tool_log().error() << log::printf_text("%lld logged messages whose MAC does not verify under --key-file were left out", static_cast<long long>(lt::unauthenticated_events()));
  if (std::fflush(stdout) != 0) {
    tool_log().error() << "cannot write to stdout";
    return kExitSystem;
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return main_impl(argc, argv);
  } catch (const std::exception& e) {
    tool_log().error() << one_line(e.what());
    return kExitSystem;
  }
}
