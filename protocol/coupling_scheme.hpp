// The coupling scheme of a coupled scene ([coupling] scheme and its keys), read by both
// servers from the same file (protocol/README.md section 13).
//
//   serial    the paper's staggered scheme (DESIGN 2.1): one exchange per LB step; the solid
//             integrates its A_T substeps with the fluid sample of the start of the interval
//             and the momentum-exchange reaction at each substep's velocity (Eqs. 18-20).
//   implicit  sub-iterations per LB step, with Aitken's dynamic relaxation (Kuettler & Wall
//             2008) as partitioned coupling libraries do (preCICE's "aitken"), until the
//             fluid sample the solid integrated with is the fluid before the step at the
//             markers where that step's impulses are spread; the reaction of Eqs. 18-20 at
//             the end velocity of each substep (backward Euler).
//   parallel  the Jacobi scheme of DESIGN 2.1 (protocol/README.md section 14): both sides
//             compute the same LB step at once with a one-step lag. While the fluid steps
//             n -> n+1 spreading J(n) (the impulses of the solid's interval n-1 -> n), the
//             solid integrates its interval n -> n+1 with the fluid sample of step n; the
//             rigid spin-up is exchanged in the serial order (the solid computes nothing
//             then, and a lagged direct forcing of a held sheet is only marginally damped).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cosim::protocol {

enum class CouplingScheme { Serial, Implicit, Parallel };

inline const char* scheme_name(CouplingScheme s) {
  return s == CouplingScheme::Implicit ? "implicit" : s == CouplingScheme::Parallel ? "parallel" : "serial";
}

/// The names the scene key takes, in the order of the enum.
inline constexpr const char* kSchemeNames[] = {"serial", "implicit", "parallel"};

/// "serial", "implicit" or "parallel"; empty for anything else.
inline std::optional<CouplingScheme> scheme_from_name(std::string_view name) {
  if (name == "serial") return CouplingScheme::Serial;
  if (name == "implicit") return CouplingScheme::Implicit;
  if (name == "parallel") return CouplingScheme::Parallel;
  return std::nullopt;
}

/// The keys of the implicit scheme, with their limits (both parsers check the same ones).
struct ImplicitSettings {
  static constexpr int max_iterations_max = 1000;
  static constexpr double tolerance_min = 1e-14;

  /// Sub-iterations of one LB step at most (1 .. max_iterations_max); a step that has not
  /// converged by then goes on with its last iterate and is counted (preCICE's behaviour).
  int max_iterations = 30;
  /// Converged when |u~ - u| <= tolerance |u~| (the fluid sample at the markers, 2-norms over
  /// all CGPs), in [tolerance_min, 1).
  double tolerance = 1e-4;
  /// The relaxation factor of the first iterate of the run, in (0, 1]; 0: the default 1/2.
  /// Later steps start from the previous step's last Aitken factor.
  double relaxation = 0.0;
};

struct SchemeSettings {
  CouplingScheme scheme = CouplingScheme::Serial;
  ImplicitSettings implicit;
  bool implicit_scheme() const { return scheme == CouplingScheme::Implicit; }
  bool parallel_scheme() const { return scheme == CouplingScheme::Parallel; }
  /// What the message checks allow for a state message's iteration: [0, this).
  int iterations_allowed() const { return implicit_scheme() ? implicit.max_iterations : 1; }
};

/// The parallel scheme (protocol/README.md section 14), with N = run.steps and
/// D = max(rigid_steps, 1), the first step whose solid_state_t is dynamic:
/// solid_state_t(m) for 1 <= m < D (the rigid spin-up) answers fluid_state_t(m), as in the
/// serial scheme; solid_state_t(m) for m >= D answers fluid_state_t(m - 1). So the fluid
/// publishes fluid_state_t(m) exactly for the m this returns true for, and the solid awaits
/// them in increasing order (they are consecutive).
inline bool parallel_fluid_state_needed(std::int64_t m, std::int64_t total_steps, std::int64_t rigid_steps) {
  const std::int64_t dynamic_from = rigid_steps > 1 ? rigid_steps : 1;
  return (m >= 1 && m < dynamic_from && m <= total_steps - 1) || (m >= dynamic_from - 1 && m <= total_steps - 2);
}

/// The first fluid_state_t of a parallel run: fluid_state_t(0) when the first dynamic step
/// is 1, else fluid_state_t(1) (as in the serial scheme).
inline std::int64_t parallel_first_fluid_state(std::int64_t rigid_steps) { return rigid_steps > 1 ? 1 : 0; }

}  // namespace cosim::protocol
