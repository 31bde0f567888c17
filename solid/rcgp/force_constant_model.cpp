#include "solid/rcgp/force_constant_model.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::solid {

namespace {

using cd = std::complex<double>;

/// Long-wave probe |q| d for the sound velocities: dispersion error ~ (q d)^2 ~ 1e-6,
/// round-off of the eigen solver ~ 1e-16 / (q d)^2 ~ 1e-10.
constexpr double kLongWaveQD = 1e-3;

/// Indices of the in-plane (x, y) and out-of-plane (z) DOF of atom `atom` among 3 per atom.
constexpr int dof(int atom, int component) { return 3 * atom + component; }

}  // namespace

ForceConstants ForceConstants::saito1998_published() {
  // Saito, Dresselhaus and Dresselhaus (1998), Table 9.1: {phi_r, phi_ti, phi_to} per shell
  // in 1e4 dyn/cm, as collected in ../shared/reference/graphene-notes.md.
  constexpr std::array<std::array<double, 3>, GrapheneLattice::kShells> table{{
      {36.50, 24.50, 9.82},
      {8.80, -3.23, -0.40},
      {3.00, -5.25, 0.15},
      {-1.92, 2.29, -0.58},
  }};
  ForceConstants fc;
  for (std::size_t s = 0; s < table.size(); ++s) {
    fc.shells[s] = ShellForceConstants{table[s][0] * kSaitoUnitN_m, table[s][1] * kSaitoUnitN_m,
                                       table[s][2] * kSaitoUnitN_m};
  }
  return fc;
}

ForceConstants ForceConstants::saito1998_corrected(const GrapheneLattice& lattice) {
  ForceConstants fc = saito1998_published();
  const auto count = lattice.neighbours_per_shell();
  // sum_s N_s phi_to^(s) R_s^2 = 0, solved for phi_to^(4).
  double others = 0.0;
  for (int s = 1; s < GrapheneLattice::kShells; ++s) {
    const double r = lattice.shell_radius_m(s);
    others += count[static_cast<std::size_t>(s - 1)] *
              fc.shells[static_cast<std::size_t>(s - 1)].tangential_out_N_m * r * r;
  }
  const double r4 = lattice.shell_radius_m(GrapheneLattice::kShells);
  const int n4 = count[GrapheneLattice::kShells - 1];
  if (n4 == 0) throw std::logic_error("ForceConstants: no 4th-shell neighbours found");
  fc.shells[GrapheneLattice::kShells - 1].tangential_out_N_m = -others / (n4 * r4 * r4);
  return fc;
}

ForceConstantModel::ForceConstantModel(ForceConstants constants, GrapheneLattice lattice,
                                       double mass_kg)
    : fc_(constants),
      lattice_(lattice),
      mass_kg_(mass_kg),
      primitive_(lattice_.primitive_cell()),
      primitive_bonds_(lattice_.bonds(primitive_)) {
  if (!(mass_kg > 0.0)) {
    throw std::invalid_argument("ForceConstantModel: the atom mass must be positive, got " +
                                std::to_string(mass_kg) + " kg");
  }
}

double ForceConstantModel::areal_density_kg_m2() const {
  return mass_kg_ / lattice_.area_per_atom_m2();
}

Eigen::Matrix3d ForceConstantModel::pair_tensor(int shell, const Eigen::Vector2d& r_m) const {
  if (shell < 1 || shell > GrapheneLattice::kShells) {
    throw std::invalid_argument("ForceConstantModel: shell " + std::to_string(shell) +
                                " is not one of 1..4");
  }
  const ShellForceConstants& c = fc_.shells[static_cast<std::size_t>(shell - 1)];
  const Eigen::Vector2d n2 = r_m.normalized();
  const Eigen::Vector3d n(n2.x(), n2.y(), 0.0);
  const Eigen::Vector3d z(0.0, 0.0, 1.0);
  const Eigen::Vector3d t = z.cross(n);
  return c.radial_N_m * n * n.transpose() + c.tangential_in_N_m * t * t.transpose() +
         c.tangential_out_N_m * z * z.transpose();
}

ForceConstantModel::Matrix6cd ForceConstantModel::dynamical_matrix(
    const Eigen::Vector2d& q_per_m) const {
  Matrix6cd k = Matrix6cd::Zero();
  for (const auto& b : primitive_bonds_) {
    const Eigen::Matrix3cd phi = pair_tensor(b.shell, b.r_m).cast<cd>();
    const cd phase = std::polar(1.0, q_per_m.dot(b.r_m));
    k.block<3, 3>(dof(b.i, 0), dof(b.j, 0)) -= phi * phase;
    k.block<3, 3>(dof(b.i, 0), dof(b.i, 0)) += phi;
  }
  return k / mass_kg_;
}

