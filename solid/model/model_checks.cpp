#include "solid/model/model_checks.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::solid {

namespace {

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

}  // namespace

void check_substep_args(double dt, const Eigen::Matrix3Xd& external_forces, Eigen::Index num_cgps) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    fail(__LINE__, "a substep needs a positive, finite dt; got " + std::to_string(dt));
  if (external_forces.cols() != num_cgps)
    fail(__LINE__, "external forces for " + std::to_string(external_forces.cols()) +
                       " CGPs handed to a model of " + std::to_string(num_cgps) + " CGPs");
}

void check_state_shape(std::string_view model, const SolidState& state, Eigen::Index num_cgps) {
  if (state.model != model)
    fail(__LINE__, "cannot restore the " + std::string(model) +
                       " model from a checkpoint of model \"" + state.model + "\"");
  if (state.positions_bohr.cols() != num_cgps || state.velocities_au.cols() != num_cgps ||
      state.external_forces_au.cols() != num_cgps)
    fail(__LINE__, "the checkpoint holds " + std::to_string(state.positions_bohr.cols()) +
                       " CGPs; this scene's sheets have " + std::to_string(num_cgps));
  if (!state.positions_bohr.allFinite() || !state.velocities_au.allFinite() ||
      !state.external_forces_au.allFinite())
    fail(__LINE__, "the checkpoint holds a non-finite position, velocity or force");
}

}  // namespace cosim::solid
