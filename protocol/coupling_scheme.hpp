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
  /// What the message checks allow for a state message's iteration: [0, this) (defined
  /// below, from the scheme's row of the name table).
  int iterations_allowed() const;
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

/// The message order of a scheme (protocol/README.md sections 5, 13, 14): the facts of it
/// that the coordinator, the replay and both sides' schemes read, one row per scheme in the
/// one name table below, so that no code outside the schemes/ folders asks which scheme runs.
struct MessageOrder {
  const char* name;  ///< [coupling] scheme, hello_t.scheme
  CouplingScheme scheme;
  /// Several state messages per LB step (iterates): both sides order them by the peer's seq,
  /// and reports name a message by its step and iteration. Such a scheme sub-iterates: the
  /// [coupling] keys max_iterations, tolerance and relaxation (ImplicitSettings) are its.
  bool several_per_step;
  /// Every [reaction] law runs under it; false: momentum_exchange only (the implicit
  /// scheme's backward-Euler drag is that law's, protocol/config/reaction_section.hpp).
  bool any_reaction_law;
  /// The step of the first fluid_state_t the solid awaits, with `rigid_steps`.
  std::int64_t (*first_fluid_step)(std::int64_t rigid_steps);
  /// The last step of any state message of a run of N = `total_steps` LB steps: N - 1, or N
  /// where solid_state_t(N, 0) accepts the last step.
  std::int64_t (*final_step)(std::int64_t total_steps);
  /// Whether the fluid publishes fluid_state_t(m) after stepping to m (a scheme with one
  /// message a step), of a run of `total_steps` with `rigid_steps`.
  bool (*fluid_publishes)(std::int64_t m, std::int64_t total_steps, std::int64_t rigid_steps);

  /// The key of the first fluid_state_t the solid awaits: its step, or seq 0 (several a step).
  std::int64_t first_fluid_key(std::int64_t rigid_steps) const {
    return several_per_step ? 0 : first_fluid_step(rigid_steps);
  }
};

/// The name table: one row per scheme, in the order of the enum.
inline constexpr MessageOrder kMessageOrders[] = {
    {"serial", CouplingScheme::Serial, false, true, [](std::int64_t) -> std::int64_t { return 1; },
     [](std::int64_t n) { return n - 1; }, [](std::int64_t m, std::int64_t n, std::int64_t) { return m >= 1 && m < n; }},
    {"implicit", CouplingScheme::Implicit, true, false, [](std::int64_t) -> std::int64_t { return 1; },
     [](std::int64_t n) { return n; }, [](std::int64_t m, std::int64_t n, std::int64_t) { return m >= 1 && m <= n; }},
    {"parallel", CouplingScheme::Parallel, false, true, &parallel_first_fluid_state,
     [](std::int64_t n) { return n - 1; },
     &parallel_fluid_state_needed},
};

/// The row of `scheme` in the name table.
inline const MessageOrder& message_order(CouplingScheme scheme) {
  for (const MessageOrder& o : kMessageOrders)
    if (o.scheme == scheme) return o;
  return kMessageOrders[0];  // unreachable: every enumerator has its row
}

inline const char* scheme_name(CouplingScheme s) { return message_order(s).name; }

inline int SchemeSettings::iterations_allowed() const {
  return message_order(scheme).several_per_step ? implicit.max_iterations : 1;
}

/// "serial", "implicit" or "parallel" (the table's names); empty for anything else.
inline std::optional<CouplingScheme> scheme_from_name(std::string_view name) {
  for (const MessageOrder& o : kMessageOrders)
    if (name == o.name) return o.scheme;
  return std::nullopt;
}

}  // namespace cosim::protocol
