// The conformance kit's checks (tools/conformance/README.md): pure functions of the sessions'
// traces, each a verdict with a one-line reason that names the fault.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "protocol/config/reaction_settings.hpp"
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
  Eigen::Matrix3Xd position_lb;  ///< X_l of the scene's [[sheet]]s at the start, dx (empty: not known)
  double dx_m = 0.0;             ///< the scene's dx, for naming positions in other units
  double energy_unit_J = 0.0;    ///< rho_air dx^3 c^2 in joules (F_LB dx): solid.h5's energies to lattice units
  double peer_timeout_s = 30.0;
  /// The scene's [reaction] law: g dA as a function of U_B and u (solid/coupling/reaction_law.hpp).
  protocol::config::ReactionLaw law = protocol::config::ReactionLaw::MomentumExchange;
};

/// The sessions the kit runs (session plans): `main` (spin-up, a stream with step changes, a
/// duplicate, a resend_t, the success stop_t), `repeat` (the same inputs again, then a stop_t
/// with an error: the solid keeps a checkpoint), `still` (a short gust, then still fluid,
/// then silence), `long` (main's inputs until a step change at `kResponseStep`, then 240
/// steps of changing streams, a duplicate and a resend_t near the end), `restart` (from
/// repeat's checkpoint, main's inputs to the end).
Plan main_plan();
Plan repeat_plan();
Plan still_plan();
Plan long_plan();
Plan restart_plan(const std::string& checkpoint_file);
/// The exchange at which the long session's stream first differs from main's.
inline constexpr std::int64_t kResponseStep = 10;

Verdict check_handshake_fields(const Trace& main);
Verdict check_initial_state(const Trace& main);
Verdict check_finite(const std::vector<const Trace*>& traces);
Verdict check_substeps(const Trace& t, const Context& c);
Verdict check_spin_up_impulse(const Trace& main, const Context& c);
/// The impulse against the scene's reaction law at the solid's reported motion, steps
/// first..last (default: from the first free step to the one before the last).
Verdict check_impulse_motion(const Trace& t, const Context& c, std::int64_t first = -1, std::int64_t last = -1);
Verdict check_lattice_units(const Trace& main, const Context& c);
/// Sessions `main` and `long` share their inputs up to kResponseStep - 1: the solid's answer
/// to the change of the stream at kResponseStep.
Verdict check_response(const Trace& main, const Trace& long_run, const Context& c);
/// The long session: the checks of one session repeated over all its steps.
Verdict check_long_session(const Trace& long_run, const Context& c);
/// The restart session against the straight run (main), bit for bit; `checkpoint` empty:
/// the solid wrote none (they are optional).
Verdict check_restart(const Trace& main, const Trace* restart, const std::string& checkpoint);
Verdict check_resend(const Trace& main);
Verdict check_duplicates(const Trace& main);
Verdict check_success_stop(const Trace& main);
Verdict check_error_stop(const Trace& repeat);
Verdict check_timeout(const Trace& still, const Context& c);
Verdict check_bit_identical(const Trace& main, const Trace& repeat);
Verdict check_still_energy(const Trace& still, const Context& c);
/// The solid's own energy (solid.h5's total_energy_J, Trace::energies) against the work of
/// the fluid's reaction on its markers computed from the exchanged J_l and X_l, step by step
/// over the free steps of each session given; not applicable (a pass saying so) where the
/// solid reports no energy.
Verdict check_energy_balance(const std::vector<const Trace*>& sessions, const Context& c);

/// The traces of the sessions that ran (null: not run; `main` always runs).
struct Sessions {
  const Trace* main = nullptr;
  const Trace* repeat = nullptr;
  const Trace* still = nullptr;
  const Trace* long_run = nullptr;
  bool restart_asked = false;     ///< the restart session was asked for (with repeat)
  const Trace* restart = nullptr;  ///< null: the solid kept no checkpoint (`checkpoint` empty)
  std::string checkpoint;
};

/// Every check whose sessions ran, in order.
std::vector<Verdict> all_checks(const Sessions& s, const Context& c);

}  // namespace cosim::conformance
