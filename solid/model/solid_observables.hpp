// What a solid model reports after a substep (DESIGN 4.4), Hartree atomic units.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace cosim::solid {

/// Per-sheet vectors follow the order of SolidConfig::sheets.
struct SolidObservables {
  /// Displacement of each sheet's marked CGP (Fig. 4) from its reference position, bohr.
  std::vector<Eigen::Vector3d> marked_displacement_bohr;
  /// Sum over each sheet's CGPs of the external (fluid) forces of the latest substep,
  /// E_h / bohr. Reactions at clamped CGPs are not included.
  std::vector<Eigen::Vector3d> total_external_force_au;
  double kinetic_energy_au = 0.0;  ///< sum_l m_l |V_l|^2 / 2, E_h
  double elastic_energy_au = 0.0;  ///< E_h; zero for a rigid model
  /// Area strain eps_l = (|dA_l| - |dA_l0|) / |dA_l0| per CGP (section 3.2); empty when a
  /// model does not compute it.
  Eigen::VectorXd area_strain;
};

}  // namespace cosim::solid
