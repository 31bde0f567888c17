// The stiffness of a periodic rectangular lattice of coarse-grained particles (CGPs) as a
// translation-invariant kernel K(R), truncated to |R_x|, |R_y| <= range (DESIGN 4.3 items
// 2-3), its long-wave moments (Eq. 6) and the moment-matched truncation of item 3.
//
// Convention: K(R) is the block K_{0,R} of the stiffness matrix, so the force on CGP 0 is
// f_0 = -sum_R K(R) u_R and the energy (1/2) sum_ij u_i K(R_j - R_i) u_j. Its Fourier
// transform K(q) = sum_R K(R) exp(i q.R) expands at long wavelength as
//   in-plane:   K_ab(q) = A C_ajbl q_j q_l,
//   flexural:   K(q)    = A (D11 qx^4 + 2 (D12 + 2 D66) qx^2 qy^2 + D22 qy^4),
// with A the area per CGP, so the second moments of the in-plane block are the elastic
// constants (Eq. 6) and the fourth moments of the flexural block the bending rigidities:
//   sum K_xx Rx^2 = -2 A C11, sum K_xx Ry^2 = sum K_yy Rx^2 = -2 A C66,
//   sum K_yy Ry^2 = -2 A C22, sum K_xy Rx Ry = -A (C12 + C66);
//   sum K Rx^4 = 24 A D11, sum K Ry^4 = 24 A D22, sum K Rx^2 Ry^2 = 8 A (D12 + 2 D66).
// SI units: K in N/m, lengths in m, C in N/m, D in J.
#pragma once

#include <complex>
#include <vector>

#include <Eigen/Core>

namespace cosim::solid {

struct CgKernel {
  double ax_m = 0.0;  ///< lattice spacing along x (zigzag)
  double ay_m = 0.0;  ///< along y (armchair)
  int range = 2;
  std::vector<Eigen::Matrix2d> in_plane;  ///< (2 range + 1)^2 blocks, components x, y
  std::vector<double> flexural;           ///< (2 range + 1)^2 values, z

  /// An all-zero kernel of the given spacing and range.
  static CgKernel zero(double ax_m, double ay_m, int range);
  int width() const { return 2 * range + 1; }
  std::size_t index(int rx, int ry) const {
    return static_cast<std::size_t>((ry + range) * width() + (rx + range));
  }
  const Eigen::Matrix2d& ip(int rx, int ry) const { return in_plane[index(rx, ry)]; }
  Eigen::Matrix2d& ip(int rx, int ry) { return in_plane[index(rx, ry)]; }
  double zz(int rx, int ry) const { return flexural[index(rx, ry)]; }
  double& zz(int rx, int ry) { return flexural[index(rx, ry)]; }
  double cell_area_m2() const { return ax_m * ay_m; }

  Eigen::Matrix2cd in_plane_q(const Eigen::Vector2d& q_per_m) const;
  double flexural_q(const Eigen::Vector2d& q_per_m) const;
};

/// Long-wave moments of a kernel. The sums are the quantities that moment matching
/// restores; the constants follow from them by the relations at the top of this file.
struct KernelMoments {
  Eigen::Matrix2d in_plane_sum = Eigen::Matrix2d::Zero();  ///< sum_R K(R), N/m (0: sum rule)
  /// sum_R K_ab(R) R_j R_l; row a b = xx, xy, yx, yy; column j l = xx, xy, yy; N m.
  Eigen::Matrix<double, 4, 3> in_plane_second = Eigen::Matrix<double, 4, 3>::Zero();
  double flexural_sum = 0.0;                                 ///< N/m
  Eigen::Vector3d flexural_second = Eigen::Vector3d::Zero();  ///< xx, xy, yy; N m
  /// sum_R K(R) R^4 components xxxx, xxxy, xxyy, xyyy, yyyy; N m^3.
  Eigen::Matrix<double, 5, 1> flexural_fourth = Eigen::Matrix<double, 5, 1>::Zero();
};

/// The intensive constants of a sheet: in-plane (plane stress, N/m) and bending (J).
struct SheetConstants {
  double c11_N_m = 0.0, c22_N_m = 0.0, c12_N_m = 0.0, c66_N_m = 0.0;
  double d11_J = 0.0, d22_J = 0.0;
  double d_mixed_J = 0.0;  ///< D12 + 2 D66 (all that a periodic kernel determines)
  /// 2D Young's modulus along x, (C11 C22 - C12^2) / C22, N/m.
  double youngs_x_N_m() const { return (c11_N_m * c22_N_m - c12_N_m * c12_N_m) / c22_N_m; }
};

KernelMoments kernel_moments(const CgKernel& k);
SheetConstants constants_from_moments(const KernelMoments& m, double cell_area_m2);
/// The moments that a kernel with these constants has on a lattice of this cell area.
KernelMoments moments_from_constants(const SheetConstants& c, double cell_area_m2);

/// K(R) <- (K(R) + K(-R)^T) / 2: the stiffness matrix of a lattice is symmetric; removes
/// round-off asymmetry of a projection.
void symmetrize(CgKernel& k);

/// A copy of `k` with every entry of |R_x| or |R_y| above `range` dropped.
CgKernel truncated(const CgKernel& k, int range);

/// Moment-matched truncation (DESIGN 4.3 item 3): the smallest change (in the Euclidean
/// norm of the entries) that makes the sum rules hold (sum_R K = 0), the in-plane second
/// moments equal `target.in_plane_second`, the flexural second moments zero and its fourth
/// moments equal `target.flexural_fourth`. Throws std::invalid_argument when the range
/// cannot carry them (range 1 has no room for a zero second and a non-zero fourth moment).
void match_moments(CgKernel& k, const KernelMoments& target);

/// Smallest eigenvalue of K(q) (in-plane: of the 2 x 2 block) over an n x n grid of the
/// Brillouin zone (q = 0 excluded), relative to the largest; negative means unstable.
struct KernelSpectrum {
  double in_plane_min_rel = 0.0, flexural_min_rel = 0.0;
  double in_plane_max_N_m = 0.0, flexural_max_N_m = 0.0;  ///< largest eigenvalue of K(q)
};
KernelSpectrum kernel_spectrum(const CgKernel& k, int n = 48);

}  // namespace cosim::solid
