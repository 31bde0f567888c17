#include "tools/conformance/checks.hpp"

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/text/text.hpp"
#include "solid/coupling/reaction_law.hpp"

namespace cosim::conformance {

namespace {

using protocol::fmt;
using Vec = Eigen::Vector3d;

Verdict pass(const std::string& check, const std::string& why) { return {check, true, why}; }
Verdict fail(const std::string& check, const std::string& why) { return {check, false, why}; }

Vec col(const std::vector<std::vector<double>>& a, std::size_t l) { return {a[l][0], a[l][1], a[l][2]}; }

std::string vec(const Vec& v) { return fmt("(%.4g, ", v[0]) + fmt("%.4g, ", v[1]) + fmt("%.4g)", v[2]); }

/// Positions and impulses of a copy hold 3 numbers per marker for `n` markers.
bool well_formed(const cosimlcm::solid_state_t& m, std::size_t n) {
  if (m.position_lb.size() != n || m.impulse_lb.size() != n) return false;
  for (std::size_t l = 0; l < n; ++l)
    if (m.position_lb[l].size() != 3 || m.impulse_lb[l].size() != 3) return false;
  return true;
}

std::size_t markers(const Trace& t) { return t.hello ? static_cast<std::size_t>(std::max(0, t.hello->num_cgps)) : 0; }

/// The first copies of steps a..b, all present and well formed; else a reason.
std::string need_steps(const Trace& t, std::int64_t a, std::int64_t b) {
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
std::string diagnose(double r, int time_ratio) {
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
Eigen::VectorXd areas(const Trace& t, const Context& c) {
  const std::size_t n = markers(t);
  if (static_cast<std::size_t>(c.area_lb.size()) == n) return c.area_lb;
  const cosimlcm::solid_state_t* m = t.state(1);
  if (m == nullptr || !well_formed(*m, n) || t.plan.rigid_steps < 2) return {};
  const Vec u = t.plan.flow(1, 1).col(0);
  Eigen::VectorXd a(static_cast<Eigen::Index>(n));
  for (std::size_t l = 0; l < n; ++l) a[Eigen::Index(l)] = -col(m->impulse_lb, l).dot(u) / (2.0 * u.squaredNorm());
  return a;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// The first difference between two copies (token aside), or "".
std::string difference(const cosimlcm::solid_state_t& a, const cosimlcm::solid_state_t& b) {
  if (a.seq != b.seq) return "seq " + std::to_string(a.seq) + " vs " + std::to_string(b.seq);
  if (a.step != b.step || a.iteration != b.iteration) return "step or iteration";
  if (a.substeps != b.substeps) return "substeps " + std::to_string(a.substeps) + " vs " + std::to_string(b.substeps);
  if (!same_bits(a.solid_time_s, b.solid_time_s)) return "solid_time_s " + fmt("%.17g", a.solid_time_s) + " vs " + fmt("%.17g", b.solid_time_s);
  if (a.num_cgps != b.num_cgps || a.position_lb.size() != b.position_lb.size() || a.impulse_lb.size() != b.impulse_lb.size())
    return "num_cgps";
  for (std::size_t l = 0; l < a.position_lb.size(); ++l)
    for (std::size_t k = 0; k < 3 && k < a.position_lb[l].size(); ++k) {
      if (!same_bits(a.position_lb[l][k], b.position_lb[l][k]))
        return "marker " + std::to_string(l) + " position_lb[" + std::to_string(k) + "] " + fmt("%.17g", a.position_lb[l][k]) +
               " vs " + fmt("%.17g", b.position_lb[l][k]);
      if (!same_bits(a.impulse_lb[l][k], b.impulse_lb[l][k]))
        return "marker " + std::to_string(l) + " impulse_lb[" + std::to_string(k) + "] " + fmt("%.17g", a.impulse_lb[l][k]) +
               " vs " + fmt("%.17g", b.impulse_lb[l][k]);
    }
  return "";
}

Eigen::Matrix3Xd uniform(Eigen::Index n, const Vec& u) { return u.replicate(1, n); }

/// u of the main session: a stream with a step change at exchange 6 (the impulse of exchange
/// k must answer the u of exchange k: causality), smooth before and after it.
Vec main_u(std::int64_t step) { return step >= 6 ? Vec(0.03, 0.005, -0.01) : Vec(0.05, 0.0, 0.01); }

/// u of the long session: main's until kResponseStep, then changes of about 0.01 every 20 steps.
Vec long_u(std::int64_t step) {
  if (step < kResponseStep) return main_u(step);
  return main_u(step) + ((step - kResponseStep) / 20 % 2 == 0 ? Vec(0.01, 0.0, 0.0) : Vec(-0.01, 0.004, -0.005));
}

}  // namespace

Plan main_plan() {
  Plan p;
  p.name = "main";
  p.total_steps = 12;
  p.rigid_steps = 4;
  p.last_step = 11;
  p.ending = Ending::Success;
  p.flow = [](std::int64_t step, Eigen::Index n) { return uniform(n, main_u(step)); };
  p.duplicate_at = 5;
  p.resend_at = 6;
  return p;
}

Plan repeat_plan() {
  Plan p = main_plan();
  p.name = "repeat";
  p.last_step = 7;
  p.ending = Ending::ErrorStop;
  p.duplicate_at = p.resend_at = -1;
  return p;
}

Plan still_plan() {
  Plan p;
  p.name = "still";
  p.total_steps = 20;
  p.rigid_steps = 0;
  p.last_step = 14;
  p.ending = Ending::Silence;
  p.flow = [](std::int64_t step, Eigen::Index n) { return uniform(n, step <= 3 ? Vec(0.05, 0.0, 0.02) : Vec::Zero()); };
  return p;
}

Plan long_plan() {
  Plan p = main_plan();
  p.name = "long";
  p.total_steps = 240;
  p.last_step = 239;
  p.flow = [](std::int64_t step, Eigen::Index n) { return uniform(n, long_u(step)); };
  p.duplicate_at = 230;
  p.resend_at = 235;
  return p;
}

Plan restart_plan(const std::string& checkpoint_file) {
  Plan p = main_plan();
  p.name = "restart";
  p.duplicate_at = p.resend_at = -1;
  p.restart_at = repeat_plan().last_step;
  p.restart_file = checkpoint_file;
  return p;
}

Verdict check_handshake_fields(const Trace& t) {
  const std::string name = "handshake fields";
  if (!t.hello) return fail(name, t.problem.empty() ? "no hello_t" : t.problem);
  if (!t.handshake.accepted) return fail(name, "the coordinator's checks refuse the hello_t: " + t.handshake.reason);
  if (t.hello->model.empty()) return fail(name, "hello_t.model is empty; allowed: the model's name");
  return pass(name, "hello_t accepted (model '" + t.hello->model + "', " + std::to_string(t.hello->num_cgps) +
                        " markers, A_T = " + std::to_string(t.handshake.time_ratio) + ", protocol " + t.hello->version + ")");
}

Verdict check_initial_state(const Trace& t) {
  const std::string name = "initial state";
  if (const std::string why = need_steps(t, 0, 0); !why.empty()) return fail(name, why);
  const cosimlcm::solid_state_t& m = *t.state(0);
  if (m.seq != 0) return fail(name, "solid_state_t(0).seq = " + std::to_string(m.seq) + ", expected 0 (the first of the channel)");
  if (m.substeps != 0 || m.solid_time_s != 0.0)
    return fail(name, "solid_state_t(0): substeps = " + std::to_string(m.substeps) + ", solid_time_s = " + fmt("%g", m.solid_time_s) + "; expected 0 and 0");
  for (std::size_t l = 0; l < m.impulse_lb.size(); ++l)
    if (col(m.impulse_lb, l) != Vec::Zero())
      return fail(name, "solid_state_t(0): marker " + std::to_string(l) + " impulse " + vec(col(m.impulse_lb, l)) + "; expected 0 (the initial positions only)");
  return pass(name, "solid_state_t(0): the initial positions, zero impulses, seq 0");
}

Verdict check_finite(const std::vector<const Trace*>& traces) {
  const std::string name = "finite values";
  std::size_t copies = 0;
  for (const Trace* t : traces)
    for (const cosimlcm::solid_state_t& m : t->states) {
      ++copies;
      for (std::size_t l = 0; l < m.position_lb.size() && l < m.impulse_lb.size(); ++l)
        for (std::size_t k = 0; k < 3 && k < m.position_lb[l].size() && k < m.impulse_lb[l].size(); ++k) {
          const double x = m.position_lb[l][k], j = m.impulse_lb[l][k];
          if (!std::isfinite(x) || !std::isfinite(j))
            return fail(name, "solid_state_t(" + std::to_string(m.step) + ") of session '" + t->name + "': marker " +
                                  std::to_string(l) + " " + (std::isfinite(x) ? "impulse_lb" : "position_lb") + "[" +
                                  std::to_string(k) + "] = " + fmt("%g", std::isfinite(x) ? j : x) +
                                  ": a NaN or an infinity reaches the fluid (end with exit code 3 instead)");
        }
      if (!std::isfinite(m.solid_time_s)) return fail(name, "solid_time_s = " + fmt("%g", m.solid_time_s));
    }
  if (copies == 0) return fail(name, "no solid_state_t received");
  return pass(name, "every position and impulse of " + std::to_string(copies) + " solid_state_t is finite");
}

Verdict check_substeps(const Trace& t, const Context& c) {
  const std::string name = "substep count";
  if (const std::string why = need_steps(t, 0, t.plan.last_step); !why.empty()) return fail(name, why);
  std::int64_t total = 0;
  for (std::int64_t k = 1; k <= t.plan.last_step; ++k) {
    const cosimlcm::solid_state_t& m = *t.state(k);
    const int expected = k < t.plan.rigid_steps ? 0 : c.time_ratio;
    if (m.substeps != expected)
      return fail(name, "solid_state_t(" + std::to_string(k) + ").substeps = " + std::to_string(m.substeps) +
                            ", expected " + std::to_string(expected) +
                            (k < t.plan.rigid_steps ? " (a spin-up step: the markers held, no substeps)"
                                                    : " = A_T ([coupling] time_ratio): every LB step takes A_T substeps"));
    total += expected;
    const double want = double(total) * c.dt_cg_s;
    if (std::abs(m.solid_time_s - want) > 1e-9 * std::max(want, c.dt_cg_s))
      return fail(name, "solid_state_t(" + std::to_string(k) + ").solid_time_s = " + fmt("%.17g", m.solid_time_s) +
                            " s, expected " + fmt("%.17g", want) + " s (the substeps so far times dt_CG)");
  }
  return pass(name, "0 substeps in the spin-up, A_T = " + std::to_string(c.time_ratio) +
                        " after it; solid_time_s = substeps x dt_CG within 1e-9");
}

Verdict check_spin_up_impulse(const Trace& t, const Context& c) {
  const std::string name = "spin-up impulse";
  const std::int64_t last = t.plan.rigid_steps - 1;
  if (const std::string why = need_steps(t, 0, last); !why.empty()) return fail(name, why);
  const Eigen::VectorXd a = areas(t, c);
  const bool inferred = a.size() != c.area_lb.size() || c.area_lb.size() == 0;
  const cosimlcm::solid_state_t& start = *t.state(0);
  for (std::int64_t k = 1; k <= last; ++k) {
    const cosimlcm::solid_state_t& m = *t.state(k);
    const Eigen::Matrix3Xd u = t.plan.flow(k, Eigen::Index(markers(t)));
    for (std::size_t l = 0; l < markers(t); ++l) {
      if (col(m.position_lb, l) != col(start.position_lb, l))
        return fail(name, "solid_state_t(" + std::to_string(k) + "): marker " + std::to_string(l) + " moved from " +
                              vec(col(start.position_lb, l)) + " to " + vec(col(m.position_lb, l)) +
                              " in the spin-up (welcome_t.rigid_steps: the markers are held)");
      const double area = a.size() > 0 ? a[Eigen::Index(l)] : 0.0;
      if (inferred && !(area > 0.0))
        return fail(name, "marker " + std::to_string(l) + ": J_1 = " + vec(col(m.impulse_lb, l)) + " in the stream u = " +
                              vec(u.col(Eigen::Index(l))) + ": " + diagnose(-1.0, c.time_ratio));
      const Vec e = -2.0 * 1.0 * area * u.col(Eigen::Index(l));
      const Vec j = col(m.impulse_lb, l);
      if ((j - e).norm() > 1e-9 * e.norm() + 1e-300) {
        const double r = j.dot(e) / e.squaredNorm();
        return fail(name, "solid_state_t(" + std::to_string(k) + "): marker " + std::to_string(l) + ": J = " + vec(j) +
                              ", expected -2 rho u dA = " + vec(e) + ": " + diagnose(r, c.time_ratio));
      }
    }
  }
  return pass(name, "J_l = -2 rho u dA_l within 1e-9 relative at every marker, steps 1-" + std::to_string(last) +
                        (inferred ? " (dA_l inferred from step 1: the solid's markers are not the scene's)" : " (dA_l of the scene)"));
}

namespace {

constexpr double kRound = 1e-12;  ///< relative round-off allowed (sums of A_T terms, differences of positions)

Vec pos(const Trace& t, std::int64_t k, std::size_t l) { return col(t.state(k)->position_lb, l); }

/// g dA of the scene's law for one marker (solid/coupling/reaction_law.hpp), rho = 1 (the mock fluid's).
Vec law_g(const Context& c, double area, const Vec& ub, const Vec& u) {
  Vec g;
  for (int i = 0; i < 3; ++i) g[i] = solid::reaction_g_da(c.law, 2.0 * area, ub[i], u[i], c.time_ratio);
  return g;
}

/// d(g dA)/dU_B of the law (linear in U_B: the mean of g over the substeps is g at the mean U_B).
double law_slope(const Context& c, double area) {
  return solid::reaction_g_da(c.law, 2.0 * area, 1.0, 0.0, c.time_ratio) -
         solid::reaction_g_da(c.law, 2.0 * area, 0.0, 0.0, c.time_ratio);
}

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

Verdict check_lattice_units(const Trace& t, const Context& c) {
  const std::string name = "lattice units";
  if (const std::string why = need_steps(t, 0, 0); !why.empty()) return fail(name, why);
  const std::size_t n = markers(t);
  if (static_cast<std::size_t>(c.position_lb.cols()) != n)
    return pass(name, "the solid's own " + std::to_string(n) + " markers (the scene's sheets have " +
                          std::to_string(c.position_lb.cols()) + "): not compared with the scene's layout");
  const cosimlcm::solid_state_t& m = *t.state(0);
  std::size_t worst = 0;
  double dev = 0.0, xs = 0.0, ss = 0.0;
  for (std::size_t l = 0; l < n; ++l) {
    const Vec x = col(m.position_lb, l), want = c.position_lb.col(Eigen::Index(l));
    const double d = (x - want).norm() / (1.0 + want.norm());
    if (d > dev) {
      dev = d;
      worst = l;
    }
    xs += x.dot(want);
    ss += want.squaredNorm();
  }
  if (dev <= 1e-9) return pass(name, "X_l(0) are the scene's [[sheet]] markers in dx within 1e-9 (1 + |X|)");
  const double ratio = ss > 0.0 ? xs / ss : 0.0;
  std::string why =
      "X_l(0) are not the scene's [[sheet]] layout in lattice units (dx, the fluid's frame: protocol/README.md sections 4, 4a)";
  for (const auto& [unit, factor] : {std::pair<const char*, double>{"um", c.dx_m * 1e6}, {"m", c.dx_m}, {"nm", c.dx_m * 1e9}})
    if (factor > 0.0 && std::abs(ratio / factor - 1.0) < 1e-3)
      why = std::string("the positions are in ") + unit + ", not in lattice units dx (1 dx = " + fmt("%g", factor) + " " +
            unit + ")";
  const Vec x = col(m.position_lb, worst), want = c.position_lb.col(Eigen::Index(worst));
  return fail(name, "solid_state_t(0): marker " + std::to_string(worst) + " at " + vec(x) + ", the scene's sheet puts it at " +
                        vec(want) + " dx: " + why);
}

Verdict check_response(const Trace& main, const Trace& lr, const Context& c) {
  const std::string name = "response to the fluid";
  const std::int64_t k = kResponseStep;
  if (const std::string why = need_steps(main, 0, k); !why.empty()) return fail(name, why);
  if (const std::string why = need_steps(lr, 0, k); !why.empty()) return fail(name, why);
  for (std::int64_t s = 0; s < k; ++s)
    if (const std::string d = difference(*main.state(s), *lr.state(s)); !d.empty())
      return fail(name, "sessions 'main' and 'long' have the same inputs up to step " + std::to_string(k - 1) +
                            " but solid_state_t(" + std::to_string(s) + ") differs: " + d);
  const Eigen::VectorXd a = areas(main, c);
  if (a.size() == 0) return fail(name, "the markers' areas are unknown");
  const Eigen::Index n = Eigen::Index(markers(main));
  const Eigen::Matrix3Xd du = lr.plan.flow(k, n) - main.plan.flow(k, n);
  // J = law(U, u) is linear: dJ = slope dU + law(0, du). P = sum 2 rho dA du . dU is the
  // work of the change of the stream on the change of the markers' motion, which starts from
  // the same state: >= 0 for a passive solid (>= sum 2 rho dA |dU|^2 even), < 0 when the
  // solid takes the reaction with the wrong sign.
  double p = 0.0, tol = 0.0;
  for (Eigen::Index l = 0; l < n; ++l) {
    const double slope = law_slope(c, a[l]);
    if (slope == 0.0) return pass(name, "the scene's [reaction] law does not involve U_B: the motion cannot show in J_l");
    const Vec jm = col(main.state(k)->impulse_lb, std::size_t(l)), jl = col(lr.state(k)->impulse_lb, std::size_t(l));
    const Vec dU = (jl - jm - law_g(c, a[l], Vec::Zero(), du.col(l))) / slope;
    p += 2.0 * a[l] * du.col(l).dot(dU);
    tol += kRound * du.col(l).norm() * (jm.norm() + jl.norm() + 2.0 * a[l] * du.col(l).norm()) * 2.0 * a[l] / std::abs(slope);
  }
  const std::string what = "the stream changed by du = " + vec(du.col(0)) + " at exchange " + std::to_string(k) +
                           " (session 'long' against 'main'): sum 2 rho dA du . dU = " + fmt("%.4g", p) +
                           " (dU: the change of the markers' mean velocity, from the impulses)";
  if (p < -tol)
    return fail(name, what + " < 0: the markers move against the change of the fluid's velocity: the reaction on the "
                             "solid has the wrong sign (the marker receives -g dA = -2 rho (U_B - u) dA; J_l, the "
                             "fluid's, is +g dA), unless J_l itself is off (then 'impulse vs motion' fails too)");
  if (p <= tol) return pass(name, what + ": the markers do not respond to the fluid within the step (held or prescribed)");
  return pass(name, what + " > 0: the markers follow the fluid");
}

Verdict check_resend(const Trace& t) {
  const std::string name = "resend";
  const std::int64_t k = t.plan.resend_at;
  if (const std::string why = need_steps(t, k, k + 1); !why.empty()) return fail(name, why);
  if (t.resend_answers.empty())
    return fail(name, "no answer to resend_t(\"solid_state\", " + std::to_string(k) +
                          ") within 2 s: keep the last two solid_state_t and publish the asked one again, unchanged");
  for (const cosimlcm::solid_state_t& r : t.resend_answers)
    if (const std::string d = difference(*t.state(k), r); !d.empty())
      return fail(name, "the answer to resend_t(\"solid_state\", " + std::to_string(k) + ") differs from the first copy: " + d +
                            " (publish the kept message unchanged, its seq too)");
  return pass(name, "resend_t(\"solid_state\", " + std::to_string(k) + ") answered bit for bit (seq " +
                        std::to_string(t.state(k)->seq) + ")");
}

Verdict check_duplicates(const Trace& t) {
  const std::string name = "duplicates ignored";
  if (const std::string why = need_steps(t, 0, t.plan.last_step); !why.empty()) return fail(name, why);
  std::map<std::int64_t, std::set<std::int64_t>> seqs;
  for (const cosimlcm::solid_state_t& m : t.states) seqs[m.step].insert(m.seq);
  for (const auto& [step, s] : seqs)
    if (s.size() > 1)
      return fail(name, "solid_state_t(" + std::to_string(step) + ") came with " + std::to_string(s.size()) +
                            " different seqs (" + std::to_string(*s.begin()) + ", " + std::to_string(*s.rbegin()) +
                            ")" + (step == t.plan.duplicate_at ? ": the duplicate fluid_state_t(" + std::to_string(step) +
                                                                     ") (same seq) was stepped again; drop a copy whose seq was had"
                                                               : ""));
  for (std::int64_t k = 0; k <= t.plan.last_step; ++k)
    if (t.state(k)->seq != k)
      return fail(name, "solid_state_t(" + std::to_string(k) + ").seq = " + std::to_string(t.state(k)->seq) + ", expected " +
                            std::to_string(k) + " (consecutive from 0 on the channel)");
  return pass(name, "a duplicate fluid_state_t(" + std::to_string(t.plan.duplicate_at) +
                        ") was dropped; one seq per step, consecutive");
}

Verdict check_success_stop(const Trace& t) {
  const std::string name = "stop (success)";
  if (!t.problem.empty()) return fail(name, "session '" + t.name + "' did not reach its end: " + t.problem);
  if (!t.exit_code) return fail(name, "still running 5 s after the fluid's stop_t(exit_code 0) at the run's end (then killed)");
  if (*t.exit_code != 0)
    return fail(name, "exit code " + std::to_string(*t.exit_code) + " after the fluid's stop_t(exit_code 0), expected 0: \"" +
                          t.last_line + "\"");
  return pass(name, "exit code 0, " + fmt("%.2f", t.exit_after_s) + " s after the fluid's stop_t(0)");
}

Verdict check_error_stop(const Trace& t) {
  const std::string name = "stop (error)";
  if (!t.problem.empty()) return fail(name, "session 'repeat' did not reach its end: " + t.problem);
  if (!t.exit_code) return fail(name, "still running 5 s after the fluid's stop_t(exit_code 3) (then killed)");
  if (*t.exit_code != 4)
    return fail(name, "exit code " + std::to_string(*t.exit_code) + " after the fluid's stop_t(exit_code 3), expected 4 (the peer stopped with an error)");
  return pass(name, "exit code 4, " + fmt("%.2f", t.exit_after_s) + " s after the fluid's stop_t(3)");
}

Verdict check_timeout(const Trace& t, const Context& c) {
  const std::string name = "timeouts";
  if (!t.problem.empty()) return fail(name, "session 'still' did not reach its end: " + t.problem);
  const std::int64_t missing = t.plan.last_step + 1;
  bool asked = false;
  for (const cosimlcm::resend_t& r : t.resends) asked = asked || r.step == missing;
  if (!asked) return fail(name, "no resend_t(\"fluid_state\", " + std::to_string(missing) + ") while the fluid was silent (ask after resend_after_s)");
  if (!t.exit_code)
    return fail(name, "still running " + fmt("%g", c.peer_timeout_s + 5.0) + " s into the fluid's silence (peer_timeout_s = " +
                          fmt("%g", c.peer_timeout_s) + "; then killed)");
  if (*t.exit_code != 4) return fail(name, "exit code " + std::to_string(*t.exit_code) + " on the fluid's silence, expected 4");
  bool stopped = false;
  for (const cosimlcm::stop_t& s : t.stops) stopped = stopped || s.exit_code == 4;
  if (!stopped) return fail(name, "exit code 4 on the fluid's silence but no stop_t(exit_code 4) to the fluid");
  return pass(name, "resend_t for the missing fluid_state_t, then stop_t(4) and exit code 4 after " +
                        fmt("%.1f", t.exit_after_s) + " s of silence (peer_timeout_s = " + fmt("%g", c.peer_timeout_s) + ")");
}

Verdict check_bit_identical(const Trace& a, const Trace& b) {
  const std::string name = "two runs bit-identical";
  const std::int64_t last = std::min(a.plan.last_step, b.plan.last_step);
  if (const std::string why = need_steps(a, 0, last); !why.empty()) return fail(name, why);
  if (const std::string why = need_steps(b, 0, last); !why.empty()) return fail(name, why);
  if (a.hello->model != b.hello->model || a.hello->num_cgps != b.hello->num_cgps ||
      !same_bits(a.hello->stable_dt_cg_s, b.hello->stable_dt_cg_s))
    return fail(name, "the two runs' hello_t differ (model, num_cgps or stable_dt_cg_s)");
  for (std::int64_t k = 0; k <= last; ++k)
    if (const std::string d = difference(*a.state(k), *b.state(k)); !d.empty())
      return fail(name, "solid_state_t(" + std::to_string(k) + ") differs between two runs with the same inputs: " + d);
  return pass(name, "solid_state_t(0-" + std::to_string(last) + ") of two runs agree bit for bit");
}

Verdict check_still_energy(const Trace& t, const Context& c) {
  const std::string name = "energy in still fluid";
  const std::int64_t first = 5, last = t.plan.last_step - 1;
  if (const std::string why = need_steps(t, first - 1, last + 1); !why.empty()) return fail(name, why);
  double work = 0.0, scale = 0.0;
  for (std::int64_t k = first; k <= last; ++k) {
    const cosimlcm::solid_state_t &m = *t.state(k), &before = *t.state(k - 1), &after = *t.state(k + 1);
    for (std::size_t l = 0; l < markers(t); ++l) {
      const Vec v = 0.5 * (col(after.position_lb, l) - col(before.position_lb, l));
      const Vec j = col(m.impulse_lb, l);
      work += j.dot(v);
      scale += j.norm() * v.norm();
    }
  }
  (void)c;
  if (scale == 0.0) return pass(name, "the markers rest or give no impulse in still fluid (steps " + std::to_string(first) + "-" + std::to_string(last) + ")");
  if (work < -1e-3 * scale)
    return fail(name, "in still fluid the fluid did work " + fmt("%.4g", -work) +
                          " on the markers (sum of J_l . V_l < 0, steps " + std::to_string(first) + "-" + std::to_string(last) +
                          "): the energy grows; the reaction on the markers has the wrong sign");
  return pass(name, "the markers gave energy to the still fluid (sum J_l . V_l = " + fmt("%.3g", work) + " >= 0, steps " +
                        std::to_string(first) + "-" + std::to_string(last) + ")");
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

Verdict check_long_session(const Trace& t, const Context& c) {
  const std::string name = "long session";
  for (const Verdict& v : {check_initial_state(t), check_finite({&t}), check_substeps(t, c), check_impulse_motion(t, c),
                           check_resend(t), check_duplicates(t), check_success_stop(t)})
    if (!v.pass) return fail(name, v.check + ": " + v.reason);
  return pass(name, std::to_string(t.plan.last_step + 1) + " steps (the first free step " +
                        std::to_string(std::max<std::int64_t>(t.plan.rigid_steps, 1)) +
                        "): initial state, finite values, substep count, impulse vs motion at every step, the resend_t of step " +
                        std::to_string(t.plan.resend_at) + ", the duplicate of step " + std::to_string(t.plan.duplicate_at) +
                        ", stop (success): all pass");
}

Verdict check_restart(const Trace& main, const Trace* r, const std::string& checkpoint) {
  const std::string name = "restart";
  if (checkpoint.empty() || r == nullptr)
    return pass(name, "the solid wrote no checkpoint when the fluid stopped with an error (session 'repeat'): checkpoints "
                      "are optional (protocol/README.md section 10); not checked");
  const std::int64_t from = r->plan.restart_at;
  if (const std::string why = need_steps(*r, from, r->plan.last_step); !why.empty())
    return fail(name, "the restart from " + checkpoint + ": " + why);
  if (const std::string why = need_steps(main, from, r->plan.last_step); !why.empty()) return fail(name, why);
  for (std::int64_t k = from; k <= r->plan.last_step; ++k)
    if (const std::string d = difference(*main.state(k), *r->state(k)); !d.empty())
      return fail(name, "solid_state_t(" + std::to_string(k) + ") after the restart from " + checkpoint +
                            " differs from the straight run (session 'main'): " + d +
                            (k == from ? " (the checkpoint's solid_state_t is published again unchanged)"
                                       : " (a restart continues bit for bit: restore() must bring back the whole state "
                                         "save() gave)"));
  if (!r->exit_code || *r->exit_code != 0)
    return fail(name, "after the restart, " + (r->exit_code ? "exit code " + std::to_string(*r->exit_code) : std::string("no exit")) +
                          " at the fluid's stop_t(0), expected 0: \"" + r->last_line + "\"");
  return pass(name, "restarted from " + checkpoint + ": solid_state_t(" + std::to_string(from) + "-" +
                        std::to_string(r->plan.last_step) + ") bit for bit those of the straight run");
}

std::vector<Verdict> all_checks(const Sessions& s, const Context& c) {
  const Trace& main = *s.main;
  std::vector<const Trace*> all{s.main};
  for (const Trace* t : {s.repeat, s.still, s.long_run})
    if (t != nullptr) all.push_back(t);
  std::vector<Verdict> v{check_handshake_fields(main), check_initial_state(main), check_lattice_units(main, c),
                         check_finite(all),            check_substeps(main, c),     check_spin_up_impulse(main, c),
                         check_impulse_motion(main, c)};
  if (s.long_run != nullptr) v.push_back(check_response(main, *s.long_run, c));
  for (const Verdict& x : {check_resend(main), check_duplicates(main), check_success_stop(main)}) v.push_back(x);
  if (s.repeat != nullptr) v.push_back(check_error_stop(*s.repeat));
  if (s.still != nullptr) v.push_back(check_timeout(*s.still, c));
  if (s.repeat != nullptr) v.push_back(check_bit_identical(main, *s.repeat));
  if (s.still != nullptr) v.push_back(check_still_energy(*s.still, c));
  {
    std::vector<const Trace*> balanced{s.main};
    if (s.long_run != nullptr) balanced.push_back(s.long_run);
    v.push_back(check_energy_balance(balanced, c));
  }
  if (s.long_run != nullptr) v.push_back(check_long_session(*s.long_run, c));
  if (s.restart_asked) v.push_back(check_restart(main, s.restart, s.checkpoint));
  return v;
}

}  // namespace cosim::conformance
