// `cosim-replay`: replays one side of a recorded coupled run against its LCM log and reports
// the first difference (issue 6, item 2; docs/replay.md; tools/replay/replay.hpp).
//
//   cosim-replay LOG --side fluid|solid --scene SCENE.toml [--output DIR] [--quiet]
//                [--channel-prefix P] [--token T]
//
// Exit status: 0 identical; 1 system error; 2 bad input (command line, log, scene, or a
// scene that does not match the log, or an incomplete log); 10 a published message differs
// from the log (or is missing from it); 11 no difference, but the server stopped with a
// non-zero exit code of its own.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

#include "common/text/cli_parse.hpp"
#include "common/text/text.hpp"
#include "tools/replay/replay.hpp"

namespace {

int main_impl(int argc, char** argv) {
  using namespace cosim::replay;
  CLI::App app{
      "Replays one side of a coupled run recorded with launch/run-coupled.sh --log: runs the fluid "
      "(or the solid) server in this process with no peer, feeds it the logged messages of the "
      "other side in the order the log shows them (any coupling scheme: serial, implicit, parallel), "
      "and compares what it publishes (fluid_state_t, or solid_state_t) with the log by seq, bit "
      "for bit. Reports the first step, CGP and field that differ, with the largest absolute and "
      "relative differences (docs/replay.md).\n"
      "Exit status: 0 identical, 1 system error, 2 bad input (command line, log, scene, a scene "
      "that does not match the log, an incomplete log), 10 different, 11 the server stopped with "
      "a non-zero code (no difference before).",
      cosim::replay::replay_log().process()};
  std::string log, side, scene, output, prefix, token;
  bool quiet = false;
  app.add_option("log", log, "the run's LCM log, e.g. OUTPUT/traffic.lcmlog")->required();
  app.add_option("--side", side, "the server to replay: fluid or solid")->required();
  app.add_option("--scene", scene, "the run's scene file (the same bytes: the handshake checks its hash)")
      ->required();
  app.add_option("--output", output,
                 "the replayed server's output folder (default: a temporary folder, removed when "
                 "identical); never the logged run's folder");
  app.add_option("--channel-prefix", prefix, "the run's channel prefix, when the log holds several");
  app.add_option("--token", token, "the run's token, when the log holds several runs");
  app.add_flag("--quiet", quiet, "no progress lines on stderr");
  std::string key_file;
  app.add_option("--key-file", key_file,
                 "the run's key (OUTPUT/run.key): verify every logged message's MAC, leave out those that do "
                 "not verify (default: MACs removed unverified)");
  if (const auto code = cosim::protocol::parse_command_line(app, argc, argv, cosim::replay::replay_log().process())) return *code;
  ReplayOptions o;
  if (side == "fluid") {
    o.side = Side::Fluid;
  } else if (side == "solid") {
    o.side = Side::Solid;
  } else {
    cosim::replay::replay_log().error() << cosim::log::printf_text("--side = \"%s\": allowed: fluid, solid", cosim::protocol::one_line(side).c_str());
    return exit_code::bad_input;
  }
  o.log_path = log;
  o.scene_path = scene;
  cosim::protocol::record_scene(scene);  // the provenance of the replay's outputs
  o.output_dir = output;
  o.channel_prefix = prefix;
  o.token = token;
  o.quiet = quiet;
  if (!key_file.empty()) {
    try {
      o.key = cosim::protocol::read_key_file(key_file);
    } catch (const std::invalid_argument& e) {
      cosim::replay::replay_log().error() << cosim::log::printf_text("--key-file: %s", cosim::protocol::one_line(e.what()).c_str());
      return exit_code::bad_input;
    }
  }
  return run_replay(o, std::cout, std::cerr);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return main_impl(argc, argv);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    cosim::replay::replay_log().error() << cosim::protocol::one_line(e.what());
    return cosim::replay::exit_code::system;
  }
}
