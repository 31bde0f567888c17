// The smoothed delta function of the immersed boundary (Eqs. 22-23) and the 4x4x4 stencil
// of lattice nodes it covers around one marker.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

namespace cosim::fluid {

/// Half-width of the kernel, h = 2 dx (Eq. 23, Niu et al. 2006), in lattice units.
constexpr double kDeltaHalfWidth = 2.0;
/// Lattice nodes per axis with a non-zero weight: those within |x| < h.
constexpr int kDeltaNodes = 4;

/// Eq. 23: delta_h(x) = (1 + cos(pi x / h)) / (2 h) for |x| <= h, else 0; h = 2 dx.
/// Its sum over the integer nodes is exactly 1 for every offset (the cosines of the four
/// nodes cancel in pairs), but its first moment is not exactly the position: see
/// delta_first_moment_error().
inline double delta_h(double x) {
  constexpr double h = kDeltaHalfWidth;
  if (std::abs(x) >= h) return 0.0;
  return (1.0 + std::cos(std::numbers::pi * x / h)) / (2.0 * h);
}

/// sum_i (i - X) delta_h(i - X) over the integer nodes i, for a marker at X = floor(X) + s:
///   e(s) = 1/2 - s + (sin(pi s / 2) - cos(pi s / 2)) / 2,
/// zero at s = 0 and 1/2 and |e| < 0.0212 dx in between. The cosine kernel conserves force
/// (zeroth moment) exactly and torque (first moment) only to this error, unlike Peskin's
/// 4-point kernel; the tests check both statements.
inline double delta_first_moment_error(double s) {
  const double a = 0.5 * std::numbers::pi * s;
  return 0.5 - s + 0.5 * (std::sin(a) - std::cos(a));
}

/// The nodes and weights of D(x - X) = prod_axes delta_h(x_a - X_a) (Eq. 22) for a marker
/// at X: along axis a the nodes first[a] .. first[a] + 3, with weights w[a][0..3].
/// Nodes are in unwrapped lattice coordinates (cell (i,j,k) centred at (i,j,k)); wrapping
/// and clipping to the domain is the caller's business.
struct DeltaStencil {
  std::array<int, 3> first{};
  std::array<std::array<double, kDeltaNodes>, 3> w{};

  /// Eq. 22: D at node (first[0] + i, first[1] + j, first[2] + k).
  double weight(int i, int j, int k) const { return w[0][i] * w[1][j] * w[2][k]; }
};

/// Eq. 22-23 evaluated at the 4 x 4 x 4 nodes around X: per axis the nodes
/// floor(X) - 1 .. floor(X) + 2, which contain every node with |x - X| < h = 2.
inline DeltaStencil delta_stencil(const std::array<double, 3>& X) {
  DeltaStencil s;
  for (int a = 0; a < 3; ++a) {
    const double base = std::floor(X[a]);
    s.first[a] = static_cast<int>(base) - 1;
    for (int i = 0; i < kDeltaNodes; ++i) s.w[a][i] = delta_h(base - 1.0 + i - X[a]);
  }
  return s;
}

}  // namespace cosim::fluid
