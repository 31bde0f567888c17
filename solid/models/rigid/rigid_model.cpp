#include "solid/models/rigid/rigid_model.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "solid/model/model_checks.hpp"

namespace cosim::solid {

namespace {

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

}  // namespace

RigidModel::RigidModel(const SolidConfig& config) : config_(config) {
  if (config_.sheets.empty())
    fail(__LINE__, "the rigid model needs at least one sheet; the scene names none");
  const Eigen::Index n = total_cgps(config_);
  positions_.resize(3, n);
  masses_.resize(n);
  for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
    const SheetSpec& spec = config_.sheets[s];
    const Eigen::Index first = first_cgp(config_, s);
    positions_.middleCols(first, spec.num_cgps()) = flat_sheet_positions(spec);
    masses_.segment(first, spec.num_cgps()).setConstant(spec.cgp_mass_me);
  }
  velocities_ = Eigen::Matrix3Xd::Zero(3, n);
  external_forces_ = Eigen::Matrix3Xd::Zero(3, n);
}

double RigidModel::stable_time_step() const { return std::numeric_limits<double>::infinity(); }

void RigidModel::substep(double dt, const Eigen::Matrix3Xd& external_forces) {
  check_substep_args(dt, external_forces, num_cgps());
  external_forces_ = external_forces;
}

SolidObservables RigidModel::observables() const {
  SolidObservables o;
  for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
    const Eigen::Index first = first_cgp(config_, s);
    o.marked_displacement_bohr.push_back(Eigen::Vector3d::Zero());
    o.total_external_force_au.push_back(
        external_forces_.middleCols(first, config_.sheets[s].num_cgps()).rowwise().sum());
  }
  o.kinetic_energy_au = 0.0;
  o.elastic_energy_au = 0.0;
  o.area_strain = Eigen::VectorXd::Zero(num_cgps());
  return o;
}

std::string RigidModel::startup_report() const {
  return "solid model: rigid (" + std::to_string(config_.sheets.size()) + " sheet(s), " +
         std::to_string(num_cgps()) + " CGPs held in place; no dynamics, no stable-step limit)\n";
}

SolidState RigidModel::state() const {
  return {std::string(kName), positions_, velocities_, external_forces_};
}

void RigidModel::restore(const SolidState& state) {
  check_state_shape(kName, state, num_cgps());
  if (state.positions_bohr != positions_ || !state.velocities_au.isZero(0.0))
    fail(__LINE__, "the checkpoint's sheets moved; a rigid model holds them at the scene's "
                   "positions: check that the checkpoint belongs to this scene");
  external_forces_ = state.external_forces_au;
}

}  // namespace cosim::solid
