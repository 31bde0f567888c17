#include "tools/conformance/checks.hpp"

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/text/text.hpp"
#include "tools/conformance/check_support.hpp"

namespace cosim::conformance {

using namespace support;

namespace {

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
