// A solid model's checkpoint: what restore() needs to continue a run bit for bit.
#pragma once

#include <string>

#include <Eigen/Core>

namespace cosim::solid {

/// Plain arrays, one column per CGP, Hartree atomic units (solid_model.hpp). The reference
/// (undeformed) geometry is not stored: it comes from the SolidConfig the model is rebuilt
/// with. A model's internal forces are a function of positions and are recomputed.
struct SolidState {
  std::string model;                 ///< name() of the model that wrote it
  Eigen::Matrix3Xd positions_bohr;
  Eigen::Matrix3Xd velocities_au;    ///< bohr per atomic time unit
  Eigen::Matrix3Xd external_forces_au;  ///< of the latest substep, E_h / bohr
};

}  // namespace cosim::solid
