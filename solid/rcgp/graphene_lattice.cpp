#include "solid/rcgp/graphene_lattice.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::solid {

namespace {

/// R_s^2 / d^2 of the shells 1..4 of the honeycomb lattice.
constexpr std::array<double, GrapheneLattice::kShells> kShellRadiusSquaredOverD2{1.0, 3.0, 4.0,
                                                                                 7.0};
/// Distances within this fraction of d count as the shell (the next shell, 3 d, is 0.35 d
/// beyond the 4th).
constexpr double kShellTolerance = 1e-6;

}  // namespace

GrapheneLattice::GrapheneLattice(double bond_length_m) : d_(bond_length_m) {
  if (!(bond_length_m > 0.0)) {
    throw std::invalid_argument("GrapheneLattice: the bond length must be positive, got " +
                                std::to_string(bond_length_m) + " m");
  }
}

double GrapheneLattice::shell_radius_m(int shell) const {
  if (shell < 1 || shell > kShells) {
    throw std::invalid_argument("GrapheneLattice: shell " + std::to_string(shell) +
                                " is not one of 1..4");
  }
  return d_ * std::sqrt(kShellRadiusSquaredOverD2[static_cast<std::size_t>(shell - 1)]);
}

double GrapheneLattice::area_per_atom_m2() const { return 3.0 * std::sqrt(3.0) * d_ * d_ / 4.0; }

PeriodicCell GrapheneLattice::primitive_cell() const {
  const double s3 = std::sqrt(3.0);
  PeriodicCell cell;
  cell.lattice_m.col(0) = d_ * Eigen::Vector2d(s3 / 2.0, 1.5);
  cell.lattice_m.col(1) = d_ * Eigen::Vector2d(-s3 / 2.0, 1.5);
  cell.positions_m = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, d_)};
  cell.sublattice = {0, 1};
  return cell;
}

PeriodicCell GrapheneLattice::rectangular_supercell(int n1, int n2) const {
  if (n1 < 1 || n2 < 1) {
    throw std::invalid_argument("GrapheneLattice: the super cell needs at least 1 x 1 unit "
                                "cells, got " + std::to_string(n1) + " x " +
                                std::to_string(n2));
  }
  const double s3 = std::sqrt(3.0);
  const double wx = 2.0 * s3 * d_;  // rectangular unit cell, 8 atoms
  const double wy = 3.0 * d_;
  // The 4-atom rectangle sqrt(3) d x 3 d (A, B, A + a1, B + a1), twice along x.
  const std::array<Eigen::Vector2d, 4> four{Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, d_),
                                            Eigen::Vector2d(s3 / 2.0 * d_, 1.5 * d_),
                                            Eigen::Vector2d(s3 / 2.0 * d_, 2.5 * d_)};
  const std::array<int, 4> four_sub{0, 1, 0, 1};
  PeriodicCell cell;
  cell.lattice_m << n1 * wx, 0.0, 0.0, n2 * wy;
  cell.positions_m.reserve(static_cast<std::size_t>(8 * n1 * n2));
  for (int c2 = 0; c2 < n2; ++c2) {
    for (int c1 = 0; c1 < n1; ++c1) {
      for (int half = 0; half < 2; ++half) {
        const Eigen::Vector2d origin(c1 * wx + half * s3 * d_, c2 * wy);
        for (std::size_t k = 0; k < four.size(); ++k) {
          cell.positions_m.push_back(origin + four[k]);
          cell.sublattice.push_back(four_sub[k]);
        }
      }
    }
  }
  return cell;
}

std::vector<LatticeBond> GrapheneLattice::bonds(const PeriodicCell& cell) const {
  const double r_max = shell_radius_m(kShells) * (1.0 + kShellTolerance);
  const Eigen::Matrix2d& lat = cell.lattice_m;
  const double area = std::abs(lat.determinant());
  if (!(area > 0.0)) throw std::invalid_argument("GrapheneLattice: degenerate periodic cell");
  // Image range: |n_k| h_k <= r_max + (extent of the basis), h_k the spacing of the lattice
  // lines parallel to the other period.
  double extent = 0.0;
  for (const auto& p : cell.positions_m) {
    for (const auto& q : cell.positions_m) extent = std::max(extent, (p - q).norm());
  }
  const double h0 = area / lat.col(1).norm();
  const double h1 = area / lat.col(0).norm();
  const int m0 = static_cast<int>(std::ceil((r_max + extent) / h0)) + 1;
  const int m1 = static_cast<int>(std::ceil((r_max + extent) / h1)) + 1;

  std::vector<LatticeBond> out;
  for (int i = 0; i < cell.size(); ++i) {
    for (int j = 0; j < cell.size(); ++j) {
      for (int n0 = -m0; n0 <= m0; ++n0) {
        for (int n1 = -m1; n1 <= m1; ++n1) {
          const Eigen::Vector2d r = cell.positions_m[static_cast<std::size_t>(j)] +
                                    lat * Eigen::Vector2d(n0, n1) -
                                    cell.positions_m[static_cast<std::size_t>(i)];
          const double r2 = r.squaredNorm() / (d_ * d_);
          for (int s = 0; s < kShells; ++s) {
            const double target = kShellRadiusSquaredOverD2[static_cast<std::size_t>(s)];
            if (std::abs(r2 - target) < kShellTolerance * target) {
              out.push_back(LatticeBond{i, j, s + 1, r});
            }
          }
        }
      }
    }
  }
  return out;
}

std::array<int, GrapheneLattice::kShells> GrapheneLattice::neighbours_per_shell() const {
  std::array<int, kShells> count{};
  for (const auto& b : bonds(primitive_cell())) {
    if (b.i == 0) ++count[static_cast<std::size_t>(b.shell - 1)];
  }
  return count;
}

}  // namespace cosim::solid
