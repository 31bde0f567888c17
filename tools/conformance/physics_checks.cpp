// The checks of the solid's physics (tools/conformance/README.md): the impulse against the
// scene's reaction law at the solid's reported motion, and the solid's energy against the
// work of the fluid's reaction on its markers.
#include <cmath>
#include <map>
#include <set>

#include "tools/conformance/check_support.hpp"
#include "tools/conformance/checks.hpp"

namespace cosim::conformance {

using namespace support;

namespace {

Vec pos(const Trace& t, std::int64_t k, std::size_t l) { return col(t.state(k)->position_lb, l); }

/// The interval's mean velocity of marker l at step m from the reported mean positions: the
/// central difference (X(m+1) - X(m-1)) / 2, exact for a constant velocity or acceleration;
/// and a bound of its error, plus 2 |X(m+1) - 2 X(m) + X(m-1)| / A_T (a first-order substep
/// scheme's velocity lags its displacement by dV / A_T) plus round-off:
/// - where the motion is smooth: the largest third difference of X around m, x''' (the
///   central difference errs by x'''/6 for a cubic motion; the factor 6 is the margin the
///   graphene models need, whose markers ring for a few exchanges after a change of u);
/// - where the fluid's input jumps within the stencil (`kink`: the release after the spin-up,
///   a step change of u), a light marker's velocity may jump too: the spread of the one-sided
///   differences X(k) - X(k-1), k = m-1 .. m+2 (they bracket the interval's mean velocity when
///   the velocity is monotonic over the stencil).
struct VelocityEstimate {
  Vec v;
  double error = 0.0;
};

VelocityEstimate velocity(const Trace& t, std::int64_t m, std::size_t l, int a_t, bool kink) {
  const Vec xm = pos(t, m - 1, l), x0 = pos(t, m, l), xp = pos(t, m + 1, l);
  const auto have = [&](std::int64_t k) {
    return k >= 0 && t.state(k) != nullptr && well_formed(*t.state(k), markers(t));
  };
  VelocityEstimate e;
  e.v = 0.5 * (xp - xm);
  const double d2 = (xp - 2.0 * x0 + xm).norm();
  double spread = -1.0;
  if (kink) {
    std::vector<Vec> d;
    for (std::int64_t k = m - 1; k <= m + 2; ++k)
      if (have(k) && have(k - 1)) d.push_back(pos(t, k, l) - pos(t, k - 1, l));
    for (std::size_t i = 0; i < d.size(); ++i)
      for (std::size_t j = i + 1; j < d.size(); ++j) spread = std::max(spread, (d[i] - d[j]).norm());
  } else {
    if (have(m - 2)) spread = (xp - 3.0 * x0 + 3.0 * xm - pos(t, m - 2, l)).norm();
    if (have(m + 2)) spread = std::max(spread, (pos(t, m + 2, l) - 3.0 * xp + 3.0 * x0 - xm).norm());
  }
  if (spread < 0.0) spread = d2;  // too few steps around m: the second difference bounds it
  e.error = spread + 2.0 * d2 / std::max(1, a_t) + kRound * (xp.norm() + xm.norm() + 1.0);
  return e;
}

/// Whether the fluid's input jumps within the stencil of step m: the first free step, or a
/// change of u at an exchange m-1 .. m+2.
bool kink_near(const Trace& t, std::int64_t m) {
  const std::int64_t first_free = std::max<std::int64_t>(t.plan.rigid_steps, 1);
  const Eigen::Index n = Eigen::Index(markers(t));
  for (std::int64_t k = m - 1; k <= m + 2; ++k) {
    if (k == first_free) return true;
    if (k >= 2 && k <= t.plan.last_step && t.plan.flow(k, n) != t.plan.flow(k - 1, n)) return true;
  }
  return false;
}

/// The law's impulses at step m and their bounds, marker by marker.
struct StepFit {
  std::vector<Vec> j, e;  ///< reported and expected
  std::vector<VelocityEstimate> v;
  std::vector<double> bound;
};

StepFit fit_step(const Trace& t, const Context& c, const Eigen::VectorXd& a, std::int64_t m) {
  StepFit f;
  const Eigen::Matrix3Xd u = t.plan.flow(m, Eigen::Index(markers(t)));
  const bool kink = kink_near(t, m);
  for (std::size_t l = 0; l < markers(t); ++l) {
    const double area = a[Eigen::Index(l)];
    const VelocityEstimate v = velocity(t, m, l, c.time_ratio, kink);
    const Vec ul = u.col(Eigen::Index(l));
    const Vec j = col(t.state(m)->impulse_lb, l), e = law_g(c, area, v.v, ul);
    const double slope = std::abs(law_slope(c, area));
    f.j.push_back(j);
    f.e.push_back(e);
    f.v.push_back(v);
    f.bound.push_back(slope * v.error + kRound * (j.norm() + law_g(c, area, Vec::Zero(), ul).norm() + slope * v.v.norm()));
  }
  return f;
}

double residual(const std::vector<Vec>& j, const std::vector<Vec>& e) {
  double r = 0.0;
  for (std::size_t l = 0; l < j.size(); ++l) r += (j[l] - e[l]).norm();
  return r;
}

/// What a failing step's impulses look like: a named factor, one exchange late, positions at
/// the interval's end, frozen positions; else the factor of the best fit.
std::string diagnose_motion(const Trace& t, const Context& c, const Eigen::VectorXd& a, std::int64_t m, const StepFit& f) {
  const std::size_t n = f.j.size();
  const double r0 = residual(f.j, f.e);
  double je = 0.0, ee = 0.0;
  for (std::size_t l = 0; l < n; ++l) {
    je += f.j[l].dot(f.e[l]);
    ee += f.e[l].squaredNorm();
  }
  const double r = ee > 0.0 ? je / ee : 0.0;
  std::vector<Vec> scaled(n);
  for (std::size_t l = 0; l < n; ++l) scaled[l] = r * f.e[l];
  if (residual(f.j, scaled) < 0.1 * r0) return diagnose(r, c.time_ratio);
  // One exchange late: the impulse the law gives for step m - 1 (its u and motion).
  if (m >= 2 && t.state(m - 2) != nullptr) {
    const StepFit before = fit_step(t, c, a, m - 1);
    if (residual(f.j, before.e) < 0.1 * r0)
      return "J_l of exchange " + std::to_string(m) + " is the reaction to fluid_state_t(" + std::to_string(m - 1) +
             "): the impulse is sent one exchange late (answer each fluid_state_t with the impulse of its own interval)";
  }
  // X_l at the end of the interval: the velocity is then X(m) - X(m-1).
  std::vector<Vec> at_end(n);
  const Eigen::Matrix3Xd u = t.plan.flow(m, Eigen::Index(n));
  bool frozen = true;
  for (std::size_t l = 0; l < n; ++l) {
    at_end[l] = law_g(c, a[Eigen::Index(l)], pos(t, m, l) - pos(t, m - 1, l), u.col(Eigen::Index(l)));
    frozen = frozen && pos(t, m - 1, l) == pos(t, m, l) && pos(t, m + 1, l) == pos(t, m, l);
  }
  if (!frozen && residual(f.j, at_end) < 0.1 * r0)
    return "J_l fits the motion if X_l were the position at the interval's end: X_l must be the marker's mean "
           "position over the A_T substeps (e.g. the trapezoid mean of the substep boundaries), not the last one";
  if (frozen)
    return "the reported positions X_l do not move, yet J_l is not the reaction on markers at rest: the positions "
           "are frozen while the impulse follows a motion (report the positions the impulse was computed at)";
  return "J_l does not follow the reaction law at the reported motion (its best fit is " + fmt("%.4g", r) +
         " times the law's impulse)";
}

}  // namespace

Verdict check_impulse_motion(const Trace& t, const Context& c, std::int64_t first, std::int64_t last) {
  const std::string name = "impulse vs motion";
  if (first < 0) first = std::max<std::int64_t>(t.plan.rigid_steps, 1);
  if (last < 0) last = t.plan.last_step - 1;
  if (const std::string why = need_steps(t, first - 1, last + 1); !why.empty()) return fail(name, why);
  const Eigen::VectorXd a = areas(t, c);
  if (a.size() == 0) return fail(name, "the markers' areas are unknown");
  // The largest bound relative to the largest |J_l| of its step, where the input is smooth
  // [0] and near a release or a step change of u [1].
  double worst[2] = {0.0, 0.0};
  std::int64_t worst_step[2] = {-1, -1};
  for (std::int64_t k = first; k <= last; ++k) {
    const StepFit f = fit_step(t, c, a, k);
    const int kink = kink_near(t, k) ? 1 : 0;
    double jmax = 0.0;
    for (const Vec& j : f.j) jmax = std::max(jmax, j.norm());
    std::size_t bad = f.j.size();
    double excess = 1.0;
    for (std::size_t l = 0; l < f.j.size(); ++l) {
      const double d = (f.j[l] - f.e[l]).norm();
      if (d > f.bound[l] && d / std::max(f.bound[l], 1e-300) > excess) {
        excess = d / std::max(f.bound[l], 1e-300);
        bad = l;
      }
      if (jmax > 0.0 && f.bound[l] / jmax > worst[kink]) {
        worst[kink] = f.bound[l] / jmax;
        worst_step[kink] = k;
      }
    }
    if (bad < f.j.size()) {
      const std::size_t l = bad;
      return fail(name, "solid_state_t(" + std::to_string(k) + "), session '" + t.name + "': marker " + std::to_string(l) +
                            ": J = " + vec(f.j[l]) + ", the law gives " + vec(f.e[l]) + " at U_B = " + vec(f.v[l].v) +
                            " (from the reported X_l) and u = " +
                            vec(t.plan.flow(k, Eigen::Index(markers(t))).col(Eigen::Index(l))) + "; |difference| " +
                            fmt("%.3g", (f.j[l] - f.e[l]).norm()) + " > bound " + fmt("%.3g", f.bound[l]) + ": " +
                            diagnose_motion(t, c, a, k, f));
    }
  }
  const auto largest = [&](int i) {
    return worst_step[i] < 0 ? std::string("none") : fmt("%.2g", worst[i]) + " (step " + std::to_string(worst_step[i]) + ")";
  };
  return pass(name, "J_l = g dA of the scene's [reaction] law at the reported motion, steps " + std::to_string(first) +
                        "-" + std::to_string(last) +
                        ", within round-off for markers at rest or at a constant velocity; the largest bound / max |J_l|: " +
                        largest(0) + " where u is steady, " + largest(1) + " near the release or a change of u");
}


namespace {

/// The balance of one free step m of a session: the solid's energy change E(m) - E(m - 1)
/// against W(m) = -sum_l J_l(m) . D_l(m), the work of the reaction -g_l dA_l on the markers
/// (Eqs. 18-19; J_l the substeps' mean of g_l dA_l, Eq. 24), D_l(m) the marker's displacement
/// over the step, U_mean_l(m) x 1 dt_LB: estimated as `velocity` does for impulse vs motion,
/// (X_l(m + 1) - X_l(m - 1)) / 2, with its error bound dV_l. The bound of |dE - W| is
/// sum_l |J_l| dV_l (the displacement's error) plus round-off, 1e-12 (|E(m)| + |E(m - 1)| +
/// sum_l |J_l| |D_l|). Not in it, and measured well inside it for every model
/// (tools/conformance/README.md): the variation of g within the step (-2 rho dA times the
/// integral of |U_B - U_mean|^2, second order) and the solid's own integrator error.
struct StepBalance {
  std::int64_t step = 0;
  double de = 0.0, work = 0.0, bound = 0.0;
  double residual() const { return de - work; }
};

/// What the energy change is, as a multiple k of the kit's work (the least-squares fit of
/// dE = k W over the steps): the usual faults named.
std::string diagnose_energy(const std::vector<StepBalance>& steps) {
  double dw = 0.0, ww = 0.0;
  for (const StepBalance& s : steps) {
    dw += s.de * s.work;
    ww += s.work * s.work;
  }
  const double k = ww > 0.0 ? dw / ww : 0.0;
  const std::string fit = "the solid's energy changes by " + fmt("%.3g", k) + " times the work of the reaction its J_l and X_l give";
  if (std::abs(k - 0.5) < 0.1)
    return fit + ": its markers receive half the reaction it reports (J_l is twice the impulse its own dynamics used)";
  if (std::abs(k - 2.0) < 0.2)
    return fit + ": its markers receive twice the reaction it reports (J_l is half the impulse its own dynamics used)";
  if (std::abs(k + 1.0) < 0.2)
    return fit + ": the reaction on its markers has the wrong sign (they receive +g dA, J_l says -g dA; the solid gains "
                 "what the fluid loses)";
  if (std::abs(k) < 0.1) return fit + ": the energy it reports does not follow its motion (energy_lb not updated?)";
  return fit + ": its energy, its motion and its impulses disagree";
}

}  // namespace

Verdict check_energy_balance(const std::vector<const Trace*>& sessions, const Context& c) {
  const std::string name = "energy balance";
  std::vector<std::string> none;
  double worst = -1.0, de_total = 0.0, w_total = 0.0;
  std::string worst_at, totals;
  for (const Trace* tp : sessions) {
    const Trace& t = *tp;
    if (!t.energies.reported()) {
      none.push_back("session '" + t.name + "': " + t.energies.none);
      continue;
    }
    const std::int64_t first = std::max<std::int64_t>(t.plan.rigid_steps, 1), last = t.plan.last_step - 1;
    if (const std::string why = need_steps(t, first - 1, last + 1); !why.empty()) return fail(name, why);
    if (!(c.energy_unit_J > 0.0)) return fail(name, "the scene's energy unit is unknown");
    std::map<std::int64_t, double> e;
    for (std::size_t i = 0; i < t.energies.step.size(); ++i) e[t.energies.step[i]] = t.energies.total_J[i] / c.energy_unit_J;
    for (std::int64_t k = first - 1; k <= last; ++k) {
      if (!e.count(k))
        return fail(name, "the solid's solid.h5 of session '" + t.name + "' has total_energy_J but no row of step " +
                              std::to_string(k));
      if (!std::isfinite(e[k]))
        return fail(name, "the solid's total_energy_J of step " + std::to_string(k) + ", session '" + t.name + "', is " +
                              fmt("%g", e[k]));
    }
    std::vector<StepBalance> steps;
    for (std::int64_t m = first; m <= last; ++m) {
      const bool kink = kink_near(t, m);
      StepBalance s;
      s.step = m;
      s.de = e[m] - e[m - 1];
      double scale = 0.0;
      for (std::size_t l = 0; l < markers(t); ++l) {
        const VelocityEstimate v = velocity(t, m, l, c.time_ratio, kink);
        const Vec j = col(t.state(m)->impulse_lb, l);
        s.work -= j.dot(v.v);
        s.bound += j.norm() * v.error;
        scale += j.norm() * v.v.norm();
      }
      s.bound += kRound * (std::abs(e[m]) + std::abs(e[m - 1]) + scale);
      steps.push_back(s);
    }
    for (const StepBalance& s : steps) {
      const double ratio = std::abs(s.residual()) / std::max(s.bound, 1e-300);
      if (ratio > 1.0)
        return fail(name, "step " + std::to_string(s.step) + ", session '" + t.name + "': the solid's energy changed by " +
                              fmt("%.4g", s.de) + " rho_air dx^3 c^2 (solid.h5's total_energy_J), the fluid's reaction did work " +
                              fmt("%.4g", s.work) + " on its markers (-sum_l J_l . D_l, D_l from the reported X_l); |difference| " +
                              fmt("%.3g", std::abs(s.residual())) + " > bound " + fmt("%.3g", s.bound) + ": " +
                              diagnose_energy(steps));
      if (ratio > worst) {
        worst = ratio;
        worst_at = "step " + std::to_string(s.step) + ", session '" + t.name + "'";
      }
      de_total += s.de;
      w_total += s.work;
    }
    totals += (totals.empty() ? "" : ", ") + t.name + " steps " + std::to_string(first) + "-" + std::to_string(last);
  }
  std::string missing;
  for (const std::string& x : none) missing += (missing.empty() ? "" : "; ") + x;
  if (totals.empty())
    return pass(name, "not applicable: the solid reports no energy (" + (none.empty() ? std::string("no session") : none.front()) +
                          "); checked where the solid writes solid.h5 with total_energy_J into its --output folder "
                          "(Solid::energy_lb, the solid server)");
  return pass(name, "the solid's energy change is the work of the fluid's reaction on its markers at every free step (" +
                        totals + "): sum dE = " + fmt("%.4g", de_total) + ", sum W = " + fmt("%.4g", w_total) +
                        " rho_air dx^3 c^2; the largest |dE - W| / bound " + fmt("%.2g", worst) + " (" + worst_at + ")" +
                        (missing.empty() ? "" : "; " + missing));
}

}  // namespace cosim::conformance
