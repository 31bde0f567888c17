// cosim-conformance: the conformance kit for a solid from outside (tools/conformance/README.md).
// A mock fluid on the session layer drives the candidate solid process through five sessions
// and reports each check as PASS or FAIL with a one-line reason naming the fault.
//
//   cosim-conformance --solid-cmd CMD [SCENE] [--work DIR] [--trace FILE] [--golden FILE]
//                     [--tolerance T] [--sessions main,repeat,still,long,restart]
//
// CMD is started as the launcher starts a solid: CMD SCENE --output DIR --channel-prefix P
// --quiet, the token in COSIM_RUN_TOKEN. SCENE defaults to scenes/conformance.toml (short
// timeouts). As root the kit runs in a private network namespace (unshare -n, lo up with
// multicast), as the launcher does; otherwise on the host with the scene's ttl=0 URL.
// Exit status: 0 every check passes, 1 a check fails, 2 bad command line or scene.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/log/logger.hpp"
#include "common/text/cli_parse.hpp"
#include "protocol/lcm_url.hpp"
#include "protocol/session/announcement.hpp"
#include "common/run/exit_codes.hpp"
#include "common/text/text.hpp"
#include "protocol/units.hpp"
#include "solid/coupling/solid_coupler.hpp"
#include "solid/config/solid_scene.hpp"
#include "tools/conformance/checks.hpp"
#include "tools/conformance/golden_trace.hpp"
#include "tools/conformance/session.hpp"

namespace fs = std::filesystem;
using namespace cosim;

