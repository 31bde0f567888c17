#include "tools/replay/replay.hpp"

#include <omp.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "fluid/coupled/coupled_fluid.hpp"
#include "fluid/config/scene_config.hpp"
#include "common/text/text.hpp"
#include "solid/coupled/coupled_solid.hpp"
#include "solid/config/solid_scene.hpp"
#include "tools/replay/compare.hpp"
#include "tools/replay/log_scan.hpp"
#include "tools/replay/replayed_peer.hpp"

namespace cosim::replay {

namespace {

namespace fs = std::filesystem;
using protocol::fmt;
using protocol::one_line;

/// The last non-empty line of a text.
std::string last_line(const std::string& text) {
  std::istringstream in(text);
  std::string line, last;
  while (std::getline(in, line))
    if (!one_line(line).empty()) last = line;
  return one_line(last);
}

fs::path make_temp_output() {
  std::string pattern = (fs::temp_directory_path() / "cosim-replay-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr)
    throw std::runtime_error("cannot create a temporary output folder " + pattern + ": " +
                             std::strerror(errno));
  return pattern;
}

class Replay {
 public:
  Replay(const ReplayOptions& o, std::ostream& out, std::ostream& err) : o_(o), out_(out), err_(err) {}

  int run() {
    LogReader log = open_log(o_.log_path);
    const LogScan s = scan(log);
    const Selected sel = select_run(s, o_, o_.log_path);
    const RunTraffic& run = *sel.run;
    check_traffic(run, sel);

    const bool fluid = o_.side == Side::Fluid;
    // The scene: the run's own file, its output redirected (never the original run's).
    std::optional<fluid::FluidScene> fscene;
    std::optional<solid::SolidScene> sscene;
    std::string scene_output;
    try {
      if (fluid) {
        fscene = fluid::load_scene(o_.scene_path);
        if (!fscene->coupling) throw ReplayError(not_coupled());
      } else {
        sscene = solid::load_solid_scene(o_.scene_path);
        if (!sscene->coupled()) throw ReplayError(not_coupled());
      }
    } catch (const fluid::SceneError& e) {
      throw ReplayError(e.what());
    } catch (const solid::SolidSceneError& e) {
      throw ReplayError(e.what());
    }
    // Every scheme is replayed the same way (the peer feeds by causality); the scheme only
    // words the report (several messages a step) and the end of a log without stop_t.
    const protocol::SchemeSettings& scheme = fluid ? fscene->coupling->scheme : sscene->coupling->scheme;
    const protocol::MessageOrder& order = protocol::message_order(scheme.scheme);
    per_message_ = order.several_per_step;
    const fs::path output = output_dir();
    if (fluid) {
      fluid::SceneOverrides ov;
      ov.output_dir = output.string();
      fluid::apply_overrides(*fscene, ov);
    } else {
      solid::SolidSceneOverrides ov;
      ov.output_dir = output.string();
      ov.channel_prefix = sel.prefix;
      try {
        solid::apply_overrides(*sscene, ov);
      } catch (const solid::SolidSceneError& e) {
        throw ReplayError(e.what());
      }
    }
    const int threads = fluid && fscene->threads > 0 ? fscene->threads : omp_get_max_threads();

    replay_log().info(out_) << "the " << side_name(o_.side) << " of run " << sel.token << " from " << o_.log_path;
    out_ << "  log: " << s.events << " events, " << run.messages << " of the run on " << sel.prefix
         << "*; solid_state_t " << describe_states(run.solid_states) << ", fluid_state_t "
         << describe_states(run.fluid_states) << "; " << run.copies << " resent or duplicate copies skipped\n"
         << "  scene " << o_.scene_path << "; server output " << output.string();
    if (fluid) out_ << "; " << threads << " OpenMP thread" << (threads == 1 ? "" : "s");
    out_ << "\n";
    out_.flush();

    lcm::LCM bus("memq://");
    if (!bus.good()) throw std::runtime_error("cannot open LCM's in-process bus memq://");
    Peer peer(bus, log, sel, o_.side, order, o_.quiet, err_);
    if (!peer.subscribed()) throw std::runtime_error("cannot subscribe to " + sel.prefix + "* on memq://");

    std::ostringstream server_out, server_err;
    int code = -1;
    std::thread server([&] {
      try {
        if (fluid) {
          // The thread count of the original process (fluid/app/main.cpp); the ICV is per thread.
          if (fscene->threads > 0) omp_set_num_threads(fscene->threads);
          fluid::CoupledFluidOptions fo;
          fo.token = sel.token;
          fo.channel_prefix = sel.prefix;
          fo.quiet = true;
          fo.bus = &bus;
          code = fluid::run_coupled_fluid(*fscene, fo, server_out, server_err);
        } else {
          solid::CoupledSolidOptions so;
          so.token = sel.token;
          so.quiet = true;
          so.bus = &bus;
          code = solid::run_coupled_solid(*sscene, so, server_out, server_err);
        }
      } catch (const std::exception& e) {
        server_err << side_name(o_.side) << ": " << one_line(e.what()) << "\n";
        code = exit_code::system;
      }
    });
    server.join();
    peer.finish();

    const fs::path server_log = output / (std::string(side_name(o_.side)) + ".log");
    std::ofstream(server_log) << server_out.str() << server_err.str();
    return report(peer, run, code, server_err.str(), output, server_log);
  }

 private:
  std::string not_coupled() const {
    return o_.scene_path + ": not a coupled scene (no [coupling] section); give the scene file of the "
                           "logged run";
  }

  void check_traffic(const RunTraffic& run, const Selected& sel) const {
    const std::string where = o_.log_path + ": run " + sel.token + " on " + sel.prefix + "*";
    if (!run.welcome)
      throw ReplayError(where + " has no welcome_t: the coordinator never decided; nothing to replay");
    if (!run.welcome->accepted)
      throw ReplayError(where + ": the handshake was refused (" + one_line(run.welcome->reason) +
                        "); nothing to replay");
    const bool fluid = o_.side == Side::Fluid;
    const auto& outputs = fluid ? run.fluid_states : run.solid_states;
    if (outputs.empty())
      throw ReplayError(where + " has no " + (fluid ? "fluid_state_t" : "solid_state_t") +
                        ": nothing to compare for --side " + side_name(o_.side));
    if (fluid && run.solid_states.empty())
      throw ReplayError(where + " has no solid_state_t to feed the fluid with");
  }

  fs::path output_dir() {
    if (o_.output_dir.empty()) {
      temporary_ = true;
      return make_temp_output();
    }
    const fs::path dir = o_.output_dir;
    std::error_code ec;
    const fs::path log_dir = fs::absolute(o_.log_path).parent_path();
    if (fs::exists(dir, ec) && fs::equivalent(dir, log_dir, ec))
      throw ReplayError("--output = " + o_.output_dir + ": is the logged run's folder (it holds " +
                        o_.log_path + "); the replay would overwrite its outputs: choose another folder");
    fs::create_directories(dir, ec);
    if (ec)
      throw std::runtime_error("cannot create the output folder " + dir.string() + ": " + ec.message());
    return dir;
  }

  int report(const Peer& p, const RunTraffic& run, int code, const std::string& server_err,
             const fs::path& output, const fs::path& server_log) {
    const bool fluid = o_.side == Side::Fluid;
    const char* type = fluid ? "fluid_state_t" : "solid_state_t";
    const char* server = side_name(o_.side);
    const std::string reason = last_line(server_err);
    if (!p.failure.empty()) {
      replay_log().error(err_) << p.failure;
      return exit_code::system;
    }
    if (p.refused) {
      replay_log().error(err_) << o_.scene_path << " does not match the logged run: "
           << (fluid ? "the fluid's coordinator refused the logged solid hello_t: "
                     : "the coordinator's check of the solid's hello_t against the logged fluid's: ")
           << one_line(*p.refused);
      cleanup(output, true);
      return exit_code::bad_input;
    }
    if (!p.welcomed) {  // the server ended before the handshake
      replay_log().error(err_) << "the " << server << " server exited " << code << " before the handshake: "
           << reason << " (its output: " << server_log.string() << ")";
      return code == exit_code::bad_input ? exit_code::bad_input : exit_code::server_failed;
    }

    // Logged outputs the server never published; published ones the log lacks (past the end
    // of an incomplete log, or of a run that the peer stopped with an error, they are the
    // log's end, not a difference: the logged server may have stopped before them). By seq.
    const auto& logged = fluid ? run.fluid_states : run.solid_states;
    std::vector<std::int64_t> missing;
    std::vector<MessageKey> not_in_log;
    for (const auto& [seq, m] : logged)
      if (!p.published.count(seq)) missing.push_back(seq);
    for (const MessageKey& k : p.not_in_log)
      if (!p.error_stop_given || k.seq < logged.rbegin()->first) not_in_log.push_back(k);

    const bool different = p.differing > 0 || !not_in_log.empty() || (code == 0 && !missing.empty());
    if (!different && code == 0 && p.log_gap.empty()) {
      out_ << "identical: " << units(p.compared) << " compared (" << type << " " << step_range(steps_of(logged))
           << (per_message_ ? ", iterations 0.." + std::to_string(max_iteration(logged)) : std::string())
           << ", by seq: " << compared_fields(o_.side) << ", bit for bit)\n";
      cleanup(output, false);
      return exit_code::identical;
    }
    if (p.first_different) {
      const StepResult& r = *p.first_different;
      const FieldDiff& d = *r.first;
      out_ << "different: first at " << where(r.step, r.iteration) << " (" << type << "), "
           << (d.cgp >= 0 ? "CGP " + std::to_string(d.cgp) + ", " : std::string()) << describe(d) << "\n";
      out_ << "  at " << where(r.step, r.iteration) << ": " << r.differing << " of " << r.values
           << " values differ; largest abs " << fmt("%.3g", r.max_abs->abs) << " (" << r.max_abs->field
           << "), largest rel " << fmt("%.3g", r.max_rel->rel) << " (" << r.max_rel->field << ")\n";
      out_ << "  over the replay: " << p.differing << " of " << units(p.compared) << " differ; largest abs "
           << fmt("%.3g", p.max_abs->abs) << " (" << where(p.max_abs_at->step, p.max_abs_at->iteration) << ", "
           << p.max_abs->field << "), largest rel " << fmt("%.3g", p.max_rel->rel) << " ("
           << where(p.max_rel_at->step, p.max_rel_at->iteration) << ", " << p.max_rel->field << ")\n";
    } else if (different) {
      out_ << "different: " << units(p.compared) << " compared and identical, but\n";
    } else {
      out_ << "identical so far: " << units(p.compared) << " compared\n";
    }
    if (!not_in_log.empty())
      out_ << "  the server published " << type << " of " << units(not_in_log.size())
           << " the log lacks (first: " << where(not_in_log.front().step, not_in_log.front().iteration) << ")\n";
    if (!missing.empty()) {
      const Logged& first = logged.at(missing.front());
      out_ << "  the server published no " << type << " of " << units(missing.size()) << " of the log (first: "
           << where(first.step, first.iteration) << ")\n";
    }
    if (!p.log_gap.empty()) out_ << "  the replay stopped early: " << p.log_gap << "\n";
    if (code != 0)
      out_ << "  the " << server << " server exited " << code << ": " << reason << "\n";
    out_ << "  server output kept in " << output.string() << "\n";
    out_.flush();
    if (different) return exit_code::different;
    if (!p.log_gap.empty()) {
      replay_log().error(err_) << o_.log_path << ": incomplete log: " << p.log_gap;
      return exit_code::bad_input;
    }
    replay_log().error(err_) << "the " << server << " server exited " << code << ": " << reason;
    return exit_code::server_failed;
  }

  /// "59 steps", or in the implicit scheme (several messages a step) "143 messages".
  std::string units(std::size_t n) const {
    const char* unit = per_message_ ? " message" : " step";
    return std::to_string(n) + unit + (n == 1 ? "" : "s");
  }
  std::string units(std::int64_t n) const { return units(static_cast<std::size_t>(n)); }

  /// "step 37", or in the implicit scheme "step 37, iteration 1".
  std::string where(std::int64_t step, std::int32_t iteration) const {
    return "step " + std::to_string(step) + (per_message_ ? ", iteration " + std::to_string(iteration) : std::string());
  }

  /// The default temporary folder goes when the replay is identical or refused.
  void cleanup(const fs::path& output, bool refused) {
    if (!temporary_) return;
    std::error_code ec;
    fs::remove_all(output, ec);
    if (!refused) out_ << "  (the server's output was a temporary folder, removed; keep it with --output DIR)\n";
  }

  const ReplayOptions& o_;
  std::ostream& out_;
  std::ostream& err_;
  bool temporary_ = false;
  bool per_message_ = false;  ///< the scene's scheme has several messages a step (the name table's)
};

}  // namespace

int run_replay(const ReplayOptions& options, std::ostream& out, std::ostream& err) {
  try {
    set_log_key(options.key);
    Replay r(options, out, err);
    return r.run();
  } catch (const ReplayError& e) {
    out.flush();
    replay_log().error(err) << one_line(e.what());
    return exit_code::bad_input;
  } catch (const std::exception& e) {
    out.flush();
    replay_log().error(err) << one_line(e.what());
    return exit_code::system;
  }
}

}  // namespace cosim::replay
