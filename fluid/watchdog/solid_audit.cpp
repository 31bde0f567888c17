#include "fluid/watchdog/solid_audit.hpp"

#include <algorithm>
#include <cmath>

#include "common/text/text.hpp"

namespace cosim::protocol {

namespace {

/// How many LB steps back the energy clause looks.
constexpr std::size_t kWindow = 10;
/// Velocities below this (c) are not compared: round-off and the markers' slow drift.
constexpr double kSpeedFloor = 0.05;
/// The motion and the impulse disagree when |V - U| exceeds this part of the larger: 2/3
/// for a marker released from rest at constant acceleration (its mean position moves a
/// third as far as its mean velocity over the first step), 1 and more for a marker whose
/// positions stand still, jump or run against its impulse.
constexpr double kDisagreement = 0.9;

double norm(const SolidAudit::Vec3& v) { return std::hypot(v[0], v[1], v[2]); }

std::string vec(const SolidAudit::Vec3& v) {
  std::string s(1, '(');  // not "(" + ...: GCC 12 warns falsely (-Wrestrict)
  s += fmt("%.4g", v[0]) + ", " + fmt("%.4g", v[1]) + ", " + fmt("%.4g", v[2]) + ")";
  return s;
}

}  // namespace

SolidAudit::SolidAudit(std::int64_t rigid_steps, bool linear_in_motion)
    : rigid_steps_(rigid_steps), linear_(linear_in_motion) {}

void SolidAudit::observe(std::int64_t step, const std::vector<Vec3>& x, const std::vector<Vec3>& j,
                         const std::vector<double>& rho, const std::vector<Vec3>& u) {
  const std::size_t n = x.size();
  // The implicit scheme's iterations of a step: the last one counts.
  if (!last_.empty() && last_.back().step == step) {
    for (const double w : last_.back().work) work_ -= w;
    last_.pop_back();
  }
  Record r{step, x, j, u, rho, std::vector<double>(n, 0.0)};
  // The spin-up holds the markers: J_l = -2 rho_l u_l dA_l' (U_l = 0) gives dA_l'.
  if (step < rigid_steps_ && rho.size() == n && u.size() == n && (last_.empty() || last_.back().step != step)) {
    area_num_.resize(n, 0.0);
    area_den_.resize(n, 0.0);
    for (std::size_t l = 0; l < n; ++l) {
      if (!(rho[l] > 0.0)) continue;
      area_num_[l] -= (j[l][0] * u[l][0] + j[l][1] * u[l][1] + j[l][2] * u[l][2]) / (2.0 * rho[l]);
      area_den_[l] += u[l][0] * u[l][0] + u[l][1] * u[l][1] + u[l][2] * u[l][2];
    }
  }
  // The fluid's work on the solid over the step: the solid receives -J_l.
  if (!last_.empty() && last_.back().step == step - 1 && last_.back().x.size() == n)
    for (std::size_t l = 0; l < n; ++l) {
      const Vec3& a = last_.back().x[l];
      r.work[l] = -(j[l][0] * (x[l][0] - a[0]) + j[l][1] * (x[l][1] - a[1]) + j[l][2] * (x[l][2] - a[2]));
      work_ += r.work[l];
    }
  last_.push_back(std::move(r));
  while (last_.size() > kWindow + 1) last_.pop_front();
}

std::optional<std::string> SolidAudit::blame(double fallback_area_lb) const {
  if (last_.size() >= 2)
    if (auto m = motion_disagrees(last_.back(), last_[last_.size() - 2], fallback_area_lb)) return m;
  return energy_from_solid();
}

std::optional<std::string> SolidAudit::motion_disagrees(const Record& now, const Record& before,
                                                        double fallback_area_lb) const {
  const std::size_t n = now.x.size();
  if (!linear_ || now.step < rigid_steps_ || now.step != before.step + 1 || before.x.size() != n ||
      now.rho.size() != n || now.u.size() != n)
    return std::nullopt;
  double worst = 0.0;
  std::size_t at = n;
  Vec3 v_at{}, u_at{};
  double area_at = 0.0;
  for (std::size_t l = 0; l < n; ++l) {
    double area = fallback_area_lb;
    if (l < area_den_.size() && area_den_[l] > 1e-12 && area_num_[l] > 0.0) area = area_num_[l] / area_den_[l];
    if (!(area > 0.0) || !(now.rho[l] > 0.0)) continue;
    Vec3 v{}, u{};
    for (int c = 0; c < 3; ++c) {
      v[c] = now.x[l][c] - before.x[l][c];                              // the positions' velocity
      u[c] = now.u[l][c] + now.j[l][c] / (2.0 * now.rho[l] * area);     // the impulse's (Eqs. 18-19)
    }
    const double d = norm({v[0] - u[0], v[1] - u[1], v[2] - u[2]});
    if (d > kSpeedFloor && d > kDisagreement * std::max(norm(v), norm(u)) && d > worst)
      worst = d, at = l, v_at = v, u_at = u, area_at = area;
  }
  if (at == n) return std::nullopt;
  return "the solid's positions and impulses disagree: at step " + std::to_string(now.step) + " CGP " +
         std::to_string(at) + "'s reported positions moved " + vec(v_at) + " dx in one LB step, while its impulse " +
         "J_l = 2 rho (U - u) dA (dA = " + fmt("%.4g", area_at) + " dx^2" +
         (at < area_den_.size() && area_den_[at] > 1e-12 ? " from the spin-up" : " of the lightest CGP") +
         ") says it moved at U = " + vec(u_at) +
         " c: the solid reports positions its impulses do not follow (positions not in lattice units dx, a jump, "
         "or positions that do not move with the marker); a fault of the solid, not of dt_CG, the inlet or the grid";
}

std::optional<std::string> SolidAudit::energy_from_solid() const {
  if (last_.size() < 4) return std::nullopt;
  // The free steps at the window's end, each with its predecessor: last_[first .. final_k].
  const std::size_t final_k = last_.size() - 1;
  std::size_t first = last_.size();
  for (std::size_t k = final_k; k >= 1; --k) {
    if (last_[k].step < rigid_steps_ + 1 || last_[k].step != last_[k - 1].step + 1) break;
    first = k;
  }
  if (first == last_.size() || final_k - first + 1 < 3) return std::nullopt;
  const auto max_speed = [&](std::size_t k) {
    double s = 0.0;
    for (std::size_t l = 0; l < last_[k].x.size() && l < last_[k - 1].x.size(); ++l)
      s = std::max(s, norm({last_[k].x[l][0] - last_[k - 1].x[l][0], last_[k].x[l][1] - last_[k - 1].x[l][1],
                            last_[k].x[l][2] - last_[k - 1].x[l][2]}));
    return s;
  };
  const double s0 = max_speed(first), s1 = max_speed(final_k);
  double w = 0.0;
  std::size_t taking = 0;
  for (std::size_t k = first; k <= final_k; ++k) {
    double wk = 0.0;
    for (const double x : last_[k].work) wk += x;
    w += wk;
    taking += wk < 0.0 ? 1 : 0;
  }
  const std::size_t steps = final_k - first + 1;
  if (!(s1 > kSpeedFloor && s1 > 2.0 * s0 && w < 0.0 && 2 * taking > steps)) return std::nullopt;
  return "the solid's markers sped up from " + fmt("%.3g", s0) + " c to " + fmt("%.3g", s1) + " c over steps " +
         std::to_string(last_[first].step) + " to " + std::to_string(last_[final_k].step) +
         " while the fluid took energy from them (its work on the solid W = " + fmt("%.4g", w) +
         " rho_air dx^3 c^2 over those steps, negative at " + std::to_string(taking) + " of " +
         std::to_string(steps) + ", -J_l . dX_l from the solid's own impulses and positions): the energy that the "
         "solid gains comes from the solid, not from the fluid (e.g. its markers receive +J_l instead of -J_l)";
}

}  // namespace cosim::protocol
