// The elastic energy of a finite sheet of CGPs, assembled from the RCGP constants (DESIGN
// 4.3 item 6: "element assembly with the RCGP constants").
//
// Why not the RCGP kernel itself: a truncated pair kernel on a finite lattice does not give
// free edges. Its tangential in-plane parts are not invariant under rotation, and a kernel
// derived in a periodic cell says nothing about the Gaussian-curvature term, which only
// acts at edges. So the finite sheet takes from the construction what is intensive and
// exact -- the elastic constants C (Eq. 6, second moments) and the bending rigidities D
// (fourth moments) -- and builds the energy from terms that are exact under rigid motion:
//
// - in-plane: bilinear (Q4) plane-stress elements on the cells between CGPs,
//   E = 1/2 int eps^T C eps dA, 2 x 2 Gauss points (translation and in-plane rotation give
//   zero strain exactly);
// - bending (Kirchhoff plate, w the normal displacement):
//   E = 1/2 int (D11 w_aa^2 + 2 D12 w_aa w_bb + D22 w_bb^2 + 4 D66 w_ab^2) dA,
//   with w_aa, w_bb the 3-point second differences at the CGPs that have both neighbours
//   (area h_a h_b each) and w_ab the 4-point cross difference on each cell (area h_a h_b).
//   In the bulk (square cells) this is exactly D/h^2 times the 13-point biharmonic stencil, which is what the
//   moment-matched RCGP flexural kernel becomes at range 2. A clamped row takes w_bb from a
//   mirror ghost (zero slope at the plate) with half the area; the free top row has no
//   w_bb (zero moment at a free edge).
//
// Axes of a sheet (sheet_spec.hpp): a along the width (index i), b up the height (j), and
// the normal n; every term's matrix here is in those local axes, 3 DOF per CGP (a, b, n).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "solid/rcgp/cg_kernel.hpp"
#include "solid/model/sheet_spec.hpp"

namespace cosim::solid {

/// Plate constants in Hartree atomic units: C in E_h / bohr^2, D in E_h.
struct PlateConstantsAu {
  double c11 = 0.0, c22 = 0.0, c12 = 0.0, c66 = 0.0;
  double d11 = 0.0, d22 = 0.0, d12 = 0.0, d66 = 0.0;
};

/// From the RCGP constants (SI). A periodic kernel fixes D12 + 2 D66 only; D12 is chosen as
/// bending_poisson sqrt(D11 D22) (0: kappa_G = -kappa). Throws std::invalid_argument when
/// the result is not positive definite or bending_poisson is outside [0, 0.5).
PlateConstantsAu plate_constants_au(const SheetConstants& si, double bending_poisson);

/// One term of the energy, E_t = 1/2 u_t^T K_t u_t, u_t the displacements (a, b, n) of the
/// term's CGPs (local sheet indices). `frame` lists the CGPs whose motion defines this
/// term's rotation in the corotational model: the cell for cell terms, the 3 x 3
/// neighbourhood of the CGP for node terms (never a collinear set). Empty for the clamped
/// row's term: its mirror ghost measures the slope against the plate, which does not
/// rotate, so the term is not invariant under rotation and must not be rotated.
struct StiffnessTerm {
  std::vector<Eigen::Index> nodes;
  Eigen::MatrixXd k;  ///< 3 nodes.size() square, E_h / bohr^2
  std::vector<Eigen::Index> frame;
};

std::vector<StiffnessTerm> sheet_stiffness_terms(const SheetSpec& spec, const PlateConstantsAu& c);

/// The sum of the terms as a sparse 3N x 3N matrix in the sheet's local axes, DOF 3 l + c.
Eigen::SparseMatrix<double> assemble_stiffness(const std::vector<StiffnessTerm>& terms,
                                               Eigen::Index num_cgps);

/// Rotation from the sheet's local axes (a, b, n) to the scene's (x, y, z): columns e_w,
/// e_h, n.
Eigen::Matrix3d sheet_axes(const SheetSpec& spec);

}  // namespace cosim::solid