Eigen::Matrix4cd ForceConstantModel::in_plane_block(const Matrix6cd& d) {
  Eigen::Matrix4cd out;
  for (int a = 0; a < 2; ++a) {
    for (int c = 0; c < 2; ++c) {
      for (int b = 0; b < 2; ++b) {
        for (int e = 0; e < 2; ++e) out(2 * a + c, 2 * b + e) = d(dof(a, c), dof(b, e));
      }
    }
  }
  return out;
}

Eigen::Matrix2cd ForceConstantModel::out_of_plane_block(const Matrix6cd& d) {
  Eigen::Matrix2cd out;
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2; ++b) out(a, b) = d(dof(a, 2), dof(b, 2));
  }
  return out;
}

ForceConstantModel::Vector6d ForceConstantModel::omega_squared(
    const Eigen::Vector2d& q_per_m) const {
  const Eigen::SelfAdjointEigenSolver<Matrix6cd> es(dynamical_matrix(q_per_m),
                                                    Eigen::EigenvaluesOnly);
  return es.eigenvalues();
}

std::array<double, 2> ForceConstantModel::flexural_omega_squared(
    const Eigen::Vector2d& q_per_m) const {
  // Out-of-plane block of K(q) = [[a_A, -(P - c)], [-(P - c)*, a_B]] with, for atom a,
  //   a_a = S_a + P,  S_a = sum_{same sublattice} phi_to (1 - cos q.r),
  //   P = sum_{other sublattice} phi_to,  c = sum_{other} phi_to (1 - exp(i q.r)).
  // a_A = a_B by inversion symmetry (averaged here), so omega^2 m = S + P -+ |P - c|, and
  //   P - |P - c| = (2 P Re c - |c|^2) / (P + |P - c|)
  // keeps the small ZA eigenvalue free of cancellation.
  std::array<double, 2> s_self{0.0, 0.0};
  double p = 0.0;
  cd c = 0.0;
  for (const auto& b : primitive_bonds_) {
    const double phi = fc_.shells[static_cast<std::size_t>(b.shell - 1)].tangential_out_N_m;
    const double x = q_per_m.dot(b.r_m);
    const double one_minus_cos = 2.0 * std::sin(0.5 * x) * std::sin(0.5 * x);
    if (primitive_.sublattice[static_cast<std::size_t>(b.j)] ==
        primitive_.sublattice[static_cast<std::size_t>(b.i)]) {
      s_self[static_cast<std::size_t>(b.i)] += phi * one_minus_cos;
    } else if (b.i == 0) {
      p += phi;
      c += phi * cd(one_minus_cos, -std::sin(x));
    }
  }
  const double s = 0.5 * (s_self[0] + s_self[1]);
  const double off = std::abs(cd(p, 0.0) - c);
  const double denom = p + off;
  const double za = denom > 0.0 ? s + (2.0 * p * c.real() - std::norm(c)) / denom
                                 : s + p - off;
  return {za / mass_kg_, (s + p + off) / mass_kg_};
}

Eigen::MatrixXd ForceConstantModel::dispersion(const Eigen::Vector2d& direction,
                                               const std::vector<double>& q_per_m) const {
  const Eigen::Vector2d e = direction.normalized();
  Eigen::MatrixXd out(static_cast<Eigen::Index>(q_per_m.size()), 6);
  for (std::size_t k = 0; k < q_per_m.size(); ++k) {
    const Vector6d w2 = omega_squared(q_per_m[k] * e);
    for (int n = 0; n < 6; ++n) {
      const double v = w2(n);
      out(static_cast<Eigen::Index>(k), n) = v >= 0.0 ? std::sqrt(v) : -std::sqrt(-v);
    }
  }
  return out;
}

Eigen::MatrixXd ForceConstantModel::force_constant_matrix(const PeriodicCell& cell) const {
  const Eigen::Index n = 3 * static_cast<Eigen::Index>(cell.size());
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
  for (const auto& b : lattice_.bonds(cell)) {
    const Eigen::Matrix3d phi = pair_tensor(b.shell, b.r_m);
    k.block<3, 3>(dof(b.i, 0), dof(b.j, 0)) -= phi;
    k.block<3, 3>(dof(b.i, 0), dof(b.i, 0)) += phi;  // K_ii = -sum_j K_ij
  }
  return k;
}

