// The conformance checks' shared helpers (tools/conformance/checks.cpp, physics_checks.cpp):
// verdicts, marker vectors, the steps a check needs, the usual faults of an impulse, the
// markers' areas.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/text/text.hpp"
#include "solid/coupling/reaction_law.hpp"
#include "tools/conformance/checks.hpp"

namespace cosim::conformance::support {

using protocol::fmt;
using Vec = Eigen::Vector3d;

inline Verdict pass(const std::string& check, const std::string& why) { return {check, true, why}; }
inline Verdict fail(const std::string& check, const std::string& why) { return {check, false, why}; }

inline Vec col(const std::vector<std::vector<double>>& a, std::size_t l) { return {a[l][0], a[l][1], a[l][2]}; }

inline std::string vec(const Vec& v) { return fmt("(%.4g, ", v[0]) + fmt("%.4g, ", v[1]) + fmt("%.4g)", v[2]); }

/// Positions and impulses of a copy hold 3 numbers per marker for `n` markers.
inline bool well_formed(const cosimlcm::solid_state_t& m, std::size_t n) {
  if (m.position_lb.size() != n || m.impulse_lb.size() != n) return false;
  for (std::size_t l = 0; l < n; ++l)
    if (m.position_lb[l].size() != 3 || m.impulse_lb[l].size() != 3) return false;
  return true;
}

inline std::size_t markers(const Trace& t) { return t.hello ? static_cast<std::size_t>(std::max(0, t.hello->num_cgps)) : 0; }

/// The first copies of steps a..b, all present and well formed; else a reason.
inline std::string need_steps(const Trace& t, std::int64_t a, std::int64_t b) {
  for (std::int64_t k = a; k <= b; ++k) {
    const cosimlcm::solid_state_t* m = t.state(k);
    if (m == nullptr)
      return "session '" + t.name + "' has no solid_state_t(" + std::to_string(k) + ")" +
             (t.problem.empty() ? "" : ": " + t.problem);
    if (!well_formed(*m, markers(t)))
      return "solid_state_t(" + std::to_string(k) + ") of session '" + t.name + "' does not hold " +
             std::to_string(markers(t)) + " markers x 3 (hello_t.num_cgps)";
  }
  return "";
}

/// Names a ratio r of the solid's impulse to the expected one: the usual faults.
inline std::string diagnose(double r, int time_ratio) {
  const double a_t = time_ratio;
  if (std::abs(r + 1.0) < 0.05) return "the sign is reversed (J_l is the impulse the fluid receives, 2 rho (U_B - u) dA; the marker gets its opposite)";
  if (std::abs(r - a_t) < 0.05 * a_t && time_ratio > 1)
    return "J_l is A_T = " + std::to_string(time_ratio) + " times too large: the substeps' impulses are summed, not averaged over the A_T substeps (Eq. 24)";
  if (std::abs(r + a_t) < 0.05 * a_t && time_ratio > 1)
    return "J_l is -A_T times the expected impulse: the sign is reversed and the A_T average missing (Eq. 24)";
  if (std::abs(r - 1.0 / a_t) < 0.05 / a_t && time_ratio > 1)
    return "J_l is 1/A_T of the expected impulse: divided by A_T once too often (Eq. 24)";
  if (std::abs(r - 2.0) < 0.05) return "J_l is twice the expected impulse (a factor 2 too many)";
  if (std::abs(r - 0.5) < 0.025) return "J_l is half the expected impulse (a factor 1/2 too few)";
  return "J_l is " + fmt("%.4g", r) + " times the expected impulse";
}

/// dA_l: the scene's when the counts agree, else inferred from the first spin-up step
/// (J = -2 rho u dA); empty if neither.
inline Eigen::VectorXd areas(const Trace& t, const Context& c) {
  const std::size_t n = markers(t);
  if (static_cast<std::size_t>(c.area_lb.size()) == n) return c.area_lb;
  const cosimlcm::solid_state_t* m = t.state(1);
  if (m == nullptr || !well_formed(*m, n) || t.plan.rigid_steps < 2) return {};
  const Vec u = t.plan.flow(1, 1).col(0);
  Eigen::VectorXd a(static_cast<Eigen::Index>(n));
  for (std::size_t l = 0; l < n; ++l) a[Eigen::Index(l)] = -col(m->impulse_lb, l).dot(u) / (2.0 * u.squaredNorm());
  return a;
}

inline constexpr double kRound = 1e-12;  ///< relative round-off allowed (sums of A_T terms, differences of positions)

/// g dA of the scene's law for one marker (solid/coupling/reaction_law.hpp), rho = 1 (the mock fluid's).
inline Vec law_g(const Context& c, double area, const Vec& ub, const Vec& u) {
  Vec g;
  for (int i = 0; i < 3; ++i) g[i] = solid::reaction_g_da(c.law, 2.0 * area, ub[i], u[i], c.time_ratio);
  return g;
}

/// d(g dA)/dU_B of the law (linear in U_B: the mean of g over the substeps is g at the mean U_B).
inline double law_slope(const Context& c, double area) {
  return solid::reaction_g_da(c.law, 2.0 * area, 1.0, 0.0, c.time_ratio) -
         solid::reaction_g_da(c.law, 2.0 * area, 0.0, 0.0, c.time_ratio);
}

}  // namespace cosim::conformance::support
