#include "protocol/units.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::protocol {

namespace {
void require_positive(double v, const char* name) {
  if (!(v > 0.0) || !std::isfinite(v))
    throw std::invalid_argument(std::string("unit input ") + name + " = " + std::to_string(v) +
                                " must be a positive finite number");
}
}  // namespace

UnitInputs scene_unit_inputs(double dx_m, const std::optional<Medium>& medium, int time_ratio) {
  UnitInputs in;
  in.dx_m = dx_m;
  in.time_ratio = time_ratio;
  if (medium) {
    in.sound_speed_m_s = medium->sound_speed_m_s;
    in.number_density_per_m3 = medium->density_kg_m3 / in.molecule_mass_kg;  // rho = n m
  }
  return in;
}

UnitConverter::UnitConverter(const UnitInputs& in) : in_(in) {
  require_positive(in.dx_m, "dx_m");
  require_positive(in.sound_speed_m_s, "sound_speed_m_s");
  require_positive(in.number_density_per_m3, "number_density_per_m3");
  require_positive(in.molecule_mass_kg, "molecule_mass_kg");
  if (in.time_ratio < 1)
    throw std::invalid_argument("unit input time_ratio = " + std::to_string(in.time_ratio) +
                                " must be a whole number >= 1");
}

double UnitConverter::lattice_speed_m_s() const { return std::sqrt(3.0) * in_.sound_speed_m_s; }
double UnitConverter::dt_lb_s() const { return in_.dx_m / lattice_speed_m_s(); }
double UnitConverter::dt_cg_s() const { return dt_lb_s() / in_.time_ratio; }
double UnitConverter::air_density_kg_m3() const {
  return in_.number_density_per_m3 * in_.molecule_mass_kg;
}
double UnitConverter::force_lb_N() const {
  const double c = lattice_speed_m_s();
  return air_density_kg_m3() * c * c * in_.dx_m * in_.dx_m;
}
double UnitConverter::velocity_au_m_s() {
  return PhysicalConstants::bohr_m / PhysicalConstants::time_au_s;
}
double UnitConverter::force_au_N() {
  const double u = velocity_au_m_s();
  return PhysicalConstants::electron_mass_kg * u * u / PhysicalConstants::bohr_m;
}
double UnitConverter::velocity_ratio() const { return velocity_au_m_s() / lattice_speed_m_s(); }
double UnitConverter::force_ratio() const { return force_au_N() / force_lb_N(); }
double UnitConverter::length_lb_from_bohr(double x_bohr) const {
  return x_bohr * PhysicalConstants::bohr_m / in_.dx_m;
}

double UnitConverter::length_bohr_from_lb(double x_lb) const {
  return x_lb * in_.dx_m / PhysicalConstants::bohr_m;
}

double UnitConverter::momentum_lb_from_au(double p_au) const {
  const double p_au_si = PhysicalConstants::electron_mass_kg * velocity_au_m_s();
  return p_au * p_au_si / (force_lb_N() * dt_lb_s());
}

double UnitConverter::viscosity_m2_s(double tau) const {
  return (tau - 0.5) / 3.0 * in_.dx_m * in_.dx_m / dt_lb_s();
}

}  // namespace cosim::protocol
