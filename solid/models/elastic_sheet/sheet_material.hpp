// A sheet of a continuum material instead of graphene's RCGP constants: [material] of a
// scene (solid/models/elastic_sheet/elastic_sheet_options.cpp), for the elastic sheet models. The bar of Turek &
// Hron's FSI benchmark (docs/validation.md, "Turek & Hron's bar") is the case it is made for.
//
// The benchmark's bar is a 2D (plane-strain) elastic body of thickness h in the plane of the
// flow. In the span-periodic 3D runs it is a sheet of CGPs whose plane holds the bar's axis
// and the span, bending out of that plane. A plane-strain bar is a plate in cylindrical
// bending with the span-wise strain and curvature held at zero, so its energy per unit area
// is the plate's with eps_aa = w_aa = 0:
//   stretching  1/2 C eps_bb^2,  C = E h / (1 - nu^2)         (plane-strain modulus times h)
//   bending     1/2 D w_bb^2,    D = E h^3 / (12 (1 - nu^2))  (per unit width)
//   mass        rho h per unit area.
// The sheet's edges along the span are free in the model, and a plate with a Poisson
// coupling C12 = nu C or D12 = nu D and free edges would relax the span-wise strain and
// curvature (anticlastic bending): its beam would be the plane-stress one, E h and
// E h^3 / 12, 1 / (1 - nu^2) = 1.19 times softer at nu = 0.4. Holding them at zero is what
// the span-periodic body does; the model does it by leaving the couplings out (C12 = D12 =
// 0): under a load uniform across the span eps_aa and w_aa then stay zero, and the energy is
// exactly the plane-strain bar's above. The remaining constants (C11 = C, C66 = G h and
// D11 = D, D66 = G h^3 / 12, G = E / (2 (1 + nu))) act only on motions that vary across the
// span, which the benchmark's bar has none of; they are the isotropic plate's.
//
// Not in the model: the shear deformation of the thick bar (Timoshenko; h / L = 1 / 17.5
// adds E' h^2 / (3 kappa G L^2) = 0.4 % to a cantilever's deflection under a uniform load,
// kappa = 5 / 6) and the bar's thickness in the fluid (the immersed boundary sees the
// sheet's mid-plane).
#pragma once

#include "solid/rcgp/cg_kernel.hpp"

namespace cosim::solid {

/// An isotropic, linear elastic material of a sheet of thickness h, SI units.
struct SheetMaterial {
  double youngs_modulus_Pa = 0.0;
  double poisson_ratio = 0.0;
  double density_kg_m3 = 0.0;
  double thickness_m = 0.0;
  /// rho h, kg/m^2.
  double mass_per_area_kg_m2() const { return density_kg_m3 * thickness_m; }
};

/// The plate constants of the plane-strain bar above (C12 = D12 = 0; the caller builds the
/// plate with bending_poisson 0, so that D12 + 2 D66 = 2 D66 = G h^3 / 6). Throws
/// std::invalid_argument unless E, rho and h are positive and finite and 0 <= nu < 0.5.
SheetConstants plane_strain_sheet_constants(const SheetMaterial& m);

}  // namespace cosim::solid
