// One graphene sheet of coarse-grained particles (CGPs) standing on the plate: its size,
// placement and clamping (DESIGN 4.3 item 6, 5; the paper's section 3, Fig. 4).
#pragma once

#include <Eigen/Core>

#include "protocol/units.hpp"

namespace cosim::solid {

/// Carbon atoms lumped into one CGP of the paper's sheets (section 3: 2e6 atoms per CGP).
inline constexpr double kPaperAtomsPerCgp = 2.0e6;

/// A flat rectangular sheet of nx_cg x ny_cg CGPs, in Hartree atomic units (see
/// solid_model.hpp). Scene axes: x stream-wise, y up from the plate, z span-wise.
///
/// CGP (i, j), i = 0..nx_cg-1 across the width and j = 0..ny_cg-1 up the height, has index
/// l = j nx_cg + i: row j = 0 stands on the plate, row ny_cg-1 is the free top edge.
/// Upright (incline_deg = 0, the paper's sheets) the sheet's height runs along +y, its width
/// direction is e_w = R_y(theta) e_x = (cos theta, 0, -sin theta) and its normal
/// n = R_y(theta) e_z = (sin theta, 0, cos theta): theta = 0 lays the sheet parallel to the
/// flow (normal span-wise), theta = 90 deg makes it face the flow (normal along x).
/// incline_deg = psi then tilts the whole sheet about the z axis, its height towards +x:
/// every axis is R_z(-psi) of the upright one, the height e_h = (sin psi, cos psi, 0).
/// psi = 90 deg, theta = -90 deg lays it flat along the stream, a bar pointing downstream
/// (height +x, width +z span-wise, normal +y): the bar of Turek & Hron's benchmark
/// (docs/validation.md, "Turek & Hron's bar").
struct SheetSpec {
  int nx_cg = 5;   ///< CGPs across the width
  int ny_cg = 40;  ///< CGPs up the height
  /// Distances between neighbouring CGPs across the width and up the height, bohr.
  /// Default: square, dx_CG = dx_LB of Table 1 (A_L = 1). The RCGP lattice itself is
  /// rectangular, 4 sqrt(3) d x 6 d times 2^(N_r - 1) (0.2519 x 0.2181 um at 9 stages), and
  /// the paper's sheet (W 1.2 um, H 8.8 um for 5 x 40 CGPs) follows it.
  double width_spacing_bohr = protocol::UnitInputs{}.dx_m / protocol::PhysicalConstants::bohr_m;
  double height_spacing_bohr = protocol::UnitInputs{}.dx_m / protocol::PhysicalConstants::bohr_m;
  /// Middle of the bottom row (on the plate), bohr.
  Eigen::Vector3d base_bohr = Eigen::Vector3d::Zero();
  double theta_deg = 90.0;  ///< angle of attack, a rotation about the y axis
  double incline_deg = 0.0;  ///< then a tilt about -z, the height from +y towards +x
  int clamped_rows = 1;     ///< bottom rows j < clamped_rows are held to the plate
  /// [[sheet]] leading_edge = "pinned": the last held row is a hinge, its position held and
  /// the sheet free to rotate about it (no bending moment across it: w_bb = 0 there, a
  /// simply supported edge); false ("clamped"): the held rows also fix the slope (the
  /// mirror ghost row of sheet_stiffness.cpp, w' = 0).
  bool pinned = false;
  /// Lumped mass of one CGP, electron masses (default: 2e6 carbon atoms, 3.99e-20 kg).
  double cgp_mass_me = kPaperAtomsPerCgp * protocol::PhysicalConstants::carbon_mass_kg /
                       protocol::PhysicalConstants::electron_mass_kg;

  double cell_area_bohr2() const { return width_spacing_bohr * height_spacing_bohr; }
  Eigen::Index num_cgps() const { return Eigen::Index{nx_cg} * Eigen::Index{ny_cg}; }
  Eigen::Index index(int i, int j) const {
    return Eigen::Index{j} * Eigen::Index{nx_cg} + Eigen::Index{i};
  }
  /// The marked CGP of Fig. 4: middle of the top edge, (nx_cg / 2, ny_cg - 1).
  Eigen::Index marked_cgp() const { return index(nx_cg / 2, ny_cg - 1); }
  bool is_clamped(Eigen::Index l) const { return l < Eigen::Index{clamped_rows} * nx_cg; }
};

/// Throws std::invalid_argument (file:line and what to change) unless nx_cg, ny_cg >= 2,
/// spacing and mass are positive and finite, theta and the base point are finite, and
/// 0 <= clamped_rows < ny_cg.
void check_sheet_spec(const SheetSpec& spec);

/// Unit width direction e_w, height direction e_h and normal n of the sheet (see SheetSpec).
Eigen::Vector3d sheet_width_direction(const SheetSpec& spec);
Eigen::Vector3d sheet_height_direction(const SheetSpec& spec);
Eigen::Vector3d sheet_normal(const SheetSpec& spec);

/// CGP positions of the flat, undeformed sheet, one column per CGP in index order, bohr:
///   X_ij = base + (i - (nx_cg - 1) / 2) h_w e_w + j h_h e_h.
/// Checks the spec first.
Eigen::Matrix3Xd flat_sheet_positions(const SheetSpec& spec);

/// The midpoint of the sheet's free (top) edge at positions x (3 x num_cgps(), this sheet's
/// CGPs in index order, any unit): each CGP carries a full cell, so the free edge lies half
/// a spacing beyond the top row (docs/solid.md), and its midpoint is extrapolated from the
/// middles (means over i) of the two top rows r_N, r_(N-1):
///   x_A = r_N + (r_N - r_(N-1)) / 2,
/// second order in the spacing for a smooth deflection (a rotated straight end exactly).
/// Turek & Hron's point A (docs/validation.md, "Turek & Hron's bar").
Eigen::Vector3d free_edge_midpoint(const SheetSpec& spec, const Eigen::Matrix3Xd& x);

}  // namespace cosim::solid
