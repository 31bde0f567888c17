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
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace cosim::protocol {

enum class CouplingScheme { Serial, Implicit };

inline const char* scheme_name(CouplingScheme s) { return s == CouplingScheme::Implicit ? "implicit" : "serial"; }

/// "serial" or "implicit"; empty for anything else.
inline std::optional<CouplingScheme> scheme_from_name(std::string_view name) {
  if (name == "serial") return CouplingScheme::Serial;
  if (name == "implicit") return CouplingScheme::Implicit;
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
  /// What the message checks allow for a state message's iteration: [0, this).
  int iterations_allowed() const { return implicit_scheme() ? implicit.max_iterations : 1; }
};

}  // namespace cosim::protocol
