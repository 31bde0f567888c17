#include "solid/coupling/solid_coupler.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/units.hpp"

namespace cosim::solid {

namespace {

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

}  // namespace

SolidCoupler::SolidCoupler(SolidModel& model, const protocol::UnitConverter& units,
                           std::vector<double> marker_area_lb, const Eigen::Vector3d& origin_lb)
    : model_(model), units_(units), area_(std::move(marker_area_lb)), origin_(origin_lb) {
  if (static_cast<Eigen::Index>(area_.size()) != model_.num_cgps())
    fail(__LINE__, std::to_string(area_.size()) + " marker areas for " +
                       std::to_string(model_.num_cgps()) + " CGPs");
  force_au_ = Eigen::Matrix3Xd::Zero(3, model_.num_cgps());
}

Eigen::Matrix3Xd SolidCoupler::positions_lb() const {
  Eigen::Matrix3Xd x(3, model_.num_cgps());
  for (Eigen::Index l = 0; l < x.cols(); ++l)
    for (int c = 0; c < 3; ++c) x(c, l) = units_.length_lb_from_bohr(model_.positions()(c, l)) + origin_[c];
  return x;
}

Eigen::Vector3d SolidCoupler::momentum_lb() const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (Eigen::Index l = 0; l < model_.num_cgps(); ++l)
    p += model_.masses()[l] * model_.velocities().col(l);
  for (int c = 0; c < 3; ++c) p[c] = units_.momentum_lb_from_au(p[c]);
  return p;
}

IntervalResult SolidCoupler::advance(const FluidSample& sample, bool rigid, bool implicit_reaction) {
  const Eigen::Index n = model_.num_cgps();
  if (sample.rho_lb.size() != n || sample.velocity_lb.cols() != n)
    fail(__LINE__, "a fluid sample of " + std::to_string(sample.rho_lb.size()) +
                       " markers for " + std::to_string(n) + " CGPs");
  if (!sample.rho_lb.allFinite() || !sample.velocity_lb.allFinite() ||
      !(sample.rho_lb.array() > 0.0).all())
    fail(__LINE__, "the fluid sample holds a non-finite value or a non-positive density");

  IntervalResult r;
  r.impulse_lb = Eigen::Matrix3Xd::Zero(3, n);
  if (rigid) {
    // The spin-up: sheets held, U_B = 0, one LB interval of g dA.
    if (law_ == ReactionLaw::MomentumExchange) {
      for (Eigen::Index l = 0; l < n; ++l)
        r.impulse_lb.col(l) = -2.0 * sample.rho_lb[l] * area_[static_cast<std::size_t>(l)] *
                              sample.velocity_lb.col(l);
    } else {
      const int a_t = units_.inputs().time_ratio;
      for (Eigen::Index l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c)
          r.impulse_lb(c, l) = reaction_g_da(law_, 2.0 * sample.rho_lb[l] * area_[static_cast<std::size_t>(l)],
                                             0.0, sample.velocity_lb(c, l), a_t);
    }
    r.position_lb = positions_lb();
    return r;
  }

  const int a_t = units_.inputs().time_ratio;
  const double dt_au = units_.dt_cg_s() / protocol::PhysicalConstants::time_au_s;
  // Trapezoid sum of the positions over the substep boundaries, in bohr (converted once).
  Eigen::Matrix3Xd position_sum = 0.5 * model_.positions();
  const double b_v = units_.velocity_ratio(), b_f = units_.force_ratio();  // Eq. 32
  const auto held = [&](Eigen::Index l) {
    return static_cast<std::size_t>(l) < held_.size() && held_[static_cast<std::size_t>(l)];
  };
  if (implicit_reaction && memory_.velocity.cols() != n) {
    memory_.velocity = model_.velocities();
    memory_.force = Eigen::Matrix3Xd::Zero(3, n);
  }
  // The model's state, updated in place by each substep: read through these references, not
  // through a virtual call per value.
  const Eigen::Matrix3Xd& velocity = model_.velocities();
  const Eigen::Matrix3Xd& position = model_.positions();
  const Eigen::VectorXd& mass = model_.masses();
  Eigen::RowVectorXd rho_da(n);  // 2 rho_l dA_l, fixed over the interval
  for (Eigen::Index l = 0; l < n; ++l) rho_da[l] = 2.0 * sample.rho_lb[l] * area_[static_cast<std::size_t>(l)];
  for (int k = 0; k < a_t; ++k) {
    // Eqs. 19-20 for all CGPs at once: g dA = 2 rho dA (U_B - u) on the fluid, -g dA / B_F on
    // the CGP, at the velocity before the substep.
    // (The default law as one Eigen expression, the same arithmetic as momentum_exchange_g_da;
    // the others through reaction_g_da, solid/coupling/reaction_law.hpp.)
    if (law_ == ReactionLaw::MomentumExchange) {
      force_au_.array() =
          -(((b_v * velocity.array() - sample.velocity_lb.array()).rowwise() * rho_da.array())) / b_f;
    } else {
      for (Eigen::Index l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c)
          force_au_(c, l) = -reaction_g_da(law_, rho_da[l], b_v * velocity(c, l), sample.velocity_lb(c, l), a_t) / b_f;
    }
    // The implicit scheme: backward Euler for the drag of every CGP that is not held (see the
    // header): h = D B_V dt / (B_F m) in atomic units.
    for (Eigen::Index l = 0; implicit_reaction && l < n; ++l) {
      if (held(l)) continue;
      const double rda = rho_da[l], m = mass[l];
      const double h = rda * b_v * dt_au / (b_f * m);
      for (int c = 0; c < 3; ++c) {
        const double v = velocity(c, l);
        const double f_other = m * (v - memory_.velocity(c, l)) / dt_au - memory_.force(c, l);
        const double v_star = v + dt_au / m * f_other;
        const double g_da = rda * (b_v * v_star - sample.velocity_lb(c, l)) / (1.0 + h);  // Eq. 19
        force_au_(c, l) = -g_da / b_f;                                                     // Eq. 20
      }
    }
    if (implicit_reaction) {
      memory_.velocity = velocity;
      memory_.force = force_au_;
    }
    // The fluid's work at the velocities the forces were computed from (before the substep).
    r.fluid_work_au += force_au_.cwiseProduct(velocity).sum() * dt_au;
    model_.substep(dt_au, force_au_);
    const Eigen::Vector3d received_au = force_au_.rowwise().sum() * dt_au;
    for (int c = 0; c < 3; ++c) r.received_impulse_lb[c] += units_.momentum_lb_from_au(received_au[c]);
    // The impulse the fluid receives is the one the CGPs got, with the opposite sign, in
    // the fluid's units: -F_CGP dt_CG / (F_LB dt_LB) = -F_CGP,lb / A_T.
    r.impulse_lb.array() -= (b_f * force_au_.array()) / static_cast<double>(a_t);
    position_sum += (k + 1 < a_t ? 1.0 : 0.5) * position;
    // The watchdog (DESIGN 6): stop within the interval, before the state can overflow.
    if (over_speed_limit(k, sample, r)) return r;
  }
  r.position_lb.resize(3, n);
  for (Eigen::Index l = 0; l < n; ++l)
    for (int c = 0; c < 3; ++c)
      r.position_lb(c, l) = units_.length_lb_from_bohr(position_sum(c, l) / a_t) + origin_[c];
  r.substeps = a_t;
  return r;
}

