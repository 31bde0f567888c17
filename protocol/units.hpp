// Unit conversions between the fluid (lattice units) and the solid (Hartree atomic units),
// the paper's section 2.4 (Eqs. 15-16, 27-32, Table 1). Every number is derived here from
// physical constants; nothing downstream types a converted value.
#pragma once

#include <optional>

namespace cosim::protocol {

/// CODATA 2018 atomic units and the paper's air properties (Table 1).
struct PhysicalConstants {
  static constexpr double bohr_m = 5.29177210903e-11;       ///< l_AU
  static constexpr double time_au_s = 2.4188843265857e-17;  ///< t_AU
  static constexpr double electron_mass_kg = 9.1093837015e-31;  ///< m_AU
  static constexpr double loschmidt_per_m3 = 2.687e25;      ///< n_0 (Table 1)
  static constexpr double air_molecule_kg = 4.851e-26;      ///< m_air (Table 1)
  static constexpr double sound_speed_air_m_s = 331.5;      ///< c_s (Table 1)
  static constexpr double carbon_mass_kg = 12.011 * 1.66053906660e-27;
  static constexpr double hartree_eV = 27.211386245988;
};

/// Inputs of the conversion; defaults are the paper's (Table 1, Eq. 30).
struct UnitInputs {
  double dx_m = 0.2561e-6;  ///< dx_LB = dx_CG (A_L = 1)
  double sound_speed_m_s = PhysicalConstants::sound_speed_air_m_s;
  double number_density_per_m3 = PhysicalConstants::loschmidt_per_m3;
  double molecule_mass_kg = PhysicalConstants::air_molecule_kg;
  int time_ratio = 150;  ///< A_T = dt_LB / dt_CG (Eq. 16)
};

/// A medium other than the paper's air (Table 1), e.g. Turek and Hron's water-like fluid:
/// its density and the lattice's sound speed c_s (dt = dx / (sqrt(3) c_s): the weakly
/// compressible model's artificial one, which sets the Mach number, not the liquid's).
/// [fluid] density_kg_m3 and sound_speed_m_s of a scene, read by both processes
/// (protocol/config/shared_sections.hpp read_medium).
struct Medium {
  double density_kg_m3 = 0.0;
  double sound_speed_m_s = 0.0;
};

/// The conversion's inputs of a scene, the one rule both processes apply: dx from [grid],
/// the medium (the paper's air when absent; rho = n m: the number density that gives its
/// density with Table 1's molecule mass) and A_T.
UnitInputs scene_unit_inputs(double dx_m, const std::optional<Medium>& medium, int time_ratio);

/// Validated converter: the constructor throws std::invalid_argument naming the input
/// that is not positive.
class UnitConverter {
 public:
  explicit UnitConverter(const UnitInputs& in = {});

  const UnitInputs& inputs() const { return in_; }
  double dx_m() const { return in_.dx_m; }
  /// c = sqrt(3) c_s, the lattice speed dx/dt in m/s.
  double lattice_speed_m_s() const;
  /// dt_LB = dx / c (section 2.4).
  double dt_lb_s() const;
  /// dt_CG = dt_LB / A_T (Eq. 16).
  double dt_cg_s() const;
  /// rho_air = n_0 m_air.
  double air_density_kg_m3() const;
  /// F_LB = rho_0 c^2 dx^(d-1) = 3 n_0 m_air c_s^2 dx^2 (Eq. 28, Table 1).
  double force_lb_N() const;
  /// E_LB = F_LB dx = rho_0 c^2 dx^3: the lattice's unit of energy (work J . X), in joules.
  double energy_lb_J() const { return force_lb_N() * in_.dx_m; }
  /// u_AU = l_AU / t_AU and F_AU = m_AU u_AU^2 / l_AU (Eq. 29).
  static double velocity_au_m_s();
  static double force_au_N();
  /// B_V = u_AU / c and B_F = F_CG / F_LB (Eq. 27; values of Eq. 31).
  double velocity_ratio() const;
  double force_ratio() const;

  /// Eq. 32: v_LB = B_V v_CG, F_LB = B_F F_CG.
  double velocity_lb_from_au(double v_au) const { return velocity_ratio() * v_au; }
  double velocity_au_from_lb(double v_lb) const { return v_lb / velocity_ratio(); }
  double force_lb_from_au(double f_au) const { return force_ratio() * f_au; }
  double force_au_from_lb(double f_lb) const { return f_lb / force_ratio(); }

  /// Lengths: bohr (the solid) <-> lattice spacings (the fluid).
  double length_lb_from_bohr(double x_bohr) const;
  double length_bohr_from_lb(double x_lb) const;
  /// Momentum: m_e bohr / t_AU (the solid) -> rho_0 dx^3 c = F_LB dt_LB (the fluid's unit
  /// of momentum, in which an LB-step impulse J = g dA is counted).
  double momentum_lb_from_au(double p_au) const;

  /// Physical <-> lattice for the fluid alone.
  double velocity_m_s(double u_lb) const { return u_lb * lattice_speed_m_s(); }
  double time_s(double steps) const { return steps * dt_lb_s(); }
  /// Kinematic viscosity in m^2/s of a BGK relaxation time (Eq. 13).
  double viscosity_m2_s(double tau) const;

 private:
  UnitInputs in_;
};

}  // namespace cosim::protocol