Eigen::MatrixXd ForceConstantModel::in_plane_block(const Eigen::MatrixXd& k) {
  const Eigen::Index atoms = k.rows() / 3;
  Eigen::MatrixXd out(2 * atoms, 2 * atoms);
  for (Eigen::Index i = 0; i < atoms; ++i) {
    for (Eigen::Index j = 0; j < atoms; ++j) {
      out.block<2, 2>(2 * i, 2 * j) = k.block<2, 2>(3 * i, 3 * j);
    }
  }
  return out;
}

Eigen::MatrixXd ForceConstantModel::out_of_plane_block(const Eigen::MatrixXd& k) {
  const Eigen::Index atoms = k.rows() / 3;
  Eigen::MatrixXd out(atoms, atoms);
  for (Eigen::Index i = 0; i < atoms; ++i) {
    for (Eigen::Index j = 0; j < atoms; ++j) out(i, j) = k(3 * i + 2, 3 * j + 2);
  }
  return out;
}

double ForceConstantModel::acoustic_sum_rule_residual(const Eigen::MatrixXd& k) {
  const Eigen::Index atoms = k.rows() / 3;
  Eigen::MatrixXd translations = Eigen::MatrixXd::Zero(k.cols(), 3);
  for (Eigen::Index i = 0; i < atoms; ++i) {
    for (int c = 0; c < 3; ++c) translations(3 * i + c, c) = 1.0;
  }
  const double scale = k.cwiseAbs().maxCoeff();
  return scale > 0.0 ? (k * translations).cwiseAbs().maxCoeff() / scale : 0.0;
}

double ForceConstantModel::acoustic_sum_rule_residual_primitive() const {
  // D(0) applied to a rigid translation along c: the row sums over the same component.
  const Matrix6cd d0 = dynamical_matrix(Eigen::Vector2d::Zero());
  double worst = 0.0;
  for (int row = 0; row < 6; ++row) {
    for (int c = 0; c < 3; ++c) {
      worst = std::max(worst, std::abs(d0(row, dof(0, c)) + d0(row, dof(1, c))));
    }
  }
  return worst / d0.cwiseAbs().maxCoeff();
}

double ForceConstantModel::rotational_sum_rule_residual_N_m() const {
  double sum = 0.0;
  for (const auto& b : primitive_bonds_) {
    if (b.i != 0) continue;
    sum += fc_.shells[static_cast<std::size_t>(b.shell - 1)].tangential_out_N_m *
           b.r_m.squaredNorm();
  }
  return sum;
}

SoundVelocities ForceConstantModel::sound_velocities(const Eigen::Vector2d& direction) const {
  const double q = kLongWaveQD / lattice_.bond_length_m();
  const Eigen::Vector2d qv = q * direction.normalized();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4cd> es(
      in_plane_block(dynamical_matrix(qv)), Eigen::EigenvaluesOnly);
  // Ascending: TA, LA, then the two in-plane optical branches.
  return SoundVelocities{std::sqrt(es.eigenvalues()(1)) / q, std::sqrt(es.eigenvalues()(0)) / q};
}

ElasticConstants2D ForceConstantModel::elastic_constants() const {
  const SoundVelocities v = sound_velocities(Eigen::Vector2d::UnitX());
  const double rho = areal_density_kg_m2();
  ElasticConstants2D e;
  e.c11_N_m = rho * v.longitudinal_m_s * v.longitudinal_m_s;
  e.c66_N_m = rho * v.transverse_m_s * v.transverse_m_s;
  e.c12_N_m = e.c11_N_m - 2.0 * e.c66_N_m;
  e.youngs_modulus_N_m = (e.c11_N_m * e.c11_N_m - e.c12_N_m * e.c12_N_m) / e.c11_N_m;
  e.poisson_ratio = e.c12_N_m / e.c11_N_m;
  return e;
}

double ForceConstantModel::bending_rigidity_J(const Eigen::Vector2d& direction,
                                              double q_per_m) const {
  const double w2 = flexural_omega_squared(q_per_m * direction.normalized())[0];
  return areal_density_kg_m2() * w2 / (q_per_m * q_per_m * q_per_m * q_per_m);
}

double ForceConstantModel::bending_rigidity_from_shells_J() const {
  double sum = 0.0;
  for (const auto& b : primitive_bonds_) {
    if (b.i != 0) continue;
    const double r2 = b.r_m.squaredNorm();
    sum += fc_.shells[static_cast<std::size_t>(b.shell - 1)].tangential_out_N_m * r2 * r2;
  }
  return -sum / (64.0 * lattice_.area_per_atom_m2());
}

}  // namespace cosim::solid
