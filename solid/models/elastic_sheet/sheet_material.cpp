#include "solid/models/elastic_sheet/sheet_material.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::solid {

SheetConstants plane_strain_sheet_constants(const SheetMaterial& m) {
  const double e = m.youngs_modulus_Pa, nu = m.poisson_ratio, h = m.thickness_m;
  if (!(e > 0.0) || !std::isfinite(e) || !(h > 0.0) || !std::isfinite(h) || !(m.density_kg_m3 > 0.0) ||
      !std::isfinite(m.density_kg_m3) || !(nu >= 0.0 && nu < 0.5))
    throw std::invalid_argument(std::string(__FILE__) + ": a sheet material needs E, density and thickness " +
                                "positive and finite and a Poisson ratio in [0, 0.5); got E " + std::to_string(e) +
                                " Pa, nu " + std::to_string(nu) + ", rho " + std::to_string(m.density_kg_m3) +
                                " kg/m^3, h " + std::to_string(h) + " m");
  const double plane_strain = e / (1.0 - nu * nu);  // E' = E / (1 - nu^2)
  const double shear = e / (2.0 * (1.0 + nu));      // G
  SheetConstants c;
  c.c11_N_m = c.c22_N_m = plane_strain * h;             // C = E' h
  c.c12_N_m = 0.0;                                      // span-wise strain held (plane strain)
  c.c66_N_m = shear * h;                                // G h
  c.d11_J = c.d22_J = plane_strain * h * h * h / 12.0;  // D = E' h^3 / 12
  c.d_mixed_J = 2.0 * shear * h * h * h / 12.0;         // D12 + 2 D66 with D12 = 0, D66 = G h^3 / 12
  return c;
}

}  // namespace cosim::solid
