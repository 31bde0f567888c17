// Atomistic harmonic model of flat graphene (DESIGN 4.3 item 1): the 4th-nearest-neighbour
// force-constant model of R. Saito, G. Dresselhaus and M. S. Dresselhaus, Physical
// Properties of Carbon Nanotubes (Imperial College Press, 1998), chapter 9.
//
// Each pair (i, j) in shell s carries the tensor
//   Phi_ij = phi_r^(s) n n + phi_ti^(s) t t + phi_to^(s) z z,   n = r_ij / |r_ij|, t = z x n,
// and the equation of motion is m u''_i = sum_j Phi_ij (u_j - u_i). The stiffness (energy
// Hessian) therefore has the blocks K_ij = -Phi_ij (j != i) and, from the acoustic sum rule,
// K_ii = -sum_{j != i} K_ij. The dynamical matrix is D(q) = K(q) / m with
// K(q)_ab = sum_{bonds a -> b + R} K_ab(R) exp(i q . r_ab), so omega^2 are its eigenvalues.
//
// Units: SI inside the whole construction -- force constants in N/m, masses in kg, D in
// (rad/s)^2, velocities in m/s, kappa in J; Saito's table is in 1e4 dyn/cm = 10 N/m and is
// converted once in ForceConstants.
//
// Decoupling: for a flat sheet every Phi has n, t in the plane and z z out of it, so
// in-plane (x, y: 2 DOF per atom) and out-of-plane (z: 1 DOF per atom) motion decouple
// exactly; the blocks are exposed separately (DESIGN 4.3 item 1).
//
// Sum rules. The acoustic (translational) rule holds by construction. The out-of-plane
// rotational rule sum_j phi_to^(j) R_j^2 = 0 (the q^2 term of the ZA branch) fails with the
// published constants (about -6.0e-20 N m): the ZA branch is imaginary for q below about
// 1.2 nm^-1. saito1998_corrected() changes only phi_to^(4) so that the rule holds
// (phi_to^(4) = -0.5729 x 1e4 dyn/cm); the in-plane phi_ti terms are not rotationally
// invariant either (../shared/reference/graphene-notes.md), which does not matter for a flat
// sheet in the harmonic limit.
#pragma once

#include <array>
#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "protocol/units.hpp"
#include "solid/rcgp/graphene_lattice.hpp"

namespace cosim::solid {

/// Force constants of one neighbour shell, N/m.
struct ShellForceConstants {
  double radial_N_m = 0.0;              ///< phi_r
  double tangential_in_N_m = 0.0;       ///< phi_ti (in-plane, along t = z x n)
  double tangential_out_N_m = 0.0;      ///< phi_to (out of plane, along z)
};

/// Force constants of shells 1..4 (index 0..3), N/m.
struct ForceConstants {
  /// Saito's table unit, 1e4 dyn/cm = 10 N/m.
  static constexpr double kSaitoUnitN_m = 10.0;

  std::array<ShellForceConstants, GrapheneLattice::kShells> shells{};

  /// Saito, Dresselhaus and Dresselhaus (1998), Table 9.1 as printed (via graphene-notes).
  static ForceConstants saito1998_published();
  /// The published constants with phi_to^(4) solved from the out-of-plane rotational sum
  /// rule sum_j phi_to^(j) R_j^2 = 0 over the geometric shells of `lattice`
  /// (= -0.5729 x 1e4 dyn/cm for graphene); every other constant is unchanged.
  static ForceConstants saito1998_corrected(const GrapheneLattice& lattice = GrapheneLattice{});
};

/// Long-wave in-plane sound velocities, m/s.
struct SoundVelocities {
  double longitudinal_m_s = 0.0;  ///< v_LA
  double transverse_m_s = 0.0;    ///< v_TA
};

/// 2D elastic constants of the sheet from the sound velocities, N/m:
/// C11 = rho_2D v_LA^2, C66 = rho_2D v_TA^2, C12 = C11 - 2 C66 (isotropic hexagonal sheet),
/// E_2D = (C11^2 - C12^2) / C11, nu = C12 / C11.
struct ElasticConstants2D {
  double c11_N_m = 0.0;
  double c12_N_m = 0.0;
  double c66_N_m = 0.0;
  double youngs_modulus_N_m = 0.0;
  double poisson_ratio = 0.0;
};

class ForceConstantModel {
 public:
  using Matrix6cd = Eigen::Matrix<std::complex<double>, 6, 6>;
  using Vector6d = Eigen::Matrix<double, 6, 1>;

  explicit ForceConstantModel(
      ForceConstants constants = ForceConstants::saito1998_corrected(),
      GrapheneLattice lattice = GrapheneLattice{},
      double mass_kg = protocol::PhysicalConstants::carbon_mass_kg);