bool SolidCoupler::over_speed_limit(int k, const FluidSample& sample, IntervalResult& r) {
  if (!std::isfinite(speed_limit_lb_)) return false;
  // The fastest CGP (first on ties), in one pass over the velocities.
  const Eigen::Matrix3Xd& v = model_.velocities();
  Eigen::Index fastest = 0;
  double v2 = -1.0;
  for (Eigen::Index l = 0; l < v.cols(); ++l) {
    const double s2 = v(0, l) * v(0, l) + v(1, l) * v(1, l) + v(2, l) * v(2, l);
    if (s2 > v2 || !(s2 == s2)) {
      v2 = s2;
      fastest = l;
      if (!(s2 == s2)) break;  // NaN: the first such CGP
    }
  }
  const double speed = units_.velocity_ratio() * std::sqrt(v2);
  if (speed > max_speed_lb_) max_speed_lb_ = speed;
  if (speed <= speed_limit_lb_) return false;
  IntervalResult::Overspeed o;
  o.substep = k + 1;
  o.cgp = fastest;
  o.speed_lb = speed;
  // T / dt_LB = m / (2 rho rho_air dA dx) in physical units; dt_CG = dt_LB / A_T.
  const int a_t = units_.inputs().time_ratio;
  const double rho = sample.rho_lb[fastest];
  const double m_kg = model_.masses()[fastest] * protocol::PhysicalConstants::electron_mass_kg;
  const double da_m2 = area_[static_cast<std::size_t>(fastest)] * units_.dx_m() * units_.dx_m();
  const double t_lb = m_kg / (2.0 * rho * units_.air_density_kg_m3() * da_m2 * units_.dx_m());
  o.dt_over_relaxation = 1.0 / (t_lb * a_t);
  r.overspeed = o;
  r.substeps = k + 1;
  return true;
}

Eigen::Matrix3Xd marker_positions_lb(const std::vector<SheetSpec>& sheets, const protocol::UnitConverter& units) {
  Eigen::Index n = 0;
  for (const SheetSpec& s : sheets) n += s.num_cgps();
  Eigen::Matrix3Xd x(3, n);
  Eigen::Index first = 0;
  const Eigen::Vector3d origin = solid_origin_lb();
  for (const SheetSpec& s : sheets) {
    const Eigen::Matrix3Xd flat = flat_sheet_positions(s);
    for (Eigen::Index l = 0; l < flat.cols(); ++l)
      for (int c = 0; c < 3; ++c) x(c, first + l) = units.length_lb_from_bohr(flat(c, l)) + origin[c];
    first += flat.cols();
  }
  return x;
}

std::vector<double> marker_areas_lb(const std::vector<SheetSpec>& sheets,
                                    const protocol::UnitConverter& units) {
  std::vector<double> area;
  for (const SheetSpec& s : sheets) {
    const double a = units.length_lb_from_bohr(s.width_spacing_bohr) *
                     units.length_lb_from_bohr(s.height_spacing_bohr);
    area.insert(area.end(), static_cast<std::size_t>(s.num_cgps()), a);
  }
  return area;
}

}  // namespace cosim::solid
