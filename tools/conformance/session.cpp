#include "tools/conformance/session.hpp"

#include <chrono>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "cosimlcm/welcome_t.hpp"
#include "protocol/coupling_scheme.hpp"
#include "protocol/hello_lcm.hpp"
#include "protocol/message_checks.hpp"
#include "common/text/text.hpp"
#include "tools/conformance/child_process.hpp"
#include "tools/conformance/mock_fluid.hpp"

namespace cosim::conformance {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

milliseconds ms(double s) { return milliseconds(static_cast<long long>(s * 1e3)); }

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

const cosimlcm::solid_state_t* Trace::state(std::int64_t step) const {
  if (indexed_ != states.size()) {
    first_.clear();
    for (std::size_t k = 0; k < states.size(); ++k) first_.emplace(states[k].step, k);  // keeps the first
    indexed_ = states.size();
  }
  const auto it = first_.find(step);
  return it == first_.end() ? nullptr : &states[it->second];
}

Trace run_session(const Candidate& c, const Plan& plan) {
  Trace t;
  t.name = plan.name;
  t.plan = plan;
  const std::string token = protocol::new_run_token();
  const std::string prefix = "CONF_" + token.substr(0, 8) + "_";
  const std::filesystem::path dir = std::filesystem::path(c.work_dir) / plan.name;
  std::filesystem::create_directories(dir);
  t.log_path = (dir / "solid.log").string();
  const std::filesystem::path series = dir / "solid.h5";
  std::filesystem::remove(series);  // a file of an earlier run in the same --work folder

  std::ostringstream link_log;
  MockFluid fluid(token, prefix, c.lcm_url, link_log);
  if (const auto e = fluid.open()) throw std::runtime_error(e->reason);
  const bool restart = plan.restart_at >= 0;
  ChildProcess solid(c.command + " " + c.scene_path + " --output " + dir.string() + " --channel-prefix " + prefix +
                         " --quiet" + (restart ? " --restart " + plan.restart_file : std::string()),
                     {{"COSIM_RUN_TOKEN", token}}, t.log_path);
  const auto running = [&] { return !solid.poll().has_value(); };
  const auto finish = [&](const std::string& problem) {
    if (t.problem.empty()) t.problem = problem;
    t.states = fluid.states();
    t.resends = fluid.resends();
    t.stops = fluid.stops();
    t.exit_code = solid.poll();
    if (!t.exit_code) solid.kill();
    t.last_line = protocol::one_line(solid.last_line());
    t.energies = read_solid_energies(series.string());
    return t;
  };
  const auto gone = [&](const std::string& waiting) {
    return "the solid exited " + std::to_string(*solid.poll()) + " while the mock fluid waited for " + waiting +
           ": \"" + protocol::one_line(solid.last_line()) + "\"";
  };

  // The handshake (section 6), judged by the coordinator's own rules (protocol/handshake.hpp).
  fluid.pump_until([&] { return !fluid.hellos().empty() || !running(); }, ms(c.handshake_wait_s));
  if (fluid.hellos().empty())
    return finish(running() ? "no hello_t within " + protocol::fmt("%g", c.handshake_wait_s) + " s" : gone("hello_t"));
  const protocol::Hello solid_hello = protocol::from_lcm(fluid.hellos().front());
  t.hello = solid_hello;
  protocol::Hello own = c.fluid_hello;  // the mock fluid's own reading of the scene
  own.token = token;
  t.handshake = protocol::check_handshake(own, solid_hello, token);
  cosimlcm::welcome_t w{};
  w.token = token;
  w.accepted = t.handshake.accepted;
  w.reason = protocol::bounded_reason(t.handshake.reason);
  w.total_steps = plan.total_steps;
  w.rigid_steps = plan.rigid_steps;
  w.time_ratio = t.handshake.accepted ? t.handshake.time_ratio : solid_hello.time_ratio;
  w.scheme = protocol::scheme_name(protocol::CouplingScheme::Serial);  // the mock fluid runs the serial scheme
  fluid.welcome(w);
  if (!t.handshake.accepted) {
    solid.wait_for(milliseconds(3000));
    return finish("handshake refused: " + t.handshake.reason);
  }
  const Eigen::Index n = solid_hello.num_cgps;

  // Step 0, then the lock-step (section 5).
  const auto answered = [&](std::int64_t step) {
    return fluid.pump_until([&] { return fluid.first_state(step) != nullptr || !running(); }, ms(c.answer_wait_s)) &&
           fluid.first_state(step) != nullptr;
  };
  // Step 0, or after a restart the checkpoint's step published again (section 10).
  const std::int64_t first = restart ? plan.restart_at : 0;
  if (!answered(first))
    return finish(running() ? "no solid_state_t(" + std::to_string(first) + ") within " +
                                  protocol::fmt("%g", c.answer_wait_s) + " s"
                            : gone("solid_state_t(" + std::to_string(first) + ")"));
  fluid.resume_seq(first);  // fluid_state_t(k) has seq k - 1, as in a run that sent each step once
  for (std::int64_t step = first + 1; step <= plan.last_step; ++step) {
    fluid.send(step, Eigen::VectorXd::Ones(n), plan.flow(step, n));
    if (step == plan.duplicate_at) fluid.send_again();
    if (!answered(step))
      return finish(running() ? "no solid_state_t(" + std::to_string(step) + ") within " +
                                    protocol::fmt("%g", c.answer_wait_s) + " s"
                              : gone("solid_state_t(" + std::to_string(step) + ")"));
    if (step == plan.resend_at + 1) {
      const std::size_t before = fluid.states().size();
      fluid.ask_resend(plan.resend_at);
      fluid.pump_until(
          [&] {
            for (std::size_t k = before; k < fluid.states().size(); ++k)
              if (fluid.states()[k].step == plan.resend_at) return true;
            return false;
          },
          milliseconds(2000));
      for (std::size_t k = before; k < fluid.states().size(); ++k)
        if (fluid.states()[k].step == plan.resend_at) t.resend_answers.push_back(fluid.states()[k]);
    }
  }
  // Let late copies (a duplicate answered twice) arrive.
  fluid.pump_until([] { return false; }, milliseconds(100));

  const Clock::time_point end = Clock::now();
  switch (plan.ending) {
    case Ending::Success:
      fluid.stop(plan.total_steps, 0, "");
      break;
    case Ending::ErrorStop:
      fluid.stop(plan.last_step, 3, "conformance: the mock fluid stops with an error");
      break;
    case Ending::Silence:
      fluid.answer_resends(false);
      break;
  }
  const double wait_s = plan.ending == Ending::Silence ? c.peer_timeout_s + 5.0 : 5.0;
  fluid.pump_until([&] { return !running(); }, ms(wait_s));
  if (!running()) t.exit_after_s = since(end);
  fluid.pump_until([] { return false; }, milliseconds(100));  // a stop_t sent just before the exit
  return finish("");
}

}  // namespace cosim::conformance
