#include "tools/conformance/checks.hpp"

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/text/text.hpp"

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

}  // namespace

Plan main_plan() {
  Plan p;
  p.name = "main";
  p.total_steps = 12;
  p.rigid_steps = 4;
  p.last_step = 11;
  p.ending = Ending::Success;
  p.flow = [](std::int64_t, Eigen::Index n) { return uniform(n, Vec(0.05, 0.0, 0.01)); };
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

Verdict check_impulse_motion(const Trace& t, const Context& c) {
  const std::string name = "impulse vs motion";
  const std::int64_t first = t.plan.rigid_steps + 1, last = t.plan.last_step - 1;
  if (const std::string why = need_steps(t, first - 1, last + 1); !why.empty()) return fail(name, why);
  const Eigen::VectorXd a = areas(t, c);
  if (a.size() == 0) return fail(name, "the markers' areas are unknown");
  for (std::int64_t k = first; k <= last; ++k) {
    const cosimlcm::solid_state_t &m = *t.state(k), &before = *t.state(k - 1), &after = *t.state(k + 1);
    const Eigen::Matrix3Xd u = t.plan.flow(k, Eigen::Index(markers(t)));
    double diff = 0.0, scale = 0.0, je = 0.0, ee = 0.0;
    for (std::size_t l = 0; l < markers(t); ++l) {
      const Vec v = 0.5 * (col(after.position_lb, l) - col(before.position_lb, l));
      const double area = a[Eigen::Index(l)];
      const Vec e = 2.0 * area * (v - u.col(Eigen::Index(l)));
      const Vec j = col(m.impulse_lb, l);
      diff += (j - e).norm();
      scale += e.norm() + 2.0 * area * u.col(Eigen::Index(l)).norm();
      je += j.dot(e);
      ee += e.squaredNorm();
    }
    if (!(diff <= 0.5 * scale))
      return fail(name, "solid_state_t(" + std::to_string(k) + "): sum |J_l - 2 rho dA (V_l - u)| = " + fmt("%.4g", diff) +
                            " (V_l from the reported positions), above half the scale " + fmt("%.4g", 0.5 * scale) + ": " +
                            diagnose(ee > 0.0 ? je / ee : 0.0, c.time_ratio));
  }
  return pass(name, "J_l = 2 rho dA (V_l - u) within half the scale at steps " + std::to_string(first) + "-" +
                        std::to_string(last) + " (V_l from the reported positions)");
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
  if (!t.problem.empty()) return fail(name, "session 'main' did not reach its end: " + t.problem);
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

std::vector<Verdict> all_checks(const Trace& main, const Trace& repeat, const Trace& still, const Context& c) {
  return {check_handshake_fields(main),     check_initial_state(main),       check_finite({&main, &repeat, &still}),
          check_substeps(main, c),          check_spin_up_impulse(main, c),  check_impulse_motion(main, c),
          check_resend(main),               check_duplicates(main),          check_success_stop(main),
          check_error_stop(repeat),         check_timeout(still, c),         check_bit_identical(main, repeat),
          check_still_energy(still, c)};
}

}  // namespace cosim::conformance