namespace {

/// The tool's lines: "cosim-conformance: ...".
log::Logger tool_log() { return log::Logger("cosim-conformance"); }

/// As root, outside a namespace of our own: run again inside one (no packet leaves the host).
void enter_private_network(int argc, char** argv) {
  if (::geteuid() != 0 || std::getenv("COSIM_CONFORMANCE_NETNS") != nullptr) return;
  ::setenv("COSIM_CONFORMANCE_NETNS", "1", 1);
  std::vector<const char*> args{"unshare", "-n", "/bin/sh", "-c",
                                "ip link set lo up && ip link set lo multicast on && "
                                "{ ip route add 224.0.0.0/4 dev lo 2>/dev/null || true; } && exec \"$0\" \"$@\""};
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  args.push_back(self.c_str());
  for (int k = 1; k < argc; ++k) args.push_back(argv[k]);
  args.push_back(nullptr);
  std::fflush(stdout);
  ::execvp("unshare", const_cast<char* const*>(args.data()));
  // unshare is not there: go on in this namespace.
}

std::string default_scene() {
  const fs::path exe = fs::read_symlink("/proc/self/exe");
  for (const fs::path& p : {exe.parent_path().parent_path() / "share" / "cosim" / "scenes" / "conformance.toml",
                            fs::path(COSIM_SOURCE_DIR) / "scenes" / "conformance.toml"})
    if (fs::exists(p)) return p.string();
  return "scenes/conformance.toml";
}

int main_impl(int argc, char** argv) {
  CLI::App app{"The conformance kit: drives a solid process through the protocol with a mock fluid and reports "
               "each check (handshake, lattice units, substeps, spin-up impulse, impulse vs motion, response to the "
               "fluid, resends, duplicates, stops, timeouts, bit-identical runs, energy in still fluid, the energy "
               "balance against the solid's own energy (its solid.h5), a long "
               "session, a restart) as PASS or FAIL with a one-line reason.\n"
               "Exit status: 0 every check passes, 1 a check fails, 2 bad command line or scene.",
               tool_log().process()};
  std::string command, scene_path = default_scene(), work, trace_out, golden;
  double tolerance = 1e-9;
  app.add_option("--solid-cmd", command, "the candidate solid's command (it gets SCENE and the launcher's options)")
      ->required();
  app.add_option("scene", scene_path, "coupled scene (default: scenes/conformance.toml)");
  app.add_option("--work", work, "folder of the sessions' logs (default: a new folder under $TMPDIR)");
  app.add_option("--trace", trace_out, "write the main session's solid_state_t as a golden trace (CSV)");
  app.add_option("--golden", golden, "compare the main session with this golden trace");
  std::vector<std::string> session_list{"main", "repeat", "still", "long", "restart"};
  app.add_option("--sessions", session_list,
                 "the sessions to run, comma-separated (default all: main,repeat,still,long,restart; main always "
                 "runs, restart needs repeat); the checks of the others are left out")
      ->delimiter(',')
      ->check(CLI::IsMember({"main", "repeat", "still", "long", "restart"}));
  app.add_option("--tolerance", tolerance, "golden trace tolerance (default 1e-9; tools/conformance/README.md)")
      ->check(CLI::PositiveNumber);
  if (const auto code = protocol::parse_command_line(app, argc, argv, tool_log().process())) return *code;

  const std::set<std::string> sessions(session_list.begin(), session_list.end());
  if (sessions.count("restart") && !sessions.count("repeat")) {
    tool_log().error() << "--sessions: 'restart' needs 'repeat' (its checkpoint); allowed: add repeat";
    return protocol::exit_code::bad_input;
  }
  solid::SolidScene scene;
  try {
    scene = solid::load_solid_scene(scene_path);
  } catch (const std::exception& e) {
    tool_log().error() << protocol::one_line(e.what());
    return protocol::exit_code::bad_input;
  }
  if (!scene.coupled()) {
    tool_log().error() << scene_path << ": not a coupled scene (no [coupling] section)";
    return protocol::exit_code::bad_input;
  }
  if (const auto why = protocol::lcm_url_problem(scene.coupling->lcm_url)) {
    tool_log().error() << scene_path << ": [coupling] lcm_url = \"" << scene.coupling->lcm_url
              << "\": " << *why;
    return protocol::exit_code::bad_input;
  }
  if (work.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    work = (fs::path(tmp ? tmp : "/tmp") / ("cosim-conformance-" + protocol::new_run_token().substr(0, 8))).string();
  }
  fs::create_directories(work);
  const protocol::UnitConverter units(scene.unit_inputs());
  conformance::Candidate cand;
  cand.command = command;
  cand.scene_path = fs::absolute(scene_path).string();
  cand.work_dir = work;
  cand.lcm_url = scene.coupling->lcm_url;
  cand.peer_timeout_s = scene.coupling->peer_timeout_s;
  cand.resend_after_s = scene.coupling->resend_after_s;
  try {
    cand.fluid_hello = protocol::announcement("fluid", "", "conformance-mock-fluid", cand.scene_path,
                                              scene.coupling->scheme.scheme, units, scene.coupling->time_ratio);
  } catch (const std::exception& e) {
    tool_log().error() << protocol::one_line(e.what());
    return protocol::exit_code::bad_input;
  }
  conformance::Context ctx;
  ctx.time_ratio = scene.coupling->time_ratio;
  ctx.dt_cg_s = units.dt_cg_s();
  const std::vector<double> areas = solid::marker_areas_lb(scene.config.sheets, units);
  ctx.area_lb = Eigen::Map<const Eigen::VectorXd>(areas.data(), Eigen::Index(areas.size()));
  ctx.peer_timeout_s = scene.coupling->peer_timeout_s;
  ctx.position_lb = solid::marker_positions_lb(scene.config.sheets, units);
  ctx.dx_m = units.dx_m();
  ctx.energy_unit_J = units.energy_lb_J();
  ctx.law = scene.reaction_law;

  tool_log().info() << "solid '" << command << "' on " << cand.scene_path << " (A_T = " << ctx.time_ratio
                    << ", peer_timeout_s = " << protocol::fmt("%g", ctx.peer_timeout_s) << "); logs in " << work;
  const auto asked = [&](const std::string& name) { return sessions.count(name) > 0; };
  const conformance::Trace main = conformance::run_session(cand, conformance::main_plan());
  std::optional<conformance::Trace> repeat, still, long_run, restart;
  if (asked("repeat")) repeat = conformance::run_session(cand, conformance::repeat_plan());
  if (asked("still")) still = conformance::run_session(cand, conformance::still_plan());
  if (asked("long")) long_run = conformance::run_session(cand, conformance::long_plan());
  conformance::Sessions traces;
  traces.main = &main;
  traces.repeat = repeat ? &*repeat : nullptr;
  traces.still = still ? &*still : nullptr;
  traces.long_run = long_run ? &*long_run : nullptr;
  traces.restart_asked = asked("restart");
  if (traces.restart_asked) {
    // The checkpoint the solid kept when session 'repeat' stopped with an error, if any.
    std::error_code ec;
    for (const fs::directory_entry& e : fs::directory_iterator(fs::path(work) / "repeat" / "checkpoints", ec))
      if (e.path().filename().string().rfind("solid_", 0) == 0 && e.path().extension() == ".h5" &&
          e.path().string() > traces.checkpoint)
        traces.checkpoint = e.path().string();
    if (!traces.checkpoint.empty()) restart = conformance::run_session(cand, conformance::restart_plan(traces.checkpoint));
    traces.restart = restart ? &*restart : nullptr;
  }
  std::vector<conformance::Verdict> verdicts = conformance::all_checks(traces, ctx);
  if (!trace_out.empty()) conformance::write_golden_trace(trace_out, main);
  if (!golden.empty()) verdicts.push_back(conformance::check_golden_trace(golden, main, tolerance));

  std::vector<std::string> failed;
  for (const conformance::Verdict& v : verdicts) {
    char head[64];
    std::snprintf(head, sizeof head, "  %s  %-24s ", v.pass ? "PASS" : "FAIL", v.check.c_str());
    std::cout << head << protocol::one_line(v.reason) << "\n";
    if (!v.pass) failed.push_back(v.check);
  }
  {
    log::Line line = tool_log().info();
    line << verdicts.size() - failed.size() << " of " << verdicts.size() << " checks pass";
    for (std::size_t k = 0; k < failed.size(); ++k) line << (k == 0 ? "; FAIL: " : ", ") << failed[k];
  }
  return failed.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  enter_private_network(argc, argv);
  try {
    return main_impl(argc, argv);
  } catch (const std::exception& e) {
    tool_log().error() << protocol::one_line(e.what());
    return protocol::exit_code::system;
  }
}
