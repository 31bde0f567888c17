#include "solid/models/elastic_sheet/elastic_sheet_options.hpp"

#include <cmath>

#include "protocol/config/scene_reader.hpp"
#include "protocol/units.hpp"

// Why the limits are what they are:
//  - stages 1..16 and truncation_range 2 or 3: what the RCGP construction accepts
//    (rcgp_construction.hpp). 16 stages are Lambda = 2^15 x 1 nm = 33 um per CGP, beyond
//    any sheet of the paper; range 1 cannot carry bending (no room for a zero second and a
//    non-zero fourth flexural moment).
//  - bending_poisson in [0, 0.5): the Poisson ratio of an isotropic plate lies in (-1, 0.5);
//    graphene's bending Poisson ratio is small and positive, and a negative one has no use
//    in these scenes. 0.5 is the incompressible limit.
//  - cutoff_um: a length within Table::length_um's range, like every length of a scene.
//  - gravity_m_s2: finite, each component at most 1e15 m/s^2 in magnitude. A micrometre flag
//    at the lattice's speeds needs a large g for a Froude number of order one (L = 0.44 um,
//    U = 60 m/s, Fr = 0.5: g = Fr U^2 / L = 4e9 m/s^2); 1e15 leaves room and keeps m g far
//    from overflowing in atomic units.
//  - [material]: E in (0, 1e13] Pa (diamond is 1.2e12), the density in (0, 1e5] kg/m^3
//    (osmium is 2.26e4), the thickness in [1e-15, 1] m (the range of every scene length,
//    a femtometre to a metre), Poisson ratio in [0, 0.5) (1 - nu^2 > 0 and below the
//    incompressible limit; a negative one has no use in these scenes). All four or none:
//    a bar with one of them left at a default would be a silent guess.

namespace cosim::solid {

namespace {

using protocol::config::Table;

constexpr int kStagesMin = 1, kStagesMax = 16;
constexpr double kGravityMax = 1e15;  ///< m/s^2, per component
constexpr double kBendingPoissonMax = 0.5;  ///< exclusive
constexpr double kYoungsMax_Pa = 1e13, kDensityMax_kg_m3 = 1e5;
constexpr double kThicknessMin_m = 1e-15, kThicknessMax_m = 1.0;
constexpr double kPoissonMax = 0.5;  ///< exclusive

void read_rcgp(const Table& sec, SolidConfig& config) {
  RcgpOptions& o = config.rcgp;
  if (const auto v = sec.integer_in("stages", kStagesMin, kStagesMax,
                                    " (stage 1 is about 1 nm per CGP, each stage doubles it; 9 "
                                    "reach the paper's 0.25 um)"))
    o.stages = *v;
  if (const auto v = sec.choice("flexural_scaling", {"paper", "physical"}))
    o.flexural_scaling = *v == 0 ? FlexuralScaling::Paper : FlexuralScaling::Physical;
  if (const auto v = sec.integer("truncation_range")) {
    if (*v != 2 && *v != 3)
      sec.bad("truncation_range", "must be 2 or 3 (CG spacings; range 1 cannot carry bending)");
    o.truncation_range = int(*v);
  }
  if (const auto v = sec.boolean("moment_matching")) o.moment_matching = *v;
  if (const auto v = sec.number("bending_poisson")) {
    if (!(*v >= 0.0 && *v < kBendingPoissonMax))
      sec.bad("bending_poisson", "must be in [0, 0.5) (the Poisson ratio of the bending energy)");
    o.bending_poisson = *v;
  }
  if (const auto v = sec.string("cache_dir")) o.cache_dir = *v;
}

void read_contact(const Table& sec, SolidConfig& config) {
  using protocol::PhysicalConstants;
  if (const auto v = sec.positive("epsilon_eV", "the Lennard-Jones energy, eV"))
    config.contact.epsilon_eV = *v;
  if (const auto v = sec.length_um("cutoff_um", "the cut-off sigma, micrometres"))
    config.contact.cutoff_bohr = *v * 1e-6 / PhysicalConstants::bohr_m;
}

void read_body_force(const Table& sec, SolidConfig& config) {
  const char* shape = "must be an array of three finite numbers [gx, gy, gz] in m/s^2, each at most 1e15 "
                      "in magnitude (the body force m g on every CGP)";
  if (const auto g = sec.numbers("gravity_m_s2", 3, 3, shape))
    for (int c = 0; c < 3; ++c) {
      const double v = (*g)[std::size_t(c)];
      if (!(std::abs(v) <= kGravityMax)) sec.bad("gravity_m_s2", shape);
      config.body.gravity_m_s2[c] = v;
    }
}

void read_material(const Table& sec, SolidConfig& config) {
  if (!sec.present()) return;
  SheetMaterial m;
  const auto need = [&](std::string_view key, const std::string& what) {
    const auto v = sec.positive(key, what);
    if (!v) sec.missing(key, what + "; [material] needs youngs_modulus_Pa, poisson_ratio, density_kg_m3 and thickness_m");
    return *v;
  };
  m.youngs_modulus_Pa = need("youngs_modulus_Pa", "Young's modulus E of the sheet's material, Pa");
  if (m.youngs_modulus_Pa > kYoungsMax_Pa)
    sec.bad("youngs_modulus_Pa", "must be in (0, 1e13] Pa (Young's modulus E)");
  m.density_kg_m3 = need("density_kg_m3", "the material's density rho, kg/m^3");
  if (m.density_kg_m3 > kDensityMax_kg_m3) sec.bad("density_kg_m3", "must be in (0, 1e5] kg/m^3 (the density rho)");
  m.thickness_m = need("thickness_m", "the sheet's thickness h, metres (the bar's in the plane of the flow)");
  if (!(m.thickness_m >= kThicknessMin_m && m.thickness_m <= kThicknessMax_m))
    sec.bad("thickness_m", "must be in [1e-15, 1] metres (the sheet's thickness h)");
  const auto nu = sec.number("poisson_ratio");
  if (!nu) sec.missing("poisson_ratio", "Poisson's ratio nu of the material, in [0, 0.5)");
  if (!(*nu >= 0.0 && *nu < kPoissonMax))
    sec.bad("poisson_ratio", "must be in [0, 0.5) (Poisson's ratio nu; the bar is plane strain, E / (1 - nu^2))");
  m.poisson_ratio = *nu;
  config.material = m;
}

constexpr std::string_view kRcgpKeys[] = {"stages",          "flexural_scaling",
                                          "truncation_range", "moment_matching",
                                          "bending_poisson", "cache_dir"};
constexpr std::string_view kContactKeys[] = {"epsilon_eV", "cutoff_um"};
constexpr std::string_view kBodyForceKeys[] = {"gravity_m_s2"};
constexpr std::string_view kMaterialKeys[] = {"youngs_modulus_Pa", "poisson_ratio", "density_kg_m3",
                                              "thickness_m"};

}  // namespace

const ModelOptions kRcgpOptions{"solid", kRcgpKeys, &read_rcgp};
const ModelOptions kContactOptions{"contact", kContactKeys, &read_contact};
const ModelOptions kBodyForceOptions{"solid", kBodyForceKeys, &read_body_force};
const ModelOptions kMaterialOptions{"material", kMaterialKeys, &read_material};

std::span<const std::string_view> rcgp_option_keys() { return kRcgpKeys; }

}  // namespace cosim::solid
