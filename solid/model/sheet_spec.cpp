#include "solid/model/sheet_spec.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace cosim::solid {

namespace {

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

double theta_rad(const SheetSpec& spec) { return spec.theta_deg * std::numbers::pi / 180.0; }

/// R_z(-psi) v: the upright sheet's axis v tilted by incline_deg (see SheetSpec).
Eigen::Vector3d inclined(const SheetSpec& spec, const Eigen::Vector3d& v) {
  if (spec.incline_deg == 0.0) return v;  // the upright sheets bit for bit as before
  const double p = spec.incline_deg * std::numbers::pi / 180.0;
  const double c = std::cos(p), s = std::sin(p);
  return {c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]};
}

}  // namespace

void check_sheet_spec(const SheetSpec& spec) {
  if (spec.nx_cg < 2 || spec.ny_cg < 2)
    fail(__LINE__, "a sheet needs at least 2 x 2 CGPs; got nx_cg = " +
                       std::to_string(spec.nx_cg) + ", ny_cg = " + std::to_string(spec.ny_cg));
  if (!(spec.width_spacing_bohr > 0.0) || !std::isfinite(spec.width_spacing_bohr) ||
      !(spec.height_spacing_bohr > 0.0) || !std::isfinite(spec.height_spacing_bohr))
    fail(__LINE__, "the CGP spacings must be positive and finite; got " +
                       std::to_string(spec.width_spacing_bohr) + " x " +
                       std::to_string(spec.height_spacing_bohr) + " bohr");
  if (!(spec.cgp_mass_me > 0.0) || !std::isfinite(spec.cgp_mass_me))
    fail(__LINE__, "the CGP mass must be positive and finite; got cgp_mass_me = " +
                       std::to_string(spec.cgp_mass_me));
  if (!std::isfinite(spec.theta_deg) || !std::isfinite(spec.incline_deg) || !spec.base_bohr.allFinite())
    fail(__LINE__, "the sheet's angle of attack, incline and base point must be finite numbers");
  if (spec.clamped_rows < 0 || spec.clamped_rows >= spec.ny_cg)
    fail(__LINE__, "clamped_rows must lie in [0, ny_cg); got " +
                       std::to_string(spec.clamped_rows) + " with ny_cg = " +
                       std::to_string(spec.ny_cg));
}

Eigen::Vector3d sheet_width_direction(const SheetSpec& spec) {
  const double t = theta_rad(spec);
  return inclined(spec, {std::cos(t), 0.0, -std::sin(t)});
}

Eigen::Vector3d sheet_height_direction(const SheetSpec& spec) { return inclined(spec, Eigen::Vector3d::UnitY()); }

Eigen::Vector3d sheet_normal(const SheetSpec& spec) {
  const double t = theta_rad(spec);
  return inclined(spec, {std::sin(t), 0.0, std::cos(t)});
}

Eigen::Matrix3Xd flat_sheet_positions(const SheetSpec& spec) {
  check_sheet_spec(spec);
  const Eigen::Vector3d e_w = sheet_width_direction(spec);
  const Eigen::Vector3d e_h = sheet_height_direction(spec);
  const double i_mid = 0.5 * static_cast<double>(spec.nx_cg - 1);
  Eigen::Matrix3Xd x(3, spec.num_cgps());
  for (int j = 0; j < spec.ny_cg; ++j)
    for (int i = 0; i < spec.nx_cg; ++i)
      x.col(spec.index(i, j)) =
          spec.base_bohr + ((static_cast<double>(i) - i_mid) * spec.width_spacing_bohr) * e_w +
          (static_cast<double>(j) * spec.height_spacing_bohr) * e_h;
  return x;
}

Eigen::Vector3d free_edge_midpoint(const SheetSpec& spec, const Eigen::Matrix3Xd& x) {
  if (x.cols() != spec.num_cgps())
    fail(__LINE__, "free_edge_midpoint: " + std::to_string(x.cols()) + " positions for a sheet of " +
                       std::to_string(spec.num_cgps()) + " CGPs");
  const auto row_middle = [&](int j) {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (int i = 0; i < spec.nx_cg; ++i) m += x.col(spec.index(i, j));
    return Eigen::Vector3d(m / double(spec.nx_cg));
  };
  const Eigen::Vector3d top = row_middle(spec.ny_cg - 1), below = row_middle(spec.ny_cg - 2);
  return top + 0.5 * (top - below);
}

}  // namespace cosim::solid
