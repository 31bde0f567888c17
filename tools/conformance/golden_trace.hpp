// Golden traces (as LAMMPS keeps one reference file per style): the main session's
// solid_state_t of a solid, one CSV row per step and marker (step, marker, X_l, J_l with 17
// digits), and the comparison of a new session with it. Tolerance t: every position within
// t (1 + |X|) dx, every impulse within t times the largest impulse of the golden trace.
#pragma once

#include <string>

#include "tools/conformance/checks.hpp"
#include "tools/conformance/session.hpp"

namespace cosim::conformance {

/// @throws std::runtime_error naming the file if it cannot be written.
void write_golden_trace(const std::string& path, const Trace& main);
/// The verdict "golden trace": the first row outside the tolerance, a missing file or a
/// differing shape named.
Verdict check_golden_trace(const std::string& path, const Trace& main, double tolerance);

}  // namespace cosim::conformance
