// The argument checks every solid model makes on its way in: a substep's step and forces, and
// a checkpoint's model name and shape. One implementation, so that each model refuses the same
// input with the same line.
#pragma once

#include <string_view>

#include <Eigen/Core>

#include "solid/model/solid_state.hpp"

namespace cosim::solid {

/// Throws std::invalid_argument unless `dt` is positive and finite and `external_forces` holds
/// one column per CGP of a model of `num_cgps` CGPs.
void check_substep_args(double dt, const Eigen::Matrix3Xd& external_forces, Eigen::Index num_cgps);

/// Throws std::invalid_argument unless `state` was written by the model named `model`, holds one
/// column per CGP (of `num_cgps`) in each of its arrays, and every entry is finite.
void check_state_shape(std::string_view model, const SolidState& state, Eigen::Index num_cgps);

}  // namespace cosim::solid
