// The conformance kit's mock fluid (tools/conformance/README.md): the fluid's side of the
// protocol on the session layer (protocol/session/: PeerLink for the transport and its gate,
// StateOutbox for fluid_state_t with the run's token, consecutive seqs and resends), without
// a flow. It records every copy the candidate solid sends, unjudged (no value checks at the
// gate: a NaN or a wrong count is the checks' to name, not the transport's to drop), and can
// misbehave on purpose: a duplicate fluid_state_t, a resend_t of its own, silence.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/hello_t.hpp"
#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "cosimlcm/welcome_t.hpp"
#include "protocol/session/peer_link.hpp"
#include "protocol/session/state_outbox.hpp"

namespace cosim::conformance {

class MockFluid {
 public:
  using Clock = std::chrono::steady_clock;

  MockFluid(const std::string& token, const std::string& prefix, const std::string& lcm_url, std::ostream& log);

  /// Opens the bus and subscribes; an ending (exit code 1 or 2) if it cannot.
  std::optional<protocol::Ending> open();

  /// welcome_t to the solid now, and again for every later hello_t.
  void welcome(const cosimlcm::welcome_t& w);
  /// fluid_state_t(step) with rho_l and u_l (3 x N) at the markers, the next seq.
  void send(std::int64_t step, const Eigen::VectorXd& rho, const Eigen::Matrix3Xd& u);
  /// The next fluid_state_t gets seq `seq` (a restart continues the run's seqs).
  void resume_seq(std::int64_t seq) { outbox_.set_seq(seq); }
  /// The last fluid_state_t again, unchanged (its seq too): a duplicate.
  void send_again();
  /// resend_t("solid_state", step): the solid must publish its kept copy again, unchanged.
  void ask_resend(std::int64_t step);
  /// stop_t(step, code) from the fluid (three copies).
  void stop(std::int64_t step, int code, const std::string& reason) { link_.publish_stop(step, code, reason); }
  /// Whether the solid's resend_t("fluid_state") are answered (not while playing silent).
  void answer_resends(bool on) { answering_ = on; }

  /// Dispatches what arrives until `done()` or `timeout`; whether done() held.
  bool pump_until(const std::function<bool()>& done, std::chrono::milliseconds timeout);

  /// What arrived from the solid, in order (every copy).
  const std::vector<cosimlcm::hello_t>& hellos() const { return hellos_; }
  const std::vector<cosimlcm::solid_state_t>& states() const { return states_; }
  const std::vector<cosimlcm::resend_t>& resends() const { return resends_; }
  const std::vector<cosimlcm::stop_t>& stops() const { return stops_; }
  /// The first copy of solid_state_t(step), or null.
  const cosimlcm::solid_state_t* first_state(std::int64_t step) const;
  int copies_of(std::int64_t step) const;
  const std::optional<protocol::Ending>& fatal() const { return link_.fatal(); }

 private:
  std::string token_;
  protocol::PeerLink link_;
  protocol::StateOutbox<cosimlcm::fluid_state_t> outbox_;
  std::optional<cosimlcm::welcome_t> welcome_;
  std::optional<cosimlcm::fluid_state_t> last_sent_;
  bool answering_ = true;
  std::vector<cosimlcm::hello_t> hellos_;
  std::vector<cosimlcm::solid_state_t> states_;
  std::vector<cosimlcm::resend_t> resends_;
  std::vector<cosimlcm::stop_t> stops_;
};

}  // namespace cosim::conformance
