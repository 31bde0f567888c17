#include "solid/models/sprung/sprung_model.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

#include "solid/model/model_checks.hpp"

#include "protocol/config/scene_reader.hpp"
#include "protocol/units.hpp"

// Why the limits are what they are:
//  - spring_frequency_hz in (0, 1e15]: any positive frequency; 1e15 Hz (a femtosecond
//    period) is far above any sheet's and keeps omega^2 finite in atomic units.

namespace cosim::solid {

namespace {

constexpr double kFrequencyMax_Hz = 1e15;

[[noreturn]] void fail(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}

void read_spring(const protocol::config::Table& sec, SolidConfig& config) {
  if (const auto f = sec.positive("spring_frequency_hz",
                                  "the plate's frequency on its spring in vacuum, Hz")) {
    if (*f > kFrequencyMax_Hz)
      sec.bad("spring_frequency_hz", "must be in (0, 1e15] Hz (the plate's frequency in vacuum)");
    config.spring.frequency_hz = *f;
  }
}

constexpr std::string_view kSpringKeys[] = {"spring_frequency_hz"};

}  // namespace

const ModelOptions kSpringOptions{"solid", kSpringKeys, &read_spring};

SprungModel::SprungModel(const SolidConfig& config) : config_(config) {
  if (config_.sheets.empty())
    fail(__LINE__, "the sprung model needs at least one sheet; the scene names none");
  if (!(config_.spring.frequency_hz > 0.0))
    fail(__LINE__, "the sprung model needs [solid] spring_frequency_hz (the plate's frequency "
                   "on its spring in vacuum, Hz)");
  const double omega_au = 2.0 * std::numbers::pi * config_.spring.frequency_hz *
                          protocol::PhysicalConstants::time_au_s;
  omega2_ = omega_au * omega_au;
  const Eigen::Index n = total_cgps(config_);
  reference_.resize(3, n);
  masses_.resize(n);
  for (std::size_t s = 0; s < config_.sheets.size(); ++s) {
    const SheetSpec& spec = config_.sheets[s];
    Plate p;
    p.first = first_cgp(config_, s);
    p.count = spec.num_cgps();
    p.normal = sheet_normal(spec);
    p.mass_me = double(p.count) * spec.cgp_mass_me;
    reference_.middleCols(p.first, p.count) = flat_sheet_positions(spec);
    masses_.segment(p.first, p.count).setConstant(spec.cgp_mass_me);
    plates_.push_back(p);
  }
  positions_ = reference_;
  velocities_ = Eigen::Matrix3Xd::Zero(3, n);
  external_forces_ = Eigen::Matrix3Xd::Zero(3, n);
}

double SprungModel::stable_time_step() const { return 2.0 / std::sqrt(omega2_); }

double SprungModel::displacement(const Plate& p) const {
  return p.normal.dot(positions_.col(p.first) - reference_.col(p.first));
}

double SprungModel::normal_force(const Plate& p, const Eigen::Matrix3Xd& forces) const {
  return p.normal.dot(forces.middleCols(p.first, p.count).rowwise().sum());
}

void SprungModel::substep(double dt, const Eigen::Matrix3Xd& external_forces) {
  check_substep_args(dt, external_forces, num_cgps());
  // Velocity Verlet on q, the external force held over the substep (as the elastic models):
  //   v += a dt / 2; q += v dt; v += a(q) dt / 2,  a = (F_n - k q) / M.
  for (const Plate& p : plates_) {
    const double f_ext = normal_force(p, external_forces);
    const double q0 = displacement(p);
    const double v0 = p.normal.dot(velocities_.col(p.first));
    const double v_half = v0 + 0.5 * dt * (f_ext / p.mass_me - omega2_ * q0);
    const double q1 = q0 + dt * v_half;
    const double v1 = v_half + 0.5 * dt * (f_ext / p.mass_me - omega2_ * q1);
    for (Eigen::Index l = p.first; l < p.first + p.count; ++l) {
      positions_.col(l) = reference_.col(l) + q1 * p.normal;
      velocities_.col(l) = v1 * p.normal;
    }
  }
  external_forces_ = external_forces;
}

SolidObservables SprungModel::observables() const {
  SolidObservables o;
  o.kinetic_energy_au = 0.0;
  o.elastic_energy_au = 0.0;
  for (std::size_t s = 0; s < plates_.size(); ++s) {
    const Plate& p = plates_[s];
    const Eigen::Index marked = p.first + config_.sheets[s].marked_cgp();
    o.marked_displacement_bohr.push_back(positions_.col(marked) - reference_.col(marked));
    o.total_external_force_au.push_back(
        external_forces_.middleCols(p.first, p.count).rowwise().sum());
    const double q = displacement(p), v = p.normal.dot(velocities_.col(p.first));
    o.kinetic_energy_au += 0.5 * p.mass_me * v * v;
    o.elastic_energy_au += 0.5 * p.mass_me * omega2_ * q * q;
  }
  return o;
}

std::string SprungModel::startup_report() const {
  char f[64];
  std::snprintf(f, sizeof f, "%.9g", config_.spring.frequency_hz * 1e-6);
  return "solid model: sprung (" + std::to_string(plates_.size()) +
         " rigid plate(s) on a spring along the normal, " + std::to_string(num_cgps()) +
         " CGPs)\neigenfrequencies in vacuum: " + f + " MHz (the plate on its spring)\n";
}

std::vector<double> SprungModel::vacuum_eigenfrequencies_hz() const {
  return {config_.spring.frequency_hz};
}

SolidState SprungModel::state() const {
  return {std::string(kName), positions_, velocities_, external_forces_};
}

void SprungModel::restore(const SolidState& state) {
  check_state_shape(kName, state, num_cgps());
  // Each plate's CGPs must share one translation and one velocity along its normal: the
  // model has no other motion. Compared in the state's own arithmetic (reference + q n),
  // to a bohr's 1e-9, so that a checkpoint of this model restores bit for bit.
  for (const Plate& p : plates_) {
    const double q = p.normal.dot(state.positions_bohr.col(p.first) - reference_.col(p.first));
    const double v = p.normal.dot(state.velocities_au.col(p.first));
    for (Eigen::Index l = p.first; l < p.first + p.count; ++l) {
      const double dq = (state.positions_bohr.col(l) - (reference_.col(l) + q * p.normal)).norm();
      const double dv = (state.velocities_au.col(l) - v * p.normal).norm();
      if (!(dq <= 1e-9 * (1.0 + std::abs(q))) || !(dv <= 1e-9 * (1.0 + std::abs(v))))
        fail(__LINE__, "the checkpoint's sheet " + describe_cgp(config_, l) +
                           " does not move with its plate along the normal; the sprung model "
                           "has no other motion (a checkpoint of another model or scene?)");
    }
  }
  positions_ = state.positions_bohr;
  velocities_ = state.velocities_au;
  external_forces_ = state.external_forces_au;
}

}  // namespace cosim::solid
