// The initial state of a run released from a held deflection ([perturbation]): the sheets
// bent along their normals in the shape of a uniformly loaded cantilever, at rest. One
// implementation for the standalone free vibration (solid/app/main.cpp) and the coupled release
// in still air or in flow (solid/coupled/solid_run.cpp).
#pragma once

#include "solid/config/solid_scene.hpp"
#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::solid {

/// Cantilever: moves every free row j of every sheet along the sheet's normal by
/// w = tip_bohr * cantilever_load_shape(s), s = (j - last clamped row) / free rows (w =
/// tip_bohr at the top row). Translation: moves every CGP, the clamped rows' too, by tip_bohr
/// along the normal (the release of a plate on a spring, the `sprung` model). Then sets
/// every velocity to zero (SolidModel::restore).
/// @pre the model has dynamics (a finite stable time step)
void apply_initial_deflection(const SolidConfig& config, double tip_bohr, DeflectionShape shape,
                              SolidModel& model);

}  // namespace cosim::solid
