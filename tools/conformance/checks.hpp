// The conformance kit's checks (tools/conformance/README.md): pure functions of the sessions'
// traces, each a verdict with a one-line reason that names the fault.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tools/conformance/session.hpp"

namespace cosim::conformance {

struct Verdict {
  std::string check;   ///< its name, e.g. "spin-up impulse"
  bool pass = false;
  std::string reason;  ///< one line
};

/// What the checks know of the run besides the traces.
struct Context {
  int time_ratio = 0;        ///< A_T of the scene
  double dt_cg_s = 0.0;      ///< dt_CG of the scene
  Eigen::VectorXd area_lb;   ///< dA_l of the scene's markers (empty: not known)
  double peer_timeout_s = 30.0;
};

/// The sessions the kit runs (session plans): `main` (spin-up, a uniform stream, a duplicate,
/// a resend_t, the success stop_t), `repeat` (the same inputs again, then a stop_t with an
/// error), `still` (a short gust, then still fluid, then silence).
Plan main_plan();
Plan repeat_plan();
Plan still_plan();

Verdict check_handshake_fields(const Trace& main);
Verdict check_initial_state(const Trace& main);
Verdict check_finite(const std::vector<const Trace*>& traces);
Verdict check_substeps(const Trace& main, const Context& c);
Verdict check_spin_up_impulse(const Trace& main, const Context& c);
Verdict check_impulse_motion(const Trace& main, const Context& c);
Verdict check_resend(const Trace& main);
Verdict check_duplicates(const Trace& main);
Verdict check_success_stop(const Trace& main);
Verdict check_error_stop(const Trace& repeat);
Verdict check_timeout(const Trace& still, const Context& c);
Verdict check_bit_identical(const Trace& main, const Trace& repeat);
Verdict check_still_energy(const Trace& still, const Context& c);

/// Every check in order.
std::vector<Verdict> all_checks(const Trace& main, const Trace& repeat, const Trace& still, const Context& c);

}  // namespace cosim::conformance
