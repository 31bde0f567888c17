// Flat graphene geometry for the atomistic harmonic model (DESIGN 4.3 item 1) and the
// periodic super cell of the first coarse-graining stage (DESIGN 4.3 item 2).
//
// Orientation: x runs along the zigzag direction, y along the armchair direction, so that
// one bond of every atom is parallel to y. The primitive cell has lattice vectors
//   a1 = d (sqrt(3)/2, 3/2),  a2 = d (-sqrt(3)/2, 3/2)
// and the basis A = (0, 0), B = (0, d). The rectangular unit cell of the coarse graining is
// 2 sqrt(3) d x 3 d with 8 atoms, so N1 x N2 of them span 2 N1 sqrt(3) d x 3 N2 d
// (10 x 10: 800 atoms, 20 sqrt(3) d x 30 d, as DESIGN 4.3 item 2 asks).
//
// Neighbour shells 1..4 (distances d, sqrt(3) d, 2 d, sqrt(7) d; 3, 6, 3, 6 neighbours) are
// found geometrically over periodic images, so a cell smaller than the interaction range
// (several images of one atom in range) is handled exactly. SI units (m) throughout.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Dense>

namespace cosim::solid {

/// A periodic 2D cell of atoms: the columns of `lattice_m` are the periods.
struct PeriodicCell {
  Eigen::Matrix2d lattice_m = Eigen::Matrix2d::Zero();
  std::vector<Eigen::Vector2d> positions_m;
  std::vector<int> sublattice;  ///< 0 for A, 1 for B
  int size() const { return static_cast<int>(positions_m.size()); }
};

/// A bond from atom i to one periodic image of atom j: r_m = x_j + L n - x_i.
struct LatticeBond {
  int i = 0;
  int j = 0;
  int shell = 0;  ///< 1..4
  Eigen::Vector2d r_m = Eigen::Vector2d::Zero();
};

class GrapheneLattice {
 public:
  static constexpr int kShells = 4;
  /// Carbon-carbon distance of flat graphene, 1.42 Angstrom.
  static constexpr double kBondLengthM = 1.42e-10;

  explicit GrapheneLattice(double bond_length_m = kBondLengthM);

  double bond_length_m() const { return d_; }
  /// Shell radius R_s for s = 1..4: d, sqrt(3) d, 2 d, sqrt(7) d.
  double shell_radius_m(int shell) const;
  /// Area per atom, 3 sqrt(3) d^2 / 4.
  double area_per_atom_m2() const;

  /// The two-atom primitive cell (a1, a2; basis A, B).
  PeriodicCell primitive_cell() const;
  /// N1 x N2 rectangular 8-atom unit cells (2 sqrt(3) d x 3 d each), periodic.
  /// Throws std::invalid_argument unless n1, n2 >= 1.
  PeriodicCell rectangular_supercell(int n1, int n2) const;

  /// All bonds of shells 1..4 from every atom of `cell`, over all periodic images.
  std::vector<LatticeBond> bonds(const PeriodicCell& cell) const;
  /// Number of neighbours per shell of one atom, counted from the bonds of the primitive
  /// cell (3, 6, 3, 6 for graphene).
  std::array<int, kShells> neighbours_per_shell() const;

 private:
  double d_;
};

}  // namespace cosim::solid
