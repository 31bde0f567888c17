// What a solid model is built from: the sheets of a scene and the models' typed options
// (DESIGN 2.5). Parsing a scene file into this struct happens in solid_scene.cpp; models
// never see TOML.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solid/models/elastic_sheet/sheet_material.hpp"
#include "solid/model/sheet_spec.hpp"

namespace cosim::solid {

/// How the flexural (out-of-plane) block of the CG stiffness scales from stage to stage
/// (DESIGN 4.3 item 4).
enum class FlexuralScaling {
  /// K^(j+1) = lambda^(d-2) K^(j) = K^(j) for every block, as the paper states (section
  /// 2.1): bending is Lambda^2 (about 1e6) times stiffer than a graphene monolayer.
  Paper,
  /// The coarse graining's own result, lambda^-2 per stage: the bending rigidity kappa of
  /// graphene is kept.
  Physical,
};

/// Options of the recursive coarse-grained particle construction (DESIGN 4.3 items 1-5, 9)
/// and of the finite sheet built from it (item 6).
struct RcgpOptions {
  /// N_r: stage 1 projects 800 atoms on 5 x 5 CGPs (spacing 4 sqrt(3) d x 6 d, about
  /// 1 nm); each further stage doubles the spacing (lambda = 2). 9 stages reach
  /// Lambda = 1024 (0.25 um), the paper's dx_CG. 1..16, or 0: from the sheets' CGP spacing,
  /// N_r = 1 + round(log2(dx_CG / h_1)) = ln Lambda / ln lambda (the paper's section 2.1).
  int stages = 0;
  FlexuralScaling flexural_scaling = FlexuralScaling::Paper;
  /// Range of the truncated CG kernel in CG spacings, 1 or 2 (the 5 x 5 periodic cell
  /// holds range 2). One of the accuracy knobs of DESIGN 6.
  int truncation_range = 2;
  /// Restore the sum rule and the long-wave moments after truncation (DESIGN 4.3 item 3).
  /// Off only to show the drift of naive recursion.
  bool moment_matching = true;
  /// Poisson ratio of the bending energy of the finite sheet. A periodic derivation fixes
  /// only D11, D22 and D12 + 2 D66 (the Gaussian-curvature term is a null Lagrangian in a
  /// periodic cell); 0 gives kappa_G = -kappa, the common default. [0, 0.5).
  double bending_poisson = 0.0;
  /// Folder of the HDF5 cache of constructions, keyed by a hash of their inputs; empty: no
  /// cache.
  std::string cache_dir;
};

/// Repulsive Lennard-Jones contact between CGPs of different sheets (the paper's section
/// 3.2); built only when a scene has two or more sheets.
struct ContactOptions {
  double epsilon_eV = 1000.0;  ///< the paper's eps
  /// sigma = cut-off distance, bohr; 0: the sheets' CGP spacing dx_CG.
  double cutoff_bohr = 0.0;
};

/// A uniform body force on every CGP, m g (the gravity of a flag in a vertical stream, e.g.
/// the Froude number Fr = g L / U^2 of Huang, Shin & Sung's filament; the elastic models).
struct BodyForceOptions {
  /// g, m/s^2, scene axes (x stream-wise in the paper's scenes, y up from the plate).
  Eigen::Vector3d gravity_m_s2 = Eigen::Vector3d::Zero();
};

/// The spring of the `sprung` model (solid/models/sprung/sprung_model.hpp): each sheet a
/// rigid plate that translates along its normal with this frequency in vacuum.
struct SpringOptions {
  double frequency_hz = 0.0;  ///< 0: unset (the model refuses it)
};

/// The CGPs of all sheets form one array: sheet 0's CGPs first (in SheetSpec index order),
/// then sheet 1's, and so on.
struct SolidConfig {
  std::vector<SheetSpec> sheets;
  RcgpOptions rcgp;
  ContactOptions contact;
  BodyForceOptions body;
  SpringOptions spring;
  /// [material]: the sheets are of this continuum material (solid/models/elastic_sheet/sheet_material.hpp), the
  /// plane-strain bar's constants instead of the RCGP construction's, and each CGP's mass
  /// rho h times its cell; unset: graphene (rcgp).
  std::optional<SheetMaterial> material;
};

/// Total number of CGPs of all sheets.
inline Eigen::Index total_cgps(const SolidConfig& config) {
  Eigen::Index n = 0;
  for (const SheetSpec& s : config.sheets) n += s.num_cgps();
  return n;
}

/// Index of the first CGP of sheet `sheet` in the model's arrays.
inline Eigen::Index first_cgp(const SolidConfig& config, std::size_t sheet) {
  Eigen::Index n = 0;
  for (std::size_t s = 0; s < sheet; ++s) n += config.sheets[s].num_cgps();
  return n;
}

/// "CGP l (sheet s, i = .., j = ..)": where CGP `l` of the model's array sits, for messages.
inline std::string describe_cgp(const SolidConfig& c, Eigen::Index l) {
  for (std::size_t s = 0; s < c.sheets.size(); ++s) {
    const Eigen::Index first = first_cgp(c, s), n = c.sheets[s].num_cgps();
    if (l >= first && l < first + n) {
      const Eigen::Index k = l - first;
      return "CGP " + std::to_string(l) + " (sheet " + std::to_string(s) + ", i = " +
             std::to_string(k % c.sheets[s].nx_cg) + ", j = " +
             std::to_string(k / c.sheets[s].nx_cg) + ")";
    }
  }
  return "CGP " + std::to_string(l);
}

}  // namespace cosim::solid
