// One session of the conformance kit: the candidate solid started as a process and driven by
// the mock fluid through a plan (how many steps, which flow, which misbehaviour, how it ends),
// everything it sent recorded as a trace for the checks (checks.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "cosimlcm/resend_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "cosimlcm/stop_t.hpp"
#include "protocol/handshake.hpp"
#include "tools/conformance/solid_energy.hpp"

namespace cosim::conformance {

/// What the candidate is and where it runs.
struct Candidate {
  std::string command;     ///< the solid's command line, before SCENE and the launcher's options
  std::string scene_path;  ///< the coupled scene it reads
  std::string work_dir;    ///< the sessions' output folders and logs
  std::string lcm_url;     ///< the scene's [coupling] lcm_url
  double handshake_wait_s = 60.0;  ///< for the first hello_t (a model may build slowly)
  double answer_wait_s = 10.0;     ///< for each solid_state_t
  double peer_timeout_s = 30.0, resend_after_s = 0.5;  ///< the scene's [coupling]
  /// The fluid's hello_t as a fluid reading the scene announces it (the token is the session's).
  protocol::Hello fluid_hello;
};

/// How a session ends.
enum class Ending { Success, ErrorStop, Silence };

struct Plan {
  std::string name;
  std::int64_t total_steps = 12, rigid_steps = 3;
  /// The last fluid_state_t sent: total_steps - 1 for Success.
  std::int64_t last_step = 11;
  Ending ending = Ending::Success;
  /// u at the markers for a step (3 x N); rho is 1 everywhere.
  std::function<Eigen::Matrix3Xd(std::int64_t step, Eigen::Index n)> flow;
  std::int64_t duplicate_at = -1;  ///< fluid_state_t of this step sent twice
  std::int64_t resend_at = -1;     ///< resend_t for solid_state_t of this step, after the next one
  /// A restart (protocol/README.md section 10): the solid started with `--restart
  /// restart_file`, which holds its state after step `restart_at`; the session then awaits
  /// that step's solid_state_t again (no step 0) and goes on from fluid_state_t(restart_at + 1),
  /// the fluid's seqs continuing as in a run that sent every step once.
  std::int64_t restart_at = -1;
  std::string restart_file;
};

struct Trace {
  std::string name;
  std::optional<protocol::Hello> hello;  ///< the solid's first hello_t
  protocol::HandshakeResult handshake;
  std::vector<cosimlcm::solid_state_t> states;  ///< every copy, in order of arrival
  std::vector<cosimlcm::solid_state_t> resend_answers;  ///< copies of resend_at after the request
  std::vector<cosimlcm::resend_t> resends;  ///< the solid's resend_t("fluid_state")
  std::vector<cosimlcm::stop_t> stops;      ///< the solid's stop_t
  std::optional<int> exit_code;   ///< nothing: still running at the end (then killed)
  double exit_after_s = -1.0;     ///< from the ending (stop_t or silence) to the exit
  std::string problem;            ///< a session that did not get through its plan: why
  std::string last_line;          ///< the solid's last output line
  Plan plan;
  std::string log_path;
  /// The solid's energies from the solid.h5 it wrote into its --output folder, if any.
  SolidEnergies energies;

  /// The first copy of solid_state_t(step), or null.
  const cosimlcm::solid_state_t* state(std::int64_t step) const;

 private:
  /// step -> index of its first copy in `states`, built again when `states` grows.
  mutable std::unordered_map<std::int64_t, std::size_t> first_;
  mutable std::size_t indexed_ = 0;
};

/// Runs the plan against a fresh process of the candidate. Never throws for the candidate's
/// behaviour (that is recorded); throws std::runtime_error if the bus cannot be opened.
Trace run_session(const Candidate& c, const Plan& plan);

}  // namespace cosim::conformance