  const ForceConstants& constants() const { return fc_; }
  const GrapheneLattice& lattice() const { return lattice_; }
  double mass_kg() const { return mass_kg_; }
  /// rho_2D = m / (3 sqrt(3) d^2 / 4), kg/m^2.
  double areal_density_kg_m2() const;

  /// Phi for a bond vector r in shell s (1..4), N/m (3 x 3, components x, y, z).
  Eigen::Matrix3d pair_tensor(int shell, const Eigen::Vector2d& r_m) const;

  /// D(q) of the primitive cell, (rad/s)^2; DOF index 3 a + c (atom a = A, B; c = x, y, z).
  Matrix6cd dynamical_matrix(const Eigen::Vector2d& q_per_m) const;
  /// In-plane block of D(q) (DOF 2 a + c, c = x, y) and out-of-plane block (DOF a).
  static Eigen::Matrix4cd in_plane_block(const Matrix6cd& d);
  static Eigen::Matrix2cd out_of_plane_block(const Matrix6cd& d);
  /// The six omega^2 at q, ascending, (rad/s)^2.
  Vector6d omega_squared(const Eigen::Vector2d& q_per_m) const;
  /// ZA and ZO omega^2 at q, (rad/s)^2, from the closed form of the 2 x 2 out-of-plane block
  /// written without cancellation (1 - cos x = 2 sin^2(x/2)): resolves the q^4 ZA branch
  /// down to q = 2 pi / (microns), where the eigen solver's round-off (~1e-16 of the
  /// largest entry) would swamp it.
  std::array<double, 2> flexural_omega_squared(const Eigen::Vector2d& q_per_m) const;
  /// Phonon frequencies omega_n(q) along `direction` (normalised here) for each |q| in
  /// `q_per_m`: one row per q, six ascending columns, rad/s; an imaginary frequency
  /// (omega^2 < 0) is returned as -sqrt(-omega^2).
  Eigen::MatrixXd dispersion(const Eigen::Vector2d& direction,
                             const std::vector<double>& q_per_m) const;

  /// Force-constant (stiffness) matrix of a periodic cell, N/m, 3N x 3N, DOF 3 i + c; self
  /// terms from the acoustic sum rule K_ii = -sum_{j != i} K_ij.
  Eigen::MatrixXd force_constant_matrix(const PeriodicCell& cell) const;
  /// In-plane block (DOF 2 i + c, c = x, y) and out-of-plane block (DOF i) of a 3N x 3N K;
  /// the coupling blocks are exactly zero for a flat sheet.
  static Eigen::MatrixXd in_plane_block(const Eigen::MatrixXd& k);
  static Eigen::MatrixXd out_of_plane_block(const Eigen::MatrixXd& k);

  // --- checks -------------------------------------------------------------------------
  /// max over rows and components of |sum_j K_ij| / max |K_ij|: a rigid translation must
  /// give zero force.
  static double acoustic_sum_rule_residual(const Eigen::MatrixXd& k);
  /// Same for D(q = 0) of the primitive cell: max |D(0) e_translation| / max |D(0)|.
  double acoustic_sum_rule_residual_primitive() const;
  /// sum_j phi_to^(j) R_j^2 over the neighbours of one atom (shells counted geometrically),
  /// N m; zero is the out-of-plane rotational sum rule.
  double rotational_sum_rule_residual_N_m() const;
  /// Long-wave slopes omega / q of the LA and TA branches along `direction`, from
  /// |q| = 1e-3 / d (dispersion error ~ (q d)^2 ~ 1e-6).
  SoundVelocities sound_velocities(const Eigen::Vector2d& direction) const;
  /// C11, C12, C66, E_2D and nu from sound_velocities along x.
  ElasticConstants2D elastic_constants() const;
  /// Bending rigidity from the ZA branch omega = sqrt(kappa / rho_2D) q^2 at |q| along
  /// `direction`: kappa = rho_2D (omega / q^2)^2, J.
  double bending_rigidity_J(const Eigen::Vector2d& direction, double q_per_m) const;
  /// The long-wave limit of the same from the shells: m omega^2 = -(q^4 / 64)
  /// sum_j phi_to^(j) R_j^4 once the rotational rule holds, so
  /// kappa = -sum_j phi_to^(j) R_j^4 / (64 A_atom), J.
  double bending_rigidity_from_shells_J() const;

 private:
  ForceConstants fc_;
  GrapheneLattice lattice_;
  double mass_kg_;
  PeriodicCell primitive_;
  std::vector<LatticeBond> primitive_bonds_;
};

}  // namespace cosim::solid
